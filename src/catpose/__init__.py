"""catpose: category-level camera pose estimation from depth.

Import root for ``catpose.bench`` (CLI, runner, metrics, tables), ``catpose.methods``
(registration methods), ``catpose.datasets`` (loaders, rendering) and ``catpose.configs``
(Hydra configs). Shared types live in :mod:`catpose.types`.
"""

__version__ = "0.1.0"
