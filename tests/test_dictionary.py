"""The partial-template dictionary: layout, visibility, caching (memory and disk)."""

from __future__ import annotations

import numpy as np
import pytest

from catpose.errors import ConfigError
from catpose.methods import dictionary as dmod
from catpose.types import Template


def _sphere_template(tid: str = "test/sphere", n: int = 800) -> Template:
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    r = np.sqrt(1 - z * z)
    phi = np.pi * (1 + 5**0.5) * i
    p = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    p[:, 0] *= 0.8  # an ellipsoid x^2/0.64 + y^2 + z^2 = 1; normal ~ (x/0.64, y, z)
    nrm = p * np.array([1 / 0.64, 1.0, 1.0])
    return Template(
        template_id=tid, category="ball", points=p, normals=nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    )


def test_layout_rings():
    v = dmod.viewpoint_layout(18, (0.0, 30.0, 60.0), 3.0)
    assert v.shape == (18, 3)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 3.0)
    el = np.degrees(np.arcsin(v[:, 2] / 3.0))
    np.testing.assert_allclose(np.sort(np.unique(np.round(el, 6))), [0.0, 30.0, 60.0], atol=1e-6)
    assert len(np.unique(np.round(v, 6), axis=0)) == 18
    with pytest.raises(ConfigError, match="multiple"):
        dmod.viewpoint_layout(17, (0.0, 30.0, 60.0))


def test_partials_are_visible_subsets_and_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("CATPOSE_CACHE_DIR", str(tmp_path))
    dmod.clear_memory_cache()
    t = _sphere_template()
    d = dmod.get_dictionary(t)
    assert len(d) == 18 and d.viewpoints.shape == (18, 3)
    for idx, pts, nrm, vp in zip(d.indices, d.points, d.normals, d.viewpoints):
        assert 0 < len(idx) < len(t.points)
        np.testing.assert_array_equal(pts, t.points[idx])
        # on a convex shape HPR keeps (mostly) the points facing the viewpoint; it is approximate
        # at the silhouette (measured 0.88-0.89 on a sphere)
        facing = np.einsum("ij,ij->i", nrm, vp - pts) > 0
        assert facing.mean() > 0.8
    assert dmod.get_dictionary(t) is d  # memory cache
    files = list((tmp_path / "dictionary").glob("*.npz"))
    assert len(files) == 1 and files[0].name.startswith("test_sphere-")
    dmod.clear_memory_cache()
    d2 = dmod.get_dictionary(t)  # from disk
    assert d2 is not d
    for a, b in zip(d.indices, d2.indices):
        np.testing.assert_array_equal(a, b)
    d3 = dmod.get_dictionary(t, num_views=12)  # other parameters: another entry
    assert len(d3) == 12 and d3.key != d.key
    dmod.clear_memory_cache()


def test_key_depends_on_points():
    a, b = _sphere_template(n=800), _sphere_template(n=801)
    args = (18, (0.0, 30.0, 60.0), 3.0, 100.0)
    assert dmod.dictionary_key(a, *args) != dmod.dictionary_key(b, *args)
    assert dmod.dictionary_key(a, *args) == dmod.dictionary_key(_sphere_template(n=800), *args)
