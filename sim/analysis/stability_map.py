"""Where the vehicle is stable, over slices of the wing configurations.

For every configuration of a grid:

(a) the thesis's straight fall in the reduced model (chapter 3: neutral
buoyancy, no drag, equilibrium 3.2 with v2 = 0 at ``V3_REDUCED``). Without
drag nothing is damped: a stable fall has every eigenvalue on the
imaginary axis, so the largest real part is 0 wherever it is stable and
says nothing more. What tells configurations apart is how hard gravity
rights the vehicle: the slowest tilt oscillation (Hz; the smallest
imaginary part, the weaker of the pitch and roll modes), with the
configurations where a real part is positive marked unstable. None where
the configuration has no such equilibrium: there the locked inertia
couples heave to surge (as it does without the symmetry wing 1 = wing 3,
wing 2 = wing 4, but for the few where the couplings cancel) and a
straight fall is not steady;

(b) the steady descent with drag the vehicle settles into (``trim``): the
largest real part of its eigenvalues, leaving out a neutral spin mode (flat
plates put no drag against spin, so a symmetric vehicle's spin eigenvalue
is 0 and would hide how well its feathering is damped); None where the
drop does not settle into a steady descent.

Two slices: wing 1 = wing 3 against wing 2 = wing 4, and wing 1 against
wing 3 with wings 2 and 4 at 45 deg.
"""

from __future__ import annotations

import numpy as np

from roboray.sim.analysis.envelope import COST_MODES_S, settle_batch, settle_cost
from roboray.sim.analysis.reduced import SPECTRAL_TOL, ReducedModel, spectrum
from roboray.sim.analysis.trim import NEUTRAL_TOL, modes
from roboray.sim.dynamics import Model
from roboray.sim.progress import QUIET
from roboray.sim.vehicle import Vehicle

V3_REDUCED = 0.3  #: m/s, the thesis's descent speed
#: Seconds of one core for a reduced-model equilibrium and its spectrum
#: (the progress bar's weight, beside ``envelope.COST_*``).
COST_REDUCED_S = 2e-4

SLICES = {
    "s13_vs_s24": ("wing 1 = wing 3 (deg)", "wing 2 = wing 4 (deg)", lambda a, b: (a, b, a, b),
                   "wing 1 = wing 3 against wing 2 = wing 4"),
    "s1_vs_s3_at_s24_45": ("wing 1 (deg)", "wing 3 (deg)", lambda a, b: (a, 45.0, b, 45.0),
                           "wing 1 against wing 3, wings 2 and 4 at 45 deg"),
}


def compute_cost(step_deg: float = 10.0, settle_s: float = 30.0) -> float:
    """What ``compute`` will cost, in the weights it reports to its progress."""
    n = len(np.arange(0.0, 90.0 + 1e-9, step_deg)) ** 2
    return len(SLICES) * (n * (COST_REDUCED_S + COST_MODES_S) + settle_cost(n, settle_s))


def _reduced(vehicle: Vehicle, wings_deg) -> tuple[float, float]:
    """(max real part 1/s, slowest tilt oscillation Hz) of the straight
    fall, NaN for both where it is no equilibrium."""
    red = ReducedModel.of(vehicle, np.radians(wings_deg))
    state = red.no_spin_state(0.0, V3_REDUCED)
    if state is None or np.abs(red.field(state)).max() > 1e-9:
        return float("nan"), float("nan")
    spec = spectrum(red.jacobian(state))
    eig = spec["eigenvalues"]
    scale = max(1.0, float(np.abs(eig).max()))
    swinging = np.abs(eig.imag)[np.abs(eig.imag) > SPECTRAL_TOL * scale]
    slowest = float(swinging.min()) / (2 * np.pi) if swinging.size else 0.0
    return spec["max_real_eig"], slowest


def compute(params=None, step_deg: float = 10.0, settle_s: float = 30.0, progress=QUIET,
            settle=settle_batch) -> dict:
    """Both slices; ``progress`` (``sim/progress.py``) advances by
    ``compute_cost``; ``settle``, ``envelope.settle_batch`` or one that runs
    the grid elsewhere (``sim/campaign/grid.py``)."""
    vehicle = Vehicle(params)
    model = Model(params)
    axis = np.arange(0.0, 90.0 + 1e-9, step_deg)
    out = {"axis_deg": axis.tolist(), "v3_reduced": V3_REDUCED, "spectral_tolerance": SPECTRAL_TOL, "slices": {}}
    for number, (name, (xlabel, ylabel, make, title)) in enumerate(SLICES.items()):
        progress.set_postfix_str("slice %d of %d" % (number + 1, len(SLICES)))
        configs = [make(a, b) for b in axis for a in axis]   # rows: y values
        reduced = np.empty(len(configs))
        tilt_hz = np.empty(len(configs))
        for k, w in enumerate(configs):
            reduced[k], tilt_hz[k] = _reduced(vehicle, w)
            progress.update(COST_REDUCED_S)
        trims = settle(params, np.array(configs), settle_s, progress)
        drag = np.full(len(configs), np.nan)
        glide = np.full(len(configs), np.nan)
        for k, t in enumerate(trims):
            if t is not None:
                lams = [m["eigenvalue"] for m in modes(model, t)["modes"]
                        if not (m["mode"] == "spin" and abs(m["eigenvalue"][0]) <= NEUTRAL_TOL)]
                drag[k] = max(lam[0] for lam in lams)
                glide[k] = t.glide_ratio if t.straight else 0.0
            progress.update(COST_MODES_S)
        shape = (len(axis), len(axis))
        out["slices"][name] = {
            "title": title, "x_label": xlabel, "y_label": ylabel,
            "reduced_max_real_eig": reduced.reshape(shape).tolist(),
            "reduced_slowest_tilt_hz": tilt_hz.reshape(shape).tolist(),
            "trim_max_real_eig": drag.reshape(shape).tolist(),
            "trim_glide_ratio": glide.reshape(shape).tolist(),
        }
    return out


