"""The paper's method (Section III), one module per stage; :class:`Ours` composes them.

=====================  ==========================================================================
module                 stage
=====================  ==========================================================================
``method``             :class:`Ours`: ``register`` lists the stages below
``settings``           the typed option groups (``configs/method/ours.yaml``)
``candidates``         what the stages hand each other (features, candidates)
``solver``             solving every dictionary candidate (``irls``, ``irls_kernel``; ``adam``)
``resting``            the resting directions of the template
``rest_search``        the coarse search over every resting pose x yaw
``check``              the occlusion-aware depth check (``check_kernel``: its compiled costs)
``choice``             the choice among the pool by the depth check, with refinement
``point_choice``       the choice without a depth image (the paper's rules), with refinement
=====================  ==========================================================================
"""

from catpose.methods.ours.candidates import Candidates
from catpose.methods.ours.method import Ours
from catpose.methods.ours.settings import OptimiserSettings, RestingSettings, SelectionSettings

__all__ = ["Candidates", "OptimiserSettings", "Ours", "RestingSettings", "SelectionSettings"]
