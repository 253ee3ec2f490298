"""Health: a sensor that stops updating drops its flag within its time-out
plus 0.12 s (the flags are refreshed by the 10 Hz housekeeping), the
estimate's validity follows its covariance, and a silent IMU is seen
through ``check()`` with the caller's clock at once.

Time-outs (``health.TIMEOUT_*_US``): IMU 50 ms, magnetometer and depth
250 ms, fixes 3 s, each counted from the last usable sample's measurement
time.
"""

from __future__ import annotations

import numpy as np
import pytest

from roboray.shared.estimator import health as H
from roboray.shared.estimator.ticks import TICKS_MAX, ticks_diff
from roboray.sim import estimation as E

SEED = 2
STOP_S = 20.0


@pytest.fixture(scope="module")
def scenario():
    truth = E.standard_truth(SEED)
    return truth, E.prepare(truth, SEED)


def _silence(calls, kind, from_tick):
    """The calls with every ``kind`` sample from ``from_tick`` on removed;
    and the measurement tick of the last one delivered."""
    out = [list(tick) for tick in calls]
    last = None
    for k, tick in enumerate(out):
        if k >= from_tick:
            out[k] = [ev for ev in tick if ev[0] != kind]
        else:
            for ev in tick:
                if ev[0] == kind:
                    last = ev[1]
    return out, last


def _run(p, calls, n):
    ns = E.replay_namespace()
    est = ns["build"](p.config)
    status, cov = [], []
    for k in range(n):
        ns["feed"](est, calls[k])
        status.append(list(est.status))
        cov.append(list(est.cov))
    return est, np.array(status), np.array(cov)


@pytest.mark.parametrize("kind,flag,timeout_us", [
    ("p", H.DEPTH_OK, H.TIMEOUT_DEPTH_US),
    ("m", H.MAG_OK, H.TIMEOUT_MAG_US),
    ("f", H.FIX_OK, H.TIMEOUT_FIX_US),
], ids=["depth", "magnetometer", "fix"])
def test_a_silent_sensor_drops_its_flag_within_its_timeout(scenario, kind, flag, timeout_us):
    truth, p = scenario
    stop = int(STOP_S * 100)
    calls, last_us = _silence(p.calls, kind, stop)
    n = stop + timeout_us // 10000 + 100
    est, status, _ = _run(p, calls, n)
    ticks = [tick[-1][1] for tick in calls[:n]]  # every tick ends with the IMU call
    assert status[stop - 1, 0] & flag
    dropped = next(k for k in range(stop, n) if not status[k, 0] & flag)
    # not before the time-out, and at most 0.12 s after it
    age_us = ticks_diff(ticks[dropped], last_us)
    assert timeout_us <= age_us <= timeout_us + 120000
    assert all(not s & flag for s in status[dropped:, 0])  # and stays down


def test_without_pressure_depth_stops_being_valid_as_its_variance_grows(scenario):
    truth, p = scenario
    stop = int(STOP_S * 100)
    calls, _ = _silence(p.calls, "p", stop)
    est, status, cov = _run(p, calls, stop + 1500)
    # a sample measured before the silence may still be fused a few ticks
    # later (jobs are levelled over steps): monotone from 0.1 s on
    depth_var = cov[stop + 10:, H.COV_DEPTH]
    assert np.all(np.diff(depth_var) >= 0.0)
    invalid = next(k for k in range(stop, len(status)) if not status[k, 0] & H.DEPTH_VALID)
    assert status[invalid, 1] == 0  # and so the estimate as a whole
    assert cov[invalid, H.COV_DEPTH] >= 0.0025 * 0.99
    assert 1.0 < (invalid - stop) / 100.0 < 15.0
    # the pressure comes back: depth is valid again within a second
    est2, status2, _ = _run(p, p.calls[:stop] + calls[stop:invalid + 10] + p.calls[invalid + 10:invalid + 110],
                            invalid + 110)
    assert status2[-1, 0] & H.DEPTH_VALID and status2[-1, 1] == 1


def test_a_silent_imu_is_seen_by_check(scenario):
    truth, p = scenario
    est, status, _ = _run(p, p.calls, int(STOP_S * 100))
    last = p.calls[int(STOP_S * 100) - 1][-1][1]
    assert est.check((last + 40000) & TICKS_MAX) & H.IMU_OK
    assert not est.check((last + 60000) & TICKS_MAX) & H.IMU_OK
    assert est.check((last + 60000) & TICKS_MAX) == est.status[H.STATUS_HEALTH]
    # the attitude held over a planned stall's silence (a flash save: up to
    # 150 ms, and the read that empties the overflowed FIFO) is still valid ...
    assert est.check((last + 240000) & TICKS_MAX) & H.ATTITUDE_VALID
    assert est.status[H.STATUS_VALID] == 1
    # ... not past it
    assert not est.check((last + 260000) & TICKS_MAX) & H.ATTITUDE_VALID
    assert est.status[H.STATUS_VALID] == 0


def test_the_imu_back_after_a_stall_raises_its_flags_at_once(scenario):
    # issue: a log flush at rest (110 ms) left IMU_OK down until the next
    # 10 Hz housekeeping, and with it the attitude: the operator's mode
    # change on the bottom was refused "no attitude estimate" now and then
    truth, p = scenario
    stop = int(STOP_S * 100)
    est, status, _ = _run(p, p.calls, stop)
    last = p.calls[stop - 1][-1][1]
    assert not est.check((last + 160000) & TICKS_MAX) & H.IMU_OK
    for k in range(stop + 17, stop + 20):     # the IMU's next samples, after the stall
        for call in p.calls[k]:
            if call[0] == "i":
                est.imu(*call[1:])
                assert est.status[H.STATUS_HEALTH] & H.IMU_OK and est.status[H.STATUS_VALID] == 1


def test_flight_keeps_every_flag_up(scenario):
    truth, p = scenario
    est, status, cov = _run(p, p.calls, len(p.calls))
    flight = status[int(E.HOLD_S * 100):]
    for flag in (H.IMU_OK, H.DEPTH_OK, H.FIX_OK, H.ATTITUDE_VALID, H.DEPTH_VALID, H.POSITION_VALID):
        assert np.all(flight[:, 0] & flag), hex(flag)
    # the magnetometer is ignored only while the servos move
    assert np.mean(flight[:, 0] & H.MAG_OK > 0) > 0.8
    assert np.all(flight[:, 1] == 1)
    assert np.all(cov[int(E.HOLD_S * 100):] > 0.0)
