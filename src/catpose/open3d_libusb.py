"""Open3D importable on its own: ``libusb-1.0.so.0`` found however catpose was installed.

Open3D's Linux wheels link against ``libusb-1.0.so.0``, which slim machines lack; the PyPI package
``libusb-package`` (a dependency) ships it, and loaded with ``RTLD_GLOBAL`` before Open3D it
satisfies the link; :mod:`catpose.o3d` calls :func:`preload_libusb`. So that ``import open3d``
works before or without catpose, ``python -m catpose.open3d_libusb`` (``make setup`` runs it; after
a wheel install or reinstalling Open3D, run it once) links it into Open3D's folder, where
``libOpen3D.so``'s RUNPATH looks first. Both do nothing when the system has libusb.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

__all__ = ["LINK_NAME", "link_libusb", "preload_libusb"]

#: the name Open3D's library asks the loader for
LINK_NAME = "libusb-1.0.so.0"


def _system_has_libusb() -> bool:
    import ctypes.util

    return ctypes.util.find_library("usb-1.0") is not None


def preload_libusb() -> None:
    """Load ``libusb-package``'s library globally unless the system provides libusb; silent when
    the package is missing (Open3D's own error then names the library)."""
    import ctypes

    if _system_has_libusb():
        return
    try:
        import libusb_package
    except ImportError:
        return
    path = libusb_package.get_library_path()
    if path is not None:
        ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)


def _open3d_dir() -> Path | None:
    from importlib.util import find_spec

    spec = find_spec("open3d")
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def link_libusb(open3d_dir: Path | None = None, force: bool = False) -> str:
    """Link ``libusb-package``'s library into ``open3d_dir`` (default: the installed Open3D's
    folder) as :data:`LINK_NAME`; a sentence saying what was done. ``force``: even where the
    system provides libusb (tests)."""
    if not force and _system_has_libusb():
        return "the system provides libusb-1.0; nothing to do"
    target_dir = open3d_dir if open3d_dir is not None else _open3d_dir()
    if target_dir is None:
        return "Open3D is not installed; nothing to do"
    try:
        import libusb_package
    except ImportError:
        return "libusb-package is not installed (pip install libusb-package); Open3D may not import"
    lib = libusb_package.get_library_path()
    if lib is None:
        return "libusb-package has no library for this platform; install libusb-1.0 from the system"
    link = Path(target_dir) / LINK_NAME
    if link.is_symlink() and Path(os.readlink(link)) == Path(lib):
        return f"{link} already links {lib}"
    tmp = link.with_name(f".{LINK_NAME}.{os.getpid()}.tmp")
    tmp.unlink(missing_ok=True)
    tmp.symlink_to(lib)
    os.replace(tmp, link)  # atomic: a concurrent import sees the old link or the new one
    return f"linked {link} -> {lib}"


if __name__ == "__main__":  # python -m catpose.open3d_libusb
    print(f"catpose.open3d_libusb: {link_libusb()}")
    sys.exit(0)
