"""Water as a radio wave sees it: permittivity, attenuation, the surface.

A plane wave in a lossy dielectric (permittivity eps = eps0 eps', permeability
mu0, conductivity sigma) has the propagation constant gamma = alpha + j beta
with (e.g. Balanis, Advanced Engineering Electromagnetics, 2nd ed., eq. 4-24)

    alpha = omega sqrt(mu eps / 2) sqrt( sqrt(1 + (sigma / (omega eps))^2) - 1 )   [Np/m]

and its power falls 8.686 alpha dB a metre (20 log10(e) = 8.686). Water
conducts (ions: ``conductivity``) and it also loses energy by itself: its
molecules' orientation lags the field (Debye relaxation),

    eps(f) = eps_inf + (eps_s - eps_inf) / (1 + j 2 pi f tau),   eps = eps' - j eps''

so its eps'' acts as a conductivity omega eps0 eps'' on top of the ionic
one (at 433 MHz and 18 C about 0.05 S/m: distilled water still attenuates
about 8 dB a metre). The static permittivity is Malmberg and Maryott's fit
(J. Res. NBS 56(1), 1956: 87.74 - 0.40008 T + 9.398e-4 T^2 - 1.410e-6 T^3,
80.1 at 20 C), the relaxation time Stogryn's (IEEE Trans. MTT 19(8), 1971:
2 pi tau = 1.1109e-10 - 3.824e-12 T + 6.938e-14 T^2 - 5.096e-16 T^3 s, a
relaxation frequency of 17.1 GHz at 20 C) with eps_inf = 4.9 (Stogryn). The
salt's small lowering of eps_s in sea water is left out: there the ionic
conductivity is 40 times the dielectric loss and sets everything.

Crossing the surface at normal incidence, the wave meets the step from the
air's 377 ohm to the water's complex intrinsic impedance
eta = sqrt(j omega mu / (sigma + j omega eps)); the reflection coefficient is
Gamma = (eta - eta0) / (eta + eta0) (Fresnel, normal incidence) and the
power that goes on into the water is 1 - |Gamma|^2 (the air is lossless, so
what is not reflected crosses).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

EPS0 = 8.8541878128e-12   #: F/m
MU0 = 4e-7 * math.pi      #: H/m (within 1e-9 of the 2019 SI value)
ETA0 = math.sqrt(MU0 / EPS0)   #: ohm, the air's (vacuum's) impedance, 376.7
NP_TO_DB = 20.0 / math.log(10.0)   #: 8.686 dB a neper
EPS_INF = 4.9             #: water's high-frequency permittivity (Stogryn 1971)


@dataclass(frozen=True)
class WaterRF:
    """A water for the radio: its ionic conductivity and temperature."""

    name: str
    conductivity: float     #: S/m, ionic (the dielectric loss is added by the model)
    temperature_c: float    #: C
    note: str = ""

    def __post_init__(self) -> None:
        if not (self.conductivity >= 0.0 and math.isfinite(self.conductivity)):
            raise ValueError("conductivity %r: a finite number of S/m >= 0" % (self.conductivity,))
        if not 0.0 <= self.temperature_c <= 40.0:
            raise ValueError("temperature_c %r: liquid water of 0..40 C (the permittivity fits' range)"
                             % (self.temperature_c,))

    def with_conductivity(self, sigma: float) -> "WaterRF":
        return WaterRF(self.name, float(sigma), self.temperature_c, "conductivity given: %g S/m" % sigma)


#: ``--water``'s names. Fresh: a pool or tap water of 0.02 S/m (200 uS/cm;
#: tap and pool water lie within 0.005-0.05 S/m, the issue's range; the
#: bottom of that range is still above the dielectric floor only at low
#: frequency). Sea: 4.5 S/m, the middle of open sea water's 4-5 S/m (35 psu
#: at 10-20 C). Both at 18 C, the twin's surface water temperature
#: (``sim/sensors/depth.py`` ``Water``).
WATERS = {
    "fresh": WaterRF("fresh", 0.02, 18.0, "pool or tap water, 200 uS/cm (0.005-0.05 S/m is usual)"),
    "sea": WaterRF("sea", 4.5, 18.0, "open sea water, 35 psu (4-5 S/m)"),
}


def water(name: str, conductivity: float | None = None) -> WaterRF:
    """``WATERS[name]``, its conductivity replaced by ``conductivity`` if given."""
    if name not in WATERS:
        raise ValueError("water %r: one of %s" % (name, ", ".join(sorted(WATERS))))
    w = WATERS[name]
    return w if conductivity is None else w.with_conductivity(conductivity)


def static_permittivity(temperature_c: float) -> float:
    """eps_s of pure water (Malmberg and Maryott 1956)."""
    t = temperature_c
    return 87.740 - 0.40008 * t + 9.398e-4 * t * t - 1.410e-6 * t * t * t


def relaxation_time(temperature_c: float) -> float:
    """tau (s) of water's Debye relaxation (Stogryn 1971)."""
    t = temperature_c
    return (1.1109e-10 - 3.824e-12 * t + 6.938e-14 * t * t - 5.096e-16 * t * t * t) / (2.0 * math.pi)


def permittivity(freq_hz: float, temperature_c: float) -> complex:
    """Water's relative permittivity eps' - j eps'' (Debye, one relaxation)."""
    es = static_permittivity(temperature_c)
    wt = 2.0 * math.pi * freq_hz * relaxation_time(temperature_c)
    return EPS_INF + (es - EPS_INF) / complex(1.0, wt)


def effective_conductivity(freq_hz: float, w: WaterRF) -> float:
    """S/m: the ionic conductivity plus the dielectric loss omega eps0 eps''."""
    eps = permittivity(freq_hz, w.temperature_c)
    return w.conductivity + 2.0 * math.pi * freq_hz * EPS0 * (-eps.imag)


def attenuation_np(freq_hz: float, w: WaterRF) -> float:
    """alpha (Np/m) of a plane wave in the water (the module docstring's equation)."""
    omega = 2.0 * math.pi * freq_hz
    eps = EPS0 * permittivity(freq_hz, w.temperature_c).real
    sigma = effective_conductivity(freq_hz, w)
    ratio = sigma / (omega * eps)
    return omega * math.sqrt(MU0 * eps / 2.0) * math.sqrt(math.sqrt(1.0 + ratio * ratio) - 1.0)


def attenuation_db_per_m(freq_hz: float, w: WaterRF) -> float:
    """The power's loss, dB a metre: 8.686 alpha."""
    return NP_TO_DB * attenuation_np(freq_hz, w)


def skin_depth(freq_hz: float, w: WaterRF) -> float:
    """m: where the field has fallen to 1/e (1/alpha)."""
    return 1.0 / attenuation_np(freq_hz, w)


def impedance(freq_hz: float, w: WaterRF) -> complex:
    """The water's intrinsic impedance (ohm), sqrt(j omega mu / (sigma + j omega eps))."""
    omega = 2.0 * math.pi * freq_hz
    eps = EPS0 * permittivity(freq_hz, w.temperature_c).real
    return cmath.sqrt(1j * omega * MU0 / complex(effective_conductivity(freq_hz, w), omega * eps))


def surface_loss_db(freq_hz: float, w: WaterRF) -> float:
    """dB lost crossing the surface at normal incidence: -10 log10(1 - |Gamma|^2)."""
    eta = impedance(freq_hz, w)
    gamma = (eta - ETA0) / (eta + ETA0)
    return -10.0 * math.log10(1.0 - abs(gamma) ** 2)
