"""Open3D, imported safely.

Open3D's Linux wheels link against ``libusb-1.0.so.0``, which slim machines lack. The PyPI
package ``libusb-package`` ships that library; loading it with ``RTLD_GLOBAL`` before Open3D
makes the import work without a system package. Import Open3D only through this module::

    from catpose.o3d import o3d
"""

from __future__ import annotations

import contextlib
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


@contextlib.contextmanager
def max_threads(n: int | None):
    """Limit Open3D's worker threads inside the block (None: leave as is).

    Open3D's parallel reductions (ICP, RANSAC) sum in a scheduling-dependent order, so with more
    than one thread two runs can differ in the last digits and pick a different start or
    candidate; one thread makes them reproducible.
    """
    if n is None:
        yield
        return
    previous = o3d.utility.get_max_threads()
    o3d.utility.set_max_threads(int(n))
    try:
        yield
    finally:
        o3d.utility.set_max_threads(previous)


__all__ = ["o3d", "max_threads"]
