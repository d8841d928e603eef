"""Open3D, imported safely.

Open3D's Linux wheels link against ``libusb-1.0.so.0``, which slim machines lack. The PyPI
package ``libusb-package`` ships that library; loading it with ``RTLD_GLOBAL`` before Open3D
makes the import work without a system package. Import Open3D only through this module::

    from catpose.o3d import o3d
"""

from __future__ import annotations

import ctypes
import ctypes.util


def _preload_libusb() -> None:
    if ctypes.util.find_library("usb-1.0"):
        return
    try:
        import libusb_package
    except ImportError:  # the system may still provide it; Open3D's own error is then clear
        return
    path = libusb_package.get_library_path()
    if path is not None:
        ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)


_preload_libusb()

import open3d as o3d  # noqa: E402

o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)

__all__ = ["o3d"]
