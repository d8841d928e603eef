"""One answer to "which instances of a category" for ``bench templates`` and the alignment study."""

from __future__ import annotations

from types import SimpleNamespace

from catpose.bench.category.template_medoids import instance_ids


class _Split:
    """ModelNet40 from OFF files: instances per category and split."""

    def instance_ids(self, category, split=None):
        return {("chair", "train"): ["chair_0001", "chair_0002"], ("chair", None): ["chair_0009"]}[category, split]


class _SplitFile:
    """ModelNet40 resampled: one split file lists every category's instances."""

    def split_ids(self, split=None):
        return {"train": ["chair_0001", "airplane_0001", "chair_0003"], None: ["chair_0100"]}[split]

    @staticmethod
    def category_of_instance(i):
        return i.rsplit("_", 1)[0]

    def observation_ids(self):  # a split file is read, the observations are not
        raise AssertionError("observations need not be rendered to list a split's instances")


class _Observed:
    """No splits, and ids that do not spell the instance (BOP-like scene/image/object)."""

    ids = {
        "000048/000001/obj_05": ("bottle", "05"),
        "000048/000002/obj_05": ("bottle", "05"),
        "000048/000001/obj_02": ("box", "02"),
        "000049/000007/obj_12": ("bottle", "12"),
    }

    def observation_ids(self):
        return list(self.ids)

    def category_of(self, obs_id):
        return self.ids[obs_id][0]

    def observation(self, obs_id):
        return SimpleNamespace(instance_id=self.ids[obs_id][1])


def test_a_dataset_with_splits_answers_for_the_split():
    assert instance_ids(_Split(), "chair", "train") == ["chair_0001", "chair_0002"]
    assert instance_ids(_Split(), "chair") == ["chair_0009"]


def test_a_split_file_is_filtered_by_category_and_the_split_is_honoured():
    # bench templates --split train on modelnet40_resampled used the dataset's own split instead
    assert instance_ids(_SplitFile(), "chair", "train") == ["chair_0001", "chair_0003"]
    assert instance_ids(_SplitFile(), "chair") == ["chair_0100"]


def test_without_splits_the_observed_instances_are_read_from_the_observations():
    # the alignment command parsed "category/instance/view" ids and found nothing in ids of another shape
    assert instance_ids(_Observed(), "bottle") == ["05", "12"]
    assert instance_ids(_Observed(), "box", "train") == ["02"]
    assert instance_ids(_Observed(), "mug") == []


def test_the_synthetic_set_lists_its_instances():
    from catpose.datasets.synthetic import SyntheticDataset

    ds = SyntheticDataset(seed=0, categories=["mug", "can"], instances_per_category=2, views_per_instance=1)
    assert instance_ids(ds, "can") == ["000", "001"]
