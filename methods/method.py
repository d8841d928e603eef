"""The method interface."""

from __future__ import annotations

from abc import ABC, abstractmethod

from catpose.types import RegistrationProblem, RegistrationResult


class RegistrationMethod(ABC):
    """A registration method: ``register(problem)`` estimates ``T_template_camera``.

    Subclasses take plain typed constructor arguments (never a config object) and must be
    deterministic given the global NumPy / torch / Open3D seeds the runner sets per sample.
    They may raise :class:`~catpose.errors.CatposeError` (or any exception): the runner records
    the sample as failed with the message and goes on.
    """

    @abstractmethod
    def register(self, problem: RegistrationProblem) -> RegistrationResult:
        """Return the estimate of ``T_template_camera``."""
