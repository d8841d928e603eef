"""Load a dataset's problems once (problem, truth, info per sample) into a pickle, so that many
settings of ours can be compared on them without loading the frames again (study: README.md).

    python experiments/search_recall/problems.py OUT.pkl dataset=clutter dataset.root=... 'dataset.scenes=[0,1]'

The problems are built as ``bench run`` builds them (the config's dataset and protocol); the pickle
stays outside the repository.
"""

from __future__ import annotations

import pickle
import sys
import time

from catpose.bench.run.config import compose_and_build


def main(argv: list[str]) -> int:
    out, overrides = argv[0], argv[1:]
    _, [(_, dataset), (_, protocol)] = compose_and_build(["method=icp", *overrides], ["dataset", "protocol"])
    rows, t0 = [], time.time()
    for sid in protocol.sample_ids(dataset):
        s = protocol.load(dataset, sid)
        rows.append((sid, s.problem, s.gt, dict(s.info)))
    with open(out, "wb") as f:
        pickle.dump(rows, f)
    print(f"{out}: {len(rows)} problems in {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
