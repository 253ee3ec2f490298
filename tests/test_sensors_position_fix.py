"""The tracker model: noise, latency, dropouts, outages, outliers."""

from __future__ import annotations

import numpy as np
import pytest

from roboray.sim.sensors import position_fix, trajectory
from roboray.sim.sensors.position_fix import TrackerSpec
from roboray.sim.sensors.sampling import interpolate


@pytest.fixture(scope="module")
def truth():
    return trajectory.descent(2, trajectory.DescentProfile(flight_s=600.0, rate_hz=100.0))


def test_noise_latency_and_dropouts_match_the_spec(truth):
    spec = TrackerSpec()
    log = position_fix.fixes(truth, spec, np.random.default_rng(1))
    n = len(log.t) + log.lost
    assert n == pytest.approx((truth.t[-1] - truth.t[0]) * spec.rate_hz, abs=1)
    # 610 fixes, 5 % lost: within 3.5 sigma of a binomial
    assert abs(log.lost / n - spec.dropout) < 3.5 * np.sqrt(spec.dropout * (1 - spec.dropout) / n)
    err = np.stack([log.north, log.east], axis=1) - interpolate(truth.t, truth.position_ned[:, :2], log.t)
    assert np.allclose(np.std(err, axis=0), spec.noise_m, rtol=0.15)
    assert np.allclose(np.mean(err, axis=0), 0.0, atol=0.005)
    latency = log.t_arrival - log.t
    assert np.all(np.abs(latency - spec.latency_s) <= spec.latency_jitter_s + 1e-12)
    assert np.all(np.diff(log.t_arrival) >= 0.0)
    assert not log.outlier.any()


def test_outages_and_outliers(truth):
    spec = TrackerSpec(dropout=0.0, outages=((100.0, 30.0),), outlier=0.1, outlier_m=1.0)
    log = position_fix.fixes(truth, spec, np.random.default_rng(2))
    assert not np.any((log.t >= 100.0) & (log.t < 130.0))
    assert log.lost == 30
    err = np.hypot(log.north - np.interp(log.t, truth.t, truth.position_ned[:, 0]),
                   log.east - np.interp(log.t, truth.t, truth.position_ned[:, 1]))
    assert 0.05 < np.mean(log.outlier) < 0.15
    assert np.all(err[log.outlier] > 0.85)
    assert np.all(err[~log.outlier] < 0.15)


@pytest.mark.parametrize("kwargs", [{"rate_hz": 0.0}, {"noise_m": -1.0}, {"dropout": 1.0},
                                    {"latency_s": 0.1, "latency_jitter_s": 0.2}])
def test_bad_spec_is_refused(kwargs):
    with pytest.raises(ValueError, match="TrackerSpec"):
        TrackerSpec(**kwargs)
