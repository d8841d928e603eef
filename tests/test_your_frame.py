"""docs/your-frame.md's templates table (issue 61): each mesh is loaded and its stated unit, up and
forward axes are checked against its shape; the dataset configs that name one of these meshes give
the same axes. Rows under ``../shared/data`` skip without it."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "your-frame.md"
SHARED = "../shared/data/"


def _rows() -> list[dict[str, str]]:
    text = DOC.read_text()
    table = text.split("<!-- templates: tests/test_your_frame.py reads this table -->")[1].split(
        "<!-- end templates -->"
    )[0]
    lines = [line for line in table.strip().splitlines() if line.startswith("|")]
    header = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = [dict(zip(header, (c.strip() for c in line.strip("|").split("|")))) for line in lines[2:]]
    for row in rows:
        row["file"] = row["file"].strip("`")
    return rows


ROWS = _rows()


def _axis(spec: str) -> np.ndarray:
    """'+y' -> (0, 1, 0); '-z (seat front)' -> (0, 0, -1)."""
    m = re.match(r"([+-])([xyz])\b", spec)
    assert m, f"{spec!r} is not an axis"
    v = np.zeros(3)
    v["xyz".index(m.group(2))] = 1.0 if m.group(1) == "+" else -1.0
    return v


def _path(row: dict[str, str], shared_dir) -> Path:
    if row["file"].startswith(SHARED):
        return shared_dir() / row["file"][len(SHARED) :]
    return REPO / row["file"]


@pytest.fixture
def shared_dir(request):
    return lambda: request.getfixturevalue("shared_data")


def _frame_coordinates(points: np.ndarray, up: np.ndarray, forward: np.ndarray | None) -> np.ndarray:
    """Points in (side, forward, up) coordinates; without forward, side and forward are the other two axes."""
    if forward is None:
        others = [np.eye(3)[i] for i in range(3) if abs(up[i]) < 0.5]
        forward, side = others
    else:
        side = np.cross(forward, up)
    return points @ np.stack([side, forward, up], axis=1)


def _slices(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bottom and top tenths of the height (up coordinate)."""
    lo, hi = c[:, 2].min(), c[:, 2].max()
    return c[c[:, 2] < lo + 0.1 * (hi - lo)], c[c[:, 2] > hi - 0.1 * (hi - lo)]


def _check_shape(name: str, forward_spec: str, c: np.ndarray) -> None:
    ext = np.ptp(c, axis=0)
    bottom, top = _slices(c)
    width = lambda s: float(np.ptp(s[:, :2], axis=0).max())  # noqa: E731
    if "round" in forward_spec:  # up is the axis of a body of revolution: the other two extents agree
        assert abs(ext[0] - ext[1]) < 0.1 * ext[:2].max(), ext
    if name.startswith("bottle"):  # the neck (or cap) is up
        assert width(top) < 0.6 * width(bottom), (width(top), width(bottom))
    if name.startswith("bowl"):  # the opening is up: the rim is wider than the foot
        assert width(top) > 1.3 * width(bottom), (width(top), width(bottom))
    if name.startswith("bottle") and "its width" in forward_spec:
        assert ext[1] > 1.3 * ext[0], ext  # forward along the longer horizontal extent
    if name.startswith("mug"):
        assert len(top) < 0.8 * len(bottom), (len(top), len(bottom))  # open at the top, a floor at the bottom
        radius = ext[0] / 2  # the body's, across the handle
        body_centre = c[:, 1].min() + radius
        assert c[:, 1].max() - body_centre > 1.3 * radius, "no handle on +forward"
    if name.startswith("chair"):  # the back rises on the -forward side
        top_forward = (top[:, 1].mean() - c[:, 1].min()) / ext[1]
        assert top_forward < 0.3, top_forward
    if name.startswith("airplane"):
        assert ext[2] < 0.3 * min(ext[0], ext[1]), ext  # flat: up is the thinnest extent
        centre_side = 0.5 * (c[:, 0].min() + c[:, 0].max())
        assert np.median(np.abs(c[:, 0] - centre_side)) < 0.15 * ext[0] / 2  # the fuselage along forward
        fin = c[c[:, 2] > c[:, 2].max() - 0.05 * ext[2]]  # the tail fin's top: at the -forward end
        assert (fin[:, 1].mean() - c[:, 1].min()) / ext[1] < 0.3


