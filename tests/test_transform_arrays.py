"""``bench score`` on transform arrays (.npy / .npz of (B, 3, 4) or (B, 4, 4), RPM-Net / DCP /
learning3d style) with an id list, its ``--acc`` / ``--auc`` summary, and BOP scoring on
``models_eval`` when the dataset has it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from catpose.bench.interop import bop_score
from catpose.bench.interop import score as score_cmd
from catpose.bench.interop.transform_arrays import read_transform_arrays
from catpose.bench.run.rundir import write_run
from catpose.errors import DatasetError, InvalidInputError
from catpose.geometry import axis_angle_to_R, invert_T, make_T, random_rotation

CFG = {
    "method": {"name": "ours", "_target_": "x.Y"},
    "dataset": {"name": "toy"},
    "protocol": {"name": "gt_model", "_target_": "catpose.bench.protocols.absolute.GtModel"},
    "seed": 0,
}
ERRORS = [3.0, 12.0, 40.0]


def _gt_run(tmp_path: Path) -> tuple[Path, list[np.ndarray]]:
    rng = np.random.default_rng(3)
    rows, T_gts = [], []
    for i in range(3):
        T_gt = make_T(random_rotation(rng), rng.normal(size=3) + [0, 0, 3])
        T_gts.append(T_gt)
        rows.append(
            {
                "sample_id": f"mug/i{i}/v0",
                "group_id": f"mug/i{i}/v0",
                "obs_id": f"mug/i{i}/v0",
                "category": "mug",
                "instance_id": f"i{i}",
                "template_id": "own",
                "status": "ok",
                "error": "",
                "T_est": T_gt.reshape(-1).tolist(),
                "T_gt": T_gt.reshape(-1).tolist(),
                "err_deg": 0.0,
                "symmetric": False,
                "symmetry_axis": None,
                "score": 0.0,
                "runtime_s": 0.1,
                "info": {},
            }
        )
    return write_run(tmp_path / "gt", rows, CFG), T_gts


def _estimates(T_gts: list[np.ndarray]) -> np.ndarray:
    """(3, 4, 4): the truths turned by ERRORS degrees about z."""
    return np.stack(
        [make_T(axis_angle_to_R(np.array([0, 0, 1.0]), np.radians(e)), np.zeros(3)) @ T for e, T in zip(ERRORS, T_gts)]
    )


def _scored(out: Path) -> list[dict]:
    return [json.loads(x) for x in (out / "samples.jsonl").read_text().splitlines()]


def test_npy_of_3x4_with_an_id_file(tmp_path: Path, capsys):
    run, T_gts = _gt_run(tmp_path)
    np.save(tmp_path / "pred.npy", _estimates(T_gts)[:, :3, :].astype(np.float32))  # RPM-Net's pred_transforms
    (tmp_path / "ids.txt").write_text("# sample ids in the arrays' order\nmug/i0/v0\nmug/i1/v0\n\nmug/i2/v0\n")
    out = tmp_path / "scored"
    assert (
        score_cmd.main(
            [
                str(tmp_path / "pred.npy"),
                "--ids",
                str(tmp_path / "ids.txt"),
                "--gt",
                str(run),
                "--method",
                "rpmnet",
                "--out",
                str(out),
                "--acc",
                "5,15",
                "--auc",
                "30",
            ]
        )
        == 0
    )
    rows = _scored(out)
    np.testing.assert_allclose([r["err_deg"] for r in rows], ERRORS, atol=1e-3)  # float32 files
    printed = capsys.readouterr().out
    table = (out / "summary_thresholds.md").read_text()
    assert table.strip() in printed and "acc5" in table and "acc15" in table and "auc30" in table
    all_row = [ln for ln in table.splitlines() if ln.startswith("| all")][0].split("|")
    assert [float(x) for x in all_row[3:6]] == pytest.approx([1 / 3, 2 / 3, np.mean([0.9, 0.6, 0.0])], abs=1e-3)


def test_npz_forms_ids_scores_and_inverse(tmp_path: Path):
    run, T_gts = _gt_run(tmp_path)
    T = _estimates(T_gts)
    gt_rows, _ = score_cmd.gt_rows_from_run(run)
    ids = np.array(["mug/i2/v0", "mug/i0/v0", "mug/i1/v0"])  # any order: ids say which is which
    order = [2, 0, 1]
    cases = {
        "T.npz": dict(transforms=T[order], ids=ids, scores=np.array([0.2, 0.1, 0.3])),
        "dcp.npz": dict(rotation_ab=T[order, :3, :3], translation_ab=T[order, :3, 3], sample_ids=ids),
        "inv.npz": dict(pred_transforms=np.stack([invert_T(x) for x in T[order]]), ids=ids),
    }
    for name, arrays in cases.items():
        np.savez(tmp_path / name, **arrays)
        preds = read_transform_arrays(tmp_path / name, inverse=name == "inv.npz")
        scored = score_cmd.score_predictions(preds, gt_rows, "ext")
        np.testing.assert_allclose([r["err_deg"] for r in scored], ERRORS, atol=1e-6, err_msg=name)
    assert score_cmd.score_predictions(read_transform_arrays(tmp_path / "T.npz"), gt_rows, "ext")[0]["score"] == 0.1


def test_bad_transform_arrays_are_one_line(tmp_path: Path):
    np.save(tmp_path / "a.npy", np.zeros((2, 3, 3)))
    with pytest.raises(
        InvalidInputError, match=r"a.npy: expected transforms of shape \(B, 3, 4\) or \(B, 4, 4\), got \(2, 3, 3\)"
    ):
        read_transform_arrays(tmp_path / "a.npy", ids=["x", "y"])
    np.save(tmp_path / "b.npy", np.tile(np.eye(4), (2, 1, 1)))
    with pytest.raises(InvalidInputError, match="holds no sample ids: pass --ids FILE"):
        read_transform_arrays(tmp_path / "b.npy")
    with pytest.raises(InvalidInputError, match="2 transforms but 1 sample ids"):
        read_transform_arrays(tmp_path / "b.npy", ids=["x"])
    with pytest.raises(DatasetError, match="--ids .*nope.txt does not exist"):
        read_transform_arrays(tmp_path / "b.npy", ids=tmp_path / "nope.txt")
    bad = np.tile(np.eye(4), (2, 1, 1))
    bad[1, 0, 3] = np.nan
    np.save(tmp_path / "c.npy", bad)
    with pytest.raises(InvalidInputError, match="transform 1 has a NaN"):
        read_transform_arrays(tmp_path / "c.npy", ids=["x", "y"])
    np.savez(tmp_path / "d.npz", foo=np.zeros(3))
    with pytest.raises(InvalidInputError, match="no transforms; name the array one of transforms"):
        read_transform_arrays(tmp_path / "d.npz", ids=["x"])
    (tmp_path / "e.npy").write_text("not numpy")
    with pytest.raises(InvalidInputError, match=r"e.npy: not a NumPy .npy file \(no NumPy header\)"):
        read_transform_arrays(tmp_path / "e.npy", ids=["x"])


def test_evaluation_models_prefers_models_eval(tmp_path: Path):
    cfg = {"root": str(tmp_path), "models_dir": "models"}
    assert bop_score.evaluation_models(cfg) == cfg
    (tmp_path / "models_eval").mkdir()
    (tmp_path / "models_eval" / "models_info.json").write_text("{}")
    assert bop_score.evaluation_models(cfg) == dict(cfg, models_dir="models_eval")
    custom = {"root": str(tmp_path), "models_dir": "my_models"}
    assert bop_score.evaluation_models(custom) == custom  # a folder the user chose is kept


@pytest.mark.data
def test_bop_scoring_reads_models_eval(shared_data: Path, tmp_path: Path):
    """The shared YCB-V frames with a models_eval/ beside models/ (links to the same meshes, a
    models_info.json whose diameters are doubled): the BOP errors use models_eval's."""
    import pandas as pd
    from omegaconf import OmegaConf

    from catpose.bench.interop.prediction_io import read_predictions
    from catpose.bench.run.config import compose

    src = shared_data / "bop" / "ycbv"
    root = tmp_path / "ycbv"
    root.mkdir()
    for item in src.iterdir():
        (root / item.name).symlink_to(item)
    (root / "models_eval").mkdir()
    info = json.loads((src / "models" / "models_info.json").read_text())
    for f in (src / "models").iterdir():
        if f.suffix == ".ply":
            (root / "models_eval" / f.name).symlink_to(f)
    (root / "models_eval" / "models_info.json").write_text(
        json.dumps({k: dict(v, diameter=2 * v["diameter"]) for k, v in info.items()})
    )
    scene = sorted((src / "test").iterdir())[0]
    im, entries = next(iter(json.loads((scene / "scene_gt.json").read_text()).items()))
    e = entries[0]
    (tmp_path / "gt_ycbv-test.csv").write_text(
        "scene_id,im_id,obj_id,score,R,t,time\n"
        f"{int(scene.name)},{im},{e['obj_id']},1,{' '.join(map(str, e['cam_R_m2c']))},{' '.join(map(str, e['cam_t_m2c']))},1\n"
    )
    cfg = OmegaConf.to_container(compose(["dataset=ycbv", f"dataset.root={root}"]).dataset, resolve=True)
    text = bop_score.score_bop(
        read_predictions(tmp_path / "gt_ycbv-test.csv"), cfg, tmp_path, "gt", ["ar_mssd"], ["object"], vsd=False
    )
    assert "models: models_eval/" in text
    errs = pd.DataFrame([json.loads(x) for x in (tmp_path / "bop_errors.jsonl").read_text().splitlines()[1:]])
    hit = errs[errs["matched"]].iloc[0]
    assert (
        hit["diameter"] == pytest.approx(2 * info[str(e["obj_id"])]["diameter"]) and hit["mssd"] < 1e-3
    )  # mm: the ground truth, as rounded in scene_gt.json
