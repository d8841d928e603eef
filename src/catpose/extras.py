"""Optional dependencies: which extra installs a module, and one line naming it when it is missing.

``pip install catpose`` installs what ``bench run`` needs for every method's defaults; the rest
are extras (``pyproject.toml``, docs/install.md), e.g. ``torch`` (ours' Adam solver, GPU path and
batched solver; out of the core so that a plain install pulls no CUDA build). Code imports one
where it needs it; the runner, the builder and the CLI turn a failed import into
:class:`MissingExtra` (:func:`missing_extra`), one line saying what to install.
"""

from __future__ import annotations

import importlib.util

from catpose.errors import CatposeError

#: import name -> (extra, what needs it)
EXTRAS: dict[str, tuple[str, str]] = {
    "torch": (
        "torch",
        "ours' Adam solver (method.optimiser.solver=adam), its GPU path (method.optimiser.device=cuda) "
        "and its batched solver (batch>1 on clouds without a depth image)",
    ),
}


class MissingExtra(CatposeError, ImportError):
    """An optional dependency that is not installed; the message names the extra to install.

    An :class:`ImportError` too, so that a run stops on it (not the sample's fault) instead of
    recording every sample as failed."""

    def __init__(self, module: str) -> None:
        extra, needs = EXTRAS.get(module, (module, ""))
        super().__init__(
            f"{needs or module} needs {module}, which is not installed: "
            f"pip install 'catpose[{extra}]' (from a clone: pip install -e '.[{extra}]'; docs/install.md)"
        )
        self.name = module


def installed(module: str) -> bool:
    """Whether ``module`` can be imported (found on the path; not imported)."""
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def missing_extra(error: BaseException) -> MissingExtra | None:
    """The :class:`MissingExtra` an import error stands for (a module of :data:`EXTRAS` not
    found), or None for any other error."""
    if isinstance(error, MissingExtra):
        return error
    if isinstance(error, ModuleNotFoundError) and error.name:
        top = error.name.split(".")[0]
        if top in EXTRAS:
            return MissingExtra(top)
    return None


def torch_threads() -> int | None:
    """torch's intra-op threads, or None without torch."""
    if not installed("torch"):
        return None
    import torch

    return int(torch.get_num_threads())


def set_torch_threads(n: int | None) -> None:
    """torch's intra-op threads, where torch is installed; without torch nothing uses them. The
    runs' ``threads`` key sets them with the kernels' count (:func:`catpose.kernel_threads.set_threads`)."""
    if n and installed("torch"):
        import torch

        torch.set_num_threads(int(n))
