"""Board code stays MicroPython code: compiles, imports, types."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from roboray.tools import boardcheck

BOARD_FILES = boardcheck.board_files()
ROOT = boardcheck.package_root()


def test_there_is_board_code_to_check():
    names = {p.name for p in BOARD_FILES}
    assert "quat.py" in names


@pytest.mark.parametrize("path", BOARD_FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_compiles_with_mpy_cross(path, tmp_path):
    assert boardcheck.mpy_cross(path, tmp_path) == ""
    assert (tmp_path / (path.stem + ".mpy")).stat().st_size > 0


@pytest.mark.parametrize("path", BOARD_FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_uses_only_what_micropython_has(path):
    assert boardcheck.source_problems(path) == []


def test_source_check_catches_cpython_only_code(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text(
        "import numpy\nfrom typing import List\nfrom dataclasses import dataclass\n"
        "@dataclass\nclass A:\n    x: int = 0\n"
        "def f(v):\n    match v:\n        case 1:\n            return f'{v=}'\n"
        "def g(a, b):\n    return f'{a == b}'\n"
    )
    problems = boardcheck.source_problems(bad)
    text = "\n".join(problems)
    assert "imports numpy" in text and "imports typing" in text and "imports dataclasses" in text
    assert "match statement" in text
    assert "dataclass (MicroPython" in text
    assert text.count("f-string") == 1  # f'{a == b}' is a comparison, not a specifier


def test_mpy_cross_reports_a_syntax_error(tmp_path):
    bad = tmp_path / "broken.py"
    bad.write_text("def f(:\n")
    assert "SyntaxError" in boardcheck.mpy_cross(bad, tmp_path)


def test_pyright_passes_against_the_micropython_stubs():
    code, out = boardcheck.pyright()
    assert code == 0, out
    assert "0 errors" in out


def test_every_package_folder_is_installed():
    # setup.py installs every folder with an __init__.py under the folders
    # pyproject.toml maps to roboray.*: a folder of modules without one
    # would be left out of an installed package while the checkout works
    tomllib = pytest.importorskip("tomllib") if sys.version_info >= (3, 11) else pytest.importorskip("tomli")
    mapping = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    assert sorted(mapping.values()) == sorted(("shared", "firmware", "sim", "ground", "tools"))
    assert "TOP = (\"shared\", \"firmware\", \"sim\", \"ground\", \"tools\")" in (ROOT / "setup.py").read_text()
    missing = []
    for folder in mapping.values():
        for d in [ROOT / folder, *(p for p in (ROOT / folder).rglob("*") if p.is_dir())]:
            if "__pycache__" in d.parts or not any(d.glob("*.py")):
                continue
            if not (d / "__init__.py").exists():
                missing.append(str(d.relative_to(ROOT)))
    assert missing == [], "folders of modules without an __init__.py are not installed: %s" % missing
