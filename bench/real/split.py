"""Development splits: which scenes (and objects) of a data set choose defaults and which report.

A split is ``configs/split/<name>.yaml`` (the rule is in docs/choosing-defaults.md): ``parts``
maps a part name to scene ids as ``[first, last]`` inclusive ranges, or to
``{scenes: [...], objects: [obj_id, ...]}`` for a split by object; ``folds`` lists
``{choose: PART, report: PART}``. Observation ids of BOP-layout sets are
``<category>/<scene_id>/<im_id>/<gt_idx>``, so a part filters the second field
(:meth:`Split.sample_ids`; rows by ``info["obj_id"]``: :meth:`Split.row_ids`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from catpose.errors import ConfigError

SPLIT_DIR = Path(__file__).resolve().parents[2] / "configs" / "split"


@dataclass(frozen=True)
class Split:
    """One split file: its data set, its parts (name -> inclusive scene-id ranges) and folds."""

    name: str
    dataset: str
    parts: dict[str, tuple[tuple[int, int], ...]]
    folds: tuple[tuple[str, str], ...]
    objects: dict[str, tuple[int, ...]] = field(default_factory=dict)  # part -> its obj_ids (absent: all)

    def contains(self, part: str, scene_id: int) -> bool:
        return any(lo <= int(scene_id) <= hi for lo, hi in self.parts[part])

    def scene_ids(self, part: str) -> list[int]:
        """Every scene id of ``part``, ascending."""
        return sorted({s for lo, hi in self.parts[part] for s in range(lo, hi + 1)})

    def sample_ids(self, part: str, ids: list[str], obj_of: Mapping[str, int] | None = None) -> list[str]:
        """The ids (``<category>/<scene>/...``; a templates-protocol suffix ``|k`` is kept) of
        ``part``; ``obj_of`` (sample id -> BOP obj_id) is needed when the part lists objects."""
        out = [i for i in ids if self.contains(part, int(i.split("|")[0].split("/")[1]))]
        if part not in self.objects:
            return out
        if obj_of is None:
            raise ConfigError(f"split {self.name}: part {part} lists objects; its samples need their obj_id")
        return [i for i in out if int(obj_of.get(i, -1)) in self.objects[part]]

    def row_ids(self, part: str, rows: list[dict]) -> list[str]:
        """:meth:`sample_ids` of rows of ``samples.jsonl`` (their ``info["obj_id"]``)."""
        obj_of = {r["sample_id"]: int((r.get("info") or {}).get("obj_id", -1)) for r in rows}
        return self.sample_ids(part, [r["sample_id"] for r in rows], obj_of)

    def role(self, part: str) -> str:
        """How the folds use ``part``: e.g. ``choose A, report B``."""
        roles = []
        for k, (choose, report) in enumerate(self.folds):
            tag = chr(ord("A") + k)
            roles += [f"choose {tag}"] if choose == part else []
            roles += [f"report {tag}"] if report == part else []
        return ", ".join(roles) or "unused"


def load_split(name: str, folder: Path = SPLIT_DIR) -> Split:
    """Read ``configs/split/<name>.yaml``; a malformed file is a one-line :class:`ConfigError`."""
    import yaml

    path = folder / f"{name}.yaml"
    if not path.is_file():
        known = sorted(p.stem for p in folder.glob("*.yaml"))
        raise ConfigError(f"no split {name!r} ({path} is absent); known splits: {', '.join(known)}")
    raw = yaml.safe_load(path.read_text()) or {}
    try:
        scenes = {str(k): v["scenes"] if isinstance(v, dict) else v for k, v in raw["parts"].items()}
        parts = {k: tuple((int(lo), int(hi)) for lo, hi in v) for k, v in scenes.items()}
        objects = {
            str(k): tuple(int(o) for o in v["objects"])
            for k, v in raw["parts"].items()
            if isinstance(v, dict) and v.get("objects") is not None
        }
        folds = tuple((str(f["choose"]), str(f["report"])) for f in raw.get("folds") or ())
        dataset = str(raw["dataset"])
    except (KeyError, TypeError, ValueError, AttributeError):
        raise ConfigError(
            f"{path}: needs dataset, parts (name: [[first, last], ...] or {{scenes: [[first, last], ...], "
            "objects: [obj_id, ...]}) and folds ([{choose: part, report: part}])"
        ) from None
    unknown = sorted({p for f in folds for p in f} - set(parts))
    if unknown:
        raise ConfigError(f"{path}: folds name parts {unknown} that parts does not define")
    split = Split(name, dataset, parts, folds, objects)
    for choose, report in folds:
        overlap = set(split.scene_ids(choose)) & set(split.scene_ids(report))
        if choose in objects and report in objects and not set(objects[choose]) & set(objects[report]):
            continue  # the same scenes, other objects: disjoint samples
        if overlap:
            raise ConfigError(
                f"{path}: parts {choose} and {report} share scenes {sorted(overlap)[:5]}; a fold must "
                "report on scenes (or objects) it did not choose on"
            )
    return split
