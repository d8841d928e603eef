"""The local search on the depth cost (:mod:`catpose.methods.ours.polish`): its moves against
scipy's rotations, and the search on a cost whose minimum is known."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from catpose.geometry import make_T
from catpose.methods.ours.polish import STEPS, moves, polish


def test_moves_are_the_turns_and_shifts_about_each_axis() -> None:
    F = moves(4.0, 0.04)
    assert F.shape == (12, 4, 4)
    for axis in range(3):
        for k, sign in enumerate((1.0, -1.0)):
            turn, shift = F[4 * axis + 2 * k], F[4 * axis + 2 * k + 1]
            rotvec = np.zeros(3)
            rotvec[axis] = np.radians(sign * 4.0)
            np.testing.assert_allclose(turn[:3, :3], Rotation.from_rotvec(rotvec).as_matrix(), atol=1e-15)
            np.testing.assert_array_equal(turn[:3, 3], 0.0)
            np.testing.assert_array_equal(shift[:3, :3], np.eye(3))
            np.testing.assert_allclose(shift[:3, 3], sign * 0.04 * np.eye(3)[axis], atol=0)


class _Bowl:
    """A cost with its minimum at ``T_best``: the rotation angle to it (rad) plus the distance of the
    translations; counts the poses it scored."""

    def __init__(self, T_best: np.ndarray) -> None:
        self.T_best, self.calls = T_best, 0

    def scores(self, T: np.ndarray) -> np.ndarray:
        self.calls += len(T)
        R = np.einsum("ji,bjk->bik", self.T_best[:3, :3], T[:, :3, :3])
        angle = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1))
        return angle + np.linalg.norm(T[:, :3, 3] - self.T_best[:3, 3], axis=1)


@pytest.mark.parametrize("levels", [1, 3, 5])
def test_the_search_goes_downhill_to_the_minimum_within_its_last_step(levels: int) -> None:
    T_best = make_T(Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix(), [0.1, 0.2, -0.1])
    start = make_T(Rotation.from_rotvec([0.05, 0.06, -0.04]).as_matrix(), [0.02, -0.03, 0.01]) @ T_best
    bowl = _Bowl(T_best)
    s0 = float(bowl.scores(start[None])[0])
    T, s = polish(bowl, start, s0, levels, 4.0, 0.04)
    assert s < s0 and np.isclose(s, bowl.scores(T[None])[0])
    assert bowl.calls <= 1 + 12 * STEPS * levels
    if levels == 5:  # the last steps are 0.25 deg and 0.0025: the answer is near the minimum
        assert s < 0.05


def test_no_level_or_no_better_move_keeps_the_pose() -> None:
    T_best = make_T(np.eye(3), [0.0, 0.0, 0.0])
    bowl = _Bowl(T_best)
    T, s = polish(bowl, T_best, 0.0, 0, 4.0, 0.04)
    assert s == 0.0 and T is not None and np.array_equal(T, T_best)
    T, s = polish(bowl, T_best, 0.0, 3, 4.0, 0.04)  # the minimum itself: every move costs more
    assert s == 0.0 and np.array_equal(T, T_best)


@pytest.mark.parametrize(
    "key, value", [("depth_polish_levels", -1), ("depth_polish_deg", 0.0), ("depth_polish_shift", -0.01)]
)
def test_bad_settings_name_their_key(key: str, value: float) -> None:
    from catpose.errors import ConfigError
    from catpose.methods.ours.settings import SelectionSettings

    with pytest.raises(ConfigError, match=f"method.selection.{key}"):
        SelectionSettings(**{key: value})
