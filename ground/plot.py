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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = series(data)
    counts = {k: len(v[0]) for k, v in s.items()}
    if not any(counts.values()):
        raise ValueError("no ATTITUDE, LOCAL_POSITION_NED or NAMED_VALUE_FLOAT messages in the log")
    fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    ax = axes[0]
    ax.plot(*s["depth"], label="depth")
    ax.set_ylabel("depth (m)")
    ax.invert_yaxis()
    ax = axes[1]
    for k in ("roll", "pitch", "yaw"):
        ax.plot(*s[k], label=k)
    ax.set_ylabel("attitude (deg)")
    ax = axes[2]
    for k, label in (("vn", "north"), ("ve", "east"), ("vd", "down")):
        ax.plot(*s[k], label=label)
    ax.set_ylabel("velocity (m/s)")
    ax = axes[3]
    for i in range(1, 5):
        ax.plot(*s["wing%d" % i], label="wing %d" % i)
    ax.set_ylabel("wing angle (deg)")
    ax.set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        if ax.lines:
            ax.legend(loc="upper right", fontsize="small")
    fig.suptitle(title or "RoboRay telemetry")
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)
    plt.close(fig)
    return counts
