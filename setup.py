"""The wheel carries vehil's data beside its code, under vehil/data: the firmware sources,
the in-repo PlatformIO platform and board, the simavr bridge's sources, the fuzz harness,
the shipped scenarios and vendored libraries (vehil/paths.py reads them from there when
vehil is installed). An editable install reads them from the checkout instead."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

DATA = ("firmware", "platform", "boards", "sim", "fuzz", "scenarios", "third_party")
DATA += ("platformio.ini",)
# Build products and caches that may sit in a checkout's data folders.
IGNORE = shutil.ignore_patterns("build", "__pycache__", "*.pyc", ".pio", "*.o", "*.d")


class BuildPyWithData(build_py):
    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        here = Path(__file__).resolve().parent
        target = Path(self.build_lib) / "vehil" / "data"
        for name in DATA:
            source = here / name
            if source.is_dir():
                shutil.copytree(source, target / name, ignore=IGNORE, dirs_exist_ok=True)
            elif source.exists():
                target.mkdir(parents=True, exist_ok=True)
                shutil.copy2(source, target / name)


setup(cmdclass={"build_py": BuildPyWithData})
