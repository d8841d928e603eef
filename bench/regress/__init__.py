"""The regression gate (``bench regress``): committed golden inputs, per-sample comparison with a
committed reference, chaos detection. Imports :mod:`catpose.bench.run` and
:mod:`catpose.bench.scoring`."""
