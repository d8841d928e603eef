"""``import open3d`` works before or without catpose: in the environment ``make setup`` makes
(issue 41: ``catpose.open3d_libusb`` links libusb-package's ``libusb-1.0.so.0`` into Open3D's
folder, where ``libOpen3D.so``'s RUNPATH (``$ORIGIN``) finds it), and after a plain ``pip install``
of the wheel (issue 61: its ``catpose-open3d-libusb.pth`` loads the library before the first
``import open3d``)."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

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


REPO = Path(__file__).resolve().parents[1]
#: stands for Open3D: its import needs the loader to find libusb-1.0.so.0 by name, as libOpen3D.so does
FAKE_OPEN3D = "import ctypes\nctypes.CDLL('libusb-1.0.so.0')\n"


@pytest.mark.slow  # builds the wheel and a venv: ~15 s
def test_a_plain_pip_install_makes_open3d_importable_in_a_fresh_venv(tmp_path):
    """The wheel, installed into a fresh venv with no link made: ``import open3d`` works in a new
    process with and without catpose imported first, and fails once the wheel's .pth is removed.
    Open3D is stood for by a package that opens libusb by name (no download); libusb-package and
    the rest come from this environment, after the venv's own site-packages."""
    if ctypes.util.find_library("usb-1.0"):
        pytest.skip("the system provides libusb-1.0: nothing to find")
    wheel_dir = tmp_path / "w"
    r = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheel_dir), str(REPO)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    venv = tmp_path / "v"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = venv / "bin" / "python"
    site = Path(
        subprocess.check_output(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], text=True
        ).strip()
    )
    wheel = next(wheel_dir.glob("catpose-*.whl"))
    r = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--target", str(site), str(wheel)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    pth = site / "catpose-open3d-libusb.pth"
    assert pth.is_file(), sorted(p.name for p in site.iterdir())
    (site / "open3d").mkdir()
    (site / "open3d" / "__init__.py").write_text(FAKE_OPEN3D)
    (site / "zz-this-env.pth").write_text(
        sysconfig.get_paths()["purelib"] + "\n"
    )  # libusb-package, after the venv's own
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONNOUSERSITE")}

    def imports(code: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [str(python), "-c", code], capture_output=True, text=True, timeout=300, cwd=tmp_path, env=env
        )

    for code in ("import open3d", "import open3d, catpose", "import catpose, open3d"):
        r = imports(code + "; import open3d; print(open3d.__file__)")
        assert r.returncode == 0 and r.stdout.startswith(str(site)), (code, r.stderr[-1500:])
    pth.unlink()  # the control: without the wheel's .pth, the fake Open3D cannot find libusb
    r = imports("import open3d")
    assert r.returncode != 0 and "libusb-1.0.so.0" in r.stderr, r.stderr[-1500:]
