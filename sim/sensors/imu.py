"""IMU model: ST LSM6DSOX (accelerometer + gyroscope) and ST LIS3MDL
(magnetometer), driven by a ``Truth``.

Parts and settings (shared with the firmware's drivers): LSM6DSOX with the
accelerometer at +-4 g (0.122 mg/LSB) and the gyroscope at +-500 dps
(17.50 mdps/LSB), both at 208 Hz in high-performance mode; LIS3MDL at +-4
gauss (6842 LSB/gauss), ultra-high-performance mode, 155 Hz (FAST_ODR, as
``firmware/drivers/lis3mdl.py`` sets it; the datasheet's noise figure is
used at that rate too). Axes here are the vehicle's body axes (z down when
level): the firmware maps the chips' axes (LSM6DSOX z up, +9.81 m/s^2 lying
flat) onto them before calling the estimator.

Datasheet figures (typical values; ST, LSM6DSOX datasheet DS12814 Rev 3,
table 2 "Mechanical characteristics"; LIS3MDL datasheet DocID024204 Rev 4,
table 2 "Magnetic characteristics"):

=====================================  =====================  ===========
quantity                               datasheet              model
=====================================  =====================  ===========
accel noise density, HP, FS +-4 g      75 ug/sqrt(Hz)         same
accel zero-g offset (TyOff)            +-20 mg                1 sigma (raw)
accel offset vs temperature            +-0.1 mg/degC          1 sigma
accel sensitivity tolerance            +-1 %                  1 sigma (raw)
gyro rate noise density, HP            3.8 mdps/sqrt(Hz)      same
gyro zero-rate level (TyOff)           +-1 dps                1 sigma
gyro zero-rate change vs temperature   +-0.01 dps/degC        1 sigma
gyro sensitivity tolerance             +-1 %                  1 sigma
mag sensitivity, FS +-4 gauss          6842 LSB/gauss         same
mag RMS noise, UHP mode                3.2 (x, y), 4.1 (z)    same
                                       mgauss
=====================================  =====================  ===========

Not in the datasheets, assumed (stated here, change them here):

- cross-axis sensitivity / mounting misalignment: 1 % (1 sigma) each
  off-diagonal term, accelerometer and gyroscope; 1 % for the magnetometer;
- bias instability, as random walks of the biases: gyro 1e-3 dps/sqrt(s)
  (0.008 dps over a 60 s descent, 0.06 dps after an hour), accelerometer
  20 ug/sqrt(s) (0.15 mg over 60 s) -- on the pessimistic side for consumer
  MEMS of this class;
- the accelerometer is six-position calibrated before use: residual offset
  2 mg, sensitivity 0.2 %, cross-axis 0.2 % (``ACCEL_CALIBRATED``); the
  gyro is not (its turn-on offset is what the estimator learns);
- magnetometer: hard iron (vehicle's batteries, servo magnets) 0.1 gauss and
  soft iron 3 % (1 sigma), removed by an ellipsoid calibration that leaves
  1 mgauss and 0.5 % (``MagSpec.residual_*``).
- servo disturbance: servo ``i`` at 60 mm from the axis on wing ``i``'s side
  draws ``I = 10 mA + 0.5 A min(|s_dot_i| / 4 rad/s, 1)``; at the
  magnetometer its current makes ``20 mgauss/A`` (a wire 10 cm away, mu0 I /
  (2 pi r)), along the line from the servo to the sensor: up to about 6
  mgauss for one wing swinging at 2.5 rad/s, on a horizontal Earth field of
  about 200 mgauss (a 2 deg heading error if not gated).

The specific force in ``Truth.specific_force_imu`` already holds the lever
arm of the IMU's position in the dome; the gyroscope sees the body rate
wherever it sits.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from roboray.sim.sensors.noise import clip16, quantize, random_walk, white
from roboray.sim.sensors.sampling import interpolate, interpolate_quaternion
from roboray.sim.truth import Truth, quaternion_to_matrix

G = 9.80665
DEG = np.pi / 180.0
MG = 1e-3 * G  # one milli-g in m/s^2


@dataclass(frozen=True)
class InertialSpec:
    """Errors of one accelerometer or gyroscope triad (SI units)."""

    rate_hz: float             #: output data rate
    lsb: float                 #: output resolution, SI per LSB
    full_scale: float          #: nominal range, SI (the register saturates at 32767 LSB)
    noise_density: float       #: one-sided, SI/sqrt(Hz)
    turn_on_bias: float        #: 1 sigma per axis, SI
    bias_walk: float           #: bias random walk, SI/sqrt(s)
    bias_tempco: float         #: 1 sigma per axis, SI/K
    scale_error: float         #: 1 sigma, relative
    cross_axis: float          #: 1 sigma per off-diagonal term, relative


#: LSM6DSOX accelerometer, +-4 g, 208 Hz, high performance (datasheet; raw errors).
LSM6DSOX_ACCEL = InertialSpec(
    rate_hz=208.0, lsb=0.122 * MG, full_scale=4.0 * G, noise_density=75e-6 * G,
    turn_on_bias=20.0 * MG, bias_walk=20e-6 * G, bias_tempco=0.1 * MG,
    scale_error=0.01, cross_axis=0.01,
)
#: The same after a six-position calibration (assumed residuals).
ACCEL_CALIBRATED = InertialSpec(
    rate_hz=208.0, lsb=0.122 * MG, full_scale=4.0 * G, noise_density=75e-6 * G,
    turn_on_bias=2.0 * MG, bias_walk=20e-6 * G, bias_tempco=0.1 * MG,
    scale_error=0.002, cross_axis=0.002,
)
#: LSM6DSOX gyroscope, +-500 dps, 208 Hz, high performance (datasheet).
LSM6DSOX_GYRO = InertialSpec(
    rate_hz=208.0, lsb=17.50e-3 * DEG, full_scale=500.0 * DEG, noise_density=3.8e-3 * DEG,
    turn_on_bias=1.0 * DEG, bias_walk=1e-3 * DEG, bias_tempco=0.01 * DEG,
    scale_error=0.01, cross_axis=0.01,
)


@dataclass(frozen=True)
class MagSpec:
    """LIS3MDL at +-4 gauss plus the vehicle's own field (gauss)."""

    rate_hz: float = 155.0
    lsb: float = 1.0 / 6842.0
    full_scale: float = 4.0                      #: nominal; the register saturates at 32767 LSB
    noise_rms: tuple = (3.2e-3, 3.2e-3, 4.1e-3)   #: per axis, at the output rate
    hard_iron: float = 0.1                        #: 1 sigma per axis
    soft_iron: float = 0.03                       #: 1 sigma per matrix term (with cross-axis)
    residual_hard_iron: float = 1e-3              #: after calibration, 1 sigma
    residual_soft_iron: float = 0.002             #: after calibration, 1 sigma
    servo_radius: float = 0.06                    #: m, servo i on wing i's side
    servo_idle_a: float = 0.01                    #: A, holding current
    servo_run_a: float = 0.5                      #: A, extra current at full speed
    servo_full_speed: float = 4.0                 #: rad/s at which the run current saturates
    servo_gauss_per_a: float = 0.02               #: field at the magnetometer per ampere


