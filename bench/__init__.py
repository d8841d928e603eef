"""The benchmark, one sub-package per concept ("wing"); the floor plan is docs/architecture.md.

- :mod:`catpose.bench.cli`: the ``bench`` command line (imports each command only when it runs);
- :mod:`catpose.bench.run`: configs into objects, samples through a method into a run directory;
- :mod:`catpose.bench.scoring`: per-sample errors, the row schema, BOP's metrics;
- :mod:`catpose.bench.protocols`: which problems a dataset gives and how their rows are scored;
- :mod:`catpose.bench.report`: tables, plots and reports from run directories;
- :mod:`catpose.bench.interop`: BOP export and external predictions scored like a run;
- :mod:`catpose.bench.regress`: the per-sample regression gate;
- :mod:`catpose.bench.perf`: speed measurements;
- :mod:`catpose.bench.category`: category tools (alignment tables, template choice);
- :mod:`catpose.bench.real`: the shared real data (suite, diagnosis, sensor statistics).

Which wing may import which is a test (tests/test_import_rules.py).
"""
