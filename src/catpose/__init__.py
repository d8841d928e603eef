"""catpose: category-level camera pose estimation from depth.

Import root for ``catpose.bench`` (CLI, runner, metrics, tables), ``catpose.methods``
(registration methods), ``catpose.datasets`` (loaders, rendering) and ``catpose.configs``
(Hydra configs). Shared types live in :mod:`catpose.types`.

``catpose.register(observation, template, method="ours", up=None, **options)`` registers one
view (an (N, 3) cloud or a ``catpose.DepthFrame``) to a template in one call;
``catpose.Registrar(template)`` holds a template between calls (:mod:`catpose.api`, imported on
first use so that ``import catpose`` stays light).
"""

from typing import Any

__version__ = "0.1.0"

_API = (
    "DepthFrame",
    "InvalidInputError",
    "NormalisedTemplate",
    "Registrar",
    "Registration",
    "RegistrationFailed",
    "build_method",
    "overlay",
    "register",
)


def __getattr__(name: str) -> Any:
    if name in _API:
        from catpose import api

        return getattr(api, name)
    raise AttributeError(f"module 'catpose' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_API])
