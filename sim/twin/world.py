"""The world the twin's firmware flies in: dynamics, sensors, battery, tracker.

``World.frame(wings)`` advances the vehicle one servo frame (two 10 ms RK4
steps of ``sim/dynamics.py``, the servo solved exactly, the wing commands
held for the frame as a servo holds the pulse it read) and returns what
each emulated part senses at the step boundaries, in the parts' own axes
and units. The register encoding (quantisation, full scale, the
MS5837's D1/D2) is the emulated devices' job in ``board/``; the errors of
the parts (noise, biases, scale and cross-axis errors, bias drift, hard and
soft iron, the servos' field, pressure offset and temperature coefficient)
are the sensor models' of ``sim/sensors/``, whose specifications
(``ImuSpec``, ``MS5837Spec``, ``Water``, ``TrackerSpec``) and formulas this
module applies sample by sample instead of to a whole recorded ``Truth``.
Positions are the centre of buoyancy's (flat wings), the point the
tracker measures and the estimator reports, as ``sim/flight.py`` refers
them. Truth outputs are computed as ``sim/simulate.py`` computes them: the
specific force at the IMU is the change of the IMU point's NED velocity
over the step less gravity (``kernels.advance`` records that velocity and
the pressure port's depth), the gyroscope reads the body rates.

Before ``release()`` the vehicle is held still at the surface (its wings
still move with the servos), as a person holds it while the estimator
aligns; after it, it falls.

The chips' axes: the 9-DoF board lies flat with its z up (the firmware's
``AHRS_ORIENTATION`` 8, roll 180 deg), so a body vector (x, y, z) reads
(x, -y, -z) on both chips. The magnetometer's hard and soft iron are drawn
per seed; ``compass_params()`` gives the COMPASS_* parameters a calibration
would have found (with its residual error).

Random streams: one ``numpy`` generator per part, seeded ``[seed, k]``, so a
seed gives the same world whatever the firmware does, and the run is
deterministic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from numba import njit

from roboray.sim import kernels
from roboray.sim.dynamics import POS, QUAT, WINGS, Bottom, Current, Model
from roboray.sim.sensors import depth as depth_model
from roboray.sim.sensors import imu as imu_model
from roboray.sim.sensors.position_fix import TrackerSpec
from roboray.sim.truth import GRAVITY_NED
from roboray.sim.vehicle import VehicleParams

STEP_S = 0.01
G = float(GRAVITY_NED[2])
_NONES = (None, None, None, None)


@dataclass(frozen=True)
class BatterySpec:
    """A 2S Li-ion pack behind the divider (assumed figures)."""

    full_v: float = 8.1            #: V at the start of a dive
    drain_v_per_s: float = 0.001   #: V/s under the electronics' load
    internal_ohm: float = 0.15     #: sag under the servos' current
    sag_tau_s: float = 1.0         #: how fast an injected sag takes hold


@dataclass(frozen=True)
class WorldSpec:
    """Where and how the vehicle dives (defaults: a 10 m fresh-water tank)."""

    bottom_depth: float = 10.0          #: m, NED z of the tank bottom
    start_depth: float = 0.05           #: m, O held just under the surface
    heading_deg: float = 0.0            #: initial heading of wing 1, from north
    current: Optional[tuple] = None     #: uniform current N, E, D (m/s)
    imu: imu_model.ImuSpec = field(default_factory=imu_model.ImuSpec)
    depth: depth_model.MS5837Spec = field(default_factory=depth_model.MS5837Spec)
    water: depth_model.Water = field(default_factory=depth_model.Water)
    tracker: TrackerSpec = field(default_factory=TrackerSpec)
    battery: BatterySpec = field(default_factory=BatterySpec)


@njit(cache=True, nogil=True)
def _advance(x, cmd, dt, steps, T, S, ks, out3, xs, sds, nus, vimu, depth):
    """``kernels.advance`` for one vehicle, without its thread pool: the twin
    steps one vehicle a frame at a time, where a parallel launch costs more
    than the two RK4 steps (and competes with the interpreter for the
    cores). The same ``rk4_one`` and ``record`` kernels, so the same numbers."""
    for k in range(1, steps + 1):
        kernels.rk4_one(0, xs[k - 1, 0], cmd[0], dt, T, S, ks, xs[k, 0])
        kernels.record(0, xs[k, 0], cmd[0], T, S, sds[k, 0], nus[k, 0], out3)
        vimu[k, 0, :] = out3[0]
        depth[k, 0] = out3[1, 0]
    x[0, :] = xs[steps, 0]


@njit(cache=True, nogil=True)
def _sense_kernel(xs, sds, nus, vimu, n, held, mg, ma, bg, ba, noise, ng, na, wg, wa, earth, soft, hard,
                  servo_dirs, idle_a, run_a, full_speed, mag_noise, nm, out, currents):
    """What the IMU and the magnetometer read at steps 1..n (chip axes) into
    out (n, 9): accel, gyro, field. The specific force is the mean over the
    step (the IMU point's NED velocity change less gravity); errors as
    ``sim/sensors/imu.py`` models them (scale and cross-axis matrices,
    drifting biases, white noise; hard and soft iron, the servos' field);
    ``currents[0]`` gets the servos' total current at the last step."""
    g = G
    for k in range(n):
        q = xs[k + 1, 0, 3:7]
        w, x, y, z = q[0], q[1], q[2], q[3]
        r00 = 1 - 2 * (y * y + z * z)
        r01 = 2 * (x * y - w * z)
        r02 = 2 * (x * z + w * y)
        r10 = 2 * (x * y + w * z)
        r11 = 1 - 2 * (x * x + z * z)
        r12 = 2 * (y * z - w * x)
        r20 = 2 * (x * z - w * y)
        r21 = 2 * (y * z + w * x)
        r22 = 1 - 2 * (x * x + y * y)
        if held:
            a0 = 0.0
            a1 = 0.0
            a2 = -g
        else:
            a0 = (vimu[k + 1, 0, 0] - vimu[k, 0, 0]) / STEP_S
            a1 = (vimu[k + 1, 0, 1] - vimu[k, 0, 1]) / STEP_S
            a2 = (vimu[k + 1, 0, 2] - vimu[k, 0, 2]) / STEP_S - g
        f = (r00 * a0 + r10 * a1 + r20 * a2, r01 * a0 + r11 * a1 + r21 * a2, r02 * a0 + r12 * a1 + r22 * a2)
        om = nus[k + 1, 0, 3:6]
        base = 12 * k
        for i in range(3):
            bg[i] += noise[base + 6 + i] * wg
            ba[i] += noise[base + 9 + i] * wa
        for i in range(3):
            gi = mg[i, 0] * om[0] + mg[i, 1] * om[1] + mg[i, 2] * om[2] + bg[i] + noise[base + i] * ng
            ai = ma[i, 0] * f[0] + ma[i, 1] * f[1] + ma[i, 2] * f[2] + ba[i] + noise[base + 3 + i] * na
            sign = 1.0 if i == 0 else -1.0      # chip axes: roll 180 deg
            out[k, i] = sign * ai
            out[k, 3 + i] = sign * gi
        e = (r00 * earth[0] + r10 * earth[1] + r20 * earth[2], r01 * earth[0] + r11 * earth[1] + r21 * earth[2],
             r02 * earth[0] + r12 * earth[1] + r22 * earth[2])
        b = np.empty(3)
        for i in range(3):
            b[i] = e[i]
        total = 0.0
        for j in range(4):
            sp = abs(sds[k + 1, 0, j]) / full_speed
            if sp > 1.0:
                sp = 1.0
            cur = idle_a + run_a * sp
            total += cur
            for i in range(3):
                b[i] += cur * servo_dirs[j, i]
        currents[0] = total
        for i in range(3):
            m = soft[i, 0] * b[0] + soft[i, 1] * b[1] + soft[i, 2] * b[2] + hard[i] + mag_noise[3 * k + i] * nm[i]
            out[k, 6 + i] = m if i == 0 else -m


def _error_matrix(rng: np.random.Generator, scale: float, cross: float) -> np.ndarray:
    # as sim/sensors/imu.py draws them: identity + scale errors + cross-axis terms
    m = np.eye(3) + np.diag(rng.standard_normal(3) * scale)
    off = rng.standard_normal((3, 3)) * cross
    np.fill_diagonal(off, 0.0)
    return m + off


def _symmetric(rng: np.random.Generator, sigma: float) -> np.ndarray:
    a = rng.standard_normal((3, 3)) * sigma
    return np.eye(3) + 0.5 * (a + a.T)


class World:
    """One vehicle in one tank, stepped by servo frames.

    Parameters
    ----------
    params:
        The vehicle (``sim/vehicles/reference.py`` or a copy).
    spec:
        ``WorldSpec``.
    seed:
        Seeds every random stream.
    steps_per_frame:
        10 ms steps in one exchange with the board.
    """

    def __init__(self, params: VehicleParams, spec: WorldSpec = WorldSpec(), seed: int = 0,
                 steps_per_frame: int = 2) -> None:
        self.spec = spec
        self.params = params
        current = Current(velocity=tuple(spec.current)) if spec.current is not None else None
        self.model = Model(params, bottom=Bottom(depth=spec.bottom_depth), current=current)
        h = math.radians(spec.heading_deg)
        self._q0 = np.array([math.cos(h / 2), 0.0, 0.0, math.sin(h / 2)])
        self.x = self.model.state(position=(0.0, 0.0, spec.start_depth), attitude=self._q0)
        self.n = steps_per_frame
        self.k = 0                              # steps taken
        self.released_at: Optional[float] = None
        self.landed_at: Optional[float] = None
        self.landing_ne: Optional[tuple] = None
        #: The centre of buoyancy with the wings flat, in the body frame from
        #: O: the point the tracker measures and the estimator reports.
        self.cb = np.asarray(self.model.vehicles[0].centre_of_buoyancy(np.zeros(4)), float)
        self.held = True
        n1 = steps_per_frame + 1
        self._xs = np.zeros((n1, 1, 17))
        self._sds = np.zeros((n1, 1, 4))
        self._nus = np.zeros((n1, 1, 6))
        self._vimu = np.zeros((n1, 1, 3))
        self._dep = np.zeros((n1, 1))
        self._scratch = kernels.scratch()
        self._rows = np.empty((steps_per_frame, 9))
        self._currents = np.zeros(1)
        self._ks = np.empty((7, 17))
        self._out3 = np.empty((2, 3))
        self._s_out = np.zeros(4)
        self._sd_out = np.zeros(4)
        cmd0 = np.zeros((1, 4))
        kernels.record_all(self.x, cmd0, self.model.T, self._sds[0], self._nus[0], self._vimu[0], self._dep[0])
        self._vimu_last = self._vimu[0].copy()
        self._sd_last = np.zeros(4)
        self._port_depth = float(self._dep[0, 0])
        # ----- sensors
        imu = spec.imu
        r = np.random.default_rng([seed, 11])
        self._rng_imu = r
        self._mg = _error_matrix(r, imu.gyro.scale_error, imu.gyro.cross_axis)
        self._ma = _error_matrix(r, imu.accel.scale_error, imu.accel.cross_axis)
        self._bg = r.standard_normal(3) * imu.gyro.turn_on_bias
        self._ba = r.standard_normal(3) * imu.accel.turn_on_bias
        self._ng = imu.gyro.noise_density * math.sqrt(imu.gyro.rate_hz)
        self._na = imu.accel.noise_density * math.sqrt(imu.accel.rate_hz)
        self._wg = imu.gyro.bias_walk * math.sqrt(STEP_S)
        self._wa = imu.accel.bias_walk * math.sqrt(STEP_S)
        ms = imu.mag
        r = np.random.default_rng([seed, 12])
        self._rng_mag = r
        self._soft = _symmetric(r, ms.soft_iron)
        self._hard = r.standard_normal(3) * ms.hard_iron
        self._cal_offset = self._hard + r.standard_normal(3) * ms.residual_hard_iron
        self._cal_matrix = _symmetric(r, ms.residual_soft_iron) @ np.linalg.inv(self._soft)
        self._cal_matrix = 0.5 * (self._cal_matrix + self._cal_matrix.T)
        self._earth = imu.earth.ned()
        self._servo_dirs = imu_model.servo_directions(np.asarray(params.imu_position, float), ms) \
            * ms.servo_gauss_per_a
        self._nm = np.asarray(ms.noise_rms, float)
        d = spec.depth
        r = np.random.default_rng([seed, 13])
        self._rng_depth = r
        self._p_offset = r.standard_normal() * d.offset_pa
        self._p_coeff = r.standard_normal() * d.temp_coeff_pa_per_k
        self._temp = float(spec.water.temperature(max(self._port_depth, 0.0)))
        w = spec.water
        frame_s = steps_per_frame * STEP_S
        self._t_surface = w.surface_temperature_c
        self._t_gradient = w.gradient_c_per_m
        self._temp_gain = 1.0 - math.exp(-frame_s / d.thermal_tau_s)
        self._p_surface = w.atmosphere_pa
        self._rho_g = w.density * G
        self._t_reference = d.reference_temperature_c
        self._p_noise = d.noise_rms_pa
        self._p_max = d.full_scale_pa
        self._t_noise = d.temperature_noise_c
        b = spec.battery
        self._sag_gain = 1.0 - math.exp(-frame_s / b.sag_tau_s)
        self._drain = b.drain_v_per_s * frame_s
        self._r_int = b.internal_ohm
        # ----- battery and leak
        self.battery_v = spec.battery.full_v
        self._sag_to: Optional[float] = None
        self._batt_sent = -1.0
        self.leak = False
        self._leak_sent: Optional[bool] = None
        # ----- tracker
        tr = spec.tracker
        r = np.random.default_rng([seed, 14])
        self._rng_fix = r
        self._next_fix = r.uniform() / tr.rate_hz
        self.fixes: list[tuple[float, float, float, float]] = []   # (arrival, t, north, east)
        # ----- record of the truth, one row a frame
        self.log_t: list[float] = []
        self.log_x: list[np.ndarray] = []
        self.log_cmd: list[np.ndarray] = []

    # ------------------------------------------------------------ control
    @property
    def t(self) -> float:
        return self.k * STEP_S

    def release(self) -> None:
        """Let go: the vehicle falls from where it was held, at rest."""
        if not self.held:
            return
        s = self.x[0, WINGS].copy()
        self.x = self.model.state(position=self.x[0, POS], attitude=self.x[0, QUAT], wings=s,
                                  wing_rates=self._sd_last)
        self.held = False
        self.released_at = self.t

    def sag(self, volts: float) -> None:
        """The pack falls towards ``volts`` (a failing cell)."""
        self._sag_to = volts

    def set_leak(self, wet: bool = True) -> None:
        self.leak = wet

    def compass_params(self) -> dict[str, float]:
        """COMPASS_* parameters of a calibration of this seed's magnetometer."""
        o = self._cal_offset * 1000.0
        m = self._cal_matrix
        return {"COMPASS_OFS_X": float(o[0]), "COMPASS_OFS_Y": float(o[1]), "COMPASS_OFS_Z": float(o[2]),
                "COMPASS_DIA_X": float(m[0, 0]), "COMPASS_DIA_Y": float(m[1, 1]), "COMPASS_DIA_Z": float(m[2, 2]),
                "COMPASS_ODI_X": float(m[0, 1]), "COMPASS_ODI_Y": float(m[0, 2]), "COMPASS_ODI_Z": float(m[1, 2]),
                "COMPASS_DEC": math.radians(self.spec.imu.earth.declination_deg)}

    # ------------------------------------------------------------ stepping
    def start_row(self) -> list:
        """The parts' inputs now, the vehicle held still (time 0)."""
        self._xs[1] = self.x
        self._sds[1, 0] = self._sd_last
        self._dep[1, 0] = self._port_depth
        held = self.held
        self.held = True
        try:
            return self._sense(self.t, 1)[0]
        finally:
            self.held = held

    def frame(self, wings: np.ndarray) -> list[list]:
        """Advance one frame with wing commands ``wings`` (4, rad); the inputs
        of the parts at the frame's step boundaries, as lists for the board."""
        n = self.n
        cmd = np.asarray(wings, float).reshape(1, 4)
        xs, sds, nus, vimu, dep = self._xs, self._sds, self._nus, self._vimu, self._dep
        xs[0] = self.x
        vimu[0] = self._vimu_last
        T = self.model.T
        if self.held:
            p = T[5]
            for k in range(1, n + 1):
                s0 = xs[k - 1, 0, WINGS]
                kernels.servo_state(p, 0, s0, cmd[0], STEP_S, self._s_out, self._sd_out)
                xs[k] = xs[k - 1]
                xs[k, 0, WINGS] = self._s_out
                sds[k, 0] = self._sd_out
                nus[k] = 0.0
                vimu[k] = 0.0
                kernels.record_all(xs[k], cmd, T, self._sds[k], self._nus[k], self._vimu[k], self._dep[k])
                nus[k] = 0.0
                vimu[k] = 0.0
                sds[k, 0] = self._sd_out
        else:
            _advance(self.x, cmd, STEP_S, n, T, self._scratch, self._ks, self._out3, xs, sds, nus, vimu, dep)
        self.x[0] = xs[n, 0]
        self._vimu_last[0] = vimu[n, 0]
        self._sd_last[:] = sds[n, 0]
        t0 = self.t
        self.k += n
        self.log_t.append(self.t)
        self.log_x.append(xs[n, 0].copy())
        self.log_cmd.append(cmd[0].copy())
        if not self.held and self.landed_at is None and self.x[0, 2] > self.spec.bottom_depth - 0.4:
            if self.model.touching_bottom(self.x)[0]:
                self.landed_at = self.t
                c = self.cb_position(self.x[0])
                self.landing_ne = (float(c[0]), float(c[1]))
        rows = self._sense(t0, n)
        self._track(t0, n)
        return rows

    def _sense(self, t0: float, n: int) -> list[list]:
        out = self._rows[:n]
        ms = self.spec.imu.mag
        _sense_kernel(self._xs, self._sds, self._nus, self._vimu, n, self.held,
                      self._mg, self._ma, self._bg, self._ba, self._rng_imu.standard_normal(4 * n * 3),
                      self._ng, self._na, self._wg, self._wa, self._earth, self._soft, self._hard,
                      self._servo_dirs, ms.servo_idle_a, ms.servo_run_a, ms.servo_full_speed,
                      self._rng_mag.standard_normal(n * 3) , self._nm, out, self._currents)
        # pressure, temperature, battery, leak: at the frame's first boundary
        port = float(self._dep[1, 0])
        self._port_depth = port
        wet = port if port > 0.0 else 0.0
        target = self._t_surface + self._t_gradient * wet
        self._temp += (target - self._temp) * self._temp_gain
        z0, z1 = self._rng_depth.standard_normal(2).tolist()
        p = (self._p_surface + self._rho_g * wet + self._p_offset
             + self._p_coeff * (self._temp - self._t_reference) + z0 * self._p_noise)
        p = min(max(p, 0.0), self._p_max)
        temp = self._temp + z1 * self._t_noise
        if self._sag_to is not None:
            self.battery_v += (self._sag_to - self.battery_v) * self._sag_gain
        else:
            self.battery_v -= self._drain
        v = self.battery_v - self._r_int * float(self._currents[0])
        volts = None
        if abs(v - self._batt_sent) >= 0.002:
            volts = v
            self._batt_sent = v
        leak = None
        if self.leak != self._leak_sent:
            leak = 1 if self.leak else 0
            self._leak_sent = self.leak
        rows = out.tolist()
        for r in rows:
            r += _NONES
        first = rows[0]
        first[9] = p
        first[10] = temp
        first[11] = volts
        first[12] = leak
        return rows

    def _track(self, t0: float, n: int) -> None:
        tr = self.spec.tracker
        t1 = t0 + n * STEP_S
        r = self._rng_fix
        while self._next_fix <= t1:
            tm = self._next_fix
            self._next_fix += 1.0 / tr.rate_hz
            draws = r.uniform(size=3)
            noise = r.standard_normal(2) * tr.noise_m
            if draws[0] < tr.dropout:
                continue
            # where O was at tm, between the frame's steps
            frac = min(max((tm - t0) / (n * STEP_S), 0.0), 1.0)
            ne = (1.0 - frac) * self.cb_position(self._xs[0, 0])[:2] + frac * self.cb_position(self._xs[n, 0])[:2]
            arrival = tm + tr.latency_s + (2.0 * draws[1] - 1.0) * tr.latency_jitter_s
            self.fixes.append((arrival, tm, float(ne[0] + noise[0]), float(ne[1] + noise[1])))

    def arrived_fixes(self) -> list[tuple[float, float, float, float]]:
        """Fixes whose arrival time has come, oldest first (taken from the queue)."""
        now = self.t
        out = [f for f in self.fixes if f[0] <= now]
        if out:
            self.fixes = [f for f in self.fixes if f[0] > now]
            out.sort()
        return out

    def antenna_depth(self) -> float:
        """Depth (m, down) of the radio's antenna: the dome's top, the
        highest point of the dry parts (the radio sits under it)."""
        x = self.x[0]
        w, a, b = x[3], x[4], x[5]
        # body z of the dome's top (z down: above the plate's top face by
        # the dome's radius), turned to NED by the quaternion's third row
        top = -0.5 * self.params.thickness - self.params.dome_radius
        return float(x[2] + (1.0 - 2.0 * (a * a + b * b)) * top)

    # ------------------------------------------------------------ truth
    def cb_position(self, x: np.ndarray) -> np.ndarray:
        """NED position of the centre of buoyancy (flat wings) for a state (17,)."""
        w, a, b, c = x[3:7]
        cb = self.cb
        rot = np.array([[1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b)],
                        [2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a)],
                        [2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b)]])
        return x[0:3] + rot @ cb

    def truth(self) -> dict[str, np.ndarray]:
        """The frames so far: ``t`` (s), ``x`` (K, 17) states, ``cb`` (K, 3) the
        centre of buoyancy's position, ``cmd`` (K, 4)."""
        x = np.array(self.log_x).reshape(-1, 17)
        return {"t": np.array(self.log_t), "x": x, "cb": np.array([self.cb_position(r) for r in x]).reshape(-1, 3),
                "cmd": np.array(self.log_cmd)}
