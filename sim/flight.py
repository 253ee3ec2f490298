"""Closed-loop flights: the dynamics model, the sensor models, the board
estimator and a board controller, stepped together.

A flight, as the firmware would fly it:

1. **Hold.** The vehicle is held still just under the surface at the
   release point for ``hold_s`` (armed, PASSIVE wings): the estimator
   aligns, learns its gyro bias and zeroes its depth, as in the estimator's
   standard scenario (``sim/estimation.py``).
2. **Release.** The requested mode starts; the dynamics integrate from rest
   (RK4 at ``dt``), the sensors sample the truth as it is made, the
   firmware's 100 Hz tick feeds the estimator (IMU every tick, the others
   when they arrive, fixes with their latency, the wing commands when they
   change) and every second tick the controller steps (50 Hz) and its
   commands take effect at the next step of the dynamics.
3. **Landing.** The run ends when a plate corner or wing tip touches the
   bottom at ``depth`` (or at ``max_flight_s``).

The plumbing is the estimator scenario's: the same sensor models, the same
calls (``estimation.REPLAY``'s ``build`` and ``feed``), the same estimator
configuration (``estimation.estimator_config``). The sensor models in
``sim/sensors`` are batch functions of a whole ``Truth``, which a closed
loop does not have in advance, so ``SensorStream`` runs them as the truth
arrives: every random draw of the models is made up front, for the whole
time grid, in the models' own order and sizes, and each sample is then
computed the models' way once the truth it needs exists. On the same truth
it reproduces ``estimation.simulate_sensors`` sample for sample
(``tests/test_flight_sensors.py`` checks that); if a model changes, that
test says so.

``--truth`` (``FlightSpec.truth``) feeds the controller the true state
through ``TruthEstimate`` instead, for comparison.

A ``FlightSpec`` is plain data (it pickles and converts to JSON), so
flights run anywhere: ``sim/montecarlo.py`` draws them and runs them as a
campaign (``sim/campaign``); ``sim/thesis_runs.py`` holds the thesis's
sec. 5.2 runs, ``sim/analysis/authority.py`` why its law cannot steer and
``sim/controller_costs.py`` what a controller step costs on MicroPython.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from roboray.shared import modes as M
from roboray.sim import estimation as E
from roboray.sim.dynamics import Bottom, Model, quat_to_rot
from roboray.sim.sensors import depth as depth_model
from roboray.sim.sensors import imu as imu_model
from roboray.sim.sensors import position_fix
from roboray.sim.sensors.imu import sample_times
from roboray.sim.sensors.noise import clip16, quantize
from roboray.sim.truth import GRAVITY_NED, Truth, quaternion_to_matrix

CONTROLLERS = ("cascade", "backstepping")
FLIGHT_MODES = {"attitude": M.ATTITUDE, "velocity": M.VELOCITY, "target": M.TARGET, "passive": M.PASSIVE}
#: Firmware tick and controller rate.
TICK_HZ = 100.0
CONTROL_EVERY = 2
#: Bands of the settling times: 1 s mean velocity error, distance to target, tilt error.
VELOCITY_BAND = 0.02
TARGET_BAND = 0.25
ATTITUDE_BAND_DEG = 1.0


@dataclass(frozen=True)
class FlightSpec:
    """One closed-loop flight. Plain data, so it pickles and converts to JSON.

    ``target`` and ``velocity`` are NED (north, east[, down]); ``heading_deg``
    is the vehicle's heading at release (its x_c axis, wing 1, from north);
    ``vehicle`` overrides fields of the reference ``VehicleParams`` (model
    errors); ``ctl`` overrides parameters of the controller's table;
    ``tracker_noise_m`` the position fixes' noise. ``radio_model`` (with
    ``water`` and ``conductivity``) sends the fixes through the radio link
    into the water (``sim/radio``): each is lost with the link's frame-loss
    probability at the depth of the vehicle's antenna (the dome's top) when
    it arrives; None: every fix arrives, at any depth. ``water`` also sets
    the density (``VehicleParams.with_water``).
    """

    controller: str = "cascade"
    mode: str = "target"
    target: tuple = (2.0, 0.0)
    depth: float = 10.0
    velocity: tuple = (0.10, 0.0, 0.0)
    attitude_deg: tuple = (0.0, 0.0)
    truth: bool = False
    seed: int = 0
    heading_deg: float = 0.0
    start_depth: float = 0.1
    hold_s: float = E.HOLD_S
    max_flight_s: float = 60.0
    dt: float = 0.005
    vehicle: tuple = ()            #: ((field, value), ...) for dataclasses.replace
    ctl: tuple = ()                #: ((parameter name, value), ...)
    tracker_noise_m: float = 0.02
    water: str = "fresh"
    radio_model: Optional[str] = None
    conductivity: Optional[float] = None
    #: The firmware's descent model, ((DR_* parameter, value), ...): the
    #: estimator dead-reckons with it (``descent_model.PARAM_NAMES``); () today's table
    descent: tuple = ()

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise ValueError("controller must be one of %s, got %r" % (CONTROLLERS, self.controller))
        if self.mode not in FLIGHT_MODES:
            raise ValueError("mode must be one of %s, got %r" % (tuple(FLIGHT_MODES), self.mode))
        if len(self.target) != 2 or len(self.velocity) != 3 or len(self.attitude_deg) != 2:
            raise ValueError("target needs 2 numbers, velocity 3, attitude_deg 2")
        if not self.depth > self.start_depth + 0.5:
            raise ValueError("depth %r m must be at least 0.5 m below the release depth %r m"
                             % (self.depth, self.start_depth))
        if not (self.dt > 0 and round(1.0 / (TICK_HZ * self.dt), 9).is_integer()):
            raise ValueError("dt %r s must divide the 10 ms tick" % self.dt)
        if not (self.hold_s >= 9.0 and self.max_flight_s > 0):
            raise ValueError("hold_s must be at least 9 s (the estimator aligns in 8) and max_flight_s > 0")
        from roboray.sim.radio.radios import NAMES as RADIOS
        from roboray.sim.vehicle import WATER_DENSITY

        if self.water not in WATER_DENSITY:
            raise ValueError("water must be one of %s, got %r" % (sorted(WATER_DENSITY), self.water))
        if self.radio_model is not None and self.radio_model not in RADIOS:
            raise ValueError("radio_model must be one of %s or None, got %r" % (RADIOS, self.radio_model))

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


# ---------------------------------------------------------------- sensors
class SensorStream:
    """The sensor models of ``sim/sensors`` run as the truth arrives.

    ``t`` is the whole time grid (uniform, from 0); ``fill(k)`` declares the
    truth rows ``0..k`` final, and ``samples_until(t_now)`` returns the
    samples a firmware would have read by ``t_now`` that it has not had yet.
    Every random draw is made at construction, in the order and sizes of
    ``estimation.simulate_sensors`` over a truth on the same grid, so the
    logs come out the same.
    """

    def __init__(self, t: np.ndarray, seed: int, imu_position: np.ndarray,
                 scenario: E.Scenario = E.STANDARD) -> None:
        self.t = t
        self.scenario = scenario
        self.n = len(t)
        # the truth, filled as it is made (Truth's fields)
        self.position = np.zeros((self.n, 3))
        self.quaternion = np.zeros((self.n, 4))
        self.omega = np.zeros((self.n, 3))
        self.specific_force = np.zeros((self.n, 3))
        self.depth_sensor = np.zeros(self.n)
        self.wing_rates = np.zeros((self.n, 4))
        self.temperature = np.zeros(self.n)
        self.imu_position = np.asarray(imu_position, float)
        self.filled = -1
        t0, t1 = float(t[0]), float(t[-1])
        spec = scenario.imu
        # --- temperature lag (depth.sensor_temperature), recursion of lfilter
        self._temp_a = math.exp(-float(np.median(np.diff(t))) / scenario.depth.thermal_tau_s)
        # --- inertial (imu.inertial): rng [seed, 1]
        rng = np.random.default_rng([seed, 1])
        self.ti = sample_times(t0, t1, spec.gyro.rate_hz, rng.uniform())
        ni = len(self.ti)
        self._inertial = []
        for s in (spec.gyro, spec.accel):
            m = imu_model._error_matrix(rng, s.scale_error, s.cross_axis)
            start = rng.standard_normal(3) * s.turn_on_bias
            dt_i = np.diff(self.ti, prepend=self.ti[0])
            steps = rng.standard_normal((ni, 3)) * (np.asarray(s.bias_walk) * np.sqrt(dt_i))[:, None]
            walk = start[None, :] + np.cumsum(steps, axis=0)
            tempco = rng.standard_normal(3) * s.bias_tempco
            white = imu_model.white(rng, s.noise_density, s.rate_hz, (ni, 3))
            self._inertial.append((m, walk, tempco, white, s.lsb))
        # --- magnetometer (imu.magnetometer): rng [seed, 2]
        ms = spec.mag
        rng = np.random.default_rng([seed, 2])
        self.tm = sample_times(t0, t1, ms.rate_hz, rng.uniform())
        self._earth = spec.earth.ned()
        self._servo_dirs = imu_model.servo_directions(self.imu_position, ms)
        self._soft = imu_model._error_matrix(rng, ms.soft_iron, ms.soft_iron)
        self._hard = rng.standard_normal(3) * ms.hard_iron
        self._mag_noise = rng.standard_normal((len(self.tm), 3)) * np.asarray(ms.noise_rms)[None, :]
        self.mag_offset = self._hard + rng.standard_normal(3) * ms.residual_hard_iron
        self.mag_matrix = imu_model._error_matrix(rng, ms.residual_soft_iron, ms.residual_soft_iron) \
            @ np.linalg.inv(self._soft)
        self._q_sign = 1.0
        self._q_prev = None
        # --- pressure (depth.pressure): rng [seed, 3]
        ds = scenario.depth
        rng = np.random.default_rng([seed, 3])
        period = 2.0 * ds.cycle_s
        start = t0 + rng.uniform(0.0, period)
        npr = int(np.floor((t1 - ds.cycle_s - start) / period)) + 1
        self._p_start = start + period * np.arange(npr)
        self._p_offset = rng.standard_normal() * ds.offset_pa
        self._p_coeff = rng.standard_normal() * ds.temp_coeff_pa_per_k
        self._p_noise = rng.standard_normal(npr) * ds.noise_rms_pa
        self._t_noise = rng.standard_normal(npr) * ds.temperature_noise_c
        self.tp = self._p_start + 0.5 * ds.conversion_s
        self.tp_ready = self._p_start + ds.cycle_s
        # --- fixes (position_fix.fixes): rng [seed, 4]
        tr = scenario.tracker
        rng = np.random.default_rng([seed, 4])
        tf = t0 + (rng.uniform() + np.arange(int(np.floor((t1 - t0) * tr.rate_hz)))) / tr.rate_hz
        keep = rng.uniform(size=len(tf)) >= tr.dropout
        for a, b in tr.outages:
            keep &= ~((tf >= a) & (tf < a + b))
        self.fixes_lost = int(np.count_nonzero(~keep))
        tf = tf[keep]
        nf = len(tf)
        f_noise = rng.standard_normal((nf, 2)) * tr.noise_m
        wrong = rng.uniform(size=nf) < tr.outlier
        angle = rng.uniform(0.0, 2.0 * np.pi, size=nf)
        jump = np.zeros((nf, 2))
        jump[wrong, 0] = tr.outlier_m * np.cos(angle[wrong])
        jump[wrong, 1] = tr.outlier_m * np.sin(angle[wrong])
        arrival = tf + tr.latency_s + rng.uniform(-1.0, 1.0, size=nf) * tr.latency_jitter_s
        order = np.argsort(arrival, kind="stable")
        self.tf = tf[order]
        self.tf_arrival = arrival[order]
        self._f_noise = f_noise[order]
        self._f_jump = jump[order]
        self._f_wrong = wrong[order]
        # outputs, computed as the truth allows
        self.gyro = np.zeros((ni, 3))
        self.accel = np.zeros((ni, 3))
        self.mag = np.zeros((len(self.tm), 3))
        self.pressure = np.zeros(npr)
        self.pressure_temperature = np.zeros(npr)
        self.fix_ne = np.zeros((len(self.tf), 2))
        self._done = {"i": 0, "m": 0, "p": 0, "f": 0}

    # ------------------------------------------------------------ truth
    def set_rows(self, k0: int, k1: int, position, quaternion, omega, specific_force, depth_sensor,
                 wing_rates) -> None:
        """Truth rows k0..k1-1, then advance the temperature lag over them."""
        self.position[k0:k1] = position
        self.quaternion[k0:k1] = quaternion
        self.omega[k0:k1] = omega
        self.specific_force[k0:k1] = specific_force
        self.depth_sensor[k0:k1] = depth_sensor
        self.wing_rates[k0:k1] = wing_rates
        water = self.scenario.water
        target = water.temperature(self.depth_sensor[k0:k1])
        a = self._temp_a
        b = 1.0 - a
        for j in range(k1 - k0):
            k = k0 + j
            if k == 0:
                # lfilter's initial condition zi = a x[0]: y[0] = x[0]
                self._temp_z = a * target[0]
            y = b * target[j] + self._temp_z
            self.temperature[k] = y
            self._temp_z = a * y
        self.filled = k1 - 1

    # ----------------------------------------------------------- samples
    def _ready(self, times: np.ndarray, key: str, until: float) -> tuple[int, int]:
        """Index range of the samples not yet produced whose time (``times``:
        when the sample exists, its truth included) is at or before ``until``."""
        i0 = self._done[key]
        i1 = int(np.searchsorted(times, until, side="right"))
        return i0, max(i0, i1)

    def produce(self, until: float) -> None:
        """Compute every sample due by ``until`` whose truth exists."""
        tt = self.t[:self.filled + 1]
        limit = min(until, float(tt[-1]))
        ref = self.scenario.imu.reference_temperature_c
        # inertial
        i0, i1 = self._ready(self.ti, "i", limit)
        if i1 > i0:
            ts = self.ti[i0:i1]
            d_temp = np.interp(ts, tt, self.temperature[:len(tt)]) - ref
            for out, true, (m, walk, tempco, white, lsb) in (
                    (self.gyro, _interp(tt, self.omega, ts), self._inertial[0]),
                    (self.accel, _interp(tt, self.specific_force, ts), self._inertial[1])):
                bias = walk[i0:i1] + d_temp[:, None] * tempco[None, :]
                raw = true @ m.T + bias + white[i0:i1]
                out[i0:i1] = clip16(quantize(raw, lsb), lsb)
            self._done["i"] = i1
        # magnetometer
        i0, i1 = self._ready(self.tm, "m", limit)
        if i1 > i0:
            ts = self.tm[i0:i1]
            q = self._quaternions(ts)
            earth_body = np.einsum("nji,j->ni", quaternion_to_matrix(q), self._earth)
            ms = self.scenario.imu.mag
            currents = imu_model.servo_currents(_interp(tt, self.wing_rates, ts), ms)
            servo = (currents * ms.servo_gauss_per_a) @ self._servo_dirs
            raw = (earth_body + servo) @ self._soft.T + self._hard + self._mag_noise[i0:i1]
            self.mag[i0:i1] = clip16(quantize(raw, ms.lsb), ms.lsb)
            self._done["m"] = i1
        # pressure: ready at the end of its slot, its window inside it
        ds = self.scenario.depth
        i0, i1 = self._ready(self.tp_ready, "p", limit)
        if i1 > i0:
            t_start = self._p_start[i0:i1]
            window = t_start[:, None] + np.linspace(0.0, ds.conversion_s, 9)[None, :]
            water = self.scenario.water
            true_p = water.pressure(np.interp(window, tt, self.depth_sensor[:len(tt)])).mean(axis=1)
            t_temp = np.interp(t_start - ds.cycle_s + 0.5 * ds.conversion_s, tt, self.temperature[:len(tt)])
            measured = (true_p + self._p_offset + self._p_coeff * (t_temp - ds.reference_temperature_c)
                        + self._p_noise[i0:i1])
            self.pressure[i0:i1] = np.clip(quantize(measured, ds.lsb_pa), 0.0, ds.full_scale_pa)
            self.pressure_temperature[i0:i1] = quantize(t_temp + self._t_noise[i0:i1], ds.temperature_lsb_c)
            self._done["p"] = i1
        # fixes: delivered at their arrival, measured earlier
        i0, i1 = self._ready(self.tf_arrival, "f", limit)
        if i1 > i0:
            pos = _interp(tt, self.position[:len(tt), :2], self.tf[i0:i1]) + self._f_noise[i0:i1]
            self.fix_ne[i0:i1] = pos + self._f_jump[i0:i1]
            self._done["f"] = i1

    def _quaternions(self, ts: np.ndarray) -> np.ndarray:
        """``sampling.interpolate_quaternion`` over the truth so far: the
        hemisphere of each row follows the previous one (a running sign)."""
        k = self.filled
        start = getattr(self, "_q_fixed", 0)
        q = self.quaternion
        if not hasattr(self, "_q_aligned"):
            self._q_aligned = np.zeros_like(q)
        al = self._q_aligned
        for j in range(start, k + 1):
            if j == 0:
                al[0] = q[0]
                continue
            if float(np.sum(q[j] * q[j - 1])) < 0.0:
                self._q_sign = -self._q_sign
            al[j] = q[j] * self._q_sign
        self._q_fixed = k + 1
        out = _interp(self.t[:k + 1], al[:k + 1], ts)
        return out / np.linalg.norm(out, axis=1, keepdims=True)

    def logs(self, until: Optional[float] = None) -> E.SensorLogs:
        """Everything produced so far (or up to ``until``) as the models' logs."""
        until = math.inf if until is None else until
        ni = min(self._done["i"], int(np.searchsorted(self.ti, until, side="right")))
        nm = min(self._done["m"], int(np.searchsorted(self.tm, until, side="right")))
        npr = min(self._done["p"], int(np.searchsorted(self.tp_ready, until, side="right")))
        nf = min(self._done["f"], int(np.searchsorted(self.tf_arrival, until, side="right")))
        zeros3 = np.zeros((ni, 3))
        return E.SensorLogs(
            inertial=imu_model.InertialLog(t=self.ti[:ni], gyro=self.gyro[:ni], accel=self.accel[:ni],
                                           gyro_bias=self._inertial[0][1][:ni] + zeros3,
                                           accel_bias=self._inertial[1][1][:ni] + zeros3),
            mag=imu_model.MagLog(t=self.tm[:nm], field=self.mag[:nm], servo_field=np.zeros((nm, 3)),
                                 offset=self.mag_offset, matrix=self.mag_matrix),
            pressure=depth_model.PressureLog(t=self.tp[:npr], t_ready=self.tp_ready[:npr],
                                             pressure_pa=self.pressure[:npr],
                                             temperature_c=self.pressure_temperature[:npr],
                                             true_pressure_pa=np.zeros(npr)),
            fixes=position_fix.FixLog(t=self.tf[:nf], t_arrival=self.tf_arrival[:nf], north=self.fix_ne[:nf, 0],
                                      east=self.fix_ne[:nf, 1], outlier=self._f_wrong[:nf], lost=self.fixes_lost),
        )


