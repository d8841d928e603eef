"""The instances of a category that the category tools work on (``bench templates``,
``experiments/alignment/align.py``).

Datasets say it in three ways, tried in this order:

- ``dataset.instance_ids(category, split)`` (ModelNet40 from OFF files): a category's split;
- ``dataset.split_ids(split)`` with ``dataset.category_of_instance(id)`` (ModelNet40 resampled:
  one split file for every category): the split's instances of the category;
- otherwise the instances observed in ``dataset.observation_ids()``, in order, each read from
  its observation (``Observation.instance_id``; observation ids need not spell it), for
  datasets without splits (the synthetic set, BOP scenes); ``split`` does not apply to them.
"""

from __future__ import annotations

from typing import Any


def instance_ids(dataset: Any, category: str, split: str | None = None) -> list[str]:
    """Instance ids of ``category`` in ``split`` (None: the dataset's own split), no duplicates."""
    if hasattr(dataset, "instance_ids"):
        return list(dataset.instance_ids(category, split))
    if hasattr(dataset, "split_ids"):
        return [i for i in dataset.split_ids(split) if dataset.category_of_instance(i) == category]
    ids: dict[str, None] = {}
    for obs_id in dataset.observation_ids():
        if dataset.category_of(obs_id) == category:
            ids.setdefault(str(dataset.observation(obs_id).instance_id))
    return list(ids)
