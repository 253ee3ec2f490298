"""``log plot FILE.BIN``: a dive's overview from the vehicle's own log.

Read with pymavlink's DFReader, as MAVExplorer reads it: top view (EST's
position and the target), depth against time (EST's estimate and the
pressure sensor's, BARO), attitude (ATT), wing commands (WING), and a time
line of the modes (MODE), arming and rest (EV) and the failsafes raised
(ERR). The firmware's records are described in
``firmware/flightlog/logger.py``.
"""

from __future__ import annotations

import os
import tempfile
from typing import Any

#: DataFlash records start with these two bytes (and the first is a FMT, type 128).
MAGIC = b"\xa3\x95\x80"

_EVENTS = {10: "armed", 11: "disarmed", 18: "at rest", 28: "moving"}


def is_dataflash(data: bytes) -> bool:
    return data[:3] == MAGIC


def _mode_name(number: int) -> str:
    """RoboRay's name of a MODE record's number (HEARTBEAT's custom_mode, as ArduPilot logs it)."""
    from roboray.shared import modes

    return modes.custom_name(number)


def read(data: bytes) -> dict[str, list[Any]]:
    """The records of a .BIN as lists of DFReader messages, by type."""
    from pymavlink import DFReader

    fd, path = tempfile.mkstemp(suffix=".BIN")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        log = DFReader.DFReader_binary(path)
        out: dict[str, list[Any]] = {}
        while True:
            m = log.recv_match()
            if m is None:
                break
            out.setdefault(m.get_type(), []).append(m)
        return out
    finally:
        os.remove(path)


#: The top view spans at least this (m) each way: a passive drop's estimate
#: wanders a few centimetres, which autoscaled filled the panel with noise.
MIN_HALF_SPAN_M = 1.0


def _failsafe_name(subsys: int) -> str:
    """The failsafe an ERR record raised (``Subsys`` 100 + its bit)."""
    from roboray.firmware.failsafe import NAMES

    from roboray.firmware.flightlog.logger import ERR_FAILSAFE_BASE

    i = subsys - ERR_FAILSAFE_BASE
    return NAMES[i] if 0 <= i < len(NAMES) else "subsystem %d" % subsys


