"""The disk cache (:mod:`catpose.disk_cache`): what it stores comes back with the same bits, a
corrupt or foreign entry is rebuilt, two processes writing one entry leave a whole file, an
unwritable folder costs only the rebuild; the template data ours loads from it gives the same
registration as data built in memory."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys

import numpy as np
import pytest

from catpose import disk_cache


@dataclasses.dataclass(frozen=True)
class _Pair:
    a: np.ndarray
    n: int


_TYPES = {f"{_Pair.__module__}:{_Pair.__qualname__}": _Pair}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CATPOSE_CACHE_DIR", str(tmp_path))
    return tmp_path


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return (
        a.dtype == b.dtype
        and a.shape == b.shape
        and a.tobytes(order="A") == b.tobytes(order="A")
        and (a.flags.f_contiguous == b.flags.f_contiguous)
    )


def test_pack_and_unpack_keep_every_bit_and_the_memory_order():
    rng = np.random.default_rng(0)
    sparse = np.zeros((300, 200), np.float32, order="F")
    sparse[rng.integers(0, 300, 500), rng.integers(0, 200, 500)] = rng.random(500, dtype=np.float32)
    dense = rng.normal(size=(7, 3))
    obj = (5, [dense, None, "lps"], _Pair(sparse, 3), {"k": np.arange(4)}, 0.1 + 0.2)
    packed = disk_cache.pack(obj)
    assert any(k.endswith("i") for k in packed)  # the sparse grid travels as its non-zero values
    back = disk_cache.unpack(packed, _TYPES)
    assert back[0] == 5 and back[1][1] is None and back[1][2] == "lps" and back[4] == 0.1 + 0.2
    assert _same(back[1][0], dense) and _same(back[2].a, sparse) and back[2].a.flags.f_contiguous
    assert _same(back[3]["k"], np.arange(4))
    with pytest.raises(KeyError):  # only allow-listed dataclasses are rebuilt
        disk_cache.unpack(packed, {})


def test_an_entry_is_built_once_then_read(cache):
    calls = []

    def build():
        calls.append(1)
        return {"x": np.arange(10.0)}

    for _ in range(3):
        out = disk_cache.cached("t", "key-1", build, disk_cache.pack, disk_cache.unpack, label="tmpl/1")
        assert _same(out["x"], np.arange(10.0))
    assert len(calls) == 1
    (entry,) = (cache / "t").iterdir()
    assert entry.name.startswith("tmpl_1-") and entry.suffix == ".npz"


@pytest.mark.parametrize("damage", ["truncate", "flip", "garbage", "other_key"])
def test_a_corrupt_or_foreign_entry_is_rebuilt_and_replaced(cache, damage):
    build_count = []

    def build():
        build_count.append(1)
        return np.arange(5000.0)

    disk_cache.cached("t", "k", build, lambda a: {"v": a}, lambda z: z["v"])
    (path,) = (cache / "t").iterdir()
    data = bytearray(path.read_bytes())
    if damage == "truncate":
        path.write_bytes(bytes(data[: len(data) // 2]))
    elif damage == "flip":
        data[len(data) // 2] ^= 0xFF
        path.write_bytes(bytes(data))
    elif damage == "garbage":
        path.write_bytes(b"not a zip file")
    else:  # an entry of another key under this name (a hash collision, a copied file)
        np.savez(path, __key__=np.array("another key"), v=np.zeros(5000))
    out = disk_cache.cached("t", "k", build, lambda a: {"v": a}, lambda z: z["v"])
    assert np.array_equal(out, np.arange(5000.0)) and len(build_count) == 2
    assert np.array_equal(disk_cache.load("t", "k")["v"], np.arange(5000.0))  # replaced by a good entry


def test_an_unwritable_cache_folder_costs_only_the_rebuild(tmp_path, monkeypatch):
    if os.geteuid() == 0:
        monkeypatch.setenv("CATPOSE_CACHE_DIR", "/proc/catpose-cache")  # not creatable, even for root
    else:
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        monkeypatch.setenv("CATPOSE_CACHE_DIR", str(ro))
    assert disk_cache.store("t", "k", {"v": np.ones(3)}) is False
    out = disk_cache.cached("t", "k", lambda: np.ones(3), lambda a: {"v": a}, lambda z: z["v"])
    assert np.array_equal(out, np.ones(3))


def test_two_processes_writing_one_entry_leave_a_whole_file(cache):
    writer = (
        "import numpy as np, sys\n"
        "from catpose import disk_cache\n"
        "v = np.full(200000, float(sys.argv[1]))\n"
        "for _ in range(15):\n"
        "    disk_cache.store('t', 'shared', {'v': v})\n"
        "    z = disk_cache.load('t', 'shared')\n"
        "    assert z is not None and len(set(z['v'].tolist())) == 1, 'torn entry'\n"
    )
    env = dict(os.environ, CATPOSE_CACHE_DIR=str(cache))
    procs = [subprocess.Popen([sys.executable, "-c", writer, str(i)], env=env) for i in (1, 2)]
    assert [p.wait(timeout=300) for p in procs] == [0, 0]
    v = disk_cache.load("t", "shared")["v"]
    assert v[0] in (1.0, 2.0) and (v == v[0]).all()
    assert [p.name for p in (cache / "t").iterdir()] == [next((cache / "t").iterdir()).name]  # no temp files left


def test_the_key_changes_with_the_code():
    assert disk_cache.fingerprint("catpose.lru") != disk_cache.fingerprint("catpose.kabsch")
    assert disk_cache.fingerprint("catpose.lru") == disk_cache.fingerprint("catpose.lru")


@pytest.mark.usefixtures("one_torch_thread")
def test_ours_gives_the_same_answer_from_disk_as_from_memory(cache):
    from catpose.datasets.meshio import sample_outer_surface, sampled_template
    from catpose.datasets.render import estimate_normals
    from catpose.datasets.shapes import make_shape
    from catpose.methods import dictionary, dictionary_features
    from catpose.methods.ours import Ours
    from catpose.types import RegistrationProblem

    mesh = make_shape("chair", np.random.default_rng(3))
    template = sampled_template(np.asarray(mesh.vertices), np.asarray(mesh.faces), "disk/chair", "chair")
    points, _ = sample_outer_surface(mesh.vertices, mesh.faces, 1500, 1)
    view = points[points[:, 0] > 0] + np.array([0.0, 0.0, 3.0])
    problem = RegistrationProblem("s", "chair", view, estimate_normals(view, 0.1), np.array([0, 0, 1.0]), template)

    def fresh_answer():
        dictionary.clear_memory_cache()
        dictionary_features.clear()
        return Ours().register(problem).T_template_camera

    built = fresh_answer()  # computed, then written
    assert {p.name for p in cache.iterdir()} >= {"dictionary", "dictionary_features"}
    loaded = fresh_answer()  # read back in a fresh memory cache
    assert np.array_equal(built, loaded)
