"""RoboRay MicroPython on the host: the twin's default interpreter.

The board runs RoboRay's own MicroPython configuration
(``tools/roboray_micropython/mpconfig_roboray.h``): floats in the object
word (``MICROPY_OBJ_REPR_C``), single precision, 32-bit words, so a float
result costs no heap. ``tools/roboray_micropython/host/`` builds the same
configuration as MicroPython's unix port for Linux x86, 32-bit and linked
statically (``build.sh``, ``BUILD.txt``); the binary is committed, so
nothing is built or installed to run it. The twin runs the firmware on it
(``--interpreter roboray-unix``) exactly as on MicroPython's stock unix
port (``unix_port.py``): a child process, ``hostlink`` over two pipes. The
firmware then allocates, and its collector runs, as on the board.

``BUILD_PROBE`` is MicroPython code that prints, as one JSON line, the
build an interpreter is: ``interpreter_build()`` runs it here; the other
interpreters run the same code (``runner``).
"""

from __future__ import annotations

import functools
import json
import platform
import struct
import subprocess
from pathlib import Path

HOST_DIR = Path(__file__).resolve().parent.parent / "roboray_micropython" / "host"
#: The committed binary (``tools/roboray_micropython/host/build.sh``).
BINARY = HOST_DIR / "micropython-roboray"

#: MicroPython: prints {"version", "obj_repr", "float_bits", "word_bits"}.
#: A float kept in the object word (REPR_C) allocates nothing when made;
#: a boxed one (REPR_A, the stock ports) takes a heap block. Single
#: precision cannot tell 1 + 2**-40 from 1; double can. (REPR_B, boxed
#: too, is used by no port the project runs on; REPR_D is 64-bit only.)
BUILD_PROBE = """
import sys, gc, json
def __probe(v):
    a = gc.mem_alloc()
    w = v * 3.0 + 1.0
    w = w * v - 2.0
    return gc.mem_alloc() - a
__probe(1.5)
print(json.dumps({"version": "%d.%d.%d" % sys.implementation.version[:3],
                  "obj_repr": "A" if __probe(1.5) > 0 else "C",
                  "float_bits": 64 if 1.0 + 2.0 ** -40 != 1.0 else 32,
                  "word_bits": 32 if sys.maxsize == 2 ** 31 - 1 else 64}))
"""


def float30(x: float) -> float:
    """``x`` as a RoboRay board holds it: a float in the object word
    (``MICROPY_OBJ_REPR_C``, ``py/obj.h``) is the IEEE single with its two
    lowest mantissa bits cut off to tag the word, and read back with bits
    3..2 copied into them (``mp_obj_float_get``): 1 sign, 8 exponent and 21
    stored mantissa bits. So 1/3 is single 0x3eaaaaab but 0x3eaaaaaa here;
    0.1 is 0x3dcccccd but 0x3dcccccf. (NaN is canonical: 0x7fc00000.)"""
    u = struct.unpack("<I", struct.pack("<f", x))[0]
    if x != x:
        u = 0x7FC00000
    u &= ~3 & 0xFFFFFFFF
    u |= (u >> 2) & 3
    return struct.unpack("<f", struct.pack("<I", u))[0]


def parse_probe(output: str) -> dict:
    """The build ``BUILD_PROBE`` printed (its last JSON line in ``output``)."""
    for line in reversed(output.splitlines()):
        if line.startswith("{") and '"obj_repr"' in line:
            return json.loads(line)
    raise RuntimeError("the interpreter did not say which build it is: %s" % output.strip()[-300:])


def available() -> bool:
    """True when the binary is there and this machine can run it (Linux on x86)."""
    return BINARY.is_file() and platform.system() == "Linux" and platform.machine() in ("x86_64", "i386", "i686")


def require() -> None:
    """Raise ``RuntimeError`` saying why the host build cannot run here."""
    if not BINARY.is_file():
        raise RuntimeError("RoboRay MicroPython's host binary is missing (%s): "
                           "run tools/roboray_micropython/host/build.sh" % BINARY)
    if not available():
        raise RuntimeError("RoboRay MicroPython's host build runs on Linux on x86 (this is %s %s): "
                           "use --interpreter micropython" % (platform.system(), platform.machine()))


def command(*args: str) -> list[str]:
    """The command line that runs ``micropython *args`` on the host build."""
    require()
    return [str(BINARY), *args]


@functools.lru_cache(maxsize=1)
def interpreter_build() -> dict:
    """``{"name", "version", "obj_repr", "float_bits", "word_bits"}`` of the host build."""
    out = subprocess.run(command("-c", BUILD_PROBE), capture_output=True, text=True, timeout=60, check=True).stdout
    return dict(name="roboray-unix", **parse_probe(out))


def version() -> str:
    """``major.minor.micro`` of the host build."""
    return interpreter_build()["version"]


__all__ = ["BINARY", "BUILD_PROBE", "float30", "available", "require", "command", "interpreter_build", "version", "parse_probe"]
