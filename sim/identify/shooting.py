"""Multiple shooting through a dive: the model flown over short segments
of the log, many vehicles and segments in one batch.

A dive is cut into segments of ``SEGMENT_S``. Each segment starts from the
log's state at its start (depth, attitude, the wings through the servo
model) and a node: body velocity, body rates and a tilt of the logged
attitude (``NODE``), zero for the segment that starts at the release (the
vehicle was held still; only its tilt may differ), unknowns for the others
(started from the estimator's EST velocity and the gyro), tied to the end
of the segment before by continuity defects (``fit``). Over the segment
the logged wing commands drive the model (``sim/dynamics.py``, RK4 at
``DT`` through the compiled batch ``kernels.advance``, commands
interpolated between WING records and held for ``CHUNK_S``), and the
outputs are compared with what was logged. Short segments keep an error in
the model from carrying the simulated vehicle away from the logged one
(heading and track drift without bound, the attitude does not), which a
single shooting over the whole dive would suffer.

The residuals, each divided by its sigma (``Residuals.sigma``):

- ``depth`` (m): the pressure port's depth at each BARO record;
- ``depth_rate`` (m/s): its change between consecutive BARO records;
- ``tilt`` (rad): the gravity direction in body axes (the third row of
  the rotation), x and y, at each ATT record: tilt errors of roll and pitch
  without Euler angles' singularities;
- ``heading`` (rad): the change of heading since the segment's start, on
  the circle;
- ``track`` (m): the change of horizontal position between two fixes in
  the segment (the tracker sees the centre of buoyancy, as the twin's and
  the firmware's positions).

A batch holds ``variants x segments`` vehicles: variant 0 is the current
guess, the others move one parameter or one velocity component of every
segment at once (segments are independent, so one variant serves each
segment's own column of the Jacobian).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roboray.sim import kernels
from roboray.sim.dynamics import Model, quat_to_rot
from roboray.sim.identify.log import DiveLog, euler_to_quaternion, unwrap_interp
from roboray.sim.vehicle import Vehicle, VehicleParams

SEGMENT_S = 4.0
#: s: shortest segment worth flying (the last of a dive may be short)
MIN_SEGMENT_S = 1.5
DT = 0.01
STEPS = 4
CHUNK_S = DT * STEPS
#: s after the release whose logged tilt is left out (``log``: the
#: estimator's tilt is pulled by the release's acceleration)
RELEASE_TILT_S = 2.0
GROUPS = ("depth", "depth_rate", "tilt", "heading", "track")
#: A segment's start (a node of the multiple shooting): body velocity (3),
#: body rates (3), tilt of the logged attitude about north and east (2).
NODE = 8
UNITS = {"depth": "m", "depth_rate": "m/s", "tilt": "rad", "heading": "rad", "track": "m"}


@dataclass
class Segment:
    log: int            #: index of its log
    t0: float
    t1: float
    from_rest: bool     #: starts at the release: zero velocity, no unknown
    depth0: float       #: m, the port's depth
    q0: np.ndarray      #: body -> NED
    rates0: np.ndarray  #: rad/s, body
    vel0: np.ndarray    #: m/s, body: the estimator's, the unknown's start
    wings0: np.ndarray  #: rad, servo angles

    def as_dict(self) -> dict:
        return {"log": self.log, "start_s": self.t0, "end_s": self.t1, "from_rest": self.from_rest}


def tilted(q: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """Quaternions q (N, 4) turned by small angles ``tilt`` (N, 2, rad)
    about the NED north and east axes: q' = dq * q."""
    a = 0.5 * tilt[:, 0]
    b = 0.5 * tilt[:, 1]
    c = np.sqrt(np.maximum(0.0, 1.0 - a * a - b * b))
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    out = np.stack([c * w - a * x - b * y, c * x + a * w + b * z, c * y - a * z + b * w,
                    c * z + a * y - b * x], axis=1)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _servo_angles(log: DiveLog, p: VehicleParams, t: float) -> np.ndarray:
    """The servos' angles at t: the commands since the release through
    the servo model (first-order lag, rate-limited, travel-clipped)."""
    t0 = log.t_release - 1.0
    n = max(1, int(math.ceil((t - t0) / 0.002)))
    times = t0 + (np.arange(n) + 0.5) * (t - t0) / n
    cmd = np.clip(log.wing_command(times), p.servo_min, p.servo_max)
    s = cmd[0].copy()
    h = (t - t0) / n
    for k in range(n):
        s += h * np.clip((cmd[k] - s) / p.servo_tau, -p.servo_rate, p.servo_rate)
    return s


