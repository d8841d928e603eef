"""Datasets: loaders for the embedded synthetic set and real benchmarks, plus rendering.

A dataset yields :class:`~catpose.datasets.dataset.Observation` objects (a partial view with its
ground truth) and the complete models and category templates they are registered to. It knows
nothing of methods; protocols (:mod:`catpose.bench.protocols`) turn observations into problems.
"""
