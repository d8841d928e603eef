"""``catpose.register``: one call from an observed view (points or a depth frame) and a template to
a camera pose; ``catpose.Registrar``: a template held between calls.

The application layer. This is the one package under ``src/catpose`` that imports
``catpose.methods`` (the method registry, whose ``configs/method/<name>.yaml`` ``method_cache``
reads without Hydra into the method ``bench run`` builds) and ``catpose.datasets`` (mesh reading,
surface sampling, normal estimation); it never imports the bench or Hydra. Every other module under
``src/catpose`` stays below those packages. ``import catpose`` does not load it: ``catpose.register`` imports it on first use.

Units and frames. The caller's two clouds share one unit (mm, m, ...). The methods work in the
object-normalised unit (the template centred at its bounding-box centre ``c`` and divided by
its radius ``s``, the distance of its farthest point from ``c``), so the template becomes
``(R_up p - c) / s`` (``R_up`` turns the caller's ``template_up`` onto +z, the methods' up
axis) and the observation ``p / s`` (camera frame, origin kept: ours scores visibility from
the camera). A method's answer ``T_n`` maps back to the caller's frames and units as
``R = R_up^T R_n``, ``t = R_up^T (s t_n + c)``.

A depth frame (:class:`~catpose.depth_frame.DepthFrame`) goes through
:func:`catpose.datasets.frame_view.frame_view`, the function ``bench run``'s BOP loader calls for
every instance, so the API and the benchmark see the same problem (modules: ``inputs`` argument
checks and the normalised template, ``observation`` points or a frame in the methods' unit,
``registrar`` the call itself, ``parallel`` ``Registrar.many`` over processes, ``overlay`` the answer drawn on the frame, ``bop`` a BOP
frame and its model as the bench loads them, ``method_cache`` methods built from configs).

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
