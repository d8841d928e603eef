"""Open3D importable on its own: ``libusb-1.0.so.0`` placed where Open3D's library finds it.

Open3D's Linux wheels (``open3d-cpu`` 0.20 included) link against ``libusb-1.0.so.0``, which slim
machines lack, so ``import open3d`` fails there with ``ImportError: libusb-1.0.so.0``.
:mod:`catpose.o3d` works around it inside catpose (it loads the library of the PyPI package
``libusb-package`` first); this module fixes the environment itself, so that ``python -c "import
open3d"`` works before or without catpose: it links ``libusb-package``'s library into Open3D's
package folder as ``libusb-1.0.so.0``, where the dynamic loader looks first (``libOpen3D.so``'s
RUNPATH starts with ``$ORIGIN``). Nothing is done when the system provides libusb.

``make setup`` runs it after installing (``python -m catpose.open3d_libusb``); rerun it after
reinstalling Open3D. It never imports Open3D.
"""

from __future__ import annotations

import ctypes.util
import os
import sys
from importlib.util import find_spec
from pathlib import Path

__all__ = ["LINK_NAME", "link_libusb"]

#: the name Open3D's library asks the loader for
LINK_NAME = "libusb-1.0.so.0"


def _open3d_dir() -> Path | None:
    spec = find_spec("open3d")
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def link_libusb(open3d_dir: Path | None = None, force: bool = False) -> str:
    """Link ``libusb-package``'s library into ``open3d_dir`` (default: the installed Open3D's
    folder) as :data:`LINK_NAME`; a sentence saying what was done. ``force``: even where the
    system provides libusb (tests)."""
    if not force and ctypes.util.find_library("usb-1.0"):
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
