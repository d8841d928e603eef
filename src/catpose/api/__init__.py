"""``catpose.register``: one call from an observed view (points or a depth frame) and a template to
a camera pose; ``catpose.Registrar``: a template held between calls.

The application layer: the one package under ``src/catpose`` that imports ``catpose.methods`` (the
method registry; ``method_cache`` builds a method from ``configs/method/<name>.yaml`` without
Hydra) and ``catpose.datasets`` (meshes, sampling, normals, a frame's view through
:func:`catpose.datasets.frame_view.frame_view` as ``bench run``'s BOP loader); never the bench or
Hydra. ``import catpose`` loads it on first use of ``catpose.register``.

Units and frames: the caller's clouds share one unit; the methods work in the object-normalised
one, the template as ``(R_up p - c) / s`` (``R_up`` turns ``template_up`` onto +z, ``c`` its
bounding-box centre, ``s`` its radius) and the observation as ``p / s`` (camera frame). An answer
``T_n`` maps back as ``R = R_up^T R_n``, ``t = R_up^T (s t_n + c)``.

Example::

    import catpose
    result = catpose.register(points_mm, "mug.ply", up=[0.0, -0.8, -0.6])
    print(result.T_template_camera)   # (4, 4), millimetres: p_template = R p_camera + t
"""

from catpose.api.inputs import NormalisedTemplate
from catpose.api.method_cache import build_method
from catpose.api.overlay import overlay
from catpose.api.register import register
from catpose.api.registrar import UP_HYPOTHESES, Registrar
from catpose.api.result import Registration
from catpose.depth_frame import DepthFrame
from catpose.errors import InvalidInputError, RegistrationFailed

__all__ = [
    "DepthFrame",
    "InvalidInputError",
    "NormalisedTemplate",
    "Registrar",
    "Registration",
    "RegistrationFailed",
    "UP_HYPOTHESES",
    "build_method",
    "overlay",
    "register",
]
