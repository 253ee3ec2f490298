"""Touchdown in TARGET: the vehicle has landed on the bottom, so the
mission's target is reached (``Mission.reached()``, MISSION_ITEM_REACHED).

In TARGET the vehicle never falls slower than about 0.36 m/s (the
controller's slowest symmetric fold, ``shared/control/cascade.py``) until
the bottom stops it, and before the release, held at the surface, it does
not fall at all. So, armed in TARGET: once the estimated descent speed has
been above ``MOVING_MPS`` (released and falling), a speed under
``STILL_MPS`` either way for ``STILL_MS`` is the bottom. In the twin's
target-landing the estimate goes from 0.44 m/s to under 0.05 within 0.3 s
of the impact, with one bounce of 0.12 m/s: touchdown is told about 0.8 s
after it.

``update(now_ms)`` runs every link slot and looks every ``CHECK_MS``, and
only in TARGET: one boxed float a look (the estimator's descent speed).
"""

from roboray.shared import modes as M

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

#: Faster than this (m/s, down) the vehicle is falling: released.
MOVING_MPS = 0.2
#: Slower than this either way (m/s), for STILL_MS, it rests on the bottom.
STILL_MPS = 0.1
STILL_MS = const(500)
#: How often it looks (ms).
CHECK_MS = const(100)
_NAV_VZ = const(1)               # estimator nav[]: descent speed (health.NAV_VZ)
_TICKS_MASK = const(0x3FFFFFFF)  # time.ticks_ms() wraps at 2**30
_TICKS_HALF = const(0x20000000)


class Touchdown:
    """Tells the landing of a dive flown in TARGET, once.

    ``nav`` is ``Navigation`` (its estimator's ``nav`` array), ``modes``
    the ``Modes``. ``landed`` is True from the touchdown until the vehicle
    leaves TARGET or disarms; ``count`` counts touchdowns told.
    """

    def __init__(self, nav, modes):
        self.nav = nav
        self.modes = modes
        self.landed = False
        self.count = 0
        self._next = -1          # when it looks next (ms ticks), -1: at once
        self._falling = False
        self._still_since = -1   # since when it has been still (ms ticks), -1: it moves

    def update(self, now):
        """True once, at the touchdown."""
        if self._next >= 0 and ((now - self._next) & _TICKS_MASK) >= _TICKS_HALF:
            return False         # not yet (the wrapped difference is negative)
        self._next = (now + CHECK_MS) & _TICKS_MASK
        m = self.modes
        if not m.armed or m.mode != M.TARGET:
            self._falling = False
            self._still_since = -1
            self.landed = False
            return False
        if self.landed:
            return False
        v = self.nav.est.nav[_NAV_VZ]
        if v > MOVING_MPS:
            self._falling = True
            self._still_since = -1
            return False
        if not self._falling or not -STILL_MPS < v < STILL_MPS:
            self._still_since = -1
            return False
        if self._still_since < 0:
            self._still_since = now
            return False
        if ((now - self._still_since) & _TICKS_MASK) < STILL_MS:
            return False
        self.landed = True
        self.count += 1
        return True
