"""A kinematically exact feathering descent, the test input of the sensor
models and the estimator until the dynamics model produces flights.

One smooth trajectory, seeded: the vehicle is held still just under the
surface for ``hold_s``, then released; it accelerates to about 0.3 m/s and
feathers (thesis sec. 5.1): tilt oscillations of 5-15 deg at 0.2-1 Hz in
roll and pitch, some spin, and the horizontal velocity that goes with the
tilt (it glides towards its lower edge, a few cm/s). The wings move between
0 and 60 deg every 6-12 s; their asymmetry trims the tilt, and their mean
fold speeds the descent.

Exactness: the attitude is analytic (Z-Y-X Euler angles with analytic first
and second derivatives), so the body rate and its derivative are exact. The
velocity is the exact solution of a first-order response to a target
velocity (``v_dot = (v_target - v) / tau``, the target sampled at 1 kHz and
taken piecewise linear), so the acceleration ``(v_target - v) / tau`` is
the velocity's derivative; the position is its trapezoidal integral
(error below 1e-6 m). The specific force at the IMU adds the lever arm:
``f = R^T (a - g) + omega_dot x r + omega x (omega x r)``.

The truth's glide is not the estimator's descent model: its gain depends
differently on the fold, the glide direction turns with the spin, and a
water current of up to 2 cm/s carries the vehicle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate, signal

from roboray.sim.truth import GRAVITY_NED, Truth, quaternion_to_matrix

DEG = np.pi / 180.0


@dataclass(frozen=True)
class DescentProfile:
    """Shape of the generated descent; ranges are (low, high) of uniform draws."""

    hold_s: float = 10.0
    flight_s: float = 60.0
    rate_hz: float = 1000.0
    start_depth: float = 0.10              #: m, centre of buoyancy while held
    release_s: float = 0.3                 #: the hold lets go over this time
    grow_s: float = 3.0                    #: feathering builds up over this time
    descent_speed: float = 0.28            #: m/s, wings flat and level
    fold_speedup: float = 0.4              #: relative descent speed gained at a 90 deg mean fold
    tilt_slowdown: float = 0.5             #: v_z *= 1 - tilt_slowdown (1 - cos tilt)
    tau_vertical_s: float = 0.6
    tau_horizontal_s: float = 0.5
    glide_gain: float = 0.95               #: v_h = K v_z tan(tilt), wings flat
    glide_gain_fold: float = -0.3          #: change of K at a 90 deg mean fold
    spin_turn: float = 0.5                 #: glide direction turns by this x yaw rate (rad per rad/s)
    tilt_main_deg: tuple = (5.0, 12.0)
    tilt_main_hz: tuple = (0.2, 0.5)
    tilt_second_deg: tuple = (1.0, 4.0)
    tilt_second_hz: tuple = (0.5, 1.0)
    initial_tilt_deg: float = 3.0
    spin_rad_s: tuple = (-0.3, 0.3)
    yaw_wobble_deg: float = 3.0
    trim_per_rad: float = 0.12             #: tilt (rad) per rad of wing asymmetry
    wing_max_deg: float = 60.0
    wing_move_s: tuple = (0.6, 1.2)
    wing_every_s: tuple = (6.0, 12.0)
    current_max: float = 0.02              #: m/s
    imu_position: tuple = (0.01, -0.005, -0.045)   #: m, body frame, from the CB
    port_position: tuple = (0.025, 0.0, -0.05)     #: m, body frame, from the CB


def smootherstep(u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """6u^5 - 15u^4 + 10u^3 on [0, 1] (held outside) and its two derivatives in u."""
    u = np.clip(u, 0.0, 1.0)
    s = u * u * u * (10.0 + u * (-15.0 + 6.0 * u))
    d = 30.0 * u * u * (1.0 - u) ** 2
    dd = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u)
    return s, d, dd


def ramp(t: np.ndarray, t0: float, duration: float):
    """0 -> 1 over [t0, t0 + duration]: value, rate, second derivative, integral."""
    u = (t - t0) / duration
    s, d, dd = smootherstep(u)
    uc = np.clip(u, 0.0, 1.0)
    integral = duration * (uc ** 6 - 3.0 * uc ** 5 + 2.5 * uc ** 4) + np.maximum(t - t0 - duration, 0.0)
    return s, d / duration, dd / duration ** 2, integral


def sinusoid(t: np.ndarray, amplitude: float, hz: float, phase: float):
    w = 2.0 * np.pi * hz
    a = w * t + phase
    return amplitude * np.sin(a), amplitude * w * np.cos(a), -amplitude * w * w * np.sin(a)


def _product(a, b):
    """(value, d, dd) of the product of two (value, d, dd) signals."""
    return a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + 2.0 * a[1] * b[1] + a[0] * b[2]


def _wings(t: np.ndarray, p: DescentProfile, rng: np.random.Generator):
    """Wing angles, rates and accelerations (N, 4)."""
    s = np.zeros((len(t), 4))
    sd = np.zeros_like(s)
    sdd = np.zeros_like(s)
    current = rng.uniform(0.0, p.wing_max_deg * DEG, size=4)
    s[:] = current
    start = p.hold_s + rng.uniform(2.0, 5.0)
    end = p.hold_s + p.flight_s
    while start < end:
        duration = rng.uniform(*p.wing_move_s)
        target = np.where(rng.uniform(size=4) < 0.7, rng.uniform(0.0, p.wing_max_deg * DEG, size=4), current)
        v, d, dd, _ = ramp(t, start, duration)
        step = target - current
        s += v[:, None] * step
        sd += d[:, None] * step
        sdd += dd[:, None] * step
        current = target
        start += duration + rng.uniform(*p.wing_every_s)
    return s, sd, sdd


def _euler_rates(phi, theta, psi):
    """Body rate and its derivative (N, 3) from Z-Y-X Euler angles given as
    (value, d, dd) triples."""
    sf, cf = np.sin(phi[0]), np.cos(phi[0])
    st, ct = np.sin(theta[0]), np.cos(theta[0])
    fd, td, yd = phi[1], theta[1], psi[1]
    fdd, tdd, ydd = phi[2], theta[2], psi[2]
    w = np.stack([fd - yd * st, td * cf + yd * sf * ct, -td * sf + yd * cf * ct], axis=1)
    wd = np.stack([
        fdd - ydd * st - yd * td * ct,
        tdd * cf - td * fd * sf + ydd * sf * ct + yd * fd * cf * ct - yd * td * sf * st,
        -tdd * sf - td * fd * cf + ydd * cf * ct - yd * fd * sf * ct - yd * td * cf * st,
    ], axis=1)
    return w, wd


def euler_to_quaternion(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cy, sy = np.cos(0.5 * yaw), np.sin(0.5 * yaw)
    return np.stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy], axis=-1)


def _first_order(u: np.ndarray, tau: float, h: float, x0: float) -> np.ndarray:
    """Exact response of x_dot = (u - x) / tau to u piecewise linear between
    samples ``h`` apart, from x(0) = x0."""
    a = np.exp(-h / tau)
    b1 = 1.0 - tau * (1.0 - a) / h
    b0 = (1.0 - a) - b1
    # x[k+1] = a x[k] + b0 u[k] + b1 u[k+1], started from (x0, u[0])
    zi = signal.lfiltic([b1, b0], [1.0, -a], y=[x0], x=[u[0]])
    rest, _ = signal.lfilter([b1, b0], [1.0, -a], u[1:], zi=zi)
    return np.concatenate(([x0], rest))


def descent(seed: int, profile: DescentProfile = DescentProfile()) -> Truth:
    """The feathering descent of ``seed`` (deterministic)."""
    p = profile
    rng = np.random.default_rng(seed)
    h = 1.0 / p.rate_hz
    n = int(round((p.hold_s + p.flight_s) * p.rate_hz)) + 1
    t = np.arange(n) * h

    release, release_rate, _, released_time = ramp(t, p.hold_s, p.release_s)
    env = ramp(t, p.hold_s, p.grow_s)[:3]
    s, sd, sdd = _wings(t, p, rng)

    def feather():
        a = sinusoid(t, rng.uniform(*p.tilt_main_deg) * DEG, rng.uniform(*p.tilt_main_hz), rng.uniform(0, 2 * np.pi))
        b = sinusoid(t, rng.uniform(*p.tilt_second_deg) * DEG, rng.uniform(*p.tilt_second_hz), rng.uniform(0, 2 * np.pi))
        return _product(env, (a[0] + b[0], a[1] + b[1], a[2] + b[2]))

    tr = p.trim_per_rad
    phi0, theta0 = rng.uniform(-1.0, 1.0, size=2) * p.initial_tilt_deg * DEG
    fr, fth = feather(), feather()
    phi = (phi0 + fr[0] + tr * (s[:, 1] - s[:, 3]), fr[1] + tr * (sd[:, 1] - sd[:, 3]), fr[2] + tr * (sdd[:, 1] - sdd[:, 3]))
    theta = (theta0 + fth[0] + tr * (s[:, 0] - s[:, 2]), fth[1] + tr * (sd[:, 0] - sd[:, 2]), fth[2] + tr * (sdd[:, 0] - sdd[:, 2]))
    spin = rng.uniform(*p.spin_rad_s)
    wob = _product(env, sinusoid(t, p.yaw_wobble_deg * DEG, rng.uniform(0.1, 0.3), rng.uniform(0, 2 * np.pi)))
    psi0 = rng.uniform(-np.pi, np.pi)
    psi = (psi0 + spin * released_time + wob[0], spin * release + wob[1], spin * release_rate + wob[2])

    q = euler_to_quaternion(phi[0], theta[0], psi[0])
    R = quaternion_to_matrix(q)
    omega, omega_dot = _euler_rates(phi, theta, psi)

    # translational response: targets from the attitude and wings, then exact first-order lags
    fold = s.mean(axis=1) / (np.pi / 2.0)
    r02, r12, r22 = R[:, 0, 2], R[:, 1, 2], R[:, 2, 2]
    vz_target = release * p.descent_speed * (1.0 + p.fold_speedup * fold) * (1.0 - p.tilt_slowdown * (1.0 - r22))
    vz = _first_order(vz_target, p.tau_vertical_s, h, 0.0)
    gain = p.glide_gain + p.glide_gain_fold * fold
    beta = p.spin_turn * psi[1]
    gx, gy = -gain * vz * r02 / r22, -gain * vz * r12 / r22
    cb, sb = np.cos(beta), np.sin(beta)
    heading = rng.uniform(0, 2 * np.pi)
    current = rng.uniform(0.0, p.current_max) * np.array([np.cos(heading), np.sin(heading), 0.0])
    vn_target = release * (cb * gx - sb * gy + current[0])
    ve_target = release * (sb * gx + cb * gy + current[1])
    vn = _first_order(vn_target, p.tau_horizontal_s, h, 0.0)
    ve = _first_order(ve_target, p.tau_horizontal_s, h, 0.0)
    vel = np.stack([vn, ve, vz], axis=1)
    acc = np.stack([(vn_target - vn) / p.tau_horizontal_s, (ve_target - ve) / p.tau_horizontal_s,
                    (vz_target - vz) / p.tau_vertical_s], axis=1)
    pos = integrate.cumulative_trapezoid(vel, t, axis=0, initial=0.0)
    pos[:, 2] += p.start_depth

    r_imu = np.asarray(p.imu_position, dtype=float)
    lever = np.cross(omega_dot, r_imu) + np.cross(omega, np.cross(omega, r_imu))
    f_imu = np.einsum("nji,nj->ni", R, acc - GRAVITY_NED) + lever
    depth_port = pos[:, 2] + R[:, 2, :] @ np.asarray(p.port_position, dtype=float)
    return Truth(
        t=t, position_ned=pos, velocity_ned=vel, quaternion=q, omega_body=omega,
        specific_force_imu=f_imu, depth_sensor=depth_port, wings=s, wing_rates=sd,
        imu_position_body=r_imu, water_velocity_ned=np.tile(current, (n, 1)),
    )


def acceleration(truth: Truth) -> np.ndarray:
    """Inertial acceleration of the centre of buoyancy implied by a truth's
    specific force (inverse of the lever-arm formula; for checks)."""
    R = truth.rotation()
    dt = np.gradient(truth.t)
    omega = truth.omega_body
    omega_dot = np.gradient(omega, axis=0) / dt[:, None]
    r = truth.imu_position_body
    lever = np.cross(omega_dot, r) + np.cross(omega, np.cross(omega, r))
    return np.einsum("nij,nj->ni", R, truth.specific_force_imu - lever) + GRAVITY_NED


def still(duration_s: float, quaternion=(1.0, 0.0, 0.0, 0.0), depth: float = 1.0, rate_hz: float = 1000.0,
          profile: DescentProfile = DescentProfile(), wings_deg: float = 20.0) -> Truth:
    """The vehicle held still at ``depth`` (m, centre of buoyancy) in the
    attitude ``quaternion`` for ``duration_s``: the simplest truth, for
    checking sensor statistics and estimator convergence."""
    if duration_s <= 0:
        raise ValueError("duration_s %r must be > 0" % duration_s)
    q = np.asarray(quaternion, dtype=float)
    q = q / np.linalg.norm(q)
    n = int(round(duration_s * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    R = quaternion_to_matrix(q)
    port = np.asarray(profile.port_position, dtype=float)
    return Truth(
        t=t, position_ned=np.tile([0.0, 0.0, depth], (n, 1)), velocity_ned=np.zeros((n, 3)),
        quaternion=np.tile(q, (n, 1)), omega_body=np.zeros((n, 3)),
        specific_force_imu=np.tile(R.T @ -GRAVITY_NED, (n, 1)),
        depth_sensor=np.full(n, depth + R[2] @ port), wings=np.full((n, 4), wings_deg * DEG),
        wing_rates=np.zeros((n, 4)), imu_position_body=np.asarray(profile.imu_position, dtype=float),
    )
