"""Instructions counted on the emulator -> microseconds on a real RP2350.

QEMU (``-icount``) counts the instructions a MicroPython program executes
exactly, but an instruction is no fixed time on the RP2350 (flash XIP
cache misses, multi-cycle loads and stores, taken branches, the FPU). We
turn counts into time with a calibration: run benchmarks whose time on a
real RP2350 at 150 MHz under MicroPython has been *published*, count their
instructions on the emulator, and take picoseconds per instruction
(published seconds / counted instructions), with the spread between
benchmarks as the uncertainty. ``docs/design/board-time-calibration.md``
has the sources, the table and the reasoning.

Each benchmark's ``program`` is MicroPython source written by us from the
published description (no third-party code is copied in). It reads one
global, ``N``, that the harness sets, and runs the measured work exactly
``N`` times and nothing else heavy; it leaves its answer in ``result`` so a
typo shows. :func:`script` prepends ``N = <n>``. Count instructions either
around the work (markers in the harness) or, with a whole-script counter,
as ``count(script(name)) - count(script(name, 0))``: the difference removes
compiling and defining, which the published timings did not include.
``counts[name]`` given to :func:`calibrate` is that figure for
``benchmark.iterations`` runs, the number the published time refers to.

For the perfbench entries the upstream file (``upstream`` below, in the
MicroPython tree the emulator firmware is built from) can be counted
instead, for exact fidelity: run its ``bm_setup(params)`` and count only
the returned ``run()``, as ``tests/perf_bench/benchrun.py`` times only
that.

Everything here is pure arithmetic and data: no emulator is needed to
import it or to test :func:`calibrate`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

#: The RP2350's default system clock (Pico 2 / Pico 2 W, MicroPython rp2 port).
CLOCK_HZ = 150_000_000


@dataclass(frozen=True)
class Figure:
    """One published time for a benchmark's work, on a real RP2350."""

    label: str
    #: Seconds for ``Benchmark.iterations`` runs of the work, at ``clock_hz``.
    seconds: float
    clock_hz: int
    url: str
    author: str
    date: str
    micropython: str
    board: str
    #: How the figure was read off the source (converted from a score, ...).
    derivation: str
    #: A build the project's firmware does not resemble (a reverted
    #: regression, a flash setting since changed): reported, never averaged.
    representative: bool = True

    def seconds_at(self, clock_hz: int) -> float:
        """The time at another clock, assuming time scales with the clock
        (CPU-bound work; flash wait states do not scale exactly)."""
        return self.seconds * self.clock_hz / clock_hz


@dataclass(frozen=True)
class Benchmark:
    name: str
    #: MicroPython source; reads ``N``, does the work ``N`` times, sets ``result``.
    program: str
    #: The number of runs of the work that each figure's time refers to.
    iterations: int
    figures: tuple[Figure, ...]
    #: How close our program is to the one that was timed.
    fidelity: str
    #: Where the benchmark's own code lives, if public: (repo, path, params).
    upstream: tuple[str, str, str] | None = None
    #: False when the published figure's source (and so its exact code)
    #: could not be found: reported, left out of the mean unless asked.
    verified: bool = True
    #: For the CPython self-test: the ``result`` the work leaves (None: not checked).
    expected_result: object = None
    notes: str = ""
    tags: tuple[str, ...] = field(default=())


# --------------------------------------------------------------------------
# The programs (MicroPython source; written for this project).

_FLOAT_POINTS = """\
# pyperformance's "float" benchmark as MicroPython's perf_bench runs it at
# N=150 M=100..440: build 250 points from sin/cos, normalise each, fold them
# with an element-wise maximum. One run = one pass over 250 fresh points.
from math import sin, cos, sqrt

POINTS = 250


class Pt:
    def __init__(self, i):
        s = sin(i)
        self.x = s
        self.y = cos(i) * 3
        self.z = (s * s) / 2

    def normalize(self):
        x = self.x
        y = self.y
        z = self.z
        k = sqrt(x * x + y * y + z * z)
        self.x /= k
        self.y /= k
        self.z /= k

    def maximize(self, o):
        self.x = self.x if self.x > o.x else o.x
        self.y = self.y if self.y > o.y else o.y
        self.z = self.z if self.z > o.z else o.z
        return self


def fold_max(pts):
    best = pts[0]
    for p in pts[1:]:
        best = best.maximize(p)
    return best


def one_pass(count):
    pts = [None] * count
    for i in range(count):
        pts[i] = Pt(i)
    for p in pts:
        p.normalize()
    return fold_max(pts)


result = None
for _ in range(N):
    best = one_pass(POINTS)
    result = (best.x, best.y, best.z)
"""

