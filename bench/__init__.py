"""The benchmark: CLI, runner, protocols, metrics and tables."""
