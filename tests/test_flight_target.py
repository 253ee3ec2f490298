"""TARGET mode with the estimator in the loop: from a release at the
surface onto a 10 m deep bottom, the vehicle lands within 0.25 m of a
target 2 m away, whichever way the target lies from its initial heading.

2 m from 10 m is inside the reach: the allocation table's best glide ratio
is 0.49 (between two wings) and 0.34 towards one, 3.4-4.9 m from 10 m."""

from __future__ import annotations

import math

import pytest

from roboray.shared.control import allocation_table as T
from roboray.sim import flight as F

HEADING_DEG = 30.0


def test_two_metres_from_ten_is_within_the_reach():
    assert 10.0 * min(T.RATIO_MAX[(T.N_FOLD - 1) * T.N_DIR:]) > 2.0 / 0.8


@pytest.mark.parametrize("relative_deg", [0.0, 90.0, 180.0, 270.0])
def test_lands_within_a_quarter_metre_in_every_direction(relative_deg):
    bearing = math.radians(HEADING_DEG + relative_deg)
    target = (2.0 * math.cos(bearing), 2.0 * math.sin(bearing))
    flight = F.fly(F.FlightSpec(mode="target", target=target, depth=10.0, heading_deg=HEADING_DEG,
                                seed=int(relative_deg)))
    m = flight.metrics
    assert m["landed"] and m["estimator"] == "board estimator"
    assert m["landing_error_m"] < 0.25, m
    # the landing is the truth's, not the estimate's: it fell the whole way
    assert flight.landing_position[2] > 9.5
    assert m["descent_time_s"] > 15.0
    assert m["max_tilt_deg"] < 20.0


def test_a_target_beyond_the_reach_saturates_towards_it():
    flight = F.fly(F.FlightSpec(mode="target", target=(0.0, 5.0), depth=6.0, truth=True))
    end = flight.landing_position
    # it glided straight at the target as far as it could
    assert end[1] > 1.5 and abs(end[0]) < 0.5
    assert flight.metrics["landing_error_m"] > 2.0
    assert flight.setpoints[:, 6].max() > 0.3   # the reach it reported