def _legend_outside(ax: Any, handles: Any = None, labels: Any = None) -> None:
    """The legend beside the panel, never over its data."""
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(handles, labels, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def _shade_gaps(ax: Any, spans: list[tuple[float, float]], label: bool) -> None:
    for k, (a, b) in enumerate(spans):
        ax.axvspan(a, b, color="0.85", zorder=0, label="not recorded" if label and k == 0 else None)


def plot(data: bytes, out_png: str, title: str = "") -> dict[str, int]:
    """Draw the overview into ``out_png``; records per type."""
    import matplotlib.pyplot as plt

    fig, counts = figure(data, title)
    fig.savefig(out_png, dpi=100)
    plt.close(fig)
    return counts


def figure(data: bytes, title: str = "") -> tuple[Any, dict[str, int]]:
    """The overview as a matplotlib figure, and the records per type. Lines
    break where records are missing (shaded: a full ring drops them) and
    where the heading wraps through north."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.ground.series import broken, gaps

    r = read(data)
    counts = {k: len(v) for k, v in r.items()}
    if not any(k in r for k in ("ATT", "EST", "BARO")):
        raise ValueError("no ATT, EST or BARO records: not a RoboRay flight log, or an empty one")
    every = [m.TimeUS for v in r.values() for m in v if hasattr(m, "TimeUS")]
    t0 = 0      # TimeUS counts from the board's start, as MAVExplorer shows it

    def t(ms: list[Any]) -> list[float]:
        return [(m.TimeUS - t0) / 1e6 for m in ms]

    att = r.get("ATT", [])
    est = r.get("EST", [])
    # the periodic record that comes most often shows where the ring dropped records
    spans = gaps(t(att)) if att else gaps(t(est))

    fig = plt.figure(figsize=(12, 10))
    grid = fig.add_gridspec(4, 2, height_ratios=(3, 2, 2, 1))
    ax = fig.add_subplot(grid[0:2, 0])
    if est:
        te = t(est)
        _, pe = broken(te, [m.PE for m in est])
        _, pn = broken(te, [m.PN for m in est])
        ax.plot(pe, pn, color="C0", label="vehicle's estimate (EST)")
        last = est[-1]
        if last.TN or last.TE:
            ax.plot(last.TE, last.TN, "x", ms=12, mew=2, color="C3", label="target")
        ax.plot(last.PE, last.PN, "o", mfc="none", ms=10, color="C2", label="last position")
        xs = [m.PE for m in est] + ([last.TE] if last.TN or last.TE else [])
        ys = [m.PN for m in est] + ([last.TN] if last.TN or last.TE else [])
        cx, cy = (min(xs) + max(xs)) / 2.0, (min(ys) + max(ys)) / 2.0
        half = max(MIN_HALF_SPAN_M, 0.55 * max(max(xs) - min(xs), max(ys) - min(ys)))
        ax.set_xlim(cx - half, cx + half)
        ax.set_ylim(cy - half, cy + half)
        ax.set_aspect("equal", adjustable="box")
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title("top view")
    if ax.lines:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(0.0, -0.1), ncol=3, borderaxespad=0.0)

    ax = fig.add_subplot(grid[0, 1])
    _shade_gaps(ax, spans, True)
    if est:
        ax.plot(*broken(t(est), [m.PD for m in est]), color="C0", label="estimate (EST)")
    baro = r.get("BARO", [])
    if baro:
        ax.plot(*broken(t(baro), [-m.Alt for m in baro]), color="C1", lw=0.8, label="pressure sensor (BARO)")
    ax.invert_yaxis()
    ax.set_ylabel("depth (m)")
    ax.set_title("depth")
    _legend_outside(ax)

    ax = fig.add_subplot(grid[1, 1], sharex=fig.axes[1])
    _shade_gaps(ax, spans, False)
    ta = t(att)
    for k in ("Roll", "Pitch"):
        ax.plot(*broken(ta, [getattr(m, k) for m in att]), label=k.lower())
    ax.set_ylabel("roll, pitch (deg)")
    ax2 = ax.twinx()
    # a line broken where the heading wraps through north, not dots
    ax2.plot(*broken(ta, [m.Yaw for m in att], wrap=360.0), color="C2", lw=1.0, label="yaw (right axis)")
    ax2.set_ylabel("yaw (deg)")
    ax2.set_ylim(0, 360)
    ax2.set_yticks([0, 90, 180, 270, 360])
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    if h1 + h2:
        ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left", bbox_to_anchor=(1.12, 1.0), borderaxespad=0.0)

    ax = fig.add_subplot(grid[2, :])
    _shade_gaps(ax, spans, True)
    wing = r.get("WING", [])
    tw = t(wing)
    for i in range(1, 5):
        ax.plot(*broken(tw, [getattr(m, "Cmd%d" % i) for m in wing]), label="wing %d" % i)
    ax.set_ylabel("wing command (deg)")
    _legend_outside(ax)

    ax = fig.add_subplot(grid[3, :], sharex=fig.axes[-1])
    end = max(every) if every else t0
    modes = r.get("MODE", [])
    for i, m in enumerate(modes):
        a = (m.TimeUS - t0) / 1e6
        b = (modes[i + 1].TimeUS - t0) / 1e6 if i + 1 < len(modes) else (end - t0) / 1e6
        ax.barh(1, b - a, left=a, height=0.6, color="C%d" % (m.ModeNum % 10), alpha=0.6)
        if b - a > 0.03 * ((end - t0) / 1e6):     # (a label for a span it fits in)
            ax.text(a, 1, " " + _mode_name(m.ModeNum), va="center", fontsize=8)
    for m in r.get("EV", []):
        x = (m.TimeUS - t0) / 1e6
        ax.axvline(x, color="k", lw=0.8, ls=":")
        ax.text(x, 0.2, " " + _EVENTS.get(m.Id, "event %d" % m.Id), fontsize=7, rotation=90, va="bottom")
    for m in r.get("ERR", []):
        if m.ECode:
            x = (m.TimeUS - t0) / 1e6
            ax.plot(x, 1.7, "v", color="C3", ms=8)
            ax.text(x, 1.7, "  " + _failsafe_name(m.Subsys), fontsize=7, va="center", color="C3")
    ax.set_yticks([1, 1.7])
    ax.set_yticklabels(["mode", "failsafe"])
    ax.set_ylim(0, 2.2)
    ax.set_xlabel("time since the board started (s)")
    fig.suptitle(title or "RoboRay flight log")
    fig.tight_layout()
    return fig, counts
