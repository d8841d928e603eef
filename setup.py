"""The one thing pyproject.toml cannot declare: ``catpose-open3d-libusb.pth`` at the top of the
wheel, so that it lands in ``site-packages`` and ``import open3d`` finds libusb after a plain
``pip install .`` (:mod:`catpose.open3d_libusb`). Everything else is in pyproject.toml."""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

PTH = Path(__file__).resolve().parent / "src" / "catpose-open3d-libusb.pth"


class BuildPyWithPth(build_py):
    def run(self) -> None:
        super().run()
        self.copy_file(str(PTH), str(Path(self.build_lib) / PTH.name), preserve_mode=False)

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        return [*super().get_outputs(include_bytecode), str(Path(self.build_lib) / PTH.name)]


setup(cmdclass={"build_py": BuildPyWithPth})
