"""Interoperability: a run exported as a BOP results CSV, and predictions made elsewhere (BOP CSV
or per-sample CSV) scored into a run directory like any run. Imports :mod:`catpose.bench.run`,
:mod:`catpose.bench.protocols`, :mod:`catpose.bench.scoring` and :mod:`catpose.bench.report`
(runs are read back as the tables read them)."""