_NQUEENS = """\
# pyperformance's "nqueens" as MicroPython's perf_bench runs it at N=150:
# every permutation of 6 columns from a pure-Python permutations generator
# (the algorithm given in the CPython itertools docs), kept when no two
# queens share a diagonal (checked with two sets). One run = one board size 6.
QUEENS = 6


def perms(seq):
    pool = tuple(seq)
    n = len(pool)
    idx = list(range(n))
    cyc = list(range(1, n + 1))[::-1]
    yield tuple(pool[i] for i in idx)
    while n:
        for i in reversed(range(n)):
            cyc[i] -= 1
            if cyc[i] == 0:
                idx[i:] = idx[i + 1:] + idx[i:i + 1]
                cyc[i] = n - i
            else:
                j = cyc[i]
                idx[i], idx[-j] = idx[-j], idx[i]
                yield tuple(pool[i] for i in idx)
                break
        else:
            return


def solutions(size):
    cols = range(size)
    for v in perms(cols):
        if size == len(set(v[i] + i for i in cols)) == len(set(v[i] - i for i in cols)):
            yield v


result = None
for _ in range(N):
    result = len(list(solutions(QUEENS)))
"""

_FANNKUCH = """\
# The Computer Language Benchmarks Game's fannkuch (pyperformance version)
# as MicroPython's perf_bench runs it at N=150: walk all permutations of 6
# by rotation (list.insert/list.pop), count prefix reversals (slice
# assignment) for those not starting or ending in place. One run = n of 6.
SIZE = 6


def fannkuch(n):
    count = list(range(1, n + 1))
    most = 0
    last = n - 1
    r = n
    check = 0
    p1 = list(range(n))
    insert = p1.insert
    pop = p1.pop
    while 1:
        if check < 30:
            check += 1
        while r != 1:
            count[r - 1] = r
            r -= 1
        if p1[0] != 0 and p1[last] != last:
            p = p1[:]
            flips = 0
            k = p[0]
            while k:
                p[:k + 1] = p[k::-1]
                flips += 1
                k = p[0]
            if flips > most:
                most = flips
        while r != n:
            insert(r, pop(0))
            count[r] -= 1
            if count[r] > 0:
                break
            r += 1
        else:
            return most


result = None
for _ in range(N):
    result = fannkuch(SIZE)
"""

_FLOAT_MUL_LOOP = """\
# "c = a * b" on two floats, loop included, at module level (globals), as
# typed at the REPL or in main.py. One iteration = one multiply, one boxed
# float allocated, one store, one step of range().
a = 1.5
b = 2.25
c = 0.0
for i in range(N):
    c = a * b
result = c
"""


# --------------------------------------------------------------------------
# The published figures.

_PR15619: dict[str, Any] = dict(
    url="https://github.com/micropython/micropython/pull/15619",
    author="Michael Bell (MichaelBell), comment on 'rp2: Add support for new RP2350 MCU.'",
    date="2024-09-04",
    micropython="v1.24.0-preview (the RP2350 support branch) with PICO_EMBED_XIP_SETUP=1",
    board="RP2350 (board not named); run-perfbench.py N=150 M=440, so 150 MHz",
    derivation="absolute microsecond time, 'after.txt' column of run-perfbench.py -m",
)
_PR19352: dict[str, Any] = dict(
    url="https://github.com/micropython/micropython/pull/19352",
    author="Angus Gratton (projectgus), 'rp2: Revert newlib nano on RP2350, ...'",
    date="2026-06-18",
    board="RP2350 (board not named; default 150 MHz assumed); run-perfbench.py N=168 M=100",
)
_PRE_NANO = "master before #19299 (newlib-nano), i.e. v1.29.0-preview; standard newlib as in v1.28"
_NANO = "master with #19299 (newlib-nano memcpy/memset; reverted by #19353 the same day)"


def _score_to_seconds(score: float, norm: float) -> float:
    """run-perfbench.py: score = 1e6 * norm / time_us, so time = 1e6 * norm / score us."""
    return norm / score