def _interp(t: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``sampling.interpolate`` of (N, D) values over the first len(t) rows."""
    return np.stack([np.interp(at, t, values[:len(t), i]) for i in range(values.shape[1])], axis=1)


class TickFeed:
    """The firmware's 100 Hz calls (``estimation.schedule``'s events), made
    as the sensors produce: at tick ``k`` the newest IMU sample, a new
    magnetometer sample, a pressure sample whose slot has ended, the fixes
    that have arrived, and the wing command when it changed."""

    def __init__(self, sensors: SensorStream, link=None, antenna_z: float = 0.0, seed: int = 0) -> None:
        self.s = sensors
        self.t0 = float(sensors.ti[0])
        self._last = [-1, -1, -1]
        self._last_w: Optional[list] = None
        #: ``sim/radio`` link the fixes cross (None: all arrive); the
        #: antenna's body z from the centre of buoyancy (the truth's point)
        self.link = link
        self._antenna_z = antenna_z
        self._dt = float(sensors.t[1] - sensors.t[0]) if sensors.n > 1 else 1.0
        self._rng_link = np.random.default_rng([seed, 17])
        self.fixes_used = 0
        self.fixes_lost_to_link = 0

    def _crosses(self, tk: float) -> bool:
        """Whether a fix arriving at ``tk`` crosses the link (one draw a fix)."""
        from roboray.sim.radio.link import frame_loss

        s = self.s
        k = min(int(round(tk / self._dt)), s.n - 1)
        a, b = s.quaternion[k, 1], s.quaternion[k, 2]
        depth = float(s.position[k, 2] + (1.0 - 2.0 * (a * a + b * b)) * self._antenna_z)
        return bool(self._rng_link.uniform() >= frame_loss(self.link.margin_db(depth)))

    def tick_time(self, k: int) -> float:
        return self.t0 + k / TICK_HZ

    def events(self, k: int, wings: Sequence[float]) -> list:
        s = self.s
        tk = self.tick_time(k)
        s.produce(tk)
        tick = []
        w = [round(float(x), 6) for x in wings]
        if w != self._last_w:
            tick.append(["w"] + w)
            self._last_w = w
        j = int(np.searchsorted(s.tm, tk, side="right")) - 1
        if j > self._last[0]:
            self._last[0] = j
            tick.append(["m", int(E.to_ticks(s.tm[j]))] + [float(x) for x in s.mag[j]])
        j = int(np.searchsorted(s.tp_ready, tk, side="right")) - 1
        if j > self._last[1]:
            self._last[1] = j
            tick.append(["p", int(E.to_ticks(s.tp[j])), float(s.pressure[j])])
        j = int(np.searchsorted(s.tf_arrival, tk, side="right")) - 1
        while j > self._last[2]:
            self._last[2] += 1
            f = self._last[2]
            if self.link is not None and not self._crosses(tk):
                self.fixes_lost_to_link += 1
                continue
            self.fixes_used += 1
            tick.append(["f", int(E.to_ticks(s.tf[f])), float(s.fix_ne[f, 0]), float(s.fix_ne[f, 1])])
        j = int(np.searchsorted(s.ti, tk, side="right")) - 1
        tick.append(["i", int(E.to_ticks(tk))] + [float(x) for x in s.gyro[j]] + [float(x) for x in s.accel[j]])
        return tick


#: Controller replay, run unchanged by CPython and by MicroPython: builds
#: the board controller as ``make_controller`` does and steps it on a
#: recorded ``Flight.control_log``.
CONTROL_REPLAY = '''
from array import array
from roboray.shared import param_defs
from roboray.shared.params import ParamTable
from roboray.shared.estimator import Estimator
from roboray.shared.control import Controller
from roboray.shared.control.backstepping import BacksteppingController


def build_controller(kind, overrides, target, velocity, attitude):
    table = ParamTable(param_defs.PARAMS)
    for item in overrides:
        if table.set_by_name(item[0], item[1]) != 0:
            raise ValueError(item[0])
    ctl = BacksteppingController(table) if kind == "backstepping" else Controller(table)
    ctl.set_target(target[0], target[1], target[2])
    ctl.set_velocity(velocity[0], velocity[1], velocity[2])
    ctl.set_attitude(attitude[0], attitude[1], attitude[2])
    return ctl


def load(est, rec):
    """The estimator's outputs of one logged step into ``est``."""
    q = est.q
    for i in range(4):
        q[i] = rec[2 + i]
    r = est.rates
    e = est.euler
    for i in range(3):
        r[i] = rec[6 + i]
        e[i] = rec[9 + i]
    n = est.nav
    for i in range(6):
        n[i] = rec[12 + i]
    s = est.status
    for i in range(5):
        s[i] = rec[18 + i]


