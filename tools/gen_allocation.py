"""Generate the board's wing allocation table from the model's steady descents.

The cascade controller (``shared/control/``) asks for a horizontal glide in
the body frame and a mean wing fold; which four wing angles give it is a
property of the vehicle, not of the controller, so it comes from the trims
of the analysis (``sim/analysis/trim.py``) and is compiled into board code
as a fixed table: ``shared/control/allocation_table.py``. The generated file
is committed; ``tests/test_control_allocation.py`` regenerates a fold row
and compares.

Family of wing configurations (the harmonic fold, clipped to the travel):

    s_i = clip(c + A cos(psi - a_i), 0, 90 deg),   a_i = (i - 1) 90 deg

``c`` the mean fold (descent speed), ``A`` the asymmetry (glide ratio),
``psi`` the side folded most (glide direction). At psi = 0 it is the axis
family of the envelope (mirror plane x_c z_c, glide towards wing 1), at
psi = 45 deg the diagonal family (c = 45, A = 64: (90, 90, 0, 0), the
reachable glide 0.49); in between it has no mirror plane and spirals
slowly (the Munk moment of the asymmetric added mass turns it), which the
grid records and the inversion avoids where the spin is fast.

1. **Forward grid.** Every (c, psi, A) of ``FOLDS_DEG`` x ``PSI_DEG`` x
   ``AMP_DEG`` is dropped at once on the compiled model (a batch), settles
   for ``SETTLE_S`` and is polished into a trim (``envelope.settle_batch``);
   per trim: the glide vector (horizontal velocity over descent speed, body
   frame), descent speed, spin rate, the gravity direction in the body
   frame, and the largest real part of its linearisation's eigenvalues.
   By the vehicle's symmetry (four quarter turns, mirror about the diagonal)
   psi in [0, 45] deg covers every direction.
2. **Inversion.** Per fold row, the forward map is interpolated (bilinear in
   psi and A) on a fine mesh (``MESH_DEG``); mesh points whose spin exceeds
   ``SPIN_MAX`` or whose trim is unstable (eigenvalue above ``UNSTABLE``)
   are dropped. For each requested glide (direction ``DIR_DEG``, ratio
   ``RATIO``) the usable mesh point nearest in the glide plane is taken, the
   smallest asymmetry among near ties. ``RATIO_MAX`` is the largest ratio
   reachable along each direction (within ``DIR_TOL_DEG``); a request
   beyond it is shortened to it, keeping its direction.

Run: ``python -m roboray.tools.gen_allocation [--check] [--out PATH] [--vehicle FILE]``.
"""

from __future__ import annotations

import math
import struct
import sys
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from roboray.tools.generated import generator_main

#: Mean folds (deg) of the table's rows: below 30 deg the glide turns to
#: the other side (c = 15: away from the folded wing) and the authority
#: vanishes near 22 deg; above 45 deg the straight glides are unstable and
#: the asymmetric ones spin at 1-3 rad/s.
FOLDS_DEG = (30.0, 35.0, 40.0, 45.0)
#: Side folded most, deg (the octant; symmetry gives the rest).
PSI_DEG = (0.0, 9.0, 18.0, 27.0, 36.0, 45.0)
#: Asymmetry, deg (64 deg folds (90, 90, 0, 0) at c = 45 and psi = 45).
AMP_DEG = (0.0, 8.0, 16.0, 24.0, 32.0, 40.0, 48.0, 56.0, 64.0)
#: Inverse table: glide direction in the body frame (deg from wing 1) ...
DIR_DEG = (0.0, 9.0, 18.0, 27.0, 36.0, 45.0)
#: ... and glide ratio (horizontal over descent speed).
RATIO = tuple(round(0.05 * k, 2) for k in range(11))
SETTLE_S = 40.0
#: Fine mesh of the inversion, deg.
MESH_DEG = 0.25
#: Fastest spin allowed, rad/s: a 0.06 rad/s turn is 3.4 deg/s, which the
#: heading loop follows; the clipped configurations beyond it spin at 0.2-1.8.
SPIN_MAX = 0.06
#: Largest real eigenvalue (1/s) a usable trim may have.
UNSTABLE = 0.02
#: Directions within this of a row count towards its RATIO_MAX, deg.
DIR_TOL_DEG = 1.0
#: Among mesh points this close (glide ratio) to a request, the smallest
#: asymmetry wins.
TIE = 0.002

QUARTER = np.radians([0.0, 90.0, 180.0, 270.0])


def harmonic(c_deg: float, a_deg: float, psi_deg: float) -> np.ndarray:
    """Wing angles (deg) of the harmonic fold, clipped to the travel."""
    return np.clip(c_deg + a_deg * np.cos(math.radians(psi_deg) - QUARTER), 0.0, 90.0)


def default_out() -> Path:
    return Path(__file__).resolve().parent.parent / "shared" / "control" / "allocation_table.py"


