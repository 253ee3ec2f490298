"""VELOCITY mode with the estimator in the loop: the horizontal velocity
reaches its set point and holds it; the descent speed follows its command;
ATTITUDE holds a tilt."""

from __future__ import annotations

import numpy as np
import pytest

from roboray.sim import flight as F


@pytest.fixture(scope="module")
def north():
    return F.fly(F.FlightSpec(mode="velocity", velocity=(0.10, 0.0, 0.0), heading_deg=-60.0, seed=2))


def test_reaches_a_tenth_of_a_metre_per_second_north_within_10_s(north):
    m = north.metrics
    assert m["estimator"] == "board estimator"
    assert m["settling_time_s"] is not None and m["settling_time_s"] <= 10.0, m
    # the true velocity, not the estimate
    after = north.t >= m["settling_time_s"]
    assert np.mean(north.velocity[after, 0]) == pytest.approx(0.10, abs=0.01)


def test_holds_it_within_two_centimetres_per_second_rms(north):
    m = north.metrics
    assert m["velocity_rms_error_mps"] <= 0.02, m
    assert abs(m["velocity_mean_mps"][1]) < 0.01
    assert north.metrics["landed"]


def test_descent_speed_follows_its_command_within_10_percent():
    flight = F.fly(F.FlightSpec(mode="velocity", velocity=(0.0, 0.05, 0.39), depth=8.0, seed=3))
    m = flight.metrics
    assert abs(m["descent_speed_error"]) <= 0.10, m
    # a command away from the default fold: the symmetric 45 deg fall descends at 0.445 m/s
    assert m["descent_speed_mps"] < 0.42


def test_attitude_mode_holds_a_tilt():
    flight = F.fly(F.FlightSpec(mode="attitude", attitude_deg=(2.0, -1.0), depth=6.0, seed=4))
    m = flight.metrics
    assert m["attitude_rms_error_deg"] < 1.0, m
    assert 1.5 < m["max_tilt_deg"] < 10.0
