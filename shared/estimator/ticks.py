"""Time stamps of the estimator: microsecond ticks that wrap like ``time.ticks_us``.

MicroPython's ``time.ticks_us()`` counts modulo ``2**30`` on the boards, so a
tick is always a small integer (31-bit) and never a heap-allocated big one.
The estimator never reads a clock: every call carries its tick, and
differences are taken modulo the period, valid for intervals under about
9 minutes.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

TICKS_PERIOD = const(0x40000000)
TICKS_MAX = const(0x3FFFFFFF)
_TICKS_HALF = const(0x20000000)


def ticks_diff(a, b):
    """``a - b`` in microseconds, signed, as ``time.ticks_diff`` computes it."""
    return ((a - b + _TICKS_HALF) & TICKS_MAX) - _TICKS_HALF


def ticks_add(a, delta):
    """The tick ``delta`` microseconds after ``a`` (``delta`` may be negative)."""
    return (a + delta) & TICKS_MAX
