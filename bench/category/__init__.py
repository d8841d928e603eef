"""Category tools: canonical-alignment tables of raw instances (``bench align``), the choice of
category templates (``bench templates``), and why a templates run's wrong views are wrong
(``python -m catpose.bench.category.why_wrong``). Imports :mod:`catpose.bench.run` and
:mod:`catpose.bench.protocols`."""
