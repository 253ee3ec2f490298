"""What ``identify`` writes: the fitted vehicle file, the firmware's
parameter file, the plot.

The vehicle file is the input's text, unchanged, with a block at its end
that says where the values came from and replaces the fitted fields of
its ``VEHICLE`` (``dataclasses.replace``): the builder's comments and
parts table stay, every command takes it (``--vehicle``), and a second
identification starts from it. Unidentifiable parameters keep the input's
values. The parameter file is ArduPilot's format (``ground/paramfile.py``),
which ``roboray-ground param load`` and MAVProxy read.
"""

from __future__ import annotations

import dataclasses
import datetime

import numpy as np

from roboray.ground import paramfile
from roboray.sim.identify.fit import Result
from roboray.sim.vehicle import VehicleParams


def changed_fields(base: VehicleParams, fitted: VehicleParams) -> dict:
    out = {}
    for f in dataclasses.fields(base):
        a, b = getattr(base, f.name), getattr(fitted, f.name)
        if a != b:
            out[f.name] = b
    return out


def vehicle_text(source_text: str, result: Result, logs: list) -> str:
    """The input vehicle file's text with the fitted values appended."""
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = ["", "", "# ---- roboray-sim identify, %s, from %s" % (when, ", ".join(l.path for l in logs)),
             "# fitted (1 sigma); the fields below are set from these:"]
    for n, p in result.params_json().items():
        if p["identifiable"]:
            lines.append("#   %-18s %.6g +- %.2g %s (was %.6g)" % (n, p["value"], p["sigma"], p["unit"], p["initial"]))
        else:
            lines.append("#   %-18s not identifiable from these logs (sigma %.2g %s): kept at %.6g"
                         % (n, p["sigma"], p["unit"], p["initial"]))
    lines.append("import dataclasses as _identify_dataclasses  # noqa: E402")
    lines.append("")
    lines.append("VEHICLE = _identify_dataclasses.replace(")
    lines.append("    VEHICLE,")
    for name, value in changed_fields(result.base, result.fitted).items():
        lines.append("    %s=%r," % (name, value))
    lines.append(")")
    return source_text.rstrip("\n") + "\n".join(lines) + "\n"


def write_vehicle(path: str, source_path: str, result: Result, logs: list) -> None:
    with open(source_path, encoding="utf-8") as f:
        text = f.read()
    with open(path, "w", encoding="utf-8") as f:
        f.write(vehicle_text(text, result, logs))


def write_params(path: str, descent: dict, logs: list) -> None:
    """The DR_* parameters as a parameter file, with a comment of their source."""
    head = "# RoboRay descent model (DR_*) fitted by roboray-sim identify to the vehicle of %s\n" \
           "# (standard flights %s, residual %.4f m/s); load: roboray-ground param load FILE\n" \
           % (", ".join(l.path for l in logs), descent["seeds"], descent["residual_mps"])
    body = paramfile.format_lines((n, "%.6g" % v) for n, v in descent["params"].items())
    paramfile.parse(head + body, path)    # what we write is what param load reads
    with open(path, "w", encoding="utf-8") as f:
        f.write(head + body)


def plot(path: str, result: Result) -> None:
    """Depth and tilt of each segment: logged, the input vehicle, the fitted."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.sim.dynamics import quat_to_rot
    from roboray.sim.identify.shooting import CHUNK_S

    sh = result.flown["shooter"]
    flown = result.flown["flown"]
    fig, (ax_d, ax_t) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for k, s in enumerate(sh.segs):
        t = s.t0 + np.arange(flown["depths"].shape[0]) * CHUNK_S
        keep = t <= s.t1 + 1e-9
        m = sh.meas[k]
        tb, d = m["depth"]
        ax_d.plot(s.t0 + tb, d, "k.", ms=3, label="log (BARO)" if k == 0 else None)
        ax_d.plot(t[keep], flown["depths"][keep, 0, k], "C1", label="fitted model" if k == 0 else None)
        R = quat_to_rot(flown["states"][keep, 0, k, 3:7])
        ta, g = m["tilt"]
        off = result.tilt_offsets[s.log]
        ax_t.plot(s.t0 + ta, np.degrees(np.arcsin(np.clip(g[:, 0] - off[0], -1, 1))), "k.", ms=2,
                  label="log (ATT), -gx" if k == 0 else None)
        ax_t.plot(t[keep], np.degrees(np.arcsin(np.clip(R[:, 2, 0], -1, 1))), "C1",
                  label="fitted, -gx" if k == 0 else None)
        ax_t.plot(s.t0 + ta, np.degrees(np.arcsin(np.clip(g[:, 1] - off[1], -1, 1))), ".", color="0.5", ms=2,
                  label="log (ATT), gy" if k == 0 else None)
        ax_t.plot(t[keep], np.degrees(np.arcsin(np.clip(R[:, 2, 1], -1, 1))), "C0",
                  label="fitted, gy" if k == 0 else None)
        for ax in (ax_d, ax_t):
            ax.axvline(s.t0, color="0.85", lw=0.8)
    ax_d.invert_yaxis()
    ax_d.set_ylabel("depth of the port, m")
    ax_t.set_ylabel("gravity in body axes, deg")
    ax_t.set_xlabel("time since boot, s")
    ax_d.legend(loc="lower left", fontsize=8)
    ax_t.legend(loc="lower left", fontsize=8)
    seen = [n for n in result.names if n not in result.unidentifiable]
    fig.suptitle("identify: %s" % ", ".join("%s %.4g" % (n, result.value[n]) for n in seen))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
