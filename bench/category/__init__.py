"""Category tools: the choice of category templates (``bench templates``: K-medoids over F-score).
Imports :mod:`catpose.bench.run` and :mod:`catpose.bench.protocols`."""
