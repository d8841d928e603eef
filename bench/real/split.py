"""Development splits: which scenes of a data set choose defaults and which report results.

A split is ``configs/split/<name>.yaml`` (the rule is in docs/choosing-defaults.md)::

    dataset: ycbv
    parts:                       # part name -> scene ids as [first, last] inclusive ranges
      scene1: [[1, 1]]
      scene2: [[2, 2]]
    folds:                       # each fold: the part that chooses, the part that reports
      - {choose: scene1, report: scene2}
      - {choose: scene2, report: scene1}

Observation ids of BOP-layout sets are ``<category>/<scene_id>/<im_id>/<gt_idx>``, so a part is
a filter on the second field (:meth:`Split.sample_ids`).
"""

from __future__ import annotations

from dataclasses import dataclass
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

    def contains(self, part: str, scene_id: int) -> bool:
        return any(lo <= int(scene_id) <= hi for lo, hi in self.parts[part])

    def scene_ids(self, part: str) -> list[int]:
        """Every scene id of ``part``, ascending."""
        return sorted({s for lo, hi in self.parts[part] for s in range(lo, hi + 1)})

    def sample_ids(self, part: str, ids: list[str]) -> list[str]:
        """The ids (``<category>/<scene>/...``; a templates-protocol suffix ``|k`` is kept) of ``part``."""
        return [i for i in ids if self.contains(part, int(i.split("|")[0].split("/")[1]))]

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
        parts = {str(k): tuple((int(lo), int(hi)) for lo, hi in v) for k, v in raw["parts"].items()}
        folds = tuple((str(f["choose"]), str(f["report"])) for f in raw.get("folds") or ())
        dataset = str(raw["dataset"])
    except (KeyError, TypeError, ValueError, AttributeError):
        raise ConfigError(
            f"{path}: needs dataset, parts (name: [[first, last], ...]) and folds ([{{choose: part, report: part}}])"
        ) from None
    unknown = sorted({p for f in folds for p in f} - set(parts))
    if unknown:
        raise ConfigError(f"{path}: folds name parts {unknown} that parts does not define")
    for choose, report in folds:
        overlap = set(Split(name, dataset, parts, folds).scene_ids(choose)) & set(
            Split(name, dataset, parts, folds).scene_ids(report)
        )
        if overlap:
            raise ConfigError(
                f"{path}: parts {choose} and {report} share scenes {sorted(overlap)[:5]}; a fold must "
                "report on scenes it did not choose on"
            )
    return Split(name, dataset, parts, folds)