# ------------------------------------------------------------------ forward
def forward_grid(params=None, folds: Sequence[float] = FOLDS_DEG, psis: Sequence[float] = PSI_DEG,
                 amps: Sequence[float] = AMP_DEG, settle_s: float = SETTLE_S) -> dict:
    """Trims of every harmonic fold of the grid. Arrays (fold, psi, amp):
    ``gx``, ``gy`` glide vector (body), ``w`` descent speed m/s, ``spin``
    rad/s, ``gamma_x``, ``gamma_y`` gravity direction (body), ``max_real``
    1/s, ``straight`` (1: straight glide, 0: spiral); NaN where no trim."""
    from roboray.sim.analysis.envelope import settle_batch
    from roboray.sim.analysis.trim import modes
    from roboray.sim.dynamics import Model

    wings = np.array([harmonic(c, a, p) for c in folds for p in psis for a in amps])
    trims = settle_batch(params, wings, settle_s)
    model = Model(params)
    shape = (len(folds), len(psis), len(amps))
    names = ("gx", "gy", "w", "spin", "gamma_x", "gamma_y", "max_real", "straight")
    out = {name: np.full(shape, np.nan) for name in names}
    for k, trim in enumerate(trims):
        if trim is None:
            continue
        idx = np.unravel_index(k, shape)
        h = trim.horizontal_velocity_body
        w = trim.descent_speed
        row = (h[0] / w, h[1] / w, w, trim.omega, trim.gamma[0], trim.gamma[1],
               modes(model, trim)["max_real_eig"], 1.0 if trim.straight else 0.0)
        for name, value in zip(names, row):
            out[name][idx] = value
    out.update(folds=np.array(folds, float), psis=np.array(psis, float), amps=np.array(amps, float))
    return out


