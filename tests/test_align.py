"""The alignment study's estimate (``experiments/alignment/alignment_estimate.py``) and its
command (``align.py``): the hypotheses, the consensus, a table the loader applies, one-line errors."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study import run_study, study_module  # noqa: E402
from test_alignment import l_shape_mesh, write_off  # noqa: E402

from catpose.datasets.alignment import FLIP, read_alignment_table  # noqa: E402
from catpose.datasets.modelnet40 import ModelNet40, ShapeFrame  # noqa: E402
from catpose.geometry import axis_angle_to_R  # noqa: E402

pytestmark = pytest.mark.experiment

est = study_module("experiments/alignment/alignment_estimate.py")
COMMITTED = Path(__file__).resolve().parents[1] / "results" / "alignment"


def align_main(argv: list[str]) -> int:
    return run_study("experiments/alignment/align.py")["main"](argv)


def test_hypotheses_form_a_group(est):
    for flip in (False, True):
        G = est.yaw_flip_hypotheses(flip)
        assert len(G) == (8 if flip else 4)
        for A in G:
            for B in G:
                assert min(np.abs(G - A @ B).max(axis=(1, 2))) < 1e-9


def test_synchronize_recovers_labels_from_noisy_pairwise_costs(est):
    G = est.yaw_flip_hypotheses(True)
    rng = np.random.default_rng(0)
    truth = rng.integers(0, len(G), 7)
    truth[2] = 0
    C = rng.uniform(0.3, 0.5, size=(7, 7, len(G)))
    for i in range(7):
        for j in range(7):
            g = int(np.argmin(np.abs(G - G[truth[j]].T @ G[truth[i]]).max(axis=(1, 2))))
            C[i, j, g] = 0.2 if (i, j) != (0, 1) else 0.6  # one misleading pair
    out = est.synchronize(C, G, reference=2)
    np.testing.assert_array_equal(out["labels"], truth)
    assert (out["confidence"] > 0).all()


def test_estimate_table_recovers_yaws_and_a_flip_of_distinct_instances(est):
    from catpose.datasets.meshio import sample_outer_surface

    v, f = l_shape_mesh()
    v = v - (v.max(0) + v.min(0)) / 2
    G = est.yaw_flip_hypotheses(True)
    truth = [0, 1, 6, 3]  # R_reference_instance labels
    clouds = []
    for k, label in enumerate(truth):
        vk = v * (1.0 + 0.05 * k)  # distinct instances: scaled, resampled
        p, _ = sample_outer_surface(vk @ G[label], f, 600, seed=k)  # raw_k = R_ref_k^T ref
        clouds.append(p / np.linalg.norm(p, axis=1).max())
    out = est.estimate_table(clouds, G, reference=0)
    np.testing.assert_array_equal(out["labels"], truth)
    np.testing.assert_allclose(G[6], est.yaw_rotations(4)[2] @ FLIP)


def test_align_writes_a_table_the_loader_applies(tmp_path, capsys, est):
    v, f = l_shape_mesh()
    root = tmp_path / "ModelNet40"
    write_off(root / "thing/train/thing_0001.off", v, f)
    yaw90 = axis_angle_to_R(np.array([0, 0, 1.0]), np.pi / 2)
    write_off(root / "thing/train/thing_0002.off", v @ yaw90.T * 7.0 + 3.0, f)  # rotated, scaled, moved
    out = tmp_path / "align.csv"
    verified = tmp_path / "verified.csv"  # in another frame (turned by 180 deg): agreement is up to one rotation
    est.write_alignment_table(
        verified,
        [
            {"category": "thing", "instance_id": "thing_0001", "R": est.yaw_rotations(2)[1]},
            {"category": "thing", "instance_id": "thing_0002", "R": est.yaw_rotations(2)[1] @ yaw90.T},
        ],
    )
    assert (
        align_main(
            [
                "dataset=modelnet40",
                f"dataset.root={root}",
                "dataset.categories=[thing]",
                "dataset.split=train",
                "--category",
                "thing",
                "--out",
                str(out),
                "--points",
                "600",
                "--compare",
                str(verified),
            ]
        )
        == 0
    )
    assert "agree 2/2" in capsys.readouterr().out
    assert (tmp_path / "align_vs_verified.csv").read_text().count(",true,") == 2
    table = read_alignment_table(out)
    np.testing.assert_allclose(table[("thing", "thing_0001")], np.eye(3), atol=1e-12)
    np.testing.assert_allclose(table[("thing", "thing_0002")], yaw90.T, atol=1e-12)
    text = out.read_text().splitlines()
    assert text[0].endswith("yaw_deg,flip,chamfer,confidence,verified,note") and ",false," in text[2]
    assert out.with_suffix(".png").stat().st_size > 1000

    ds = ModelNet40(str(root), categories=["thing"], split="train", frame=ShapeFrame(alignment_table=str(out)))
    a, _ = ds.canonical_mesh("thing", "thing_0001")
    b, _ = ds.canonical_mesh("thing", "thing_0002")
    np.testing.assert_allclose(a, b, atol=1e-9)
    raw = ModelNet40(str(root), categories=["thing"], split="train")
    assert not np.allclose(raw.canonical_mesh("thing", "thing_0002")[0], a, atol=1e-3)
    assert ds.observation("thing/thing_0002/v00").info["aligned"] is True

    sheet = tmp_path / "redrawn.png"  # --draw-only redraws the table as it is
    assert (
        align_main(
            [
                "dataset=modelnet40",
                f"dataset.root={root}",
                "dataset.categories=[thing]",
                "dataset.split=train",
                "--category",
                "thing",
                "--out",
                str(out),
                "--draw-only",
                "--sheet",
                str(sheet),
            ]
        )
        == 0
    )
    assert sheet.stat().st_size > 1000


def test_align_reports_a_bad_root_in_one_line(tmp_path, capsys):
    argv = [
        "dataset=modelnet40",
        f"dataset.root={tmp_path / 'none'}",
        "--category",
        "x",
        "--out",
        str(tmp_path / "o.csv"),
    ]
    assert align_main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("align.py: error: ") and "\n" not in err


@pytest.mark.data
@pytest.mark.slow
def test_shared_airplanes_fuselage_axis_matches_the_verified_table(shared_data, tmp_path, est):
    out = tmp_path / "airplane.csv"
    assert (
        align_main(
            [
                "dataset=modelnet40",
                f"dataset.root={shared_data / 'ModelNet40'}",
                "--category",
                "airplane",
                "--out",
                str(out),
                "--points",
                "512",
            ]
        )
        == 0
    )
    found, verified = read_alignment_table(out), read_alignment_table(COMMITTED / "modelnet40_airplane.csv")
    assert set(found) == set(verified)
    np.testing.assert_allclose(found[("airplane", "airplane_0001")], np.eye(3))
    for key, R in found.items():
        # the fuselage axis is found; nose against tail (180 deg) is what the person checks
        assert np.allclose(R, verified[key], atol=1e-9) or np.allclose(
            R, est.yaw_rotations(2)[1] @ verified[key], atol=1e-9
        )


def _one_error_line(capsys) -> str:
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("align.py: error: "), err
    return err[0]


def _things(tmp_path: Path) -> list[str]:
    """Two instances of a category ``thing`` in a ModelNet40 folder: the dataset overrides."""
    v, f = l_shape_mesh()
    root = tmp_path / "ModelNet40"
    write_off(root / "thing/train/thing_0001.off", v, f)
    write_off(root / "thing/train/thing_0002.off", v * 3.0, f)
    return ["dataset=modelnet40", f"dataset.root={root}", "dataset.categories=[thing]", "dataset.split=train"]


@pytest.mark.parametrize(
    "args, said",
    [
        (["dataset=modelnet40", "--category", "airplane", "--icp-distance", "-1"], "--icp-distance -1: pass"),
        (["dataset=modelnet40", "--category", "airplane", "--points", "0"], "--points 0: pass at least 64"),
        (["dataset=synthetic", "--category", "mug"], "dataset synthetic has no alignment table"),
    ],
)
def test_options_are_one_line(tmp_path, capsys, args, said):
    assert align_main([*args, "--out", str(tmp_path / "a.csv")]) == 2
    assert said in _one_error_line(capsys)
    assert not list(tmp_path.iterdir())


def test_a_verified_table_and_its_sheet_are_never_overwritten(tmp_path, capsys):
    """An --out with verified rows sends the estimate to <name>.new.csv (said on stderr), even with
    --force; a verified table's sheet, or a --sheet that is no picture, is refused in one line."""
    table = tmp_path / "thing.csv"
    text = (
        "category,instance_id,yaw_deg,verified,note\nthing,thing_0001,0,true,checked\nthing,thing_0002,0,true,checked\n"
    )
    table.write_text(text)
    args = [*_things(tmp_path), "--category", "thing", "--points", "300", "--no-refine"]
    assert align_main([*args, "--out", str(table), "--force"]) == 0
    err = capsys.readouterr().err
    assert table.read_text() == text  # untouched, even with --force
    new = tmp_path / "thing.new.csv"
    assert "2 row(s) marked verified" in err and str(new) in err and new.is_file()
    unverified = tmp_path / "u.csv"
    unverified.write_text("category,instance_id,yaw_deg\nthing,thing_0001,0\n")
    assert align_main([*args, "--out", str(unverified)]) == 2
    assert "exists; pass another --out, or add --force" in _one_error_line(capsys)
    sheet = tmp_path / "thing.png"
    sheet.write_bytes(b"the checked picture")
    for extra in ([], ["--force"]):
        assert align_main([*args, "--out", str(tmp_path / "new.csv"), "--sheet", str(sheet), *extra]) == 2
        line = _one_error_line(capsys)
        assert "--sheet" in line and "is the contact sheet of" in line and "marked verified" in line
    assert sheet.read_bytes() == b"the checked picture" and not (tmp_path / "new.csv").exists()
    assert align_main([*args, "--out", str(tmp_path / "a.csv"), "--sheet", str(tmp_path / "x.csv")]) == 2
    assert "--sheet" in (line := _one_error_line(capsys)) and "is not a picture file name" in line


def test_table_destination_never_overwrites_verified_rows(tmp_path):
    from catpose.errors import InvalidInputError

    table_destination = run_study("experiments/alignment/align.py")["table_destination"]

    t = tmp_path / "airplane.csv"
    assert table_destination(t) == (t, None)
    t.write_text("category,instance_id,yaw_deg,verified,note\nairplane,a1,0,false,\n")
    with pytest.raises(InvalidInputError, match=r"--out .*airplane.csv exists; .*--force"):
        table_destination(t)
    assert table_destination(t, force=True) == (t, None)
    t.write_text(
        "category,instance_id,yaw_deg,verified,note\nairplane,a1,0,true,checked by eye\nairplane,a2,90,false,\n"
    )
    for force in (False, True):
        path, note = table_destination(t, force)
        assert path == tmp_path / "airplane.new.csv" and "1 row(s) marked verified" in note and str(path) in note
    path.write_text("x")
    assert table_destination(t)[0] == tmp_path / "airplane.new2.csv"
