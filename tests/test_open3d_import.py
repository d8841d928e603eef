"""``import open3d`` works before or without catpose: in the environment ``make setup`` makes
(issue 41: ``catpose.open3d_libusb`` links libusb-package's ``libusb-1.0.so.0`` into Open3D's
folder, where ``libOpen3D.so``'s RUNPATH (``$ORIGIN``) finds it)."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import subprocess
import sys

from catpose.open3d_libusb import LINK_NAME, link_libusb


def test_open3d_imports_in_a_fresh_interpreter_without_catpose():
    probe = "import sys, open3d; assert not [m for m in sys.modules if m.startswith('catpose.') and m != 'catpose.open3d_libusb']"
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, cwd="/")
    assert r.returncode == 0, "make setup runs `python -m catpose.open3d_libusb`; " + r.stderr[-1500:]


def test_the_link_is_made_once_and_loads(tmp_path):
    import libusb_package

    first = link_libusb(tmp_path, force=True)
    link = tmp_path / LINK_NAME
    assert first.startswith("linked") and link.is_symlink()
    assert os.path.samefile(link, libusb_package.get_library_path())
    assert "already links" in link_libusb(tmp_path, force=True)
    ctypes.CDLL(str(link))  # the loader can open it under the name Open3D asks for
