"""Checks a handler makes on a received field before it reaches state.

A float field off the radio may be NaN or infinite: a NaN compares false
with every bound (``x > limit`` lets it through), and ``int(x)`` raises on
either, killing the link task. Every handler that acts on a float checks it
here first and refuses it with its own protocol's answer (COMMAND_ACK,
MISSION_ACK, PARAM_VALUE, STATUSTEXT: the module of each protocol says
which).

Allocation-free: the checks compare and subtract, no more.
"""


def finite(x):
    """Whether ``x`` is a number: NaN and the infinities give NaN for ``x - x``."""
    return x - x == 0.0


def whole(x, hi):
    """``x`` (a float field meant as an integer) as an int when it is finite,
    whole and within 0..``hi``; else -1."""
    if not 0.0 <= x <= hi:      # (NaN fails: comparisons with it are false)
        return -1
    i = int(x)
    return i if i == x else -1
