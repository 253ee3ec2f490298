"""The horizontal filter without fixes (issue 27): its variance grows with
the descent model's error over the distance it dead-reckons, a fix brings
it back down, and the bookkeeping costs a few floats, on the real
MicroPython interpreter."""

from __future__ import annotations

import pytest

from roboray.shared.estimator.horizontal import FIX_RESET, FIX_USED, MODEL_ERROR

# A level vehicle gliding north at 0.345 x 0.3 m/s (a differential fold's
# glide, descent_model.DIFF_GAIN's order): 20 s of 100 Hz predictions,
# the covariance brought up to date at 10 Hz as the estimator does, after a
# first fix at the release point. ``model_error`` given, or the default.
SCRIPT = """
from roboray.shared.estimator.horizontal import Horizontal
R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
def dive(model_error, seconds=20.0):
    h = Horizontal(tau=0.0, model_error=model_error) if model_error >= 0.0 else Horizontal(tau=0.0)
    h.set_gain(0.0, 0.345, 0.0)
    t = 1000
    h.predict(t, 0.01, R, 0.3)
    first = h.update(t, t, 0.0, 0.0)
    for k in range(int(seconds * 100)):
        t += 10000
        h.predict(t, 0.01, R, 0.3)
        if k % 10 == 9:
            h.propagate(t)
    return h, t, first
"""


def _dive(mp, model_error, seconds=20.0):
    mp.exec(SCRIPT)
    mp.exec("__h, __t, __first = dive(%r, %r)" % (model_error, seconds))
    return mp.eval("(__first, __h.P[0], __h.P[2], __h.x[0], __h.x[1], __t)")


def test_the_variance_grows_with_the_distance_reckoned_and_a_fix_brings_it_down(micropython):
    mp = micropython
    first, p_model, pcc, north, east, t = _dive(mp, -1.0)    # the default, MODEL_ERROR
    assert first == FIX_RESET
    assert north == pytest.approx(0.345 * 0.3 * 20.0, rel=0.01) and abs(east) < 1e-6
    _, p_none, _, _, _, _ = _dive(mp, 0.0)
    # without the model's term: the bias's random walk and the white noise alone
    assert p_none < p_model
    # the term is the model's relative error times the distance, squared
    assert p_model - p_none == pytest.approx((MODEL_ERROR * north) ** 2, rel=0.02)
    # longer, farther: more
    _, p_40, _, north_40, _, _ = _dive(mp, -1.0, 40.0)
    assert north_40 > 1.9 * north and p_40 > 2.0 * p_model
    # a fix where the vehicle is: the variance falls below the fix's own
    # (4e-4 m^2), and the reckoning starts again from there
    mp.exec("__r = __h.update(__t, __t - 200000, __h.x[0] + 0.05, __h.x[1])")
    assert mp.eval("__r") == FIX_USED
    assert mp.eval("__h.P[0]") < 4e-4
    assert mp.eval("__h.reckoned[2]") == 0.0
    # a second of reckoning after it adds only that second's distance
    mp.exec("for __k in range(100):\n    __t += 10000\n    __h.predict(__t, 0.01, R, 0.3)\n__h.propagate(__t)")
    assert mp.eval("__h.P[0]") < 1e-3


def _propagate_bytes(mp, model_error):
    """Heap bytes of a 10 Hz propagate after a step of new distance (measured
    on alloc_bytes' second run: a step is predicted before each run)."""
    mp.exec(SCRIPT)
    mp.exec("__h, __t, __first = dive(%r, 2.0)" % model_error)
    return mp.alloc_bytes("__t += 10000\n__h.predict(__t, 0.01, R, 0.3)\n__h.propagate(__t)") - \
        mp.alloc_bytes("__t += 10000\n__h.predict(__t, 0.01, R, 0.3)")


def test_the_model_term_costs_a_few_floats_and_no_other_allocation(micropython):
    # the floats this interpreter boxes (16 bytes each; none on the board's
    # REPR_C build) are the term's only cost: no list, tuple or object
    with_term = _propagate_bytes(micropython, -1.0)
    without = _propagate_bytes(micropython, 0.0)
    assert micropython.eval("__h.reckoned[2]") > 0.0
    assert with_term - without <= 6 * 16
    assert (with_term - without) % 16 == 0