@dataclass(frozen=True)
class EarthField:
    """Local geomagnetic field (defaults: Seattle, about 2020)."""

    intensity_gauss: float = 0.53
    inclination_deg: float = 68.5
    declination_deg: float = 15.5

    def ned(self) -> np.ndarray:
        inc = self.inclination_deg * DEG
        dec = self.declination_deg * DEG
        h = self.intensity_gauss * np.cos(inc)
        return np.array([h * np.cos(dec), h * np.sin(dec), self.intensity_gauss * np.sin(inc)])


@dataclass(frozen=True)
class ImuSpec:
    accel: InertialSpec = ACCEL_CALIBRATED
    gyro: InertialSpec = LSM6DSOX_GYRO
    mag: MagSpec = field(default_factory=MagSpec)
    earth: EarthField = field(default_factory=EarthField)
    reference_temperature_c: float = 20.0


@dataclass(frozen=True)
class InertialLog:
    """LSM6DSOX output samples and the errors behind them (for scoring)."""

    t: np.ndarray           #: (N,) s, sample times
    gyro: np.ndarray        #: (N, 3) rad/s
    accel: np.ndarray       #: (N, 3) m/s^2
    gyro_bias: np.ndarray   #: (N, 3) rad/s, true gyro bias
    accel_bias: np.ndarray  #: (N, 3) m/s^2, true accelerometer bias


@dataclass(frozen=True)
class MagLog:
    """LIS3MDL output samples, the servo field in them, and the calibration
    an ellipsoid fit would give (``calibrated = matrix @ (raw - offset)``)."""

    t: np.ndarray             #: (N,) s
    field: np.ndarray         #: (N, 3) gauss, raw
    servo_field: np.ndarray   #: (N, 3) gauss, the servo part, body frame
    offset: np.ndarray        #: (3,) gauss
    matrix: np.ndarray        #: (3, 3)