def _check_unit(unit: str, extent: np.ndarray) -> None:
    longest = float(extent.max())
    if unit in ("m", "mm"):
        metres = longest / (1000.0 if unit == "mm" else 1.0)
        assert 0.03 < metres < 2.0, f"{longest} {unit} is no household object or chair"
    elif unit.startswith("none"):
        stated = float(re.search(r"\(([0-9.]+) long\)", unit).group(1))
        assert abs(longest - stated) < 0.01 * stated, longest
    elif "diagonal 1" in unit:
        assert abs(float(np.linalg.norm(extent)) - 1.0) < 0.02, extent
    else:
        raise AssertionError(f"unit {unit!r} has no check")


def test_the_table_lists_the_templates_with_every_column():
    assert len(ROWS) >= 8 and {r["unit"] for r in ROWS} >= {"m", "mm"}
    for row in ROWS:
        assert row["file"] and row["where from, licence"] and row["up"] and row["forward"], row
        assert row["file"].startswith(SHARED) or (REPO / row["file"]).is_file(), row["file"]


@pytest.mark.parametrize("row", ROWS, ids=[r["template"] for r in ROWS])
def test_each_template_has_the_unit_and_axes_the_table_states(row, shared_dir):
    import trimesh

    mesh = trimesh.load(_path(row, shared_dir), force="mesh")
    vertices = np.asarray(mesh.vertices, float)
    _check_unit(row["unit"], np.ptp(vertices, axis=0))
    up = _axis(row["up"])
    forward = None if "any" in row["forward"] else _axis(row["forward"])
    surface = np.asarray(trimesh.sample.sample_surface(mesh, 20000, seed=0)[0])
    _check_shape(row["template"], row["forward"], _frame_coordinates(surface, up, forward))


def test_the_pybullet_mug_and_shapenet_chair_figures_quoted_in_the_doc(shared_data):
    import trimesh

    mug = trimesh.load(shared_data / "templates/pybullet/mug.obj", force="mesh").vertices
    lo, hi = mug.min(axis=0).round(3), mug.max(axis=0).round(3)
    assert list(lo[:2]) == [-0.041, -0.041] and list(hi[:2]) == [0.041, 0.081]
    assert "x in [-0.041, 0.041] m and y in\n[-0.041, 0.081] m" in DOC.read_text()
    chair = trimesh.load(shared_data / "shapenet/chair/models/model_normalized.obj", force="mesh")
    p = np.asarray(trimesh.sample.sample_surface(chair, 20000, seed=0)[0])
    y = p[:, 1]
    top = p[y > y.max() - 0.1 * np.ptp(y)]
    assert round(float(top[:, 2].mean()), 2) == 0.06
    assert [round(float(v), 2) for v in (chair.vertices[:, 2].min(), chair.vertices[:, 2].max())] == [-0.38, 0.09]


def test_dataset_configs_give_the_tables_axes():
    """A config's {path, up, forward} for one of these meshes agrees with the table (tyol.yaml's
    mug said forward +x while its handle is +y)."""
    by_tail = {r["file"].split("/", 3)[-1] if r["file"].startswith(SHARED) else r["file"]: r for r in ROWS}
    seen = 0
    for config in sorted((REPO / "configs" / "dataset").glob("*.yaml")):
        templates = (yaml.safe_load(config.read_text()) or {}).get("templates") or {}
        for specs in templates.values():
            for spec in specs:
                if not isinstance(spec, dict):
                    continue
                path = spec["path"].lstrip("./")
                row = next((r for tail, r in by_tail.items() if tail.endswith(path)), None)
                if row is None:
                    continue
                seen += 1
                assert spec.get("up", "+z") == row["up"].split()[0], (config.name, spec)
                if "any" not in row["forward"]:
                    assert spec.get("forward", "+x") == row["forward"].split()[0], (config.name, spec)
    assert seen >= 4  # tyol's bottle, can, mug and redwood's chair
