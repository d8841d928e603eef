"""``catpose.register``: one call from an observed view (points or a depth frame) and a template to
a camera pose; ``catpose.Registrar``: a template held between calls.

The application layer: the one package under ``src/catpose`` that imports ``catpose.methods`` and
``catpose.datasets``; never the bench or Hydra. The caller's clouds share one unit; the methods
work in the object-normalised one (:mod:`catpose.api.inputs`), and answers come back in the
caller's frames and unit.

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
