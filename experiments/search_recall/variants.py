"""Ours under one setting over pickled problems (``problems.py``): per sample, the error of the
answer, of the best pose held at each stage of the search (hypothesis recall) and the CPU seconds,
one JSON line each (study: README.md).

    python experiments/search_recall/variants.py OUT.jsonl PROBLEMS.pkl[,MORE.pkl] resting.grid_yaws=8 ...

Settings are ``selection.<key>=<value>`` or ``resting.<key>=<value>`` (JSON values); the rest are
the defaults of configs/method/ours.yaml. Ground truth is read here to score, never by ours.
"""

from __future__ import annotations

import json
import pickle
import sys
import time

from catpose.bench.scoring.metrics import sample_errors, stage_errors
from catpose.methods.ours import Ours
from catpose.methods.ours.settings import RestingSettings, SelectionSettings


def build(settings: list[str]) -> Ours:
    groups: dict[str, dict] = {"selection": {}, "resting": {}}
    for item in settings:
        key, value = item.split("=", 1)
        group, name = key.split(".")
        groups[group][name] = json.loads(value)
    return Ours(selection=SelectionSettings(**groups["selection"]), resting=RestingSettings(**groups["resting"]))


def main(argv: list[str]) -> int:
    out, data, method = argv[0], argv[1].split(","), build(argv[2:])
    with open(out, "w") as f:
        for path in data:
            with open(path, "rb") as fp:
                problems = pickle.load(fp)
            for sid, problem, gt, info in problems:
                t0 = time.process_time()
                r = method.register(problem)
                cpu = time.process_time() - t0
                err = sample_errors(r.T_template_camera, gt.T_template_camera, gt.symmetry_axis, gt.symmetries)
                stages = stage_errors(
                    r.extras.get("hypothesis_stages", {}), gt.T_template_camera, gt.symmetry_axis, gt.symmetries
                )
                row = {
                    "sample_id": sid,
                    "obj_id": info.get("obj_id"),
                    "category": problem.category,
                    "err_deg": err["err_deg"],
                    "found_err_deg": min([err["err_deg"], *stages.values()]),
                    "stages": stages,
                    "cpu_s": cpu,
                    "poor_fit": bool(r.extras.get("depth_poor_fit", False)),
                }
                f.write(json.dumps(row) + "\n")
                f.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
