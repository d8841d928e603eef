"""Protocols: which problems a dataset's observations give and how their rows are scored
(``gt_model`` and ``templates``: :mod:`.absolute`; ``relative``: :mod:`.relative`). Imports
:mod:`catpose.bench.scoring` only.

The protocol classes are the package's interface: the configs name them here
(``_target_: catpose.bench.protocols.GtModel``).
"""

from catpose.bench.protocols.absolute import GtModel, Protocol, Templates
from catpose.bench.protocols.relative import Relative

__all__ = ["GtModel", "Protocol", "Relative", "Templates"]
