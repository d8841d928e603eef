"""A study's variants that patch ours in the study's process (no key, nothing in the product): one
JSON line per sample and variant on bench run's problems, or a ``bench`` command with one variant
installed.

    python experiments/<study>/run.py OUT_DIR SEED VARIANT[,VARIANT ...] [OVERRIDE ...]
    python experiments/<study>/run.py --bench VARIANT BENCH_ARG ...

The study's ``run.py`` calls :func:`main` with its variants: name -> a function installing that
variant (``default`` must install ours' own behaviour back). Each problem is loaded once and
registered by every variant in turn, into ``OUT_DIR/<variant>.jsonl`` (:mod:`sample_rows`, as
``bench run`` builds and seeds them); ``--bench`` runs the ``bench`` command line (``bench run ...``)
with the variant installed (the category templates, whose problems ``bench run`` builds).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path


def main(argv: list[str], variants: dict[str, Callable[[], None]]) -> int:
    if argv and argv[0] == "--bench":
        if argv[1] not in variants:
            raise SystemExit(f"{argv[1]!r}: not in the study's variants ({', '.join(variants)})")
        variants[argv[1]]()
        from catpose.bench.cli import main as bench_main

        return bench_main(argv[2:])
    from sample_rows import build, variant_rows

    out_dir, seed, names = Path(argv[0]), int(argv[1]), argv[2].split(",")
    unknown = [v for v in names if v not in variants]
    if unknown:
        raise SystemExit(f"{unknown}: not in the study's variants ({', '.join(variants)})")
    _, method, dataset, protocol = build(seed, argv[3:])

    def method_for(v: str):
        variants[v]()
        return method

    variant_rows(out_dir, seed, names, dataset, protocol, method_for)
    return 0
