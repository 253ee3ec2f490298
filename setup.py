"""What the package build adds to pyproject.toml: the subpackages, found, and
the identity of the checkout it builds from, recorded in the package.

Subpackages: every folder holding an ``__init__.py`` under the five
top-level folders pyproject.toml maps to ``roboray.*`` (a hand-kept list
left a new one out of the installed package while the checkout worked).

A board built from an installed package (``pip install .``) has no git
checkout to ask, so its start-up line said ``0.1.0 unknown``. The commit and
the dirty flag of ``shared/`` and ``firmware/`` are written into the built
``roboray/tools/flash/`` (tools/flash/buildinfo.py reads and writes them);
an editable install reads git itself.
"""

import importlib.util
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent


#: The top-level folders and the subpackage each becomes (pyproject.toml's package-dir).
TOP = ("shared", "firmware", "sim", "ground", "tools")


def _packages():
    found = []
    for top in TOP:
        for init in sorted((ROOT / top).rglob("__init__.py")):
            rel = init.parent.relative_to(ROOT)
            if "__pycache__" not in rel.parts:
                found.append("roboray." + ".".join(rel.parts))
    return found


def _buildinfo():
    # By path: the package being built is not importable yet.
    spec = importlib.util.spec_from_file_location("_roboray_buildinfo", ROOT / "tools" / "flash" / "buildinfo.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildPyWithRevision(build_py):
    def run(self):
        super().run()
        if not self.dry_run and not getattr(self, "editable_mode", False):
            _buildinfo().write_record(ROOT, Path(self.build_lib) / "roboray" / "tools" / "flash")


setup(packages=_packages(), cmdclass={"build_py": BuildPyWithRevision})
