"""Speed (``bench perf``): seconds per registration and per stage. Imports :mod:`catpose.bench.run`."""
