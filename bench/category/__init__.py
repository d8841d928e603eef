"""Category tools: canonical-alignment tables of raw instances (``bench align``) and the choice of
category templates (``bench templates``). Imports :mod:`catpose.bench.run` and
:mod:`catpose.bench.protocols`."""
