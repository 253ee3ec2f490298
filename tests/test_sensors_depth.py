"""The MS5837-30BA model: noise, quantisation, rate and timing, conversion
averaging, fluid density and the temperature effect."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from roboray.sim.sensors import depth, trajectory
from roboray.sim.sensors.depth import G, MS5837Spec, Water


def test_pressure_noise_and_level_match_the_datasheet():
    truth = trajectory.still(60.0, depth=5.0, rate_hz=200.0)
    spec = MS5837Spec()
    log = depth.pressure(truth, spec, Water(), np.random.default_rng(1))
    # 1500 samples: the spread within 8 % (4 sigma); 0.2 mbar plus the 0.1 mbar LSB
    assert np.std(log.pressure_pa) == pytest.approx(np.hypot(20.0, 10.0 / np.sqrt(12.0)), rel=0.08)
    expected = Water().pressure(truth.depth_sensor[0])
    assert np.mean(log.true_pressure_pa) == pytest.approx(expected)
    # constant offset (2 mbar, 1 sigma) and the temperature term: well under 1 kPa
    assert abs(np.mean(log.pressure_pa) - expected) < 1000.0
    assert np.allclose(log.pressure_pa / spec.lsb_pa, np.round(log.pressure_pa / spec.lsb_pa))


def test_pressure_every_40_ms_stamped_mid_conversion():
    truth = trajectory.still(5.0, rate_hz=200.0)
    spec = MS5837Spec()
    log = depth.pressure(truth, spec, Water(), np.random.default_rng(2))
    assert spec.rate_hz == pytest.approx(25.0)
    assert np.allclose(np.diff(log.t), 0.040)
    assert np.allclose(log.t_ready - log.t, spec.cycle_s - 0.5 * spec.conversion_s)
    assert 0.0 <= log.t[0] - truth.t[0] < 0.040 + 0.5 * spec.conversion_s


def test_a_sample_averages_its_conversion_window():
    truth = trajectory.descent(0)
    log = depth.pressure(truth, MS5837Spec(), Water(), np.random.default_rng(3))
    at_mid = Water().pressure(np.interp(log.t, truth.t, truth.depth_sensor))
    # the depth is smooth: the window mean is the mid-window value to within a few Pa
    assert np.max(np.abs(log.true_pressure_pa - at_mid)) < 3.0


def test_sea_water_is_denser():
    truth = trajectory.still(10.0, depth=10.0, rate_hz=200.0)
    quiet = replace(MS5837Spec(), noise_rms_pa=0.0, offset_pa=0.0, temp_coeff_pa_per_k=0.0, lsb_pa=1e-6)
    fresh = depth.pressure(truth, quiet, Water(density=depth.FRESH_WATER), np.random.default_rng(4))
    sea = depth.pressure(truth, quiet, Water(density=depth.SEA_WATER), np.random.default_rng(4))
    d = truth.depth_sensor[0]
    assert np.mean(fresh.pressure_pa) == pytest.approx(101325.0 + 1000.0 * G * d)
    assert np.mean(sea.pressure_pa) == pytest.approx(101325.0 + 1025.0 * G * d)
    with pytest.raises(ValueError, match="density"):
        Water(density=0.0)


def test_temperature_effect_is_one_coefficient_times_the_sensor_temperature():
    truth = trajectory.descent(1)
    spec = replace(MS5837Spec(), noise_rms_pa=0.0, offset_pa=0.0, lsb_pa=1e-6, temp_coeff_pa_per_k=5.0)
    water = Water(surface_temperature_c=18.0, gradient_c_per_m=-0.2)
    log = depth.pressure(truth, spec, water, np.random.default_rng(5))
    error = log.pressure_pa - log.true_pressure_pa
    d_temp = log.temperature_c - spec.reference_temperature_c
    coeff = np.sum(error * d_temp) / np.sum(d_temp * d_temp)
    assert np.allclose(error, coeff * d_temp, atol=0.05 * abs(coeff) + 1e-6)
    assert 0.0 < abs(coeff) < 20.0
    # the sensor cools as it sinks, with a lag
    assert log.temperature_c[-1] < log.temperature_c[0] - 1.0
