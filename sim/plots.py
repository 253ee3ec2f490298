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


def same_series(series, rel: float = 1e-3) -> list:
    """Groups (lists of indices) of the series (K, N) that coincide: within
    ``rel`` of the span of all of them at every sample. One line drawn
    over another hides it; a group is drawn once and named for all."""
    ys = np.asarray(series, float)
    lo, hi = np.nanmin(ys), np.nanmax(ys)
    tol = rel * max(hi - lo, np.nanmax(np.abs(ys)), 1e-300)
    groups = []
    for k in range(len(ys)):
        for g in groups:
            if np.nanmax(np.abs(ys[k] - ys[g[0]])) <= tol:
                g.append(k)
                break
        else:
            groups.append([k])
    return groups


def plot_series(ax, t, series, labels, styles=None, rel: float = 1e-3) -> None:
    """Plot the series (K, N) against t with their labels; series that
    coincide (``same_series``) are one line labelled "a = b", in the first
    one's colour and style, so that none hides behind another; the others
    each in a style of their own (default ``WING_STYLES``), so that two
    that meet for a while both show there."""
    styles = WING_STYLES if styles is None else styles
    for g in same_series(series, rel):
        ax.plot(t, np.asarray(series[g[0]], float), color="C%d" % g[0], ls=styles[g[0]],
                label=" = ".join(labels[k] for k in g))


def drop_figure(run, title: str, vehicle: int = 0):
    """Body velocities, NED velocities, rates, horizontal position, depth
    and wings against time, as a matplotlib figure: one quantity a panel,
    one y axis a panel."""
    t = run.t
    nu = run.nu[:, vehicle]
    vel = run.velocity_ned()[:, vehicle]
    pos = run.x[:, vehicle, :3]
    fig, axes = plt.subplots(6, 1, figsize=(8, 13), sharex=True)
    ax = axes[0]
    plot_series(ax, t, nu[:, :3].T, ("V1 (x_c)", "V2 (y_c)", "V3 (z_c)"))
    ax.set_ylabel("body velocity (m/s)")
    hold_span(ax, 0.02)
    ax.legend(loc="best", fontsize=8)
    ax = axes[1]
    plot_series(ax, t, vel.T, ("north", "east", "down"))
    ax.set_ylabel("NED velocity (m/s)")
    hold_span(ax, 0.02)
    ax.legend(loc="best", fontsize=8)
    ax = axes[2]
    plot_series(ax, t, nu[:, 3:6].T, ("p (x_c)", "q (y_c)", "r (z_c)"))
    ax.set_ylabel("body rates (rad/s)")
    hold_span(ax, 0.02)
    ax.legend(loc="best", fontsize=8)
    ax = axes[3]
    plot_series(ax, t, pos[:, :2].T, ("north", "east"))
    ax.set_ylabel("horizontal (m)")
    hold_span(ax, 0.02)
    ax.legend(loc="best", fontsize=8)
    ax = axes[4]
    ax.plot(t, pos[:, 2], color="k", label="depth")
    ax.set_ylabel("depth (m)")
    hold_span(ax, 0.02)
    ax.invert_yaxis()
    ax = axes[5]
    plot_series(ax, t, np.degrees(run.x[:, vehicle, 13:17]).T, WINGS, WING_STYLES)
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
