"""The shared real data: every method on it in one table (``bench suite real``, ``bench suite
clutter``) and its development splits. Imports
:mod:`catpose.bench.run`, :mod:`catpose.bench.protocols` and :mod:`catpose.bench.scoring`."""
