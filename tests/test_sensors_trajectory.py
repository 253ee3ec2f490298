"""The kinematic descent is exact (position, velocity, specific force,
attitude and rates are consistent derivatives of one trajectory) and looks
like the thesis's feathering."""

from __future__ import annotations

import numpy as np
import pytest

from roboray.sim import estimation as E
from roboray.sim.sensors import trajectory
from roboray.sim.truth import quaternion_to_matrix


@pytest.fixture(scope="module")
def truth():
    return trajectory.descent(4)


def test_derivatives_are_consistent(truth):
    dt = truth.t[1] - truth.t[0]
    inner = slice(5, -5)
    v_fd = np.gradient(truth.position_ned, dt, axis=0)
    assert np.max(np.abs(v_fd - truth.velocity_ned)[inner]) < 1e-5
    a_fd = np.gradient(truth.velocity_ned, dt, axis=0)
    a = trajectory.acceleration(truth)
    # finite differences of a velocity whose derivative jumps at the release
    assert np.max(np.abs(a_fd - a)[inner]) < 2e-3
    assert np.percentile(np.abs(a_fd - a)[inner], 99) < 1e-5
    # q_dot = 1/2 q (x) (0, omega)
    q = truth.quaternion
    q_fd = np.gradient(q, dt, axis=0)
    w, x, y, z = q.T
    p, r_, s = truth.omega_body.T
    q_dot = 0.5 * np.stack([-x * p - y * r_ - z * s, w * p + y * s - z * r_,
                            w * r_ - x * s + z * p, w * s + x * r_ - y * p], axis=1)
    assert np.max(np.abs(q_fd - q_dot)[inner]) < 1e-5


def test_still_while_held_then_a_feathering_descent(truth):
    hold = truth.t < E.HOLD_S
    assert np.allclose(truth.velocity_ned[hold], 0.0)
    assert np.allclose(truth.omega_body[hold], 0.0)
    R = truth.rotation()
    assert np.allclose(np.einsum("nji,j->ni", R[hold], [0.0, 0.0, -9.80665]), truth.specific_force_imu[hold])
    flight = truth.t > E.HOLD_S + 5.0
    assert 0.25 < np.mean(truth.velocity_ned[flight, 2]) < 0.45
    tilt = np.degrees(np.arccos(R[flight, 2, 2]))
    assert 5.0 < tilt.max() < 35.0
    horizontal = np.hypot(truth.velocity_ned[flight, 0], truth.velocity_ned[flight, 1])
    assert 0.01 < np.sqrt(np.mean(horizontal ** 2)) < 0.12  # a few cm/s
    # feathering accelerations (and the IMU's lever arm) turn the apparent
    # gravity by tenths of a degree: what the attitude filter must not follow
    f = truth.specific_force_imu[flight]
    down = -f / np.linalg.norm(f, axis=1, keepdims=True)
    off = np.degrees(np.arccos(np.clip(np.sum(down * R[flight, 2, :], axis=1), -1.0, 1.0)))
    assert 0.1 < np.sqrt(np.mean(off ** 2)) < 5.0
    spin = np.abs(truth.omega_body[flight, 2]).mean()
    assert spin > 0.0


def test_wings_move_within_their_range(truth):
    wings = np.degrees(truth.wings)
    assert wings.min() >= 0.0 and wings.max() <= 60.0 + 1e-9
    moving = np.abs(truth.wing_rates).max(axis=1) > 0.1
    assert 0.02 < np.mean(moving) < 0.5
    assert np.allclose(np.gradient(truth.wings, truth.t, axis=0)[5:-5], truth.wing_rates[5:-5], atol=1e-3)


def test_seeds_are_deterministic_and_different():
    a = trajectory.descent(7, trajectory.DescentProfile(flight_s=5.0))
    b = trajectory.descent(7, trajectory.DescentProfile(flight_s=5.0))
    c = trajectory.descent(8, trajectory.DescentProfile(flight_s=5.0))
    assert np.array_equal(a.quaternion, b.quaternion)
    assert not np.allclose(a.quaternion, c.quaternion)


def test_with_hold_prepends_a_still_segment():
    flight = trajectory.descent(3, trajectory.DescentProfile(hold_s=0.0, flight_s=5.0))
    held = E.with_hold(flight, 2.0)
    assert held.t[-1] == pytest.approx(flight.t[-1] + 2.0)
    assert np.allclose(held.position_ned[:2000], flight.position_ned[0])
    assert np.allclose(held.specific_force_imu[2000:], flight.specific_force_imu)
    assert np.allclose(held.specific_force_imu[0], quaternion_to_matrix(flight.quaternion[0]).T @ [0, 0, -9.80665])
    moving = trajectory.descent(3, trajectory.DescentProfile(hold_s=0.0, flight_s=5.0))
    late = type(moving)(**{**moving.__dict__, "velocity_ned": moving.velocity_ned + 0.1})
    with pytest.raises(ValueError, match="at rest"):
        E.with_hold(late, 1.0)


def test_an_unknown_truth_source_is_refused():
    with pytest.raises(ValueError, match="truth source 'wind-tunnel' unknown; known: dynamics, kinematic"):
        E.standard_truth(0, source="wind-tunnel")
