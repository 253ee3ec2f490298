"""The IMU model's statistics match its parameters: noise densities
(spectrum and Allan deviation), bias random walk, turn-on bias spread,
quantisation and range, magnetometer noise, servo field and calibration."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from roboray.sim.sensors import imu, noise, trajectory
from roboray.sim.sensors.imu import DEG, LSM6DSOX_GYRO, ImuSpec, MagSpec
from roboray.sim.truth import quaternion_to_matrix

ATTITUDE = trajectory.euler_to_quaternion(np.array(0.1), np.array(-0.2), np.array(1.0))


@pytest.fixture(scope="module")
def still_log():
    truth = trajectory.still(60.0, quaternion=ATTITUDE, rate_hz=250.0)
    return truth, imu.inertial(truth, ImuSpec(), np.random.default_rng(7))


@pytest.mark.parametrize("sensor", ["gyro", "accel"])
def test_white_noise_density_matches_the_datasheet(still_log, sensor):
    truth, log = still_log
    spec = getattr(ImuSpec(), sensor)
    true = truth.omega_body[0] if sensor == "gyro" else truth.specific_force_imu[0]
    err = getattr(log, sensor) - getattr(log, sensor + "_bias") - true[None, :]
    for axis in range(3):
        density = noise.noise_density(err[:, axis], spec.rate_hz)
        # quantisation adds lsb^2/12 over the band; scale and cross-axis errors are constant here
        expected = np.sqrt(spec.noise_density ** 2 + spec.lsb ** 2 / 12.0 / (spec.rate_hz / 2.0))
        assert density == pytest.approx(expected, rel=0.05)
        taus, adev = noise.allan_deviation(err[:, axis] - err[:, axis].mean(), spec.rate_hz, np.array([0.05, 0.2, 1.0]))
        assert np.allclose(adev, expected / np.sqrt(2.0 * taus), rtol=0.15)


def test_bias_random_walk_grows_as_its_parameter_says():
    spec = ImuSpec()
    truth = trajectory.still(100.0, rate_hz=50.0)
    steps = []
    for seed in range(12):
        log = imu.inertial(truth, spec, np.random.default_rng(seed))
        b = log.gyro_bias
        lag = int(10.0 * spec.gyro.rate_hz)
        steps.append(b[lag::lag] - b[:-lag:lag][: len(b[lag::lag])])
    steps = np.concatenate(steps).ravel()
    # var of a 10 s increment = K^2 * 10 s; 360 samples: +-25 % at 3 sigma
    assert np.var(steps) == pytest.approx(spec.gyro.bias_walk ** 2 * 10.0, rel=0.25)


def test_turn_on_bias_spread_matches_the_datasheet():
    truth = trajectory.still(0.05, rate_hz=1000.0)
    first = np.array([imu.inertial(truth, ImuSpec(), np.random.default_rng(s)).gyro_bias[0] for s in range(300)])
    # 900 draws: std within 10 % (4 sigma)
    assert np.std(first) == pytest.approx(LSM6DSOX_GYRO.turn_on_bias, rel=0.1)
    assert abs(np.mean(first)) < 0.2 * LSM6DSOX_GYRO.turn_on_bias


def test_outputs_are_whole_lsbs_and_saturate_at_the_register_limit():
    spec = ImuSpec()
    truth = trajectory.still(1.0, rate_hz=1000.0)
    fast = replace(truth, omega_body=np.tile([0.0, 0.0, 700.0 * DEG], (len(truth), 1)))
    log = imu.inertial(fast, spec, np.random.default_rng(1))
    counts = log.gyro / spec.gyro.lsb
    assert np.allclose(counts, np.round(counts), atol=1e-6)
    assert np.max(log.gyro[:, 2]) == pytest.approx(32767 * spec.gyro.lsb)  # 573 dps
    assert np.allclose(np.diff(log.t), 1.0 / 208.0)


def test_magnetometer_noise_and_calibration():
    truth = trajectory.still(30.0, quaternion=ATTITUDE, rate_hz=200.0)
    spec = ImuSpec()
    log = imu.magnetometer(truth, spec, np.random.default_rng(3))
    assert np.allclose(np.diff(log.t), 1.0 / 155.0)
    assert np.allclose(np.std(log.field, axis=0), spec.mag.noise_rms, rtol=0.1)
    earth_body = quaternion_to_matrix(np.asarray(ATTITUDE)).T @ spec.earth.ned()
    raw_error = np.linalg.norm(log.field.mean(axis=0) - earth_body)
    calibrated = (log.field - log.offset) @ log.matrix.T
    cal_error = np.linalg.norm(calibrated.mean(axis=0) - earth_body)
    # hard and soft iron move the raw field by ~0.1 gauss; calibration leaves ~1 mgauss
    assert raw_error > 0.03
    assert cal_error < 0.006


def test_servo_current_makes_the_stated_field():
    spec = MagSpec()
    truth = trajectory.still(2.0, rate_hz=200.0)
    moving = replace(truth, wing_rates=np.tile([2.0, 0.0, 0.0, 0.0], (len(truth), 1)))
    log = imu.magnetometer(moving, ImuSpec(mag=spec), np.random.default_rng(4))
    amps = spec.servo_idle_a + spec.servo_run_a * 2.0 / spec.servo_full_speed
    one = spec.servo_gauss_per_a * amps
    idle = spec.servo_gauss_per_a * spec.servo_idle_a
    d = imu.servo_directions(truth.imu_position_body, spec)
    expected = one * d[0] + idle * d[1:].sum(axis=0)
    assert np.allclose(log.servo_field, expected[None, :])
    assert np.linalg.norm(expected) == pytest.approx(0.0051, abs=0.0005)  # about 5 mgauss
