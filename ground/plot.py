"""``log plot``: depth, attitude, velocities and wing angles of a tlog against time."""

from __future__ import annotations

import math
from typing import Any

from roboray.ground import tlog


def series(data: bytes) -> dict[str, Any]:
    """Time series (s from the first record) decoded with the board codec."""
    dec = tlog.Decoder()
    out: dict[str, Any] = {k: ([], []) for k in (
        "depth", "roll", "pitch", "yaw", "vn", "ve", "vd", "wing1", "wing2", "wing3", "wing4")}
    t0 = None
    deg = 180.0 / math.pi
    for t_us, frame in tlog.records(data):
        m = dec.decode(frame)
        if not m["crc_ok"]:
            continue
        t0 = t_us if t0 is None else t0
        t = (t_us - t0) / 1e6
        kind = m["mavpackettype"]
        if kind == "ATTITUDE":
            for k in ("roll", "pitch", "yaw"):
                out[k][0].append(t)
                out[k][1].append(m[k] * deg)
        elif kind == "LOCAL_POSITION_NED":
            for k, f in (("vn", "vx"), ("ve", "vy"), ("vd", "vz")):
                out[k][0].append(t)
                out[k][1].append(m[f])
        elif kind == "NAMED_VALUE_FLOAT":
            name = m["name"]
            key = "depth" if name == "depth_m" else name[:5] if name.startswith("wing") else None
            if key in out:
                out[key][0].append(t)
                out[key][1].append(m["value"])
    return out


def plot(data: bytes, out_png: str, title: str = "") -> dict[str, int]:
    """Draw the four panels into ``out_png``; samples per series."""
    import matplotlib.pyplot as plt

    fig, counts = figure(data, title)
    fig.savefig(out_png, dpi=100)
    plt.close(fig)
    return counts


def figure(data: bytes, title: str = "") -> tuple[Any, dict[str, int]]:
    """The four panels as a matplotlib figure, and the samples per series.
    Lines break where the radio brought nothing (a dive loses the link
    below a few metres) and where the heading wraps through +-180 degrees."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.ground.series import broken

    s = series(data)
    counts = {k: len(v[0]) for k, v in s.items()}
    if not any(counts.values()):
        raise ValueError("no ATTITUDE, LOCAL_POSITION_NED or NAMED_VALUE_FLOAT messages in the log")
    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    ax = axes[0]
    ax.plot(*broken(*s["depth"]), label="depth")
    ax.set_ylabel("depth (m)")
    ax.invert_yaxis()
    ax = axes[1]
    for k in ("roll", "pitch", "yaw"):
        ax.plot(*broken(*s[k], wrap=360.0 if k == "yaw" else None), label=k)
    ax.set_ylabel("attitude (deg)")
    ax = axes[2]
    for k, label in (("vn", "north"), ("ve", "east"), ("vd", "down")):
        ax.plot(*broken(*s[k]), label=label)
    ax.set_ylabel("velocity (m/s)")
    ax = axes[3]
    for i in range(1, 5):
        ax.plot(*broken(*s["wing%d" % i]), label="wing %d" % i)
    ax.set_ylabel("wing angle (deg)")
    ax.set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        if ax.lines:
            # beside the panel: over it, the legend hid the data
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize="small")
    fig.suptitle(title or "RoboRay telemetry")
    fig.tight_layout()
    return fig, counts
