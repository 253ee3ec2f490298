"""Random processes of sensor errors, and the statistics that check them.

Conventions (those of the ST and TE datasheets the models cite):

- A noise *density* ``N`` is one-sided: white noise sampled at ``rate_hz``
  over its Nyquist band has standard deviation ``N sqrt(rate_hz / 2)``
  (ST's "noise RMS related to BW = ODR/2"), and its one-sided power
  spectral density is ``N^2``. Its Allan deviation is ``N / sqrt(2 tau)``.
- A bias *random walk* ``K`` (units/sqrt(s)) grows the bias variance by
  ``K^2 t``; its Allan deviation rises as ``K sqrt(tau / 3)``.
"""

from __future__ import annotations

import numpy as np
from scipy import signal


def white(rng: np.random.Generator, density: float | np.ndarray, rate_hz: float, shape: tuple) -> np.ndarray:
    """White noise of one-sided density ``density`` sampled at ``rate_hz``."""
    if rate_hz <= 0:
        raise ValueError("rate_hz %r must be > 0" % rate_hz)
    return rng.standard_normal(shape) * (np.asarray(density) * np.sqrt(rate_hz / 2.0))


def random_walk(rng: np.random.Generator, walk: float | np.ndarray, t: np.ndarray, start: np.ndarray) -> np.ndarray:
    """A random walk of ``walk`` units/sqrt(s) sampled at times ``t`` (N,),
    starting at ``start`` (D,): returns (N, D)."""
    t = np.asarray(t, dtype=float)
    start = np.atleast_1d(np.asarray(start, dtype=float))
    dt = np.diff(t, prepend=t[0])
    steps = rng.standard_normal((len(t), start.size)) * (np.asarray(walk) * np.sqrt(dt))[:, None]
    return start[None, :] + np.cumsum(steps, axis=0)


def quantize(x: np.ndarray, lsb: float) -> np.ndarray:
    """Round to whole LSBs (what a sensor's integer output register holds)."""
    return np.round(np.asarray(x) / lsb) * lsb


def clip16(x: np.ndarray, lsb: float) -> np.ndarray:
    """Saturate at a 16-bit two's-complement output register: -32768 ..
    32767 LSB (ST parts keep converting past their nominal full scale, up to
    the register's limit: +-573 dps for the +-500 dps gyro setting)."""
    return np.clip(x, -32768.0 * lsb, 32767.0 * lsb)


def allan_deviation(x: np.ndarray, rate_hz: float, taus: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of the rate samples ``x`` (N,) at cluster
    times ``taus`` (s; default: octaves from one sample to a ninth of the
    record)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    if taus is None:
        m = np.unique(np.round(2.0 ** np.arange(0, np.log2(n / 9.0))).astype(int))
    else:
        m = np.unique(np.maximum(1, np.round(np.asarray(taus) * rate_hz).astype(int)))
    theta = np.concatenate(([0.0], np.cumsum(x))) / rate_hz
    adev = np.empty(len(m))
    for i, k in enumerate(m):
        d = theta[2 * k:] - 2.0 * theta[k:-k] + theta[:-2 * k]
        tau = k / rate_hz
        adev[i] = np.sqrt(np.mean(d * d) / (2.0 * tau * tau))
    return m / rate_hz, adev


def noise_density(x: np.ndarray, rate_hz: float, segment: int = 256) -> float:
    """One-sided amplitude spectral density of ``x`` (N,), averaged over the
    band (Welch, Hann windows of ``segment`` samples, mean removed)."""
    f, pxx = signal.welch(np.asarray(x, dtype=float), fs=rate_hz, nperseg=segment, detrend="constant")
    band = (f > 0) & (f < 0.9 * rate_hz / 2.0)
    return float(np.sqrt(np.mean(pxx[band])))
