"""Speed (``bench perf``): seconds per registration and per stage, the TEASER solver benchmark,
and the solver-only GPU check. Imports :mod:`catpose.bench.run` and :mod:`catpose.bench.regress`
(the golden inputs)."""
