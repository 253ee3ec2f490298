"""Figures: what the thesis's figures 5.1-5.15 show, from our runs; and the
style every figure of roboray-sim keeps: wings are "wing 1".."wing 4",
units in parentheses ("depth (m)"), and a quantity that is zero up to
round-off is drawn as zero, not as its round-off at full scale."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # files only; no display needed

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

#: The wings' names in every legend (wing k is servo k, s_k in the thesis).
WINGS = tuple("wing %d" % k for k in range(1, 5))
#: A line style a wing, so that wings at the same angle stay visible.
WING_STYLES = ("-", "--", "-.", ":")


def hold_span(ax, span: float) -> None:
    """Show at least ``span`` (in data units) on the y axis around the
    data: a panel whose lines are all zero up to round-off (1e-16 after a
    symmetric drop) would otherwise be scaled up to that round-off."""
    lo, hi = ax.dataLim.intervaly
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return
    if hi - lo < span:
        mid = 0.5 * (lo + hi) if max(abs(lo), abs(hi)) >= span else 0.0
        inverted = ax.yaxis_inverted()
        ax.set_ylim(mid - span / 2, mid + span / 2)
        if inverted:
            ax.invert_yaxis()


def drop_figure(run, title: str, vehicle: int = 0):
    """Body velocities, NED velocities, rates, position and wings against
    time, as a matplotlib figure."""
    t = run.t
    nu = run.nu[:, vehicle]
    vel = run.velocity_ned()[:, vehicle]
    pos = run.x[:, vehicle, :3]
    fig, axes = plt.subplots(5, 1, figsize=(8, 12), sharex=True)
    ax = axes[0]
    for k, name in enumerate(("V1 (x_c)", "V2 (y_c)", "V3 (z_c)")):
        ax.plot(t, nu[:, k], label=name)
    ax.set_ylabel("body velocity (m/s)")
    hold_span(ax, 0.02)
    ax.legend(loc="best", fontsize=8)
    ax = axes[1]
    for k, name in enumerate(("north", "east", "down")):
        ax.plot(t, vel[:, k], label=name)
    ax.set_ylabel("NED velocity (m/s)")
    hold_span(ax, 0.02)
    ax.legend(loc="best", fontsize=8)
    ax = axes[2]
    for k, name in enumerate(("p (x_c)", "q (y_c)", "r (z_c)")):
        ax.plot(t, nu[:, 3 + k], label=name)
    ax.set_ylabel("body rates (rad/s)")
    hold_span(ax, 0.02)
    ax.legend(loc="best", fontsize=8)
    ax = axes[3]
    ax.plot(t, pos[:, 0], label="north")
    ax.plot(t, pos[:, 1], label="east")
    ax.set_ylabel("horizontal (m)")
    hold_span(ax, 0.02)
    ax2 = ax.twinx()
    ax2.plot(t, pos[:, 2], "k--", label="depth")
    ax2.set_ylabel("depth (m)")
    ax2.invert_yaxis()
    hold_span(ax2, 0.02)
    lines = ax.get_legend_handles_labels()
    more = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], loc="upper right", fontsize=8)
    ax = axes[4]
    for k in range(4):
        ax.plot(t, np.degrees(run.x[:, vehicle, 13 + k]), ls=WING_STYLES[k], label=WINGS[k])
    ax.set_ylabel("wing angle (deg)")
    hold_span(ax, 2.0)
    ax.set_xlabel("time (s)")
    ax.legend(loc="best", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_drop(run, path: str, title: str, vehicle: int = 0) -> None:
    """``drop_figure`` written to ``path``."""
    fig = drop_figure(run, title, vehicle)
    fig.savefig(path, dpi=90)
    plt.close(fig)
