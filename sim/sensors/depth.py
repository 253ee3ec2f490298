"""Depth sensor model: TE MS5837-30BA (the Bar30 of ArduSub vehicles).

Settings shared with the firmware's driver: OSR 8192 for both conversions,
D1 (pressure) and D2 (temperature) started alternately every 20 ms, so a
pressure every 40 ms (25 Hz). Datasheet (TE, MS5837-30BA rev. C2 12/2019,
and 10/11/2015):

- pressure resolution RMS at OSR 8192: 0.2 mbar = 20 Pa ("high-resolution
  module 0.2 mbar", "water depth resolution of 2 mm");
- ADC conversion time at OSR 8192: 16.44 ms typical, 18.08 ms maximum
  (so a pressure-temperature pair takes up to 36.2 ms: about 27 Hz);
- output ``P`` in 0.1 mbar (the datasheet's example P = 39998 = 3999.8
  mbar), so 10 Pa quantisation; ``TEMP`` in 0.01 degC;
- range 0-30 bar.

Assumed (the datasheet gives an error band, not these terms):

- a constant offset of 2 mbar (1 sigma), removed by zeroing at the surface
  (``Estimator.zero_depth``);
- a residual temperature coefficient of 5 Pa/K (1 sigma) after the chip's
  first- and second-order compensation, referred to 20 degC;
- the sensor's temperature follows the water at the port through a 30 s
  lag (gel-filled cap in the dome wall); the water cools by 0.1 K/m;
- temperature resolution 0.002 degC RMS at OSR 8192.

A pressure sample is the mean of the true pressure over its conversion
window; its time stamp (``t``) is the window's middle, and the driver can
read it at the end of its 20 ms slot (``t_ready``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from roboray.sim.sensors.noise import quantize
from roboray.sim.truth import GRAVITY_NED, Truth

G = float(GRAVITY_NED[2])
FRESH_WATER = 1000.0   #: kg/m^3
SEA_WATER = 1025.0     #: kg/m^3
ATMOSPHERE_PA = 101325.0


@dataclass(frozen=True)
class Water:
    """The water column the vehicle falls through."""

    density: float = FRESH_WATER             #: kg/m^3
    atmosphere_pa: float = ATMOSPHERE_PA     #: Pa at the surface
    surface_temperature_c: float = 18.0
    gradient_c_per_m: float = -0.1

    def __post_init__(self) -> None:
        if not self.density > 0:
            raise ValueError("Water.density %r must be > 0 kg/m^3" % self.density)
        if not self.atmosphere_pa > 0:
            raise ValueError("Water.atmosphere_pa %r must be > 0 Pa" % self.atmosphere_pa)

    def pressure(self, depth: np.ndarray) -> np.ndarray:
        """Absolute pressure (Pa) at ``depth`` (m)."""
        return self.atmosphere_pa + self.density * G * np.asarray(depth)

    def temperature(self, depth: np.ndarray) -> np.ndarray:
        return self.surface_temperature_c + self.gradient_c_per_m * np.maximum(np.asarray(depth), 0.0)


@dataclass(frozen=True)
class MS5837Spec:
    """MS5837-30BA at OSR 8192 (datasheet) plus the assumptions above."""

    cycle_s: float = 0.020               #: one conversion slot; D1 and D2 alternate
    conversion_s: float = 0.01808        #: OSR 8192, maximum
    noise_rms_pa: float = 20.0           #: 0.2 mbar
    lsb_pa: float = 10.0                 #: 0.1 mbar
    full_scale_pa: float = 30e5
    offset_pa: float = 200.0             #: 1 sigma, constant
    temp_coeff_pa_per_k: float = 5.0     #: 1 sigma
    reference_temperature_c: float = 20.0
    thermal_tau_s: float = 30.0
    temperature_noise_c: float = 0.002
    temperature_lsb_c: float = 0.01

    @property
    def rate_hz(self) -> float:
        """Pressure samples per second."""
        return 1.0 / (2.0 * self.cycle_s)


@dataclass(frozen=True)
class PressureLog:
    t: np.ndarray                 #: (N,) s, middle of the D1 conversion
    t_ready: np.ndarray           #: (N,) s, when the driver reads it
    pressure_pa: np.ndarray       #: (N,) measured
    temperature_c: np.ndarray     #: (N,) the latest D2 reading before it
    true_pressure_pa: np.ndarray  #: (N,) mean true pressure over the window


def sensor_temperature(truth: Truth, water: Water, tau_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(times, degC): the water temperature at the pressure port through a
    first-order lag of ``tau_s``, starting settled."""
    t = truth.t
    target = water.temperature(truth.depth_sensor)
    dt = float(np.median(np.diff(t)))
    a = np.exp(-dt / tau_s)
    out, _ = signal.lfilter([1.0 - a], [1.0, -a], target, zi=[a * target[0]])
    return t, out


def pressure(truth: Truth, spec: MS5837Spec, water: Water, rng: np.random.Generator) -> PressureLog:
    """MS5837-30BA pressure samples over the whole ``truth``."""
    period = 2.0 * spec.cycle_s
    start = truth.t[0] + rng.uniform(0.0, period)
    n = int(np.floor((truth.t[-1] - spec.cycle_s - start) / period)) + 1
    t_start = start + period * np.arange(n)
    # mean over the conversion window, from 9 points across it
    window = t_start[:, None] + np.linspace(0.0, spec.conversion_s, 9)[None, :]
    true_p = water.pressure(np.interp(window, truth.t, truth.depth_sensor)).mean(axis=1)
    ts, temp = sensor_temperature(truth, water, spec.thermal_tau_s)
    # the compensation uses the D2 conversion of the previous slot
    t_temp = np.interp(t_start - spec.cycle_s + 0.5 * spec.conversion_s, ts, temp)
    offset = rng.standard_normal() * spec.offset_pa
    coeff = rng.standard_normal() * spec.temp_coeff_pa_per_k
    measured = (true_p + offset + coeff * (t_temp - spec.reference_temperature_c)
                + rng.standard_normal(n) * spec.noise_rms_pa)
    measured = np.clip(quantize(measured, spec.lsb_pa), 0.0, spec.full_scale_pa)
    temp_read = quantize(t_temp + rng.standard_normal(n) * spec.temperature_noise_c, spec.temperature_lsb_c)
    return PressureLog(t=t_start + 0.5 * spec.conversion_s, t_ready=t_start + spec.cycle_s,
                       pressure_pa=measured, temperature_c=temp_read, true_pressure_pa=true_p)
