"""The estimator's parts one by one, and the whole on the standard scenario."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roboray.shared.estimator import Estimator, descent_model
from roboray.shared.estimator import health as H
from roboray.shared.estimator.attitude import Attitude
from roboray.shared.estimator.horizontal import FIX_REJECTED, FIX_RESET, FIX_TOO_OLD, FIX_USED, Horizontal
from roboray.shared.estimator.ticks import TICKS_MAX, ticks_add, ticks_diff
from roboray.shared.estimator.vertical import Vertical
from roboray.sim import estimation as E


def test_ticks_wrap_as_micropython_counts_them(micropython):
    micropython.exec("import time")
    for a, b in ((5, TICKS_MAX - 3), (TICKS_MAX - 3, 5), (123456, 123), (0, 1 << 29)):
        assert ticks_diff(a, b) == micropython.eval("time.ticks_diff(%d, %d)" % (a, b))
    assert ticks_add(TICKS_MAX, 1) == micropython.eval("time.ticks_add(%d, 1)" % TICKS_MAX) == 0
    assert ticks_add(0, -1) == TICKS_MAX


def test_one_seed_of_the_standard_scenario_is_near_the_targets():
    # the targets hold for the 10-seed mean (roboray-sim bench estimator);
    # one seed's attitude varies with its calibration residuals (0.5-1.2 deg)
    truth, est, scores = E.run_seed(0)
    assert scores["attitude_rms_deg"] < 1.5
    assert scores["tilt_rms_deg"] < 1.0
    assert scores["depth_rms_m"] < 0.01
    assert scores["vz_rms_mps"] < 0.01
    assert scores["horizontal_rms_m"] < 0.05
    assert scores["valid_fraction"] == 1.0
    # the run crossed the tick counter's wrap (TICK0_US) without a hitch
    assert E.to_ticks(0.0) > E.to_ticks(5.0)


def _descend(vertical, seconds, speed, accel_bias, rng, dt=0.01, every=4, meas_sigma=0.002):
    """A steady descent fed to a vertical filter: ticks, and its estimates."""
    t_us = 0
    vertical.reset(0.0, t_us)
    depth = 0.0
    for k in range(int(seconds / dt)):
        t_us += int(dt * 1e6)
        depth += speed * dt
        vertical.predict(dt, accel_bias + rng.normal(0.0, 0.01))
        if k % every == 0:
            vertical.propagate(t_us)
            vertical.update(depth + rng.normal(0.0, meas_sigma), 0.0, 0.0)
    return depth


def test_vertical_filter_learns_speed_and_accelerometer_bias():
    rng = np.random.default_rng(1)
    v = Vertical()
    depth = _descend(v, 30.0, 0.3, 0.05, rng)
    assert v.x[0] == pytest.approx(depth, abs=0.003)
    assert v.x[1] == pytest.approx(0.3, abs=0.005)
    assert v.x[2] == pytest.approx(0.05, abs=0.005)
    # and knows it: the variances are consistent with those errors
    assert 0.0 < v.P[0] < 0.002 ** 2 and 0.0 < v.P[5] < 0.005 ** 2


def test_vertical_covariance_propagation_composes():
    a, b = Vertical(), Vertical()
    for f in (a, b):
        f.P[:] = [1e-4, 2e-5, -1e-5, 4e-4, -3e-5, 1e-4]
    a.propagate(200000)
    b.propagate(100000)
    b.propagate(200000)
    # F composes exactly; only the O(T^3) and O(T^2) noise terms differ, and little
    assert np.allclose(a.P, b.P, rtol=1e-3, atol=1e-9)


def test_a_delayed_fix_is_applied_at_its_measurement_time():
    """The vehicle drifts north at 10 cm/s (a current the model does not
    know); fixes measured every second arrive 0.5 s late. Applied at their
    measurement time they lead to the truth; applied as if current they would
    lag it by 5 cm."""
    h = Horizontal(history=80, fix_var=1e-6, pos_psd=1e-6, bias_psd=1e-4, tau=0.0)
    h.set_gain(0.0)
    t = 0
    pending = []
    for k in range(3000):
        t += 10000
        h.predict(t, 0.01, (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), 0.3)
        if k % 100 == 0:
            pending.append((t, 0.1 * t * 1e-6))
        if pending and ticks_diff(t, pending[0][0]) >= 500000:
            t_m, north = pending.pop(0)
            result = h.update(t, t_m, north, 0.0)
            assert result in (FIX_USED, FIX_RESET)
    assert h.x[0] == pytest.approx(0.1 * t * 1e-6, abs=0.005)
    assert h.x[2] == pytest.approx(0.1, abs=0.005)
    # too old for the ring: refused and said so
    assert h.update(t, t - 900000, 0.0, 0.0) == FIX_TOO_OLD
    # far off: gated
    assert h.update(t, t - 100000, h.x[0] + 1.0, 0.0) == FIX_REJECTED


def test_descent_model_table_interpolates_and_holds():
    f, g = descent_model.FOLD_DEG, descent_model.GLIDE_GAIN
    assert list(f) == sorted(f) and len(f) == len(g)
    assert descent_model.glide_gain(-10.0) == g[0]
    assert descent_model.glide_gain(200.0) == g[-1]
    assert descent_model.glide_gain(f[1]) == pytest.approx(g[1])
    assert descent_model.glide_gain(0.5 * (f[0] + f[1])) == pytest.approx(0.5 * (g[0] + g[1]))


def test_descent_model_table_is_what_the_scenario_calibrates():
    fitted = E.calibrate_descent_model([E.standard_truth(s) for s in range(10)], taus_s=(descent_model.TAU_S,))
    assert fitted["tau_s"] == descent_model.TAU_S
    assert np.allclose(fitted["glide_gain"], descent_model.GLIDE_GAIN, rtol=0.01, atol=0.002)
    assert fitted["diff_gain"] == pytest.approx(descent_model.DIFF_GAIN, abs=0.002)
    assert fitted["residual_mps"] < 0.004


def test_differential_glide_matches_the_trims():
    """The descent model's differential term against the dynamics model's
    steady glides: (0, 45, 90, 45) glides towards wing 3 at 0.345 of its
    descent speed, (0, 0, 90, 90) towards the folded pair."""
    from roboray.sim.analysis.trim import find_trims
    from roboray.sim.dynamics import Model

    model = Model(None)
    for wings_deg in ((0, 45, 90, 45), (0, 0, 90, 90)):
        wings = np.radians(wings_deg)
        trim = find_trims(model, wings, settle_s=20.0)[0]
        g = [0.0, 0.0]
        descent_model.glide_vector(*wings, g)
        gx, gy = g
        h = trim.horizontal_velocity_body / trim.descent_speed
        # bearings on the circle: with no lateral glide, 180 and -180 are one
        # bearing, and the sign of a zero decides which atan2 returns
        off = np.arctan2(gy, gx) - np.arctan2(h[1], h[0])
        assert abs(np.degrees(np.angle(np.exp(1j * off)))) <= 1.0
        assert np.hypot(gx, gy) == pytest.approx(np.hypot(h[0], h[1]), rel=0.25)


@pytest.mark.parametrize("kwargs,what", [
    ({"fluid_density": 0.0}, "fluid_density"),
    ({"port_position": (0.0, 0.0)}, "port_position"),
    ({"timeouts_us": (1, 2, 3)}, "timeouts_us"),
])
def test_estimator_rejects_a_bad_configuration(kwargs, what):
    with pytest.raises(ValueError, match=what):
        Estimator(**kwargs)


def test_filters_reject_bad_parameters():
    with pytest.raises(ValueError, match="gains"):
        Attitude(kp=0.0)
    with pytest.raises(ValueError, match="accel_band"):
        Attitude(accel_band=1.5)
    with pytest.raises(ValueError, match="positive"):
        Vertical(meas_var=0.0)
    with pytest.raises(ValueError, match="history"):
        Horizontal(history=2)
    with pytest.raises(ValueError, match="calibration"):
        Estimator().set_mag_calibration((0.0, 0.0), (1.0,) * 9)


def test_outputs_exist_before_any_sample_and_after_the_first():
    est = Estimator()
    assert list(est.q) == [1.0, 0.0, 0.0, 0.0]
    assert est.status[H.STATUS_VALID] == 0
    # first sample: levelled from the accelerometer (rolled 30 deg)
    g = 9.80665
    est.imu(1000, 0.0, 0.0, 0.0, 0.0, -g * math.sin(math.radians(30)), -g * math.cos(math.radians(30)))
    assert math.degrees(est.euler[0]) == pytest.approx(30.0, abs=0.01)
    assert est.status[H.STATUS_HEALTH] & H.IMU_OK
    assert est.status[H.STATUS_HEALTH] & H.FAST_ALIGN
    # a repeated or older tick is ignored
    before = list(est.q)
    est.imu(1000, 1.0, 1.0, 1.0, 0.0, 0.0, -g)
    assert list(est.q) == before


def test_reset_starts_the_alignment_again():
    truth = E.standard_truth(1)
    p = E.prepare(truth, 1)
    ns = E.replay_namespace()
    est = ns["build"](p.config)
    for tick in p.calls[:1500]:
        ns["feed"](est, tick)
    assert est.status[H.STATUS_VALID] == 1 and not est.att.fast
    est.reset()
    ns["feed"](est, p.calls[1500])
    h = est.status[H.STATUS_HEALTH]
    assert h & H.FAST_ALIGN and not h & (H.ATTITUDE_VALID | H.DEPTH_VALID | H.POSITION_VALID)
    assert est.status[H.STATUS_VALID] == 0
    # depth comes back with the next pressure sample, attitude after the alignment
    for tick in p.calls[1501:1525]:
        ns["feed"](est, tick)
    h = est.status[H.STATUS_HEALTH]
    assert h & H.DEPTH_VALID and not h & H.ATTITUDE_VALID
    for tick in p.calls[1525:2600]:
        ns["feed"](est, tick)
    assert est.status[H.STATUS_VALID] == 1
    depth_true = np.interp(p.t[2599], truth.t, truth.position_ned[:, 2])
    assert est.nav[H.NAV_DEPTH] == pytest.approx(depth_true, abs=0.01)


def test_the_estimators_inlined_constants_are_the_health_modules():
    from roboray.shared.estimator import estimator as module

    for name in ("IMU_OK", "MAG_OK", "DEPTH_OK", "FIX_OK", "ATTITUDE_VALID", "DEPTH_VALID",
                 "POSITION_VALID", "ACCEL_USED", "SERVOS_MOVING", "FAST_ALIGN"):
        assert getattr(module, "_" + name) == getattr(H, name), name
    assert (H.STATUS_HEALTH, H.STATUS_VALID) == (0, 1)
    assert module._HALF * 2 == module._TMAX + 1 == 1 << 30
