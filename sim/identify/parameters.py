"""The uncertain parameters of a vehicle file, as the fit moves them.

Each parameter is one number a builder can picture, mapped onto the
``VehicleParams`` fields behind it:

=====================  ======================================================
name                   what moves in the vehicle file
=====================  ======================================================
``cd``                 ``cd``, the plates' normal-drag coefficient
``added_mass_wing``    scale of ``k_wing``, ``kx_wing``, ``ky_wing`` (the
                       wings' added mass and added inertia, eqs. 2.2-2.4)
``added_mass_center``  scale of ``k_center``, ``kx_center``, ``ky_center``
``net_weight``         N, weight less buoyancy: ``total_mass`` (the payload,
                       i.e. the ballast, takes the difference)
``ell``                m, CG below CB with flat wings: ``payload_height``
``munk_scale``         ``munk_scale``, the Munk moment's share (0..1)
=====================  ======================================================

``net_weight`` and ``ell`` are set together: a heavier payload also moves
the CG, so the mass is set first and then the payload's height that gives
the asked ell (ell is affine in the height at a fixed mass: two
evaluations solve it, as ``sim/montecarlo.py`` does).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from roboray.sim.vehicle import Vehicle, VehicleParams

_FLAT = np.zeros(4)

#: name -> (unit, typical change the fit is scaled by, lower, upper bound).
#: The bounds keep the model physical, and wide enough that a true value
#: is never on one (a value on a bound has no honest sigma).
PARAMETERS = {
    "cd": ("-", 0.1, 0.2, 5.0),
    "added_mass_wing": ("x", 0.1, 0.1, 4.0),
    "added_mass_center": ("x", 0.1, 0.1, 4.0),
    "net_weight": ("N", 0.05, 0.05, 20.0),
    "ell": ("m", 0.001, -0.02, 0.05),
    "munk_scale": ("-", 0.1, -1.0, 2.0),
}
#: What ``identify`` fits without ``--fit``.
DEFAULT_FIT = ("cd", "added_mass_wing", "added_mass_center", "net_weight", "ell", "munk_scale")
_WING = ("k_wing", "kx_wing", "ky_wing")
_CENTER = ("k_center", "kx_center", "ky_center")


def parse_names(text: str) -> tuple:
    """``"cd,ell"`` -> ("cd", "ell"); ValueError names an unknown one."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in PARAMETERS]
    if bad or not names:
        raise ValueError("unknown parameter %s; known: %s" % (", ".join(bad) or "(none given)",
                                                              ", ".join(PARAMETERS)))
    if len(set(names)) != len(names):
        raise ValueError("a parameter is named twice in %r" % text)
    return names


def values(params: VehicleParams, base: VehicleParams) -> dict:
    """Every parameter's value for ``params`` (scales relative to ``base``)."""
    v = Vehicle(params)
    return {"cd": params.cd, "added_mass_wing": params.k_wing / base.k_wing,
            "added_mass_center": params.k_center / base.k_center, "net_weight": v.net_weight,
            "ell": v.ell(_FLAT), "munk_scale": params.munk_scale}


def apply(base: VehicleParams, changes: dict) -> VehicleParams:
    """``base`` with the named parameters set (names as ``PARAMETERS``)."""
    p = base
    edit = {}
    if "cd" in changes:
        edit["cd"] = float(changes["cd"])
    if "added_mass_wing" in changes:
        edit.update({f: getattr(base, f) * float(changes["added_mass_wing"]) for f in _WING})
    if "added_mass_center" in changes:
        edit.update({f: getattr(base, f) * float(changes["added_mass_center"]) for f in _CENTER})
    if "munk_scale" in changes:
        edit["munk_scale"] = float(changes["munk_scale"])
    p = dataclasses.replace(p, **edit)
    if "net_weight" in changes:
        v = Vehicle(p)
        # the volume does not depend on the mass: W = (m - rho V) g
        mass = float(changes["net_weight"]) / p.g + p.rho * v.volume
        ell = changes.get("ell", v.ell(_FLAT))
        p = dataclasses.replace(p, total_mass=mass)
        changes = dict(changes, ell=ell)
    if "ell" in changes:
        p = dataclasses.replace(p, payload_height=payload_height_for(p, float(changes["ell"])))
    return p


def payload_height_for(p: VehicleParams, ell: float) -> float:
    """The payload height that gives ``ell`` (flat wings) at p's mass."""
    h0 = p.payload_height
    e0 = Vehicle(p).ell(_FLAT)
    e1 = Vehicle(dataclasses.replace(p, payload_height=h0 + 1e-3)).ell(_FLAT)
    return h0 + (ell - e0) * 1e-3 / (e1 - e0)
