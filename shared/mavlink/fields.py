"""Checks a handler makes on a received field before it reaches state.

A float field off the radio may be NaN or infinite: a NaN compares false
with every bound (``x > limit`` lets it through), and ``int(x)`` raises on
either, killing the link task. Every handler that acts on a float checks it
here first and refuses it with its own protocol's answer (COMMAND_ACK,
MISSION_ACK, PARAM_VALUE, STATUSTEXT: the module of each protocol says
which).

Allocation-free: the checks compare and subtract, no more. A leaf module
(it imports nothing): the handlers import it without deepening the import
chain, which RoboRay MicroPython's small C stack bounds.
"""

#: The farthest a local x or y goes (m): MISSION_ITEM_INT carries them as
#: metres x 1e7 (``mission.LOCAL_SCALE``) in 32 bits, INT32_MAX / 1e7
#: rounded down; beyond, a download wraps (1000 m read 141.0 m).
LOCAL_MAX_M = 214.7


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
