"""Run board code on CPython and on MicroPython and compare the answers.

The default board (RP2350) computes in single precision and the WebAssembly
port in double, so results are compared with a float32 tolerance, never for
equality.
"""

from __future__ import annotations

import importlib
import math
from array import array
from typing import Any

from .interpreter import MicroPython

#: Relative tolerance: a few float32 ulps (eps = 1.19e-7) after accumulation.
F32_RTOL = 1e-5
#: Absolute floor for values near zero.
F32_ATOL = 1e-6


def plain(o: Any) -> Any:
    """CPython value in the shape ``MicroPython.eval`` returns."""
    if isinstance(o, (list, tuple, array)):
        return [plain(x) for x in o]
    if isinstance(o, dict):
        return {str(k): plain(v) for k, v in o.items()}
    if isinstance(o, (bytearray, memoryview)):
        return bytes(o)
    return o


def differences(a: Any, b: Any, rtol: float = F32_RTOL, atol: float = F32_ATOL, where: str = "") -> list[str]:
    """Every place where ``a`` and ``b`` differ beyond the tolerance."""
    here = where or "result"
    if isinstance(a, bool) or isinstance(b, bool):
        return [] if a == b else ["%s: %r != %r" % (here, a, b)]
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if math.isnan(a) and math.isnan(b):
            return []
        if a == b or abs(a - b) <= atol + rtol * max(abs(a), abs(b)):
            return []
        return ["%s: %r != %r (diff %.3g)" % (here, a, b, abs(a - b))]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return ["%s: length %d != %d" % (here, len(a), len(b))]
        out: list[str] = []
        for i, (x, y) in enumerate(zip(a, b)):
            out += differences(x, y, rtol, atol, "%s[%d]" % (here, i))
        return out
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return ["%s: keys %s != %s" % (here, sorted(a), sorted(b))]
        out = []
        for k in sorted(a):
            out += differences(a[k], b[k], rtol, atol, "%s[%r]" % (here, k))
        return out
    return [] if a == b else ["%s: %r != %r" % (here, a, b)]


def assert_close_f32(a: Any, b: Any, rtol: float = F32_RTOL, atol: float = F32_ATOL) -> None:
    """Raise AssertionError listing every difference beyond float32 tolerance."""
    diffs = differences(plain(a), plain(b), rtol, atol)
    if diffs:
        shown = diffs[:20] + (["... %d more" % (len(diffs) - 20)] if len(diffs) > 20 else [])
        raise AssertionError("CPython and MicroPython differ:\n  " + "\n  ".join(shown))


def run_both(mp: MicroPython, target: str, *args: Any) -> tuple[Any, Any]:
    """Call ``"package.module:function"`` on CPython and on MicroPython."""
    module, func = target.split(":")
    on_cpython = plain(getattr(importlib.import_module(module), func)(*args))
    on_micropython = mp.call(target, *args)
    return on_cpython, on_micropython


def check_same(mp: MicroPython, target: str, *args: Any, rtol: float = F32_RTOL, atol: float = F32_ATOL) -> Any:
    """``run_both`` then ``assert_close_f32``; returns the CPython result."""
    on_cpython, on_micropython = run_both(mp, target, *args)
    assert_close_f32(on_cpython, on_micropython, rtol, atol)
    return on_cpython
