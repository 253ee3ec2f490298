"""Install the MicroPython WebAssembly port into a cache outside the repository.

The interpreter comes from the npm registry and runs under Node.js. It is
installed on first use into ``$ROBORAY_CACHE`` (default
``~/.cache/roboray``), one folder per pinned version, so a fresh clone needs
nothing but ``node`` and ``npm`` on the PATH.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
from pathlib import Path

PACKAGE = "@micropython/micropython-webassembly-pyscript"
#: Matches mpy-cross 1.29 and the 1.29 board stubs (same .mpy format).
VERSION = "1.29.0-6"
MIN_NODE_MAJOR = 18


class MicroPythonUnavailable(RuntimeError):
    """Node.js, npm or the interpreter package cannot be had on this machine."""


def cache_dir() -> Path:
    root = os.environ.get("ROBORAY_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "roboray"
    )
    return Path(root)


def node_executable() -> str:
    """Path of a usable ``node``, or MicroPythonUnavailable naming what to install."""
    node = shutil.which("node")
    if node is None:
        raise MicroPythonUnavailable(
            "node not found on PATH: install Node.js >= %d (https://nodejs.org, "
            "or 'apt install nodejs npm') to run board code on MicroPython" % MIN_NODE_MAJOR
        )
    try:
        out = subprocess.run([node, "--version"], capture_output=True, text=True, timeout=30).stdout
        major = int(out.strip().lstrip("v").split(".")[0])
    except (OSError, ValueError, subprocess.TimeoutExpired) as exc:
        raise MicroPythonUnavailable("cannot run %s --version: %s" % (node, exc)) from exc
    if major < MIN_NODE_MAJOR:
        raise MicroPythonUnavailable(
            "node %s is too old: install Node.js >= %d" % (out.strip(), MIN_NODE_MAJOR)
        )
    return node


def interpreter_module(version: str = VERSION) -> Path:
    """Path of ``micropython.mjs``, installing the package first if needed."""
    target = cache_dir() / ("micropython-wasm-" + version)
    mjs = target / "node_modules" / PACKAGE / "micropython.mjs"
    if mjs.is_file():
        return mjs
    npm = shutil.which("npm")
    if npm is None:
        raise MicroPythonUnavailable(
            "npm not found on PATH: install npm (it comes with Node.js) so the "
            "MicroPython interpreter %s@%s can be installed" % (PACKAGE, version)
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    # One installer at a time: pytest-xdist workers and parallel CLI runs
    # share the cache.
    with open(str(target) + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if mjs.is_file():
            return mjs
        staging = Path(str(target) + ".partial")
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir()
        (staging / "package.json").write_text('{"private": true}\n')
        proc = subprocess.run(
            [npm, "install", "--no-audit", "--no-fund", "--loglevel=error",
             "%s@%s" % (PACKAGE, version)],
            cwd=staging, capture_output=True, text=True, timeout=600,
        )
        if proc.returncode != 0 or not (staging / "node_modules" / PACKAGE / "micropython.mjs").is_file():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
            raise MicroPythonUnavailable(
                "npm install %s@%s failed: %s" % (PACKAGE, version, tail[0])
            )
        shutil.rmtree(target, ignore_errors=True)
        staging.rename(target)  # atomic: a half install is never seen as done
    return mjs


#: Builds the package ships beside the plain one, by name.
VARIANTS = ("settrace",)


def variant_wasm(variant: str, version: str = VERSION) -> Path:
    """Path of another build's ``.wasm`` (``settrace``: ``sys.settrace``
    works, at some cost in speed), installing the package first if needed."""
    if variant not in VARIANTS:
        raise ValueError("unknown MicroPython build %r (have: %s)" % (variant, ", ".join(VARIANTS)))
    return interpreter_module(version).with_name("micropython-%s.wasm" % variant)


def host_script() -> Path:
    return Path(__file__).with_name("host.mjs")