def _perfbench_figures(us_2024: float, norm: float, score_pre_nano: float,
                       score_nano: float) -> tuple[Figure, ...]:
    conv = "score %.2f -> 1e6 * norm(%g) / score us (run-perfbench.py's score formula)"
    return (
        Figure(label="PR15619 after XIP setup (2024)", seconds=us_2024 / 1e6,
               clock_hz=CLOCK_HZ, **_PR15619),
        Figure(label="PR19352 pre-nano (2026)", seconds=_score_to_seconds(score_pre_nano, norm),
               clock_hz=CLOCK_HZ, micropython=_PRE_NANO,
               derivation=conv % (score_pre_nano, norm), **_PR19352),
        Figure(label="PR19352 newlib-nano master (2026, reverted)",
               seconds=_score_to_seconds(score_nano, norm), clock_hz=CLOCK_HZ,
               micropython=_NANO, derivation=conv % (score_nano, norm),
               representative=False, **_PR19352),
    )


_PERFBENCH_FIDELITY = (
    "Same algorithm, operation mix, sizes and data as the upstream file at these "
    "params, rewritten by us; bytecode differs only in small details (local "
    "names, the outer loop at module level instead of run()'s closure loop). "
    "The published times are of run() alone, like our N-loop. For exact "
    "fidelity count the upstream file (field `upstream`).")

BENCHMARKS: dict[str, Benchmark] = {
    b.name: b
    for b in (
        Benchmark(
            name="perfbench_bm_float",
            program=_FLOAT_POINTS,
            iterations=1,
            # bm_float at (100, 100): params (1, 250), norm 1 * 250.
            figures=_perfbench_figures(51853.88, 250, 4833.23, 4362.35),
            fidelity=_PERFBENCH_FIDELITY,
            upstream=("micropython/micropython", "tests/perf_bench/bm_float.py",
                      "bm_params[(100, 100)] = (1, 250)"),
            tags=("float", "objects", "attributes", "allocation"),
        ),
        Benchmark(
            name="perfbench_bm_nqueens",
            program=_NQUEENS,
            iterations=1,
            # bm_nqueens at (100, 25): params (1, 6), norm 1 * 10 ** 3.
            figures=_perfbench_figures(263226.62, 1000, 3708.24, 3124.45),
            fidelity=_PERFBENCH_FIDELITY,
            upstream=("micropython/micropython", "tests/perf_bench/bm_nqueens.py",
                      "bm_params[(100, 25)] = (1, 6)"),
            expected_result=4,
            tags=("generators", "tuples", "sets", "int"),
        ),
        Benchmark(
            name="perfbench_bm_fannkuch",
            program=_FANNKUCH,
            iterations=1,
            # bm_fannkuch at (100, 10): params (6,), norm 6.
            figures=_perfbench_figures(78101.38, 6, 92.60, 84.65),
            fidelity=_PERFBENCH_FIDELITY,
            upstream=("micropython/micropython", "tests/perf_bench/bm_fannkuch.py",
                      "bm_params[(100, 10)] = (6,)"),
            expected_result=10,
            notes="The two representative figures disagree by 19% (78.1 ms in 2024, "
                  "64.8 ms in 2026), where bm_float and bm_nqueens agree within 2.5%.",
            tags=("lists", "slices", "int"),
        ),
        Benchmark(
            name="float_mul_loop",
            program=_FLOAT_MUL_LOOP,
            iterations=1_000_000,
            figures=(
                Figure(
                    label="project reference notes",
                    seconds=7.2e-6 * 1_000_000, clock_hz=CLOCK_HZ,
                    url="(not located: quoted without source in the project's reference notes)",
                    author="unknown", date="unknown", micropython="unknown",
                    board="RP2350 at 150 MHz (same note: RP2040 13.4 us, STM32F405 10.7 us, "
                          "ESP32-S3 5.3 us an iteration)",
                    derivation="7.2 us an iteration x 10^6 iterations, loop included",
                ),
            ),
            fidelity="Low: only the statement 'c = a * b', loop included, is known. Whether "
                     "it ran at module level (globals, as here) or inside a function "
                     "(locals: several times fewer instructions an iteration), the float "
                     "values, and the MicroPython version are not. 7.2 us is ~1080 cycles "
                     "an iteration, plausible only for the module-level form.",
            verified=False,
            expected_result=1.5 * 2.25,
            tags=("float", "allocation", "globals"),
        ),
    )
}


def script(name: str, n: int | None = None) -> str:
    """The program ``name`` as a runnable script doing its work ``n`` times
    (default: the ``iterations`` its published figures refer to)."""
    bench = _lookup(name)
    if n is None:
        n = bench.iterations
    if not isinstance(n, int) or isinstance(n, bool) or n < 0:
        raise ValueError("n must be a non-negative int, not %r" % (n,))
    return "N = %d\n%s" % (n, bench.program)


def _lookup(name: str, benchmarks: dict[str, Benchmark] | None = None) -> Benchmark:
    table = BENCHMARKS if benchmarks is None else benchmarks
    try:
        return table[name]
    except KeyError:
        raise ValueError("unknown benchmark %r (known: %s)"
                         % (name, ", ".join(sorted(table)))) from None


