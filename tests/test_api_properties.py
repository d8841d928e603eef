"""Property-based tests of ``catpose.DepthFrame`` and ``catpose.register``'s inputs (issue 42): any
input is either taken (and then gives a finite rigid pose) or refused with one
:class:`~catpose.errors.InvalidInputError` line; no other exception, no silent nonsense.

The method is a stub that answers the identity at once: what is tested is the API's handling of
its arguments, which happens before any method runs."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra import numpy as hnp  # noqa: E402

import catpose  # noqa: E402
from catpose.errors import InvalidInputError  # noqa: E402
from catpose.types import RegistrationResult  # noqa: E402

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class Identity:
    """A method that answers the identity (inputs are checked before it runs)."""

    def register(self, problem):
        return RegistrationResult(np.eye(4), 0.0)


def _refused_in_one_line(call):
    """Run ``call``; return its result, or None when it was refused in one InvalidInputError line."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return call()
    except InvalidInputError as e:
        assert "\n" not in str(e) and str(e), repr(e)
        return None


floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
dtypes = st.sampled_from(["uint8", "uint16", "int32", "float32", "float64", "bool", "complex64"])


@st.composite
def arrays(draw, shape):
    dtype = np.dtype(draw(dtypes))
    elements = None
    if dtype.kind == "f":
        elements = st.floats(allow_nan=True, allow_infinity=True, width=dtype.itemsize * 8)
    return draw(hnp.arrays(dtype, shape, elements=elements))


@st.composite
def frame_args(draw):
    h, w = draw(st.integers(0, 12)), draw(st.integers(0, 12))
    shape = draw(st.sampled_from([(h, w), (h, w, 1), (h, w, 3), (h,)]))
    depth = draw(arrays(shape))
    K = draw(
        st.one_of(
            st.just(np.array([[10.0, 0, w / 2], [0, 10.0, h / 2], [0, 0, 1]])),
            hnp.arrays(np.float64, st.sampled_from([(3, 3), (9,), (2, 2)]), elements=floats),
        )
    )
    mask = draw(st.one_of(st.none(), arrays(draw(st.sampled_from([(h, w), (w, h), (h, w, 1)])))))
    scale = draw(st.one_of(floats, st.just(1.0), st.just("1"), st.booleans()))
    return depth, K, mask, scale


@SETTINGS
@given(frame_args())
def test_a_depth_frame_is_taken_whole_or_refused_in_one_line(args):
    depth, K, mask, scale = args
    frame = _refused_in_one_line(lambda: catpose.DepthFrame(depth, K, mask, scale))
    if frame is None:
        return
    d = frame.depth_in_unit
    assert d.ndim == 2 and np.isfinite(d).all() and (d >= 0).all() and (d > 0).any()
    assert frame.K.shape == (3, 3) and frame.K[0, 0] > 0 and frame.K[1, 1] > 0 and frame.K[2, 2] == 1
    assert frame.mask is None or (frame.mask.shape == d.shape and frame.object_pixels.any())


@st.composite
def clouds(draw, least=0):
    n = draw(st.integers(least, 40))
    kind = draw(st.sampled_from(["float", "int", "bool", "complex", "wide", "str"]))
    if kind == "str":
        return draw(st.sampled_from(["points.ply", ["a", "b", "c"]]))
    if kind == "wide":
        return draw(hnp.arrays(np.float64, (n, draw(st.integers(1, 5))), elements=floats))
    dtype = {"float": np.float64, "int": np.int64, "bool": np.bool_, "complex": np.complex128}[kind]
    elements = st.floats(-1e6, 1e6) if kind == "float" and draw(st.booleans()) else None
    if kind == "float" and elements is None:
        elements = floats
    return draw(hnp.arrays(dtype, (n, 3), elements=elements))


@SETTINGS
@given(
    observation=clouds(),
    template=st.one_of(clouds(), st.just(np.random.default_rng(0).normal(size=(200, 3)))),
    up=st.one_of(st.none(), hnp.arrays(np.float64, st.sampled_from([(3,), (2,)]), elements=floats)),
    max_points=st.one_of(st.integers(-2, 3000), st.just(True), st.just(2.5)),
)
def test_register_takes_points_or_refuses_them_in_one_line(observation, template, up, max_points):
    kwargs = {"method": Identity(), "up": up, "max_points": max_points}
    r = _refused_in_one_line(lambda: catpose.register(observation, template, **kwargs))
    if r is not None:
        T = r.T_template_camera
        assert T.shape == (4, 4) and np.isfinite(T).all()
        assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)


@SETTINGS
@given(frame_args(), st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True), st.just("10"), st.just(True)))
def test_register_takes_a_frame_or_refuses_it_in_one_line(args, plane_distance):
    depth, K, mask, scale = args
    frame = _refused_in_one_line(lambda: catpose.DepthFrame(depth, K, mask, scale))
    if frame is None:
        return
    template = np.random.default_rng(0).normal(size=(200, 3))
    call = lambda: catpose.register(frame, template, method=Identity(), plane_distance=plane_distance)  # noqa: E731
    r = _refused_in_one_line(call)
    if r is not None:
        assert np.isfinite(r.T_template_camera).all()
