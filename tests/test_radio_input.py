"""Radio input that is not a finite, reachable number (issue 26 item 2): each
handler refuses it with its protocol's answer before it reaches state.

Unit tests on CPython per handler, one on the MicroPython interpreter; the
class test over every handled message on the twin is
``tests/test_radio_input_twin.py``."""
from __future__ import annotations

import math

from roboray.shared.estimator.horizontal import FIX_REJECTED, Horizontal

INF = float("inf")
NAN = float("nan")


def _settled_filter():
    h = Horizontal(history=80, fix_var=1e-6, pos_psd=1e-6, bias_psd=1e-4, tau=0.0)
    h.set_gain(0.0)
    t = 0
    for k in range(200):
        t += 10000
        h.predict(t, 0.01, (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), 0.3)
        if k % 50 == 0:
            h.update(t, t, 0.0, 0.0)
    return h, t


def test_the_horizontal_filter_never_fuses_a_non_finite_fix():
    """A NaN compares false with the gate (``d2 > g2s``): it was fused and the
    position went NaN. Any number of them, enough to pass the re-acquire
    count, leaves the estimate finite."""
    h, t = _settled_filter()
    for bad in (NAN, INF, -INF):
        for _ in range(10):
            assert h.update(t, t, bad, 0.0) == FIX_REJECTED
            assert h.update(t, t, 0.0, bad) == FIX_REJECTED
    assert all(math.isfinite(v) for v in h.x)
    assert all(math.isfinite(v) for v in h.P)