def segments(logs: list, p: VehicleParams, length: float = SEGMENT_S) -> list:
    """The segments of every log whose input (WING) is known throughout."""
    out = []
    for i, log in enumerate(logs):
        edges = list(np.arange(log.t_release, log.t_end, length)) + [log.t_end]
        if len(edges) > 2 and edges[-1] - edges[-2] < MIN_SEGMENT_S:
            del edges[-2]
        for a, b in zip(edges[:-1], edges[1:]):
            if b - a < MIN_SEGMENT_S or not log.input_known(a, b):
                continue
            e = np.array([np.interp(a, log.att_t, log.euler[:, 0]), np.interp(a, log.att_t, log.euler[:, 1]),
                          float(unwrap_interp(np.array([a]), log.att_t, log.euler[:, 2])[0])])
            q = euler_to_quaternion(*e)
            rest = a == log.t_release
            R = quat_to_rot(q[None])[0]
            vel_ned = np.array([np.interp(a, log.est_t, log.est_vel[:, k]) for k in range(3)]) \
                if len(log.est_t) else np.zeros(3)
            out.append(Segment(
                log=i, t0=float(a), t1=float(b), from_rest=bool(rest),
                depth0=float(np.interp(a, log.baro_t, log.depth)), q0=q,
                rates0=np.zeros(3) if rest else np.array([np.interp(a, log.imu_t, log.gyro[:, k]) for k in range(3)]),
                vel0=np.zeros(3) if rest else R.T @ vel_ned, wings0=_servo_angles(log, p, a)))
    return out


