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


def plot(data: bytes, out_png: str, title: str = "") -> dict[str, int]:
    """Draw the overview into ``out_png``; records per type."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = read(data)
    counts = {k: len(v) for k, v in r.items()}
    if not any(k in r for k in ("ATT", "EST", "BARO")):
        raise ValueError("no ATT, EST or BARO records: not a RoboRay flight log, or an empty one")
    every = [m.TimeUS for v in r.values() for m in v if hasattr(m, "TimeUS")]
    t0 = 0      # TimeUS counts from the board's start, as MAVExplorer shows it

    def t(ms: list[Any]) -> list[float]:
        return [(m.TimeUS - t0) / 1e6 for m in ms]

    fig = plt.figure(figsize=(11, 10))
    grid = fig.add_gridspec(4, 2, height_ratios=(3, 2, 2, 1))
    ax = fig.add_subplot(grid[0:2, 0])
    est = r.get("EST", [])
    if est:
        ax.plot([m.PE for m in est], [m.PN for m in est], color="C0", label="vehicle's estimate (EST)")
        last = est[-1]
        if last.TN or last.TE:
            ax.plot(last.TE, last.TN, "x", ms=12, mew=2, color="C3", label="target")
        ax.plot(last.PE, last.PN, "o", mfc="none", ms=10, color="C2", label="last position")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("top view")
    if ax.lines:
        ax.legend(fontsize=8, loc="best")

    ax = fig.add_subplot(grid[0, 1])
    if est:
        ax.plot(t(est), [m.PD for m in est], color="C0", label="estimate (EST)")
    baro = r.get("BARO", [])
    if baro:
        ax.plot(t(baro), [-m.Alt for m in baro], ".", ms=2, color="C1", label="pressure sensor (BARO)")
    ax.invert_yaxis()
    ax.set_ylabel("depth (m)")
    ax.set_title("depth")
    if ax.lines:
        ax.legend(fontsize=8)

    ax = fig.add_subplot(grid[1, 1], sharex=fig.axes[1])
    att = r.get("ATT", [])
    for k in ("Roll", "Pitch"):
        ax.plot(t(att), [getattr(m, k) for m in att], label=k.lower())
    ax.set_ylabel("attitude (deg)")
    ax2 = ax.twinx()
    # (dots: a heading near north jumps between 0 and 360)
    ax2.plot(t(att), [m.Yaw for m in att], ".", ms=1.5, color="C2", label="yaw (right)")
    ax2.set_ylabel("yaw (deg)")
    ax2.set_ylim(0, 360)
    lines = ax.get_lines() + ax2.get_lines()
    if lines:
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, loc="upper right")

    ax = fig.add_subplot(grid[2, :])
    wing = r.get("WING", [])
    for i in range(1, 5):
        ax.plot(t(wing), [getattr(m, "Cmd%d" % i) for m in wing], label="wing %d" % i)
    ax.set_ylabel("wing command (deg)")
    if ax.lines:
        ax.legend(fontsize=8, loc="upper right", ncol=4)

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
    raised = [m for m in r.get("ERR", []) if m.ECode]
    for m in raised:
        ax.plot((m.TimeUS - t0) / 1e6, 1.7, "v", color="C3", ms=8)
    ax.set_yticks([1, 1.7])
    ax.set_yticklabels(["mode", "failsafe"])
    ax.set_ylim(0, 2.2)
    ax.set_xlabel("time since the board started (s)")
    fig.suptitle(title or "RoboRay flight log")
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)
    plt.close(fig)
    return counts