def control_replay(ctl, est, log):
    out = array("f", [0.0, 0.0, 0.0, 0.0])
    result = []
    for rec in log:
        load(est, rec)
        ctl.step(rec[0], rec[1], est, out)
        result.append([out[0], out[1], out[2], out[3]])
    return result
'''


def control_replay_namespace() -> dict:
    """``CONTROL_REPLAY`` executed on CPython."""
    namespace: dict = {}
    exec(compile(CONTROL_REPLAY, "<control replay>", "exec"), namespace)
    return namespace


def controller_setup(spec: FlightSpec) -> tuple:
    """JSON-able arguments of ``CONTROL_REPLAY``'s ``build_controller``."""
    return (spec.controller, [list(item) for item in spec.ctl],
            [spec.target[0], spec.target[1], spec.depth], list(spec.velocity),
            [math.radians(spec.attitude_deg[0]), math.radians(spec.attitude_deg[1]), 0.0])


# ----------------------------------------------------------- estimates
class TruthEstimate:
    """The estimator's outputs (``q``, ``rates``, ``euler``, ``nav``,
    ``status``) filled from the true state: ``--truth``."""

    def __init__(self) -> None:
        from array import array

        from roboray.shared.estimator import health as H

        self.q = array("f", [1.0, 0.0, 0.0, 0.0])
        self.rates = array("f", [0.0] * 3)
        self.euler = array("f", [0.0] * 3)
        self.nav = array("f", [0.0] * H.NAV_SIZE)
        self.status = array("i", [0] * H.STATUS_SIZE)
        self.status[H.STATUS_HEALTH] = H.IMU_OK | H.DEPTH_OK | H.FIX_OK | H.MAG_OK | H.ATTITUDE_VALID \
            | H.DEPTH_VALID | H.POSITION_VALID
        self.status[H.STATUS_VALID] = 1

    def update(self, x: np.ndarray, nu: np.ndarray, reference: Optional[np.ndarray] = None) -> None:
        """From the state ``x`` and velocities ``nu`` of O; positions and
        velocities of the body point ``reference`` (m from O; default O)."""
        q = x[3:7]
        r = quat_to_rot(q[None, :])[0]
        ref = np.zeros(3) if reference is None else reference
        v = r @ (nu[:3] + np.cross(nu[3:6], ref))
        p = x[0:3] + r @ ref
        for i in range(4):
            self.q[i] = q[i]
        for i in range(3):
            self.rates[i] = nu[3 + i]
        self.euler[0] = math.atan2(r[2, 1], r[2, 2])
        self.euler[1] = -math.asin(max(-1.0, min(1.0, r[2, 0])))
        self.euler[2] = math.atan2(r[1, 0], r[0, 0])
        self.nav[0] = p[2]
        self.nav[1] = v[2]
        self.nav[2] = p[0]
        self.nav[3] = p[1]
        self.nav[4] = v[0]
        self.nav[5] = v[1]


# --------------------------------------------------------------- flight
@dataclass
class Flight:
    """A flown run: the truth, the estimates and the controller's outputs at
    the controller's steps (50 Hz, from release), and the figures."""

    spec: FlightSpec
    t: np.ndarray               #: (K,) s since release
    position: np.ndarray        #: (K, 3) NED of the centre of buoyancy (flat wings), as the estimator reports
    velocity: np.ndarray        #: (K, 3) NED, of the same point
    quaternion: np.ndarray      #: (K, 4)
    wings: np.ndarray           #: (K, 4) rad, reached
    command: np.ndarray         #: (K, 4) rad, commanded
    estimate_nav: np.ndarray    #: (K, 6) the estimator's nav
    estimate_euler: np.ndarray  #: (K, 3)
    setpoints: np.ndarray       #: (K, n) the controller's ``command`` array
    landed_at: Optional[float]  #: s since release, None if it never touched
    landing_position: Optional[np.ndarray]
    metrics: dict = field(default_factory=dict)
    #: The controller's inputs, one per step from the last held one:
    #: [t_us, mode, q (4), rates (3), euler (3), nav (6), status (5)], for
    #: ``CONTROL_REPLAY`` (the same steps on another interpreter).
    control_log: list = field(default_factory=list)

    def tilt_deg(self) -> np.ndarray:
        r = quat_to_rot(self.quaternion)
        return np.degrees(np.arccos(np.clip(r[:, 2, 2], -1.0, 1.0)))


def descent_config(params: dict) -> dict:
    """The replay's ``descent`` config from DR_* parameters (today's
    table where one is missing)."""
    from roboray.shared.estimator.descent_model import DEFAULT, PARAM_NAMES

    k = [params.get(PARAM_NAMES[i], DEFAULT.gain[i]) for i in range(3)]
    return {"glide_gain": k, "diff_gain": params.get(PARAM_NAMES[3], DEFAULT.diff_gain),
            "tau_s": params.get(PARAM_NAMES[4], DEFAULT.tau_s)}


def vehicle_params(spec: FlightSpec):
    from roboray.sim.vehicle import load_params

    params = load_params()
    if spec.vehicle:
        params = dataclasses.replace(params, **dict(spec.vehicle))
    return params.with_water(spec.water) if spec.water != "fresh" else params


def make_controller(spec: FlightSpec):
    """The board controller of ``spec`` with its parameter overrides."""
    from roboray.shared import param_defs
    from roboray.shared.params import ParamTable

    table = ParamTable(param_defs.PARAMS)
    for name, value in spec.ctl:
        if table.set_by_name(name, value) != 0:
            raise ValueError("controller parameter %s = %r refused (unknown or out of range)" % (name, value))
    if spec.controller == "backstepping":
        from roboray.shared.control.backstepping import BacksteppingController

        return BacksteppingController(table), table
    from roboray.shared.control import Controller

    return Controller(table), table


def _quat_heading(heading_deg: float) -> np.ndarray:
    a = math.radians(heading_deg) / 2.0
    return np.array([math.cos(a), 0.0, 0.0, math.sin(a)])


def fly(spec: FlightSpec, record_every: int = 1, depth=None) -> Flight:
    """Fly ``spec`` to the bottom (or ``max_flight_s``); see the module
    docstring. ``depth(m)`` hears the vehicle's depth at each control step
    after the release (a progress bar's measure: the bottom is the end)."""
    from array import array

    _single_thread()
    params = vehicle_params(spec)
    model = Model(params, bottom=Bottom(depth=spec.depth))
    ctl, table = make_controller(spec)
    mode = FLIGHT_MODES[spec.mode]
    _, _, target, velocity, attitude = controller_setup(spec)
    ctl.set_target(*target)
    ctl.set_velocity(*velocity)
    ctl.set_attitude(*attitude)
    dt = spec.dt
    steps_per_tick = int(round(1.0 / (TICK_HZ * dt)))
    n_grid = int(round((spec.hold_s + spec.max_flight_s) / dt)) + 1
    t_grid = np.arange(n_grid) * dt
    k_release = int(round(spec.hold_s / dt))
    passive = math.radians(table.get(table.index("PASSIVE_WING_DEG")))
    # The estimator reports the centre of buoyancy (flat wings), the point
    # the tracker's fixes measure: the truth the sensors see is referenced
    # to it, as in estimation.dynamics_descent; it starts at start_depth.
    cb = model.vehicles[0].centre_of_buoyancy(np.zeros(4))
    x = model.state(position=(0.0, 0.0, spec.start_depth - cb[2]), attitude=_quat_heading(spec.heading_deg),
                    wings=np.clip(np.full(4, passive), 0.0, math.pi / 2))
    scenario = dataclasses.replace(E.STANDARD, hold_s=spec.hold_s, tracker=dataclasses.replace(
        E.STANDARD.tracker, noise_m=spec.tracker_noise_m))
    sensors = SensorStream(t_grid, spec.seed, model.imu[0] - cb, scenario)
    # The hold: still at the release point (specific force -g in the body).
    rot0 = quat_to_rot(x[:, 3:7])[0]
    still_f = rot0.T @ -GRAVITY_NED
    port_depth = float(x[0, 2] + rot0[2] @ model.port[0])
    sensors.set_rows(0, k_release + 1, x[0, 0:3] + rot0 @ cb, x[0, 3:7], np.zeros(3), still_f, port_depth,
                     np.zeros(4))
    link = None
    if spec.radio_model is not None:
        from roboray.sim.radio import link as link_mod

        link = link_mod.make(spec.radio_model, spec.water, spec.conductivity)
    # the antenna: the dome's top, from the centre of buoyancy (body z, down)
    feed = TickFeed(sensors, link, -0.5 * params.thickness - params.dome_radius - float(cb[2]), spec.seed)
    # The estimator, built as the scenario builds it once the hold's
    # pressures are in (the firmware zeroes depth at the surface).
    if spec.truth:
        est = TruthEstimate()
        ns = None
    else:
        sensors.produce(spec.hold_s)
        hold_truth = Truth(t=t_grid[:k_release + 1], position_ned=sensors.position[:k_release + 1],
                           velocity_ned=np.zeros((k_release + 1, 3)), quaternion=sensors.quaternion[:k_release + 1],
                           omega_body=np.zeros((k_release + 1, 3)),
                           specific_force_imu=sensors.specific_force[:k_release + 1],
                           depth_sensor=sensors.depth_sensor[:k_release + 1], wings=np.zeros((k_release + 1, 4)),
                           wing_rates=np.zeros((k_release + 1, 4)), imu_position_body=model.imu[0] - cb,
                           port_position_body=model.port[0] - cb)
        config = E.estimator_config(sensors.logs(spec.hold_s), hold_truth, scenario)
        if spec.descent:
            config["descent"] = descent_config(dict(spec.descent))
        ns = E.replay_namespace()
        est = ns["build"](config)
    out = array("f", [passive] * 4)
    cmd = x[:, 13:17].copy()
    # recording
    rec: dict[str, list] = {k: [] for k in ("t", "pos", "vel", "q", "wings", "cmd", "nav", "euler", "sp")}
    # the dynamics through its public API, one step at a time
    imu_o = model.imu[0]
    port_o = model.port[0]
    k_grid = k_release
    near_bottom = spec.depth - (params.wing_height + params.plate_side + params.dome_radius)
    nu = model.velocities(x, model.servo_rate(x[:, 13:17], cmd))[0]
    v_imu = np.zeros(3)
    landed_at = None
    landing_pos = None
    tick = 0
    released = False
    control_count = 0
    control_log: list = []
    while True:
        tk = feed.tick_time(tick)
        if tk > t_grid[-1] - dt * steps_per_tick:
            break
        if tk >= spec.hold_s and not released:
            released = True
        if released:
            # advance the dynamics to the first grid point at or after the tick
            k_need = int(math.ceil(tk / dt - 1e-9))
            while k_grid < k_need:
                x = model.step(x, cmd, dt)
                sd = model.servo_rate(x[:, 13:17], cmd)
                nu = model.velocities(x, sd)[0]
                rot = _rotation(x[0, 3:7])
                # the IMU's NED velocity; the accelerometer reads its mean
                # change over the step less gravity (as simulate() does)
                v_new = rot @ (nu[:3] + _cross(nu[3:6], imu_o))
                f_imu = rot.T @ ((v_new - v_imu) / dt - GRAVITY_NED)
                v_imu = v_new
                k_grid += 1
                sensors.set_rows(k_grid, k_grid + 1, x[0, 0:3] + rot @ cb, x[0, 3:7], nu[3:6], f_imu,
                                 x[0, 2] + rot[2] @ port_o, sd[0])
                # contact is possible only within a wing's span of the bottom
                if landed_at is None and x[0, 2] > near_bottom and model.touching_bottom(x)[0]:
                    landed_at = t_grid[k_grid] - spec.hold_s
                    landing_pos = x[0, 0:3] + rot @ cb
        if ns is not None:
            ns["feed"](est, feed.events(tick, out))
        if tick % CONTROL_EVERY == 0:
            if spec.truth:
                est.update(x[0], nu if released else np.zeros(6), cb)
            flight_mode = mode if released else M.PASSIVE
            t_us = int(E.to_ticks(tk))
            if released or feed.tick_time(tick + CONTROL_EVERY) >= spec.hold_s:
                control_log.append([t_us, flight_mode] + [float(v) for v in est.q] + [float(v) for v in est.rates]
                                   + [float(v) for v in est.euler] + [float(v) for v in est.nav]
                                   + [int(v) for v in est.status])
            ctl.step(t_us, flight_mode, est, out)
            cmd[0, :] = out
            if released and depth is not None:
                depth(float(x[0, 2]))
            if released and control_count % record_every == 0:
                rec["t"].append(tk - spec.hold_s)
                rr = _rotation(x[0, 3:7])
                rec["pos"].append(x[0, 0:3] + rr @ cb)
                rec["vel"].append(rr @ (nu[:3] + _cross(nu[3:6], cb)))
                rec["q"].append(x[0, 3:7].copy())
                rec["wings"].append(x[0, 13:17].copy())
                rec["cmd"].append(np.array(out, float))
                rec["nav"].append(np.array(est.nav, float))
                rec["euler"].append(np.array(est.euler, float))
                rec["sp"].append(np.array(ctl.command, float))
            if released:
                control_count += 1
        if landed_at is not None:
            break
        tick += 1
    flight = Flight(spec=spec, t=np.array(rec["t"]), position=np.array(rec["pos"]), velocity=np.array(rec["vel"]),
                    quaternion=np.array(rec["q"]), wings=np.array(rec["wings"]), command=np.array(rec["cmd"]),
                    estimate_nav=np.array(rec["nav"]), estimate_euler=np.array(rec["euler"]),
                    setpoints=np.array(rec["sp"]), landed_at=landed_at, landing_position=landing_pos,
                    control_log=control_log)
    flight.metrics = metrics(flight)
    flight.metrics["fixes_used"] = feed.fixes_used
    flight.metrics["fixes_lost_to_link"] = feed.fixes_lost_to_link
    return flight


def _rotation(q: np.ndarray) -> np.ndarray:
    """Body -> NED matrix of one quaternion (``quat_to_rot`` without its
    batch overhead, which a 200 Hz loop of one vehicle feels)."""
    w, x, y, z = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _single_thread() -> None:
    """One vehicle gains nothing from numba's thread pool, and on a busy
    machine each parallel launch costs about a millisecond."""
    try:
        import numba

        if numba.get_num_threads() != 1:
            numba.set_num_threads(1)
    except (ImportError, ValueError):  # pragma: no cover - numba is a dependency
        pass


# --------------------------------------------------------------- figures
def _settled_after(t: np.ndarray, outside: np.ndarray) -> Optional[float]:
    """Time after which ``outside`` stays False (None if it never settles)."""
    if len(t) == 0 or outside[-1]:
        return None
    idx = np.flatnonzero(outside)
    return float(t[idx[-1] + 1]) if len(idx) else float(t[0])


def _running_mean(x: np.ndarray, n: int) -> np.ndarray:
    if len(x) < n:
        return np.full_like(x, np.nan)
    c = np.cumsum(np.insert(x, 0, 0.0, axis=0), axis=0)
    out = np.full_like(x, np.nan)
    out[n - 1:] = (c[n:] - c[:-n]) / n
    return out


def _airborne(f: Flight) -> np.ndarray:
    return f.t < f.landed_at if f.landed_at is not None else np.ones(len(f.t), bool)


def metrics(f: Flight) -> dict:
    """The issue's figures of a flight."""
    spec = f.spec
    out: dict = {
        "controller": spec.controller, "mode": spec.mode, "estimator": "truth" if spec.truth else "board estimator",
        "seed": spec.seed, "depth_m": spec.depth,
        "descent_time_s": f.landed_at if f.landed_at is not None else (float(f.t[-1]) if len(f.t) else 0.0),
        "landed": f.landed_at is not None,
        # in flight: the bottom's contact tilts the vehicle as it lands
        "max_tilt_deg": float(f.tilt_deg()[_airborne(f)].max()) if _airborne(f).any() else 0.0,
        "servo_travel_deg": float(np.degrees(np.abs(np.diff(f.wings, axis=0)).sum())) if len(f.t) > 1 else 0.0,
        "landing_error_m": None, "velocity_rms_error_mps": None, "settling_time_s": None,
    }
    if len(f.t) < 2:
        return out
    dt = float(np.median(np.diff(f.t)))
    per_s = max(1, int(round(1.0 / dt)))
    out["descent_speed_mps"] = float(np.mean(f.velocity[len(f.t) // 2:, 2]))
    out["estimate_position_rms_m"] = float(np.sqrt(np.mean(np.sum((f.estimate_nav[:, 2:4] - f.position[:, :2]) ** 2, 1))))
    out["estimate_velocity_rms_mps"] = float(np.sqrt(np.mean(np.sum((f.estimate_nav[:, 4:6] - f.velocity[:, :2]) ** 2, 1))))
    if spec.mode == "target":
        err = np.hypot(f.position[:, 0] - spec.target[0], f.position[:, 1] - spec.target[1])
        if f.landing_position is not None:
            out["landing_error_m"] = float(math.hypot(f.landing_position[0] - spec.target[0],
                                                      f.landing_position[1] - spec.target[1]))
            out["landing_position"] = [float(v) for v in f.landing_position]
        out["settling_time_s"] = _settled_after(f.t, err > TARGET_BAND)
        out["target"] = list(spec.target)
    elif spec.mode == "velocity":
        cmd = np.array(spec.velocity[:2])
        err = np.hypot(*(f.velocity[:, :2] - cmd).T)
        mean_err = np.hypot(*(_running_mean(f.velocity[:, :2], per_s) - cmd).T)
        settle = _settled_after(f.t, ~(mean_err <= VELOCITY_BAND))
        out["settling_time_s"] = settle
        # after settling; over the second half when it never settles
        after = f.t >= (settle if settle is not None else f.t[-1] / 2)
        out["velocity_rms_error_mps"] = float(np.sqrt(np.mean(err[after] ** 2)))
        out["velocity_mean_mps"] = [float(v) for v in f.velocity[after, :2].mean(axis=0)]
        if spec.velocity[2] > 0:
            w = f.velocity[:, 2]
            late = f.t >= max(5.0, (settle or 0.0))
            out["descent_speed_mps"] = float(np.mean(w[late])) if late.any() else None
            out["descent_speed_error"] = (out["descent_speed_mps"] / spec.velocity[2] - 1.0
                                          if out["descent_speed_mps"] is not None else None)
    elif spec.mode == "attitude":
        r = quat_to_rot(f.quaternion)
        roll = np.degrees(np.arctan2(r[:, 2, 1], r[:, 2, 2]))
        pitch = np.degrees(-np.arcsin(np.clip(r[:, 2, 0], -1, 1)))
        err = np.hypot(roll - spec.attitude_deg[0], pitch - spec.attitude_deg[1])
        out["settling_time_s"] = _settled_after(f.t, err > ATTITUDE_BAND_DEG)
        late = f.t >= f.t[-1] / 2
        out["attitude_rms_error_deg"] = float(np.sqrt(np.mean(err[late] ** 2)))
    return out
