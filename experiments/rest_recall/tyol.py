"""TYO-L's one frame under seeds 0-4, as ``dataset=bop`` and ``dataset=tyol`` (study: README.md):
ours' error, the best pose it held (found) and the stage that lost it, one row per run.

    python experiments/rest_recall/tyol.py OUT.md RUN_DIR   (RUN_DIR/tyol_{bop,tyol}-seed<k>.jsonl)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def main(argv: list[str]) -> int:
    from catpose.atomic import write_text

    out, runs = Path(argv[0]), Path(argv[1])
    lines = [
        "# Rest recall: the TYO-L frame (basket, obj 19) under seeds 0-4",
        "",
        "Written by `experiments/rest_recall/tyol.py` (study: `experiments/rest_recall/README.md`). "
        "err: ours' answer (deg); found: the best pose ours held at any stage; the stages' best poses "
        'in the order of the search (`extras["hypothesis_stages"]`).',
        "",
        "| dataset | seed | err | found | answer in the truth's rest | best held per stage |",
        "|---|---|---|---|---|---|",
    ]
    for ds in ("bop", "tyol"):
        for path in sorted(runs.glob(f"tyol_{ds}-seed*.jsonl")):
            for line in path.read_text().splitlines():
                r = json.loads(line)
                stages = ", ".join(f"{k} {v:.1f}" for k, v in r["stages"].items())
                same = "yes" if r["answer_rest"] == r["truth_rest"] else "no"
                lines.append(
                    f"| {ds} | {r['seed']} | {r['err_deg']:.2f} | {r['found_err_deg']:.2f} | {same} | {stages} |"
                )
    write_text(out, "\n".join([*lines, ""]))
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