# ------------------------------------------------------------------ inverse
def _bilinear(grid_x: np.ndarray, grid_y: np.ndarray, values: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    i = np.clip(np.searchsorted(grid_x, x, side="right") - 1, 0, len(grid_x) - 2)
    j = np.clip(np.searchsorted(grid_y, y, side="right") - 1, 0, len(grid_y) - 2)
    u = (x - grid_x[i]) / (grid_x[i + 1] - grid_x[i])
    v = (y - grid_y[j]) / (grid_y[j + 1] - grid_y[j])
    return ((1 - u) * (1 - v) * values[i, j] + u * (1 - v) * values[i + 1, j]
            + (1 - u) * v * values[i, j + 1] + u * v * values[i + 1, j + 1])


def invert_row(fwd: dict, row: int) -> dict:
    """Inverse tables of one fold row: ``psi_deg``, ``amp_deg`` (dir, ratio)
    and ``ratio_max`` (dir)."""
    psis, amps = fwd["psis"], fwd["amps"]
    mp, ma = np.meshgrid(np.arange(psis[0], psis[-1] + 1e-9, MESH_DEG),
                         np.arange(amps[0], amps[-1] + 1e-9, MESH_DEG), indexing="ij")
    mp, ma = mp.ravel(), ma.ravel()
    field = {}
    for name in ("gx", "gy", "spin", "max_real"):
        values = fwd[name][row]
        if np.isnan(values).any():
            raise ValueError("fold %g deg: the grid has configurations without a trim" % fwd["folds"][row])
        field[name] = _bilinear(psis, amps, values, mp, ma)
    # A = 0 is the symmetric fall whatever psi: no glide, no spin.
    usable = (np.abs(field["spin"]) <= SPIN_MAX) & (field["max_real"] <= UNSTABLE)
    gx, gy = field["gx"][usable], field["gy"][usable]
    up, ua = mp[usable], ma[usable]
    ratio = np.hypot(gx, gy)
    direction = np.degrees(np.arctan2(gy, gx))
    psi_t = np.empty((len(DIR_DEG), len(RATIO)))
    amp_t = np.empty_like(psi_t)
    rmax = np.empty(len(DIR_DEG))
    for i, d in enumerate(DIR_DEG):
        along = np.abs(direction - d) <= DIR_TOL_DEG
        rmax[i] = ratio[along].max() if along.any() else 0.0
        for j, r in enumerate(RATIO):
            # beyond the reach, the reachable glide in the same direction
            r = min(r, rmax[i])
            tx, ty = r * math.cos(math.radians(d)), r * math.sin(math.radians(d))
            err = np.hypot(gx - tx, gy - ty)
            near = err <= err.min() + TIE
            k = np.flatnonzero(near)[np.argmin(ua[near])]
            psi_t[i, j] = up[k]
            amp_t[i, j] = ua[k]
    return {"psi_deg": psi_t, "amp_deg": amp_t, "ratio_max": rmax}


def invert(fwd: dict) -> dict:
    rows = [invert_row(fwd, k) for k in range(len(fwd["folds"]))]
    return {
        "psi_deg": np.array([r["psi_deg"] for r in rows]),
        "amp_deg": np.array([r["amp_deg"] for r in rows]),
        "ratio_max": np.array([r["ratio_max"] for r in rows]),
        # descent speed of the symmetric fall at each fold (A = 0)
        "descent": fwd["w"][:, 0, 0].copy(),
    }


# ------------------------------------------------------------------ output
def _floats(values: np.ndarray, per_line: int, indent: str = "    ", digits: int = 5) -> str:
    flat = [("%.*f" % (digits, v)).rstrip("0").rstrip(".") if v == v else "nan" for v in np.ravel(values)]
    flat = [f if "." in f else f + ".0" for f in flat]
    lines = [indent + ", ".join(flat[k:k + per_line]) + "," for k in range(0, len(flat), per_line)]
    return "\n".join(lines)


def _table(name: str, values: np.ndarray, per_line: int, digits: int = 5) -> str:
    """``NAME = array('f', b'...')``, the values in a comment above it.

    A bytes constant, not a tuple of floats: the module's constants live as
    long as the module, and a tuple of N floats is N boxed floats (16 bytes
    each on the board) that every collection marks one by one; past 64 of
    them MicroPython's mark stack overflows and the collector rescans the
    whole heap (``docs/design/board-time.md``). A bytes constant is one
    block with no pointers in it, and stays in flash when the firmware runs
    from ROMFS. The values are rounded as printed, then stored as float32,
    as ``array('f', (...))`` stored them."""
    flat = np.ravel(values)
    text = _floats(flat, per_line, indent="#   ", digits=digits)
    raw = struct.pack("<%df" % len(flat), *[float(f) for f in _rounded(flat, digits)])
    return "%s\n%s = array('f', %r)" % (text, name, raw)


def _rounded(values: np.ndarray, digits: int) -> list:
    # the printed numbers, read back: what the tuple literal held
    return [float(("%.*f" % (digits, v))) if v == v else float("nan") for v in values]


def render(inv: dict, fwd: dict, source: str) -> str:
    """The board module's text. Angles in radians (the board's unit),
    rounded to 1e-5 rad so a regeneration compares exactly."""
    rad = math.pi / 180.0
    nf, nd, nr = len(FOLDS_DEG), len(DIR_DEG), len(RATIO)
    summary = []
    for k, c in enumerate(FOLDS_DEG):
        summary.append("#   fold %4.1f deg: descent %.3f m/s, reach %s" % (
            c, inv["descent"][k], " ".join("%.3f" % r for r in inv["ratio_max"][k])))
    return "\n".join([
        '"""Wing allocation table of the cascade controller. GENERATED by',
        "``python -m roboray.tools.gen_allocation`` from the trims of %s; do not" % source,
        "edit (the generator's docstring says how it is made; a test regenerates",
        "it).",
        "",
        "Lookup (``allocation.Allocation``): mean fold ``c`` (rows ``FOLD``),",
        "glide direction in the body frame reduced to the octant [0, 45] deg",
        "(columns every ``DIR_STEP``) and glide ratio (every ``RATIO_STEP``) give",
        "the harmonic fold's side ``psi`` and asymmetry ``A`` (``PSI``, ``AMP``,",
        "index ``(fold * N_DIR + dir) * N_RATIO + ratio``), so that",
        "``s_i = clip(c + A cos(psi - (i - 1) pi/2), 0, pi/2)``. ``RATIO_MAX``",
        "(fold, dir) is the reach; ``DESCENT`` (fold) the descent speed of the",
        "symmetric fall. Radians.",
        '"""',
        "",
        "from array import array",
        "",
        "# Reach (largest glide ratio) per direction 0, 9, ..., 45 deg:",
        *summary,
        "",
        "N_FOLD = %d" % nf,
        "N_DIR = %d" % nd,
        "N_RATIO = %d" % nr,
        "FOLD_STEP = %r" % round((FOLDS_DEG[1] - FOLDS_DEG[0]) * rad, 7),
        "DIR_STEP = %r" % round((DIR_DEG[1] - DIR_DEG[0]) * rad, 7),
        "RATIO_STEP = %r" % (RATIO[1] - RATIO[0]),
        "# Tables as float32 bytes (the values above each; see _table in the generator)",
        _table("FOLD", np.array(FOLDS_DEG) * rad, 8, digits=9),
        _table("DESCENT", np.round(inv["descent"], 5), 8),
        _table("RATIO_MAX", np.round(inv["ratio_max"], 5), nd),
        _table("PSI", np.round(inv["psi_deg"] * rad, 5), nr),
        _table("AMP", np.round(inv["amp_deg"] * rad, 5), nr),
        "",
    ])


def generate(params=None, source: str = "sim/vehicles/reference.py") -> str:
    fwd = forward_grid(params)
    return render(invert(fwd), fwd, source)


def main(argv: Optional[Sequence[str]] = None) -> int:
    return generator_main("gen_allocation", __doc__.splitlines()[0], generate, default_out(), argv)


if __name__ == "__main__":
    sys.exit(main())
