"""Scoring: per-sample pose errors (symmetry-aware), summaries, BOP's standard metrics, and the
row schema every per-sample row follows. Imports no other wing."""
