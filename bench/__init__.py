"""The benchmark, one sub-package per concept ("wing"): run, scoring, protocols, report, interop,
regress, perf, category, real. The floor plan, and which wing may import which
(tests/test_import_rules.py), is docs/architecture.md; :mod:`catpose.bench.cli` is the ``bench``
command line."""
