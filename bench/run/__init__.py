"""Running: the config composed and built into objects, every sample through a method into a run
directory (rows appended as they finish, resumable, locked), sweeps, and the errors and
summaries recomputed from the run directory's files. Imports :mod:`catpose.bench.scoring` only."""
