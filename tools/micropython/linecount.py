"""Lines and calls the board code executes, per function, on MicroPython.

A deterministic measure of the board code's cost: the same run gives the
same counts, where wall time on a shared machine varies by tens of
percent. It runs on the interpreter's ``settrace`` build
(``MicroPython(variant="settrace")``), whose ``sys.settrace`` reports a
``call`` event for each Python function entered and a ``line`` event for
each line run. On this interpreter a Python call costs about 0.3-0.8 us and
a line about 0.2 us; native built-ins count nothing, which is the point:
work moved into them is work saved.

    mp = MicroPython(variant="settrace")
    linecount.start(mp)
    ...                       # run board code (the twin: bench sil --count-lines)
    counts = linecount.stop(mp)
    linecount.summary(counts, per=frames)
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

#: MicroPython code: the trace function and its tallies, keyed by
#: "file:function". The tracer's own lines are not traced (the interpreter
#: turns tracing off while a trace function runs).
_TRACER = r'''
import sys
__lc_calls = {}
__lc_lines = {}
def __lc_trace(frame, event, arg, _c=__lc_calls, _l=__lc_lines):
    if event == "line":
        c = frame.f_code
        k = c.co_filename + ":" + c.co_name
        _l[k] = _l.get(k, 0) + 1
    elif event == "call":
        c = frame.f_code
        k = c.co_filename + ":" + c.co_name
        _c[k] = _c.get(k, 0) + 1
    return __lc_trace
'''

#: Where the board code lives on the interpreter's file system.
_LIB = "/lib/roboray/"


def start(mp: Any) -> None:
    """Install the tracer in ``mp`` (a settrace build) and start counting."""
    mp.exec(_TRACER)
    if not mp.eval("hasattr(sys, 'settrace')"):
        raise RuntimeError("this MicroPython build has no sys.settrace: use MicroPython(variant='settrace')")
    mp.exec("sys.settrace(__lc_trace)")


def stop(mp: Any) -> dict[str, tuple[int, int]]:
    """Stop counting; ``{"file:function": (lines, calls)}``, board-code paths
    relative to the package (``firmware/scheduler.py:run_slot``)."""
    mp.exec("sys.settrace(None)")
    lines = mp.eval("__lc_lines")
    calls = mp.eval("__lc_calls")
    out: dict[str, tuple[int, int]] = {}
    for key in set(lines) | set(calls):
        out[key.replace(_LIB, "", 1)] = (int(lines.get(key, 0)), int(calls.get(key, 0)))
    return out


def _group(name: str) -> str:
    # firmware/drivers/x.py -> firmware/drivers; sim/twin/board/x.py -> sim/twin/board
    path = name.split(":", 1)[0]
    parts = path.split("/")
    depth = 3 if parts[0] == "sim" else 2
    return "/".join(parts[:depth]) if len(parts) > depth else path


def summary(counts: dict[str, tuple[int, int]], per: float = 1.0, top: int = 25) -> dict:
    """Totals, folders and the ``top`` functions by lines, divided by ``per``."""
    folders: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0])
    for name, (lines, calls) in counts.items():
        f = folders[_group(name)]
        f[0] += lines
        f[1] += calls
    ranked = sorted(counts.items(), key=lambda kv: (-kv[1][0], -kv[1][1], kv[0]))
    return {
        "lines": round(sum(v[0] for v in counts.values()) / per, 1),
        "calls": round(sum(v[1] for v in counts.values()) / per, 1),
        "by_folder": {k: {"lines": round(v[0] / per, 1), "calls": round(v[1] / per, 1)}
                      for k, v in sorted(folders.items(), key=lambda kv: -kv[1][0])},
        "top": [{"function": k, "lines": round(v[0] / per, 1), "calls": round(v[1] / per, 1)}
                for k, v in ranked[:top]],
    }