class Shooter:
    """Flies segments for batches of vehicles and makes their residuals."""

    def __init__(self, logs: list, segs: list, base: VehicleParams) -> None:
        if not segs:
            raise ValueError("no segment of the dive has its wing commands logged throughout")
        self.logs = logs
        self.segs = segs
        self.length = max(s.t1 - s.t0 for s in segs)
        self.chunks = int(math.ceil(self.length / CHUNK_S))
        tau = (np.arange(self.chunks) + 0.5) * CHUNK_S
        #: (chunks, K, 4) commands, held over each chunk
        self.cmd = np.stack([logs[s.log].wing_command(s.t0 + tau) for s in segs], axis=1)
        self.cb = Vehicle(base).centre_of_buoyancy(np.zeros(4))
        self._measurements()

    # ------------------------------------------------------------ data
    def _measurements(self) -> None:
        """Per segment: times (relative) and logged values of each group."""
        self.meas = []
        for s in self.segs:
            log = self.logs[s.log]
            m = {}
            kb = (log.baro_t > s.t0) & (log.baro_t <= s.t1)
            tb = log.baro_t[kb]
            m["depth"] = (tb - s.t0, log.depth[kb])
            m["depth_rate"] = (tb - s.t0, log.depth[kb])
            ka = (log.att_t > max(s.t0, log.t_release + RELEASE_TILT_S)) & (log.att_t <= s.t1)
            ta = log.att_t[ka]
            roll, pitch = log.euler[ka, 0], log.euler[ka, 1]
            gx = -np.sin(pitch)
            gy = np.sin(roll) * np.cos(pitch)
            yaw = unwrap_interp(np.concatenate(([s.t0], ta)), log.att_t, log.euler[:, 2])
            m["tilt"] = (ta - s.t0, np.stack([gx, gy], axis=1))
            m["heading"] = (ta - s.t0, yaw[1:] - yaw[0])
            kf = (log.fix_t >= s.t0) & (log.fix_t <= s.t1)
            m["track"] = (log.fix_t[kf] - s.t0, log.fix_ne[kf])
            self.meas.append(m)

    # ------------------------------------------------------------ flying
    def commands_between(self, rng: np.random.Generator, slews: list) -> np.ndarray:
        """(chunks, K, 4) commands as they may have been between the WING
        records: on each interval of length d the linear interpolation plus
        a bump a sin(pi u), u the phase in the interval, a uniform within
        +-slew d / 4 per wing (a command slewing at most ``slew`` can leave
        the straight line by up to slew d / 2; the firmware's move less)."""
        out = self.cmd.copy()
        tau = (np.arange(self.chunks) + 0.5) * CHUNK_S
        bumps = {}
        for k, s in enumerate(self.segs):
            log = self.logs[s.log]
            if s.log not in bumps:
                d = np.diff(log.wing_t)
                bumps[s.log] = rng.uniform(-1.0, 1.0, (len(d), 4)) * (slews[s.log] * d / 4.0)[:, None]
            t = s.t0 + tau
            i = np.clip(np.searchsorted(log.wing_t, t) - 1, 0, len(log.wing_t) - 2)
            u = (t - log.wing_t[i]) / (log.wing_t[i + 1] - log.wing_t[i])
            inside = (u >= 0) & (u <= 1)
            out[:, k] += np.where(inside, np.sin(np.pi * np.clip(u, 0, 1)), 0.0)[:, None] * bumps[s.log][i]
        return out

    def fly(self, vehicles: list, nodes: np.ndarray, commands: np.ndarray | None = None) -> dict:
        """Fly every segment for each vehicle: ``vehicles`` J parameter
        sets, ``nodes`` (J, K, NODE) each segment's start: body velocity
        (m/s), body rates (rad/s) and a tilt of the logged attitude (rad,
        about north and east). Returns at the chunk boundaries states
        (chunks + 1, J, K, 17), port depths (chunks + 1, J, K) and
        velocities nu (chunks + 1, J, K, 6). ``commands`` (J, chunks, K, 4):
        each vehicle's own, instead of the log's."""
        J, K = len(vehicles), len(self.segs)
        model = Model(vehicles)
        rows = np.repeat(np.arange(J), K)     # batch member n = j * K + k
        T = model.T
        T = (T[0][rows], T[1], T[2][rows], T[3], T[4][rows], T[5][rows], T[6])
        n = J * K
        nodes = nodes.reshape(n, NODE)
        x = np.zeros((n, 17))
        seg = np.tile(np.arange(K), J)
        q0 = tilted(np.array([s.q0 for s in self.segs])[seg], nodes[:, 6:8])
        R = quat_to_rot(q0)
        port = T[5][:, kernels.P_PORT:kernels.P_PORT + 3]
        depth0 = np.array([s.depth0 for s in self.segs])[seg]
        x[:, 2] = depth0 - np.einsum("nj,nj->n", R[:, 2, :], port)
        x[:, 3:7] = q0
        x[:, 13:17] = np.array([s.wings0 for s in self.segs])[seg]
        nu = np.ascontiguousarray(nodes[:, :6])
        mvv = np.empty((n, 6, 6))
        mvs = np.empty((n, 6, 4))
        kernels.inertia(np.ascontiguousarray(x[:, 13:17]), T, mvv, mvs)
        if commands is None:
            commands = np.broadcast_to(self.cmd[None], (J,) + self.cmd.shape)
        cmds = np.ascontiguousarray(commands.transpose(1, 0, 2, 3).reshape(self.chunks, n, 4))
        cmd0 = cmds[0]
        sd = np.clip((np.clip(cmd0, T[5][:, [kernels.P_SMIN]], T[5][:, [kernels.P_SMAX]]) - x[:, 13:17])
                     / T[5][:, [kernels.P_TAU]], -T[5][:, [kernels.P_RATE]], T[5][:, [kernels.P_RATE]])
        x[:, 7:13] = np.einsum("nij,nj->ni", mvv, nu) + np.einsum("nij,nj->ni", mvs, sd)
        states = np.empty((self.chunks + 1, n, 17))
        depths = np.empty((self.chunks + 1, n))
        vel = np.empty((self.chunks + 1, n, 6))
        states[0] = x
        depths[0] = depth0
        vel[0] = nu
        xs = np.empty((2, n, 17))
        sds = np.empty((2, n, 4))
        nus = np.empty((2, n, 6))
        vimu = np.empty((2, n, 3))
        dep = np.empty((2, n))
        for c in range(self.chunks):
            xs[0] = x
            kernels.advance(x, cmds[c], DT, 1, STEPS, T, xs, sds, nus, vimu, dep)
            states[c + 1] = x
            depths[c + 1] = dep[1]
            vel[c + 1] = nus[1]
        return {"states": states.reshape(self.chunks + 1, J, K, 17),
                "depths": depths.reshape(self.chunks + 1, J, K), "nu": vel.reshape(self.chunks + 1, J, K, 6)}

    def ends(self, flown: dict, j: int) -> np.ndarray:
        """(K, 8) each segment's velocity, rates and gravity direction (x, y
        in body axes) at its end, for vehicle j."""
        out = np.empty((len(self.segs), 8))
        for k, s in enumerate(self.segs):
            e = int(round((s.t1 - s.t0) / CHUNK_S))
            out[k, :6] = flown["nu"][e, j, k]
            R = quat_to_rot(flown["states"][e, j, k, 3:7][None])[0]
            out[k, 6:8] = R[2, :2]
        return out

    def starts(self, nodes: np.ndarray) -> np.ndarray:
        """(K, 8) each segment's velocity, rates and gravity direction at its start."""
        q = tilted(np.array([s.q0 for s in self.segs]), nodes[:, 6:8])
        out = np.empty((len(self.segs), 8))
        out[:, :6] = nodes[:, :6]
        out[:, 6:8] = quat_to_rot(q)[:, 2, :2]
        return out

    def links(self) -> list:
        """(k - 1, k) for each segment that starts where the one before ends."""
        return [(k - 1, k) for k in range(1, len(self.segs))
                if self.segs[k - 1].log == self.segs[k].log and abs(self.segs[k - 1].t1 - self.segs[k].t0) < 1e-9]

    # ------------------------------------------------------------ residuals
    def residuals(self, flown: dict, j: int, late: np.ndarray | None = None) -> dict:
        """Raw residuals (model - log) of vehicle j, per group, per segment:
        {group: [array per segment]}. ``late`` (per log, s): how much later
        than detected each log's release was; a segment from rest is then
        compared at its times less that (held still, the model's state
        before its start is its start)."""
        out = {g: [] for g in GROUPS}
        for k, s in enumerate(self.segs):
            m = self.meas[k]
            tt = np.arange(self.chunks + 1) * CHUNK_S
            if late is not None and s.from_rest:
                tt = tt + late[s.log]
            X = flown["states"][:, j, k]
            D = flown["depths"][:, j, k]
            t, d = m["depth"]
            sim_d = np.interp(t, tt, D)
            out["depth"].append(sim_d - d)
            if len(t) > 1:
                out["depth_rate"].append(np.diff(sim_d - d) / np.diff(t))
            else:
                out["depth_rate"].append(np.zeros(0))
            R = quat_to_rot(X[:, 3:7])
            t, g = m["tilt"]
            gx = np.interp(t, tt, R[:, 2, 0])
            gy = np.interp(t, tt, R[:, 2, 1])
            out["tilt"].append(np.stack([gx - g[:, 0], gy - g[:, 1]], axis=1).reshape(-1))
            yaw = np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))
            t, h = m["heading"]
            dh = np.interp(t, tt, yaw - yaw[0]) - h
            out["heading"].append((dh + np.pi) % (2 * np.pi) - np.pi)
            t, ne = m["track"]
            if len(t) > 1:
                cb = X[:, :2] + np.einsum("cij,j->ci", R, self.cb)[:, :2]
                sim = np.stack([np.interp(t, tt, cb[:, 0]), np.interp(t, tt, cb[:, 1])], axis=1)
                out["track"].append((np.diff(sim, axis=0) - np.diff(ne, axis=0)).reshape(-1))
            else:
                out["track"].append(np.zeros(0))
        return out
