"""The figure of a twin run: track, depth, wings, and what the firmware did."""

from __future__ import annotations

from typing import Any

import numpy as np

from roboray.shared.modes import MODES
from roboray.shared.modes import NAMES as MODE_NAMES


def plot(twin: Any, report: dict, out_png: str) -> None:
    """``figure`` of a twin's run written to ``out_png``."""
    import matplotlib.pyplot as plt

    fig = figure(twin.world.truth(), twin.ground.seen.positions, report)
    fig.savefig(out_png, dpi=110)
    plt.close(fig)


def figure(truth: dict, positions: list, report: dict):
    """Top view (true track, the vehicle's own estimate, target, landing),
    depth against time, wing angles (true) against time, and the modes and
    failsafes on a time line, as a matplotlib figure. ``truth``: the world's
    (``t``, ``x``, ``cb``); ``positions``: the LOCAL_POSITION_NED rows the
    ground received (t, north, east, down, ...); ``report``: the run's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.sim.plots import WING_STYLES, WINGS, plot_series

    t = truth["t"]
    x = truth["x"]
    cb = truth["cb"]
    est = np.array(positions) if len(positions) else np.zeros((0, 7))
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    ax = axes[0, 0]
    ax.plot(cb[:, 1], cb[:, 0], color="C0", label="true track (centre of buoyancy)")
    if len(est):
        ax.plot(est[:, 2], est[:, 1], ".", ms=2, color="C1", label="vehicle's estimate (LOCAL_POSITION_NED)")
    if report.get("target") is not None:
        n, e = report["target"]
        ax.plot(e, n, "x", ms=12, mew=2, color="C3", label="target")
    if report.get("landing_point") is not None:
        n, e = report["landing_point"]
        label = "landing"
        if report.get("landing_error_m") is not None:
            label += " (%.2f m from the target)" % report["landing_error_m"]
        ax.plot(e, n, "o", mfc="none", ms=10, color="C2", label=label)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title("top view")

    ax = axes[0, 1]
    ax.plot(t, cb[:, 2], color="C0", label="true depth (centre of buoyancy)")
    if len(est):
        ax.plot(est[:, 0], est[:, 3], ".", ms=2, color="C1", label="estimate")
    ax.axhline(report["bottom_depth_m"], color="k", lw=0.8, ls="--", label="bottom")
    # the radio through water: where it reaches, and when the ground lost and found it (the
    # estimate's dots stop there because LOCAL_POSITION_NED no longer arrives, not the vehicle)
    if report.get("radio_reach_m") is not None:
        ax.axhline(report["radio_reach_m"], color="C4", lw=0.8, ls=":",
                   label="radio reach %.1f m (%s)" % (report["radio_reach_m"], report.get("radio_model", "")))
    for ev in report.get("link_events", []):
        ax.plot([ev["t"]], [ev["depth_m"]], "v" if ev["event"] == "lost" else "^", ms=7, color="C4",
                label="link %s at %.1f s, %.1f m" % (ev["event"], ev["t"], ev["depth_m"]))
    ax.invert_yaxis()
    ax.set_xlabel("time (s)")
    ax.set_ylabel("depth (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[1, 0]
    plot_series(ax, t, np.degrees(x[:, 13:17]).T, WINGS, WING_STYLES)   # wings at one angle: one line
    ax.set_xlabel("time (s)")
    ax.set_ylabel("wing angle (deg), 0 flat, 90 folded")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, ncol=2)

    ax = axes[1, 1]
    end = float(t[-1]) if len(t) else 0.0
    span = max(end, 1.0)
    names = mode_rows(report.get("modes", []))
    handles = _mode_rows(ax, report.get("modes", []), report.get("arming", []), end, names)
    # events in the legend with their times (two a few seconds apart would
    # print over each other as labels); failsafes labelled at their line,
    # a close one on the other side of its line, the third lower down
    from matplotlib.lines import Line2D

    for key, label, style in (("released_at_s", "released", ":"), ("landed_at_s", "landed", "-.")):
        if report.get(key) is not None:
            ax.axvline(report[key], color="k", lw=0.8, ls=style)
            handles.append(Line2D([], [], color="k", lw=0.8, ls=style, label="%s at %.2f s" % (label, report[key])))
    lost = [ev["t"] for ev in report.get("link_events", []) if ev["event"] == "lost"]
    for ev in report.get("link_events", []):
        ax.axvline(ev["t"], color="C4", lw=0.8, ls="--" if ev["event"] == "lost" else "-")
    if lost:
        handles.append(Line2D([], [], color="C4", lw=0.8, ls="--", label="link lost at %.2f s" % lost[0]))
    last, close = -float("inf"), 0
    for f in sorted(report.get("failsafes", []), key=lambda f: f["t"]):
        close = close + 1 if f["t"] - last < 0.04 * span else 0
        last = f["t"]
        ax.axvline(f["t"], color="C3", lw=0.8)
        ax.text(f["t"], len(names) - 0.6 - 1.5 * (close // 2 % 3), f["name"], rotation=90, fontsize=7, va="top",
                ha="left" if close % 2 else "right", color="C3")
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels(names, fontsize=8)
    ax.set_ylim(-0.7, len(names) + 0.9)   # a band above the rows for the legend
    ax.set_xlim(0, span)
    ax.set_xlabel("time (s)")
    ax.set_title("firmware mode and failsafes", fontsize=10)
    ax.legend(handles=handles, fontsize=7, loc="upper center", ncol=len(handles) if len(handles) <= 3 else 3)
    rtf = report.get("real_time_factor")
    fig.suptitle("roboray-sim sil --scenario %s (%s, seed %d%s)" % (
        report["scenario"], report["interpreter"], report["seed"],
        ", %.1fx real time" % rtf if rtf else ""), fontsize=11)
    fig.tight_layout()
    return fig


#: What the mode log says while no firmware runs (a reset): no mode, no row.
NO_FIRMWARE = "OFF"


def mode_rows(modes: list) -> list:
    """The rows of the mode time line: the firmware's modes in their order,
    then any other name the log gives (never dropped), never OFF."""
    rows = [MODE_NAMES[m] for m in MODES]
    for _, name in modes:
        if name != NO_FIRMWARE and name not in rows:
            rows.append(name)
    return rows


def _mode_rows(ax: Any, modes: list, arming: list, end: float, names: list) -> list:
    """One row a mode (arming is a flag, not a row): a thick bar while armed,
    a thin one while disarmed, grey where no firmware ran (a reset). The
    legend's handles."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    cuts = sorted({float(t) for t, _ in modes} | {float(t) for t, _ in arming} | {end})

    def at(log: list, t: float) -> Any:
        now = None
        for when, what in log:
            if when <= t:
                now = what
        return now

    off = False
    held = {True: {}, False: {}}    # seconds in each row, armed and disarmed
    for a, b in zip(cuts[:-1], cuts[1:]):
        mode = at(modes, a)
        if mode == NO_FIRMWARE:
            ax.axvspan(a, b, color="0.85", lw=0)
            off = True
        elif mode in names:
            y = names.index(mode)
            armed = at(arming, a) == "armed"
            held[armed][y] = held[armed].get(y, 0.0) + (b - a)
            ax.plot([a, b], [y, y], lw=6 if armed else 2, alpha=1.0 if armed else 0.6, solid_capstyle="butt",
                    color="C%d" % y)
    # Each swatch is a bar as the plot draws it: the width says armed or
    # not, in the colour of the row the run spent longest in that state (a
    # grey swatch would read as the grey of "no firmware", and no bar is
    # grey); a state the run never had gets no swatch.
    handles = []
    for armed, label, lw, alpha in ((True, "armed: thick bar", 6, 1.0), (False, "disarmed: thin bar", 2, 0.6)):
        if held[armed]:
            y = max(held[armed], key=held[armed].get)
            handles.append(Line2D([], [], lw=lw, alpha=alpha, color="C%d" % y, label=label))
    if off:
        handles.append(Patch(color="0.85", label="no firmware (reset)"))
    return handles