#: What a grey cell means, column by column.
NO_EQUILIBRIUM = "grey: a straight fall is not steady (heave couples to surge)"
NO_TRIM = "grey: the drop does not settle into a steady descent"


def figure(result: dict):
    """The map as a matplotlib figure: a row a slice; left, the reduced
    model's slowest tilt oscillation (hatched where unstable); right, the
    largest real part with drag (red: unstable)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.patches import Patch, Rectangle

    axis = np.array(result["axis_deg"])
    step = axis[1] - axis[0] if len(axis) > 1 else 1.0
    extent = (axis[0] - step / 2, axis[-1] + step / 2, axis[0] - step / 2, axis[-1] + step / 2)

    def cells(ax):
        # a tick on each cell's wing angle, and the axes end at the grid's
        # first and last angles (0 and the 90 deg wing limit): the outer
        # cells are half cells, nothing is drawn past the wings' travel
        ticks = axis if len(axis) <= 10 else axis[::int(np.ceil(len(axis) / 10))]
        ax.set_xticks(ticks)
        ax.set_yticks(ticks)
        ax.set_xlim(axis[0], axis[-1])
        ax.set_ylim(axis[0], axis[-1])
    slices = result["slices"]
    fig, axes = plt.subplots(len(slices), 2, figsize=(12, 5.2 * len(slices)), squeeze=False)
    drag_all = np.concatenate([np.ravel(np.array(sl["trim_max_real_eig"], float)) for sl in slices.values()])
    drag_all = drag_all[np.isfinite(drag_all)]
    # one scale for both slices, so the same colour is the same damping
    lim = float(np.abs(drag_all).max()) if drag_all.size and np.abs(drag_all).max() > 0 else 1.0
    for row, sl in enumerate(slices.values()):
        ax = axes[row, 0]
        hz = np.array(sl["reduced_slowest_tilt_hz"], float)
        grows = np.array(sl["reduced_max_real_eig"], float)
        cmap = matplotlib.colormaps["viridis"].with_extremes(bad="lightgrey")
        finite = hz[np.isfinite(hz)]
        im = ax.imshow(np.ma.masked_invalid(hz), origin="lower", extent=extent, cmap=cmap, aspect="auto",
                       vmin=float(finite.min()) if finite.size else 0.0,
                       vmax=float(finite.max()) if finite.size and finite.max() > finite.min() else None)
        scale = np.nanmax(np.abs(grows)) if np.isfinite(grows).any() else 1.0
        unstable = np.isfinite(grows) & (grows > result.get("spectral_tolerance", 1e-6) * max(1.0, scale))
        # grey in the legend only where the panel has grey cells
        handles = [Patch(facecolor="lightgrey", label=NO_EQUILIBRIUM)] if not np.isfinite(hz).all() else []
        if unstable.any():
            for i, j in zip(*np.nonzero(unstable)):
                ax.add_patch(Rectangle((axis[j] - step / 2, axis[i] - step / 2), step, step, fill=False,
                                       hatch="xx", lw=0.0))
            handles.append(Patch(facecolor="none", hatch="xx", label="unstable: a real part > 0"))
        cells(ax)
        ax.set_xlabel(sl["x_label"])
        ax.set_ylabel(sl["y_label"])
        ax.set_title("%s\nno drag (reduced model, ch. 3), straight fall at %g m/s"
                     % (sl["title"], result["v3_reduced"]), fontsize=9)
        fig.colorbar(im, ax=ax, label="slowest tilt oscillation (Hz)")
        if handles:
            ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), fontsize=8, frameon=False)

        ax = axes[row, 1]
        drag = np.array(sl["trim_max_real_eig"], float)
        cmap = matplotlib.colormaps["RdBu_r"].with_extremes(bad="lightgrey")
        im = ax.imshow(np.ma.masked_invalid(drag), origin="lower", extent=extent, cmap=cmap, aspect="auto",
                       norm=TwoSlopeNorm(vcenter=0.0, vmin=-lim, vmax=lim))
        cells(ax)
        ax.set_xlabel(sl["x_label"])
        ax.set_ylabel(sl["y_label"])
        ax.set_title("%s\nwith drag, the settled descent (neutral spin left out)" % sl["title"], fontsize=9)
        fig.colorbar(im, ax=ax, label="largest real part of the eigenvalues (1/s)\nred: unstable, blue: damped")
        if not np.isfinite(drag).all():
            ax.legend(handles=[Patch(facecolor="lightgrey", label=NO_TRIM)], loc="upper center",
                      bbox_to_anchor=(0.5, -0.13), fontsize=8, frameon=False)
    fig.suptitle("RoboRay stability over wing configurations")
    fig.tight_layout()
    return fig


def plot(result: dict, path: str) -> None:
    import matplotlib.pyplot as plt

    fig = figure(result)
    fig.savefig(path, dpi=90)
    plt.close(fig)
