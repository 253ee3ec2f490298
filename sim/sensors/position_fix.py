"""Position fixes from an external tracker (an acoustic or camera system)
that reach the vehicle through the ground station (MAVLink ATT_POS_MOCAP).

Each fix is the tracker's measurement of the centre of buoyancy's north and
east at its measurement time ``t``, plus white noise; it arrives at
``t + latency`` (tracker processing, ground station, radio), with a jitter.
Fixes are lost independently with probability ``dropout`` and all of them
inside the ``outages`` windows; a fraction ``outlier`` is wrong by
``outlier_m`` in a random direction (a reflection, a mistaken marker).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roboray.sim.sensors.sampling import interpolate
from roboray.sim.truth import Truth


@dataclass(frozen=True)
class TrackerSpec:
    rate_hz: float = 1.0
    noise_m: float = 0.02            #: 1 sigma per axis
    latency_s: float = 0.2
    latency_jitter_s: float = 0.02   #: uniform, +-
    dropout: float = 0.05            #: probability a fix is lost
    outages: tuple = ()              #: ((start_s, duration_s), ...) with no fix
    outlier: float = 0.0             #: probability a fix is wrong
    outlier_m: float = 1.0           #: how wrong

    def __post_init__(self) -> None:
        if not self.rate_hz > 0:
            raise ValueError("TrackerSpec.rate_hz %r must be > 0" % self.rate_hz)
        if self.noise_m < 0 or self.latency_s < 0 or self.latency_jitter_s < 0:
            raise ValueError("TrackerSpec noise and latency must be >= 0")
        if self.latency_jitter_s > self.latency_s:
            raise ValueError("TrackerSpec.latency_jitter_s cannot exceed latency_s")
        if not 0.0 <= self.dropout < 1.0 or not 0.0 <= self.outlier < 1.0:
            raise ValueError("TrackerSpec.dropout and outlier must be in [0, 1)")


@dataclass(frozen=True)
class FixLog:
    t: np.ndarray           #: (N,) s, measurement times
    t_arrival: np.ndarray   #: (N,) s, when the vehicle receives them
    north: np.ndarray       #: (N,) m
    east: np.ndarray        #: (N,) m
    outlier: np.ndarray     #: (N,) bool, the wrong ones
    lost: int               #: fixes measured but never delivered


def fixes(truth: Truth, spec: TrackerSpec, rng: np.random.Generator) -> FixLog:
    """The tracker's fixes over ``truth``, in order of arrival."""
    t = truth.t[0] + (rng.uniform() + np.arange(int(np.floor((truth.t[-1] - truth.t[0]) * spec.rate_hz)))) / spec.rate_hz
    keep = rng.uniform(size=len(t)) >= spec.dropout
    for start, duration in spec.outages:
        keep &= ~((t >= start) & (t < start + duration))
    lost = int(np.count_nonzero(~keep))
    t = t[keep]
    pos = interpolate(truth.t, truth.position_ned[:, :2], t)
    pos = pos + rng.standard_normal(pos.shape) * spec.noise_m
    wrong = rng.uniform(size=len(t)) < spec.outlier
    angle = rng.uniform(0.0, 2.0 * np.pi, size=len(t))
    pos[wrong, 0] += spec.outlier_m * np.cos(angle[wrong])
    pos[wrong, 1] += spec.outlier_m * np.sin(angle[wrong])
    arrival = t + spec.latency_s + rng.uniform(-1.0, 1.0, size=len(t)) * spec.latency_jitter_s
    order = np.argsort(arrival, kind="stable")
    return FixLog(t=t[order], t_arrival=arrival[order], north=pos[order, 0], east=pos[order, 1],
                  outlier=wrong[order], lost=lost)
