"""The shared real data: every method on it in one table (``bench suite real``), the diagnosis of
ours' failures, and the sensor model's statistics beside the real frames. Imports
:mod:`catpose.bench.run`, :mod:`catpose.bench.protocols` and :mod:`catpose.bench.scoring`."""