def calibrate(counts: dict[str, int], *, include_unverified: bool = False,
              clock_hz: int = CLOCK_HZ,
              benchmarks: dict[str, Benchmark] | None = None) -> dict:
    """Picoseconds per instruction from instructions counted on the emulator.

    ``counts[name]``: instructions the work of benchmark ``name`` executed
    for ``benchmark.iterations`` runs. Benchmarks absent from ``counts`` are
    not used. Per figure: ps/insn = published seconds (scaled to
    ``clock_hz``) / instructions; per benchmark: the mean over its
    representative figures.

    Overall ``ps_per_insn`` is the unweighted mean over the benchmarks used
    (verified ones, and unverified ones only with ``include_unverified``):
    each benchmark is one independent workload, and weighting by time or by
    instructions would let the longest one decide. The spread is given two
    ways: ``half_range_rel`` = (max - min) / 2 / mean over every
    representative figure of the benchmarks used (build-to-build differences
    included), the quoted uncertainty, conservative with so few
    benchmarks; and ``std_rel``, the sample standard deviation of the
    per-benchmark values over their mean (None with one benchmark).
    ``cpi`` = cycles per instruction at ``clock_hz``.

    Raises ValueError naming the problem: no counts, an unknown benchmark,
    a count that is not a positive integer, or nothing usable.
    """
    table = BENCHMARKS if benchmarks is None else benchmarks
    if not counts:
        raise ValueError("counts is empty: give instructions for at least one of %s"
                         % ", ".join(sorted(table)))
    if clock_hz <= 0:
        raise ValueError("clock_hz must be positive, not %r" % (clock_hz,))
    ps_per_cycle = 1e12 / clock_hz

    per_bench: dict[str, dict] = {}
    for name, insns in counts.items():
        bench = _lookup(name, table)
        if not isinstance(insns, int) or isinstance(insns, bool) or insns <= 0:
            raise ValueError("count for %r must be a positive int of instructions, not %r"
                             % (name, insns))
        figs = []
        for fig in bench.figures:
            ps = fig.seconds_at(clock_hz) * 1e12 / insns
            figs.append({
                "label": fig.label,
                "published_s": fig.seconds,
                "clock_hz": fig.clock_hz,
                "ps_per_insn": ps,
                "cpi": ps / ps_per_cycle,
                "representative": fig.representative,
                "url": fig.url,
            })
        rep = [f["ps_per_insn"] for f in figs if f["representative"]]
        if not rep:
            raise ValueError("benchmark %r has no representative published figure" % name)
        ps = sum(rep) / len(rep)
        per_bench[name] = {
            "instructions": insns,
            "iterations": bench.iterations,
            "verified": bench.verified,
            "ps_per_insn": ps,
            "cpi": ps / ps_per_cycle,
            "us_per_iteration": ps * insns / bench.iterations / 1e6,
            "figures": figs,
        }

    used = sorted(n for n, b in per_bench.items() if b["verified"] or include_unverified)
    if not used:
        raise ValueError("no usable benchmark in counts (%s are unverified; pass "
                         "include_unverified=True to use them)" % ", ".join(sorted(per_bench)))
    values = [per_bench[n]["ps_per_insn"] for n in used]
    mean = sum(values) / len(values)
    spread = [f["ps_per_insn"] for n in used for f in per_bench[n]["figures"]
              if f["representative"]]
    lo, hi = min(spread), max(spread)
    if len(values) > 1:
        var = sum((v - mean) ** 2 for v in values) / (len(values) - 1)
        std_rel: float | None = math.sqrt(var) / mean
    else:
        std_rel = None
    return {
        "clock_hz": clock_hz,
        "ps_per_cycle": ps_per_cycle,
        "benchmarks": per_bench,
        "used": used,
        "ps_per_insn": mean,
        "cpi": mean / ps_per_cycle,
        "min_ps_per_insn": lo,
        "max_ps_per_insn": hi,
        "half_range_rel": (hi - lo) / 2 / mean,
        "std_rel": std_rel,
        "uncertainty": "half_range_rel",
        "method": "unweighted mean over benchmarks of (published s / counted instructions); "
                  "uncertainty = half the range of all representative figures over the mean",
    }


def to_us(instructions: int, calibration: dict) -> float:
    """Microseconds on the RP2350 for ``instructions`` counted on the
    emulator, with a result of :func:`calibrate`."""
    return instructions * calibration["ps_per_insn"] / 1e6
