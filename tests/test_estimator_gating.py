"""Innovation gates: an outlier pressure, a wrong fix and a disturbed
magnetometer sample are rejected and counted; a persistent disagreement
makes the filter restart on the measurements instead."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from roboray.shared.estimator import health as H
from roboray.sim import estimation as E

SEED = 5
#: Inject 25 s into the run: 15 s after release, in full feathering.
AT_S = 25.0


@pytest.fixture(scope="module")
def scenario():
    truth = E.standard_truth(SEED)
    p = E.prepare(truth, SEED)
    return truth, p


def _replay(p, calls, upto):
    ns = E.replay_namespace()
    est = ns["build"](p.config)
    out = []
    for k in range(upto):
        ns["feed"](est, calls[k])
        out.append((list(est.nav), list(est.status), list(est.innovation), list(est.euler)))
    return est, out


def _first(calls, kind, after_tick):
    for k in range(after_tick, len(calls)):
        for j, ev in enumerate(calls[k]):
            if ev[0] == kind:
                return k, j
    raise AssertionError("no %r call after tick %d" % (kind, after_tick))


def _without(calls, k, j):
    """``calls`` as if the sample at tick ``k``, position ``j`` never came."""
    out = copy.deepcopy(calls)
    del out[k][j]
    return out


def test_an_outlier_pressure_is_rejected(scenario):
    truth, p = scenario
    k, j = _first(p.calls, "p", int(AT_S * 100))
    bad = copy.deepcopy(p.calls)
    bad[k][j][2] += 5000.0  # half a metre of water
    _, clean = _replay(p, _without(p.calls, k, j), k + 30)
    est, hit = _replay(p, bad, k + 30)
    assert hit[-1][1][H.STATUS_DEPTH_REJECTS] == clean[-1][1][H.STATUS_DEPTH_REJECTS] + 1
    assert max(r[2][H.INNOV_DEPTH] for r in hit[k:]) > 1.0
    # the estimate is the one without the sample
    for (nav_c, _, _, _), (nav_h, status, _, _) in zip(clean[k:], hit[k:]):
        assert abs(nav_c[H.NAV_DEPTH] - nav_h[H.NAV_DEPTH]) < 1e-6
        assert status[H.STATUS_HEALTH] & H.DEPTH_OK


def test_a_wrong_fix_is_rejected(scenario):
    truth, p = scenario
    k, j = _first(p.calls, "f", int(AT_S * 100))
    bad = copy.deepcopy(p.calls)
    bad[k][j][2] += 0.6
    bad[k][j][3] -= 0.8  # a metre off
    _, clean = _replay(p, _without(p.calls, k, j), k + 50)
    _, hit = _replay(p, bad, k + 50)
    assert hit[-1][1][H.STATUS_FIX_REJECTS] == clean[-1][1][H.STATUS_FIX_REJECTS] + 1
    assert hit[k][2][H.INNOV_FIX] > 1.0
    for (nav_c, _, _, _), (nav_h, _, _, _) in zip(clean[k:], hit[k:]):
        assert abs(nav_c[H.NAV_NORTH] - nav_h[H.NAV_NORTH]) < 1e-6
        assert abs(nav_c[H.NAV_EAST] - nav_h[H.NAV_EAST]) < 1e-6


def test_fixes_that_keep_disagreeing_restart_the_position(scenario):
    truth, p = scenario
    shifted = copy.deepcopy(p.calls)
    start = int(AT_S * 100)
    for tick in shifted[start:]:
        for ev in tick:
            if ev[0] == "f":
                ev[2] += 1.0  # the tracker's origin moved by a metre north
    est, out = _replay(p, shifted, start + 800)
    rejects = out[-1][1][H.STATUS_FIX_REJECTS]
    assert 3 <= rejects <= 5  # the gate held for the first fixes ...
    north_true = np.interp(p.t[start + 799], truth.t, truth.position_ned[:, 0])
    assert abs(out[-1][0][H.NAV_NORTH] - (north_true + 1.0)) < 0.05  # ... then it followed them
    assert out[-1][1][H.STATUS_HEALTH] & H.FIX_OK


def test_a_disturbed_magnetometer_is_rejected(scenario):
    truth, p = scenario
    _, ref = _replay(p, p.calls, int(AT_S * 100) + 1000)
    # 0.25 s of samples while the servos hold still: a steel object goes by
    start = next(k for k in range(int(AT_S * 100), len(ref) - 100)
                 if not any(r[1][H.STATUS_HEALTH] & H.SERVOS_MOVING for r in ref[k - 40:k + 60]))
    bad = copy.deepcopy(p.calls)
    hits = 0
    for tick in bad[start:]:
        for ev in tick:
            if ev[0] == "m" and hits < 20:
                ev[2] += 0.3  # gauss, along body x
                hits += 1
    _, out = _replay(p, bad, start + 60)
    rejected = out[-1][1][H.STATUS_MAG_REJECTS] - ref[start + 59][1][H.STATUS_MAG_REJECTS]
    # every disturbed sample that got a fusion slot: 0.2 s of them at the
    # estimator's 25 Hz magnetometer fusion (MAG_PERIOD_S)
    assert rejected >= 5
    # heading held by the gyro meanwhile
    yaw_change = np.degrees(np.angle(np.exp(1j * (out[-1][3][2] - ref[start + 59][3][2]))))
    assert abs(yaw_change) < 0.2
