"""Figures: what the thesis's figures 5.1-5.15 show, from our runs."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # files only; no display needed

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_drop(run, path: str, title: str, vehicle: int = 0) -> None:
    """Body velocities, NED velocities, rates, position and wings against time."""
    t = run.t
    nu = run.nu[:, vehicle]
    vel = run.velocity_ned()[:, vehicle]
    pos = run.x[:, vehicle, :3]
    fig, axes = plt.subplots(5, 1, figsize=(8, 12), sharex=True)
    ax = axes[0]
    for k, name in enumerate(("V1 (x_c)", "V2 (y_c)", "V3 (z_c)")):
        ax.plot(t, nu[:, k], label=name)
    ax.set_ylabel("body velocity, m/s")
    ax.legend(loc="best", fontsize=8)
    ax = axes[1]
    for k, name in enumerate(("north", "east", "down")):
        ax.plot(t, vel[:, k], label=name)
    ax.set_ylabel("NED velocity, m/s")
    ax.legend(loc="best", fontsize=8)
    ax = axes[2]
    for k, name in enumerate(("p (x_c)", "q (y_c)", "r (z_c)")):
        ax.plot(t, nu[:, 3 + k], label=name)
    ax.set_ylabel("body rates, rad/s")
    ax.legend(loc="best", fontsize=8)
    ax = axes[3]
    ax.plot(t, pos[:, 0], label="north")
    ax.plot(t, pos[:, 1], label="east")
    ax2 = ax.twinx()
    ax2.plot(t, pos[:, 2], "k--", label="depth")
    ax2.set_ylabel("depth, m")
    ax2.invert_yaxis()
    ax.set_ylabel("horizontal, m")
    ax.legend(loc="upper left", fontsize=8)
    ax = axes[4]
    for k in range(4):
        ax.plot(t, np.degrees(run.x[:, vehicle, 13 + k]), label="s%d" % (k + 1))
    ax.set_ylabel("wings, deg")
    ax.set_xlabel("time, s")
    ax.legend(loc="best", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