def _error_matrix(rng: np.random.Generator, scale: float, cross: float) -> np.ndarray:
    m = np.eye(3) + np.diag(rng.standard_normal(3) * scale)
    off = rng.standard_normal((3, 3)) * cross
    np.fill_diagonal(off, 0.0)
    return m + off


def sample_times(t0: float, t1: float, rate_hz: float, phase: float) -> np.ndarray:
    """Sample instants of a free-running output at ``rate_hz`` in [t0, t1]."""
    start = t0 + phase / rate_hz
    return start + np.arange(int(np.floor((t1 - start) * rate_hz)) + 1) / rate_hz


def _temperature(temperature_c, t: np.ndarray, reference: float) -> np.ndarray:
    if temperature_c is None:
        return np.zeros_like(t)
    ts, temp = temperature_c
    return np.interp(t, ts, temp) - reference


def inertial(truth: Truth, spec: ImuSpec, rng: np.random.Generator, temperature_c=None) -> InertialLog:
    """LSM6DSOX samples over the whole ``truth``; ``temperature_c`` is an
    optional (times, degC) pair of the sensor's temperature."""
    t = sample_times(truth.t[0], truth.t[-1], spec.gyro.rate_hz, rng.uniform())
    n = len(t)
    d_temp = _temperature(temperature_c, t, spec.reference_temperature_c)
    out = {}
    for name, s, true in (
        ("gyro", spec.gyro, interpolate(truth.t, truth.omega_body, t)),
        ("accel", spec.accel, interpolate(truth.t, truth.specific_force_imu, t)),
    ):
        m = _error_matrix(rng, s.scale_error, s.cross_axis)
        bias = random_walk(rng, s.bias_walk, t, rng.standard_normal(3) * s.turn_on_bias)
        bias = bias + d_temp[:, None] * (rng.standard_normal(3) * s.bias_tempco)[None, :]
        raw = true @ m.T + bias + white(rng, s.noise_density, s.rate_hz, (n, 3))
        out[name] = (clip16(quantize(raw, s.lsb), s.lsb), bias)
    return InertialLog(t=t, gyro=out["gyro"][0], accel=out["accel"][0],
                       gyro_bias=out["gyro"][1], accel_bias=out["accel"][1])


def servo_currents(wing_rates: np.ndarray, spec: MagSpec) -> np.ndarray:
    """Current (A) each servo draws at the given wing rates (..., 4) rad/s."""
    speed = np.minimum(np.abs(wing_rates) / spec.servo_full_speed, 1.0)
    return spec.servo_idle_a + spec.servo_run_a * speed


def servo_directions(mag_position: np.ndarray, spec: MagSpec) -> np.ndarray:
    """(4, 3) unit vectors from each servo to the magnetometer, body frame."""
    az = np.arange(4) * np.pi / 2.0
    servos = np.stack([spec.servo_radius * np.cos(az), spec.servo_radius * np.sin(az), np.zeros(4)], axis=1)
    d = np.asarray(mag_position, dtype=float)[None, :] - servos
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def magnetometer(truth: Truth, spec: ImuSpec, rng: np.random.Generator) -> MagLog:
    """LIS3MDL samples over the whole ``truth``, with hard and soft iron,
    the servos' field, noise, quantisation and range; and the calibration."""
    ms = spec.mag
    t = sample_times(truth.t[0], truth.t[-1], ms.rate_hz, rng.uniform())
    q = interpolate_quaternion(truth.t, truth.quaternion, t)
    earth_body = np.einsum("nji,j->ni", quaternion_to_matrix(q), spec.earth.ned())
    currents = servo_currents(interpolate(truth.t, truth.wing_rates, t), ms)
    servo = (currents * ms.servo_gauss_per_a) @ servo_directions(truth.imu_position_body, ms)
    soft = _error_matrix(rng, ms.soft_iron, ms.soft_iron)
    hard = rng.standard_normal(3) * ms.hard_iron
    noise = rng.standard_normal((len(t), 3)) * np.asarray(ms.noise_rms)[None, :]
    raw = (earth_body + servo) @ soft.T + hard + noise
    raw = clip16(quantize(raw, ms.lsb), ms.lsb)
    offset = hard + rng.standard_normal(3) * ms.residual_hard_iron
    matrix = _error_matrix(rng, ms.residual_soft_iron, ms.residual_soft_iron) @ np.linalg.inv(soft)
    return MagLog(t=t, field=raw, servo_field=servo, offset=offset, matrix=matrix)
