"""The link budget from the ground station to the vehicle's antenna in water.

The path: the ground antenna, ``ground_distance_m`` of air to the surface
point above the vehicle (free space, Friis: FSPL = 20 log10(4 pi d /
lambda)), the surface (``water.surface_loss_db``), then the depth of the
vehicle's antenna (the dome's top) in the water at ``attenuation_db_per_m``.
The margin over the receiver's sensitivity is

    M(depth) = P_tx + G_ground + G_vehicle - FSPL - L_surface - a depth - S

(the same both ways: the two ends are the same radio, and the path is
reciprocal). Above the surface (depth < 0) only the air counts.

Frame loss from the margin: the received level fades about its mean with a
Gaussian spread in dB (log-normal shadowing, ``FADE_SIGMA_DB`` = 4 dB), so a
frame is lost with probability Q(M / sigma) = erfc(M / (sigma sqrt 2)) / 2:
half the frames at M = 0, 10 % at M = 5.1 dB. Log-normal rather than
Rayleigh because the path over the water is a line of sight to the point
above the vehicle: what moves the level is the antenna's depth changing
with the waves and the vehicle's sway (a few centimetres: a few dB in fresh
water), not many paths of equal strength, which is Rayleigh's case (its
outage, 1 - exp(-10^(-M/10)), would still lose 1 % of the frames at 20 dB).
4 dB is an assumed spread, the middle of the 2-8 dB usually quoted for
shadowing.

``reach_m`` is the depth at which half the frames are lost (M = 0),
``holds_to_m`` the depth to which nine in ten cross (M = 5.1 dB).

``Channel`` loses frames by this model, deterministically for its seed:
the fade is a Gauss-Markov process (correlation time ``FADE_TAU_S``), the
same for both directions at an instant (the path is reciprocal), so frames
come and go in runs as on a real link rather than one in N at random.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from roboray.sim.radio import water as water_mod
from roboray.sim.radio.radios import Radio

C = 299792458.0
FADE_SIGMA_DB = 4.0
#: s, assumed: the waves and the vehicle's sway change the path over about a second
FADE_TAU_S = 0.5
#: The margin (dB) at which nine frames in ten cross: Q^-1(0.1) sigma.
HOLDS_MARGIN_DB = 1.2815515655446004 * FADE_SIGMA_DB
#: m, assumed: the ground station at the pool's edge or on the boat
GROUND_DISTANCE_M = 10.0


def frame_loss(margin_db: float) -> float:
    """Probability a frame is lost at a mean margin (log-normal fading)."""
    return 0.5 * math.erfc(margin_db / (FADE_SIGMA_DB * math.sqrt(2.0)))


@dataclass(frozen=True)
class Link:
    """One radio in one water, the ground station ``ground_distance_m`` away."""

    radio: Radio
    water: water_mod.WaterRF
    ground_distance_m: float = GROUND_DISTANCE_M

    def __post_init__(self) -> None:
        lam = C / self.radio.freq_hz
        if not (math.isfinite(self.ground_distance_m) and self.ground_distance_m >= lam):
            raise ValueError("ground distance %r m: at least a wavelength (%.2f m), Friis's far field"
                             % (self.ground_distance_m, lam))
        f = self.radio.freq_hz
        r = self.radio
        object.__setattr__(self, "attenuation_db_per_m", water_mod.attenuation_db_per_m(f, self.water))
        object.__setattr__(self, "surface_loss_db", water_mod.surface_loss_db(f, self.water))
        object.__setattr__(self, "air_loss_db", 20.0 * math.log10(4.0 * math.pi * self.ground_distance_m / lam))
        object.__setattr__(self, "air_margin_db", r.tx_dbm + 2.0 * r.antenna_dbi - self.air_loss_db
                           - r.sensitivity_dbm)

    attenuation_db_per_m: float = field(init=False, default=0.0)
    surface_loss_db: float = field(init=False, default=0.0)
    air_loss_db: float = field(init=False, default=0.0)
    #: dB: the margin with the antenna just above the surface
    air_margin_db: float = field(init=False, default=0.0)

    def margin_db(self, depth: float) -> float:
        """The mean margin (dB) with the vehicle's antenna at ``depth`` (m, down)."""
        if depth < 0.0:
            return self.air_margin_db
        return self.air_margin_db - self.surface_loss_db - self.attenuation_db_per_m * depth

    def depth_at(self, margin_db: float) -> float:
        """The depth (m) at which the margin falls to ``margin_db`` (0 if it
        is lower just below the surface)."""
        below = self.air_margin_db - self.surface_loss_db - margin_db
        return max(below / self.attenuation_db_per_m, 0.0)

    @property
    def reach_m(self) -> float:
        return self.depth_at(0.0)

    @property
    def holds_to_m(self) -> float:
        return self.depth_at(HOLDS_MARGIN_DB)

    def received_dbm(self, depth: float) -> float:
        return self.margin_db(depth) + self.radio.sensitivity_dbm


def make(radio_name: str | None, water_name: str, conductivity: float | None = None,
         ground_distance_m: float = GROUND_DISTANCE_M) -> Link:
    """The link of a named radio (None: the buildable vehicle's) in a named water."""
    from roboray.sim.radio.radios import radio

    return Link(radio(radio_name), water_mod.water(water_name, conductivity), ground_distance_m)


class Channel:
    """Loses frames by a ``Link``'s margin at the antenna's depth, fading
    as a Gauss-Markov process; ``step(depth, dt)`` once a frame time, then
    ``passes()`` for each frame that crosses in it."""

    def __init__(self, link: Link, rng: np.random.Generator) -> None:
        self.link = link
        self._rng = rng
        self.fade_db = float(rng.standard_normal()) * FADE_SIGMA_DB
        self.margin = link.margin_db(0.0)
        self.depth = 0.0

    def step(self, depth: float, dt: float) -> None:
        a = math.exp(-dt / FADE_TAU_S)
        self.fade_db = a * self.fade_db + math.sqrt(1.0 - a * a) * FADE_SIGMA_DB * float(self._rng.standard_normal())
        self.depth = depth
        self.margin = self.link.margin_db(depth)

    @property
    def level_db(self) -> float:
        """The margin now, with the fade (dB over the sensitivity)."""
        return self.margin + self.fade_db

    def passes(self) -> bool:
        return self.level_db >= 0.0
