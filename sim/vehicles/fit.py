"""Choosing the sizes the thesis does not give, so that its numbers come out.

The thesis fixes m_v = 1.0625 kg, the locked masses m1, m2, m3 and ell for
two configurations (Tables 3.1/3.2) and starts its runs at a 0.30 m/s flat
descent, but gives no plate size, dome, density or volume. Each unknown
follows from one of those numbers:

- centre plate side a: its added mass 0.1132 kg (eq. 2.2, k = sqrt(2)/2);
- wing height h: the wing's added mass 0.2722 kg (eq. 2.2, k = 0.91, span =
  hinge = a, mean chord h/2);
- displaced volume, hence the dome radius: net weight = drag at 0.30 m/s with
  the wings flat;
- wing density: ell rising from 16.7 mm to 17.1 mm when wings 2 and 4 fold;
- payload height: ell = 16.7 mm with the wings flat.

``fit()`` solves them and ``python -m roboray.sim.vehicles.fit`` prints them;
``reference.py`` holds the result and a test checks that the two agree.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

from roboray.sim.vehicle import Vehicle, VehicleParams

#: The thesis's numbers (Tables 3.1/3.2, sec. 5.1).
M_V = 1.0625
ADDED_CENTER = 2.2645 - 1.0625 - 2 * (1.6069 - 1.0625)  # 0.1132 kg
ADDED_WING = (1.6069 - 1.0625) / 2                      # 0.2722 kg
ELL_FLAT = 0.0167
ELL_WINGS_2_4_UP = 0.0171
TERMINAL_FLAT = 0.30
FOLD_2_4 = np.radians([0.0, 90.0, 0.0, 90.0])


def fit(base: VehicleParams | None = None) -> VehicleParams:
    """``base`` with plate_side, wing_height, dome_radius, wing_density and
    payload_height chosen to reproduce the thesis's numbers in fresh water."""
    if base is None:
        from roboray.sim.vehicles.reference import VEHICLE as base
    p = base
    rho = p.rho
    a = (ADDED_CENTER / (math.pi / 4 * rho * p.k_center)) ** (1.0 / 3.0)
    h = 2.0 * math.sqrt(ADDED_WING / (math.pi / 4 * rho * p.k_wing * a))
    p = replace(p, plate_side=a, wing_height=h, total_mass=M_V)

    area = a * a + 4 * 0.5 * a * h
    volume_needed = (M_V - 0.5 * rho * p.cd * area * TERMINAL_FLAT ** 2 / p.g) / rho

    def volume_error(radius: float) -> float:
        return _build(replace(p, dome_radius=radius)).volume - volume_needed

    p = replace(p, dome_radius=brentq(volume_error, 0.01, 0.15, xtol=1e-12))

    # ell depends on the payload height linearly and on the wing density; the
    # change of ell on folding depends on the wing density only.
    def fold_error(density: float) -> float:
        v = _build(replace(p, wing_density=density))
        return (v.ell(FOLD_2_4) - v.ell(np.zeros(4))) - (ELL_WINGS_2_4_UP - ELL_FLAT)

    p = replace(p, wing_density=brentq(fold_error, 10.0, 5000.0, xtol=1e-10))

    def flat_error(height: float) -> float:
        return _build(replace(p, payload_height=height)).ell(np.zeros(4)) - ELL_FLAT

    return replace(p, payload_height=brentq(flat_error, -0.05, 0.1, xtol=1e-12))


def _build(p: VehicleParams) -> Vehicle:
    return Vehicle(p)


def main() -> None:
    p = fit()
    for name in ("plate_side", "wing_height", "dome_radius", "wing_density", "payload_height"):
        print("%-15s %.9g" % (name, getattr(p, name)))
    v = Vehicle(p)
    for label, wings in (("flat", np.zeros(4)), ("2,4 up", FOLD_2_4)):
        props = v.properties(wings)
        print("%-7s m1 %.4f m2 %.4f m3 %.4f ell %.5f v_t %.4f" % (
            label, props["m1"], props["m2"], props["m3"], props["ell"], props["terminal_speed"]))


if __name__ == "__main__":
    main()
