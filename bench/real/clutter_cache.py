"""``bench clutter``: generate the cluttered synthetic set ahead of a run and say where it is.

The set (``dataset=clutter``, :mod:`catpose.datasets.clutter`) is also generated on first use;
this command does it once, for the scenes of a split part or all, and prints the cache folder and
how many instances each part has (before and after the BOP19 visibility filter).

    bench clutter                                  # all 200 scenes of the default settings
    bench clutter --part dev                       # only the scenes that choose defaults
    bench clutter dataset.sensor=realsense         # any dataset override
"""

from __future__ import annotations

import argparse
import json
import sys


def main(argv: list[str]) -> int:
    from catpose.bench.real.split import load_split
    from catpose.bench.run.config import compose_and_build, shared_data_dir
    from catpose.errors import ConfigError

    parser = argparse.ArgumentParser(
        prog="bench clutter", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("overrides", nargs="*", help="dataset overrides, e.g. dataset.num_scenes=40")
    parser.add_argument("--part", default=None, help="only the scenes of this part of configs/split/clutter.yaml")
    args = parser.parse_args(argv)
    split = load_split("clutter")
    overrides = ["dataset=clutter", f"dataset.root={shared_data_dir() / 'bop' / 'ycbv'}", *args.overrides]
    if args.part and args.part not in split.parts:
        raise ConfigError(
            f"--part {args.part!r} is not a part of configs/split/clutter.yaml; pass one of {list(split.parts)}"
        )
    if args.part:
        overrides.append(f"dataset.scenes={split.scene_ids(args.part)}")
    _, [(_, dataset)] = compose_and_build(overrides, ["dataset"])
    ids = dataset.observation_ids()
    print(f"clutter: {dataset.root}")
    by_part = {name: len(split.sample_ids(name, ids)) for name in split.parts}
    print(json.dumps({"instances": len(ids), "filters": dataset.filters, "by_part": by_part}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
