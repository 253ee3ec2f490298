"""Running the model: fixed-step and reference integration, recorded runs.

Two integrators share the model's right-hand side:

- ``rk4``: classical Runge-Kutta with a fixed step, for twins and batches.
  The servo is not integrated but solved exactly over each step (rate-limited
  ramp, then first-order lag towards a command held for the step), so its
  corner never lands inside a Runge-Kutta stage and the step is limited only
  by the body's dynamics. Commands change only at step boundaries.
- ``dop853``: scipy's adaptive 8th-order Dormand-Prince on the full state
  (servo included as an ODE), segment by segment between command changes,
  for validation.

Quaternions are renormalised after every step.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np
from scipy.integrate import solve_ivp

from roboray.sim import kernels
from roboray.sim.dynamics import POS, QUAT, STATE_SIZE, WINGS, Model, quat_to_rot
from roboray.sim.truth import GRAVITY_NED, Truth

Controller = Callable[[float, np.ndarray], np.ndarray]


def reference_segment(model: Model, x: np.ndarray, command: np.ndarray, dt: float,
                      rtol: float = 1e-11, atol: float = 1e-13) -> np.ndarray:
    """Integrate every vehicle over ``dt`` with DOP853 (full state, servo as ODE)."""
    out = np.empty_like(x)
    n = len(x)
    for i in range(n):
        sub = model if n == 1 else model.single(i)
        cmd = command[i:i + 1]

        def fun(_t, y):
            return sub.rhs(y[None, :], cmd)[0]

        sol = solve_ivp(fun, (0.0, dt), x[i], method="DOP853", rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError("reference integrator failed: %s" % sol.message)
        out[i] = sol.y[:, -1]
    out[:, QUAT] /= np.linalg.norm(out[:, QUAT], axis=1, keepdims=True)
    return out


@dataclass
class Run:
    """A recorded simulation of N vehicles at K times."""

    t: np.ndarray                   #: (K,) s
    x: np.ndarray                   #: (K, N, 17) states
    nu: np.ndarray                  #: (K, N, 6) body velocities (V, Omega) of O
    wing_rates: np.ndarray          #: (K, N, 4) rad/s
    command: np.ndarray             #: (K, N, 4) rad, servo commands in force after t
    specific_force_imu: np.ndarray  #: (K, N, 3) m/s^2, body frame, mean over the last step
    depth_sensor: np.ndarray        #: (K, N) m
    landed_at: np.ndarray           #: (N,) s, first touch of the bottom (nan: never)
    imu_position: np.ndarray        #: (N, 3) m from O
    port_position: np.ndarray       #: (N, 3) m from O, the pressure port
    wall_time_s: float = 0.0
    integrator: str = "rk4"
    dt: float = 0.01
    water_velocity: Optional[np.ndarray] = None  #: (K, N, 3)

    @property
    def n(self) -> int:
        return self.x.shape[1]

    def velocity_ned(self) -> np.ndarray:
        """(K, N, 3) NED velocity of O (including any current)."""
        rot = quat_to_rot(self.x[..., QUAT].reshape(-1, 4)).reshape(self.x.shape[:2] + (3, 3))
        v = np.einsum("knij,knj->kni", rot, self.nu[..., :3])
        if self.water_velocity is not None:
            v = v + self.water_velocity
        return v

    def truth(self, i: int = 0, reference=None) -> Truth:
        """Vehicle i's run as a ``Truth`` for the sensor models. Positions and
        velocities are of the plate centre O, or of ``reference`` (a body
        point, m from O; e.g. the centre of buoyancy, which the estimator
        reports), and the IMU and pressure port are given from that point."""
        ref = np.zeros(3) if reference is None else np.asarray(reference, float)
        rot = quat_to_rot(self.x[:, i, QUAT])
        position = self.x[:, i, POS] + np.einsum("kij,j->ki", rot, ref)
        spin = np.cross(self.nu[:, i, 3:], ref)
        velocity = self.velocity_ned()[:, i] + np.einsum("kij,kj->ki", rot, spin)
        return Truth(
            t=self.t.copy(),
            position_ned=position,
            velocity_ned=velocity,
            quaternion=self.x[:, i, QUAT].copy(),
            omega_body=self.nu[:, i, 3:].copy(),
            specific_force_imu=self.specific_force_imu[:, i].copy(),
            depth_sensor=self.depth_sensor[:, i].copy(),
            wings=self.x[:, i, WINGS].copy(),
            wing_rates=self.wing_rates[:, i].copy(),
            imu_position_body=self.imu_position[i] - ref,
            water_velocity_ned=None if self.water_velocity is None else self.water_velocity[:, i].copy(),
            port_position_body=self.port_position[i] - ref,
        )


def simulate(model: Model, x0: np.ndarray, duration: float, dt: float = 0.01,
             controller: Optional[Controller] = None, command: Optional[np.ndarray] = None,
             control_period: Optional[float] = None, integrator: str = "rk4",
             stop_when_landed: bool = False, record_every: int = 1,
             rtol: float = 1e-11, atol: float = 1e-13) -> Run:
    """Integrate N vehicles from x0 (N, 17) for ``duration`` seconds.

    Wing commands come from ``controller(t, x) -> (N, 4)`` called every
    ``control_period`` (default: every step) and held in between, or are the
    constant ``command`` (default: hold the initial wing angles). With a
    bottom in the model and ``stop_when_landed``, the run ends when every
    vehicle has touched it. ``record_every`` records one step in so many
    (a batch of thousands need not keep every 10 ms); the specific force is
    then the mean over the recorded interval, and the controller's period
    must be a whole number of recorded intervals.
    """
    if not (dt > 0 and math.isfinite(dt)):
        raise ValueError("dt must be a positive number of seconds, got %r" % dt)
    if not (duration >= 0 and math.isfinite(duration)):
        raise ValueError("duration must be a non-negative number of seconds, got %r" % duration)
    if integrator not in ("rk4", "dop853"):
        raise ValueError("integrator must be 'rk4' or 'dop853', got %r" % integrator)
    if int(record_every) != record_every or record_every < 1:
        raise ValueError("record_every must be a whole number of steps >= 1, got %r" % record_every)
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (model.n, STATE_SIZE):
        raise ValueError("x0 must have shape (%d, %d), got %s" % (model.n, STATE_SIZE, x0.shape))
    n = model.n
    r = int(record_every)
    rows = int(round(duration / dt)) // r
    step_r = r * dt   # time between records
    if controller is not None:
        ctl = max(1, int(round((control_period if control_period is not None else dt) / dt)))
        if ctl % r:
            raise ValueError("the control period (%d steps) must be a multiple of record_every (%d)" % (ctl, r))
        every = ctl // r
    else:
        # Nothing changes between steps: run in chunks only to check for landing now and then.
        every = max(1, 200 // r) if model.bottom is not None else max(rows, 1)
    xs = np.empty((rows + 1, n, STATE_SIZE))
    sds = np.empty((rows + 1, n, 4))
    nus = np.empty((rows + 1, n, 6))
    vimu = np.empty((rows + 1, n, 3))
    depth = np.empty((rows + 1, n))
    cmds = np.empty((rows + 1, n, 4))
    landed = np.full(n, np.nan)
    xs[0] = x0
    cmd = x0[:, WINGS].copy() if command is None else np.broadcast_to(np.asarray(command, float), (n, 4)).copy()
    cmd = np.ascontiguousarray(cmd)
    start = time.perf_counter()
    k = 0
    end = rows
    while True:
        t = k * step_r
        if controller is not None and k % every == 0:
            cmd = np.ascontiguousarray(np.asarray(controller(t, xs[k]), dtype=float).reshape(n, 4))
        cmds[k] = cmd
        kernels.record_all(xs[k], cmd, model.T, sds[k], nus[k], vimu[k], depth[k])
        if k == 0 and model.bottom is not None:
            landed[model.touching_bottom(xs[0])] = 0.0
        if k >= rows:
            break
        chunk = min(every - k % every, rows - k)
        if integrator == "rk4":
            x = xs[k].copy()
            kernels.advance(x, cmd, float(dt), chunk, r, model.T, xs[k:k + chunk + 1], sds[k:k + chunk + 1],
                            nus[k:k + chunk + 1], vimu[k:k + chunk + 1], depth[k:k + chunk + 1])
        else:
            for j in range(chunk):
                xs[k + j + 1] = reference_segment(model, xs[k + j], cmd, step_r, rtol, atol)
                kernels.record_all(xs[k + j + 1], cmd, model.T, sds[k + j + 1], nus[k + j + 1],
                                   vimu[k + j + 1], depth[k + j + 1])
        cmds[k + 1:k + chunk + 1] = cmd
        if model.bottom is not None:
            for j in range(k + 1, k + chunk + 1):
                new = np.isnan(landed) & model.touching_bottom(xs[j])
                landed[new] = j * step_r
            if stop_when_landed and not np.isnan(landed).any():
                end = int(round(np.nanmax(landed) / step_r))
                k = end
                break
        k += chunk
    end = min(end, k)
    wall = time.perf_counter() - start
    k_total = end + 1
    rot = quat_to_rot(xs[:k_total].reshape(-1, STATE_SIZE)[:, QUAT]).reshape(k_total, n, 3, 3)
    # An accelerometer averaging over each interval reads the change of the
    # IMU's NED velocity less gravity; at the start, the instantaneous value.
    # (An instantaneous formula would miss the impulse of a wing-rate jump.)
    f_imu = np.empty((k_total, n, 3))
    f_imu[0] = model.specific_force(xs[0], cmds[0], model.imu)
    if k_total > 1:
        acc = (vimu[1:k_total] - vimu[:k_total - 1]) / step_r - GRAVITY_NED
        f_imu[1:] = np.einsum("knji,knj->kni", rot[1:], acc)
    water = None
    if model.current is not None:
        water = model.current.at(xs[:k_total, :, 2])
    return Run(t=np.arange(k_total) * step_r, x=xs[:k_total], nu=nus[:k_total], wing_rates=sds[:k_total],
               command=cmds[:k_total], specific_force_imu=f_imu, depth_sensor=depth[:k_total],
               landed_at=landed, imu_position=np.broadcast_to(model.imu, (n, 3)).copy(),
               port_position=np.broadcast_to(model.port, (n, 3)).copy(), wall_time_s=wall,
               integrator=integrator, dt=step_r, water_velocity=water)
