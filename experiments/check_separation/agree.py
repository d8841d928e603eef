"""@10 of each run and how often the runs' answers agree (``bench suite``'s rule, within 10 deg of
each other relative to the truth): ``python experiments/check_separation/agree.py RUN_DIR ...`` (one
``bench run`` directory per seed of one setting)."""

from __future__ import annotations

import sys
from pathlib import Path


def main(argv: list[str]) -> int:
    from catpose.bench.real.suite_table import estimate, seed_agreement
    from catpose.bench.run.rundir import latest_rows

    per_seed = []
    for run in argv:
        rows = [r for r in latest_rows(Path(run) / "samples.jsonl") if r.get("status") == "ok"]
        per_seed.append({r["sample_id"]: estimate(r) for r in rows})
        acc = sum(r["err_deg"] < 10.0 for r in rows) / max(len(rows), 1)
        print(f"{run}: n={len(rows)} @10 {acc:.3f}")
    print(f"agree {seed_agreement(per_seed):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
