"""``catpose.overlay``: the template drawn at the answer and the runner-up on the shipped generated
frame (``examples/data``, a rendered chair with its true pose)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from scipy.ndimage import binary_dilation

import catpose
from catpose.api.overlay import ANSWER_RGB, MASK_RGB, RUNNER_UP_RGB
from catpose.api.result import Registration
from catpose.errors import InvalidInputError
from catpose.geometry import make_T

CAPTION = 22  # the caption band's height, pixels


@pytest.fixture(scope="module")
def chair(repo_root):
    data = np.load(repo_root / "examples" / "data" / "chair_frame.npz")
    frame = catpose.DepthFrame(data["depth"], data["K"], mask=data["mask"])
    return frame, data["T_template_camera"], str(repo_root / "examples" / "data" / "chair.ply")


def _result(T, runner_up=None, margin=float("nan")):
    return Registration(T, 0.0, T[None], np.zeros(1), "ours", 450.0, None, runner_up=runner_up, runner_up_margin=margin)


def _colour(picture: np.ndarray, rgb, k: int) -> np.ndarray:
    """(H, W) bool, frame pixels: where the picture (enlarged ``k`` times) has exactly ``rgb``."""
    hit = (picture[CAPTION:] == np.array(rgb, np.uint8)).all(axis=2)
    return hit.reshape(hit.shape[0] // k, k, hit.shape[1] // k, k).any(axis=(1, 3))


def test_the_true_pose_covers_the_mask_and_a_half_turn_is_drawn_beside_it(chair, tmp_path):
    frame, T_true, ply = chair
    half_turn = make_T(np.diag([-1.0, -1.0, 1.0]), np.zeros(3)) @ T_true  # about the template's z
    out = tmp_path / "new" / "o.png"
    picture = catpose.overlay(frame, _result(T_true, half_turn, 0.01), ply, out)
    h, w = frame.shape
    k = picture.shape[1] // w
    assert k >= 2 and picture.shape == (CAPTION + k * h, k * w, 3) and picture.dtype == np.uint8
    assert np.array_equal(np.asarray(Image.open(out).convert("RGB")), picture)  # the PNG is the picture
    assert [p.name for p in out.parent.iterdir()] == ["o.png"]  # no temporary file left
    # the answer's fill (blended green) lies on the object: its pixels are those of the mask
    body = picture[CAPTION::k, ::k].astype(int)
    greenish = (body[..., 1] > body[..., 0] + 40) & (body[..., 1] > body[..., 2] + 40)
    mask = frame.mask
    iou = (greenish & mask).sum() / (greenish | mask).sum()
    assert iou > 0.8, iou
    assert _colour(picture, RUNNER_UP_RGB, k).sum() > 50  # the runner-up's outline


def test_a_point_cloud_template_and_no_runner_up(chair):
    frame, T_true, ply = chair
    import trimesh

    points = trimesh.load(ply).sample(4000, seed=0)
    picture = catpose.overlay(frame, _result(T_true), points)
    k = picture.shape[1] // frame.shape[1]
    drawn = _colour(picture, ANSWER_RGB, k)
    near_mask = binary_dilation(frame.mask, iterations=2)  # a point on the edge rounds either way
    assert drawn.sum() > 100 and (drawn & near_mask).sum() > 0.98 * drawn.sum()
    assert not _colour(picture, RUNNER_UP_RGB, k).any()
    assert _colour(picture, MASK_RGB, k).sum() > 50  # the mask's outline, where no point covers it


def test_bad_arguments_are_one_line(chair, tmp_path):
    frame, T_true, ply = chair
    with pytest.raises(InvalidInputError, match="pass the DepthFrame"):
        catpose.overlay(np.zeros((4, 4)), _result(T_true), ply)
    with pytest.raises(InvalidInputError, match="pass what catpose.register returned"):
        catpose.overlay(frame, T_true, ply)
