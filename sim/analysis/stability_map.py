"""Where the vehicle is stable, over slices of the wing configurations.

For every configuration of a grid: the largest real part of the eigenvalues
of (a) the thesis's straight fall in the reduced model (chapter 3: neutral
buoyancy, no drag, equilibrium 3.2 with v2 = 0 at ``V3_REDUCED``; blank
where the configuration has no such equilibrium: without the symmetry
s1 = s3, s2 = s4 the locked inertia couples heave to surge and a straight
fall is not steady), and (b) the steady descent with drag the vehicle
settles into (``trim``), leaving out a neutral spin mode (flat plates put
no drag against spin, so a symmetric vehicle's spin eigenvalue is 0 and
would hide how well its feathering is damped). Two slices: s1 = s3 against
s2 = s4, and s1 against s3 with s2 = s4 = 45 deg.
"""

from __future__ import annotations

import numpy as np

from roboray.sim.analysis.envelope import settle_batch
from roboray.sim.analysis.reduced import ReducedModel, spectrum
from roboray.sim.analysis.trim import NEUTRAL_TOL, modes
from roboray.sim.dynamics import Model
from roboray.sim.vehicle import Vehicle

V3_REDUCED = 0.3  #: m/s, the thesis's descent speed

SLICES = {
    "s13_vs_s24": ("s1 = s3 (deg)", "s2 = s4 (deg)", lambda a, b: (a, b, a, b)),
    "s1_vs_s3_at_s24_45": ("s1 (deg)", "s3 (deg)", lambda a, b: (a, 45.0, b, 45.0)),
}


def compute(params=None, step_deg: float = 10.0, settle_s: float = 30.0) -> dict:
    vehicle = Vehicle(params)
    model = Model(params)
    axis = np.arange(0.0, 90.0 + 1e-9, step_deg)
    out = {"axis_deg": axis.tolist(), "v3_reduced": V3_REDUCED, "slices": {}}
    for name, (xlabel, ylabel, make) in SLICES.items():
        configs = [make(a, b) for b in axis for a in axis]   # rows: y values
        reduced = np.empty(len(configs))
        for k, w in enumerate(configs):
            red = ReducedModel.of(vehicle, np.radians(w))
            state = red.no_spin_state(0.0, V3_REDUCED)
            if np.abs(red.field(state)).max() > 1e-9:
                reduced[k] = np.nan       # not an equilibrium of this configuration
            else:
                reduced[k] = spectrum(red.jacobian(state))["max_real_eig"]
        trims = settle_batch(params, np.array(configs), settle_s)
        drag = np.full(len(configs), np.nan)
        glide = np.full(len(configs), np.nan)
        for k, t in enumerate(trims):
            if t is not None:
                lams = [m["eigenvalue"] for m in modes(model, t)["modes"]
                        if not (m["mode"] == "spin" and abs(m["eigenvalue"][0]) <= NEUTRAL_TOL)]
                drag[k] = max(lam[0] for lam in lams)
                glide[k] = t.glide_ratio if t.straight else 0.0
        shape = (len(axis), len(axis))
        out["slices"][name] = {
            "x_label": xlabel, "y_label": ylabel,
            "reduced_max_real_eig": reduced.reshape(shape).tolist(),
            "trim_max_real_eig": drag.reshape(shape).tolist(),
            "trim_glide_ratio": glide.reshape(shape).tolist(),
        }
    return out


def plot(result: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm

    axis = np.array(result["axis_deg"])
    step = axis[1] - axis[0] if len(axis) > 1 else 1.0
    fig, axes = plt.subplots(2, 2, figsize=(11, 9))
    extent = (axis[0] - step / 2, axis[-1] + step / 2, axis[0] - step / 2, axis[-1] + step / 2)
    for row, (name, sl) in enumerate(result["slices"].items()):
        for col, (key, title) in enumerate((
                ("reduced_max_real_eig", "reduced model (no drag), straight fall v3 = %g m/s" % result["v3_reduced"]),
                ("trim_max_real_eig", "full model with drag, settled descent (neutral spin left out)"))):
            data = np.array(sl[key], float)
            finite = data[np.isfinite(data)]
            lim = max(1e-3, float(np.abs(finite).max())) if finite.size else 1.0
            ax = axes[row, col]
            cmap = matplotlib.colormaps["RdBu_r"].copy()
            cmap.set_bad("lightgrey")   # no equilibrium / no trim
            im = ax.imshow(np.ma.masked_invalid(data), origin="lower", extent=extent, cmap=cmap,
                           norm=TwoSlopeNorm(vcenter=0.0, vmin=-lim, vmax=lim), aspect="auto")
            ax.set_xlabel(sl["x_label"])
            ax.set_ylabel(sl["y_label"])
            ax.set_title(title, fontsize=9)
            fig.colorbar(im, ax=ax, label="max Re(eigenvalue), 1/s (red: unstable)")
    fig.suptitle("RoboRay stability over wing configurations")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
