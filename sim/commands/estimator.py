"""``roboray-sim bench estimator``: the on-board estimator on the standard
scenario, its errors against truth and its cost on the real MicroPython."""

from __future__ import annotations

import argparse
import logging

import numpy as np

from roboray.sim import progress
from roboray.tools.cli import UsageError, add_json, command, emit, output_file

log = logging.getLogger("roboray.sim.estimator")

#: What the steps cost against one seed's truth, sensors and estimator
#: (measured with --seeds 1 and without --no-micropython / with
#: --compare-attitude): the weights of the progress bar.
COST_MEKF_RUN = 0.1
COST_MICROPYTHON = 0.45

#: Targets of issue 6, averaged over the seeds.
TARGETS = {
    "attitude_rms_deg": 1.0,
    "depth_rms_m": 0.01,
    "vz_rms_mps": 0.01,
    "horizontal_rms_m": 0.05,
    "micropython_bytes_per_step": 4000,
    "estimated_board_ms_per_step": 2.0,
}


def _count(text: str) -> int:
    """A whole number >= 0 (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("%r is not a whole number" % text)
    if value < 0:
        raise argparse.ArgumentTypeError("%r must be >= 0" % text)
    return value


def do_bench_estimator(args: argparse.Namespace) -> None:
    from roboray.sim import estimation

    if args.seeds < 1:
        raise UsageError("--seeds must be at least 1")
    seeds = list(range(args.seed, args.seed + args.seeds))
    if args.plot and not args.plot.lower().endswith(".png"):
        raise UsageError("--plot %r must name a .png file" % args.plot)
    if args.source not in estimation.TRUTH_SOURCES:
        raise UsageError("--source %r unknown; known: %s" % (args.source, ", ".join(sorted(estimation.TRUTH_SOURCES))))
    per_seed = []
    mekf_seed = []
    first = None
    micropython = 0.0 if args.no_micropython else COST_MICROPYTHON * (2 if args.compare_attitude else 1)
    total = len(seeds) * (1 + (COST_MEKF_RUN if args.compare_attitude else 0.0)) + micropython
    with progress.bar(args, total, "bench estimator") as bar:
        for seed in seeds:
            bar.set_postfix_str("seed %d" % seed)
            log.info("seed %d: truth, sensors, estimator", seed)
            truth = estimation.standard_truth(seed, args.source)
            logs = estimation.simulate_sensors(truth, seed)
            t_ticks, calls = estimation.schedule(truth, logs)
            config = estimation.estimator_config(logs, truth)
            est = estimation.run(config, calls, t_ticks)
            scores = estimation.score(truth, est)
            scores["seed"] = seed
            per_seed.append(scores)
            bar.update(1)
            if args.compare_attitude:
                mekf = dict(config, attitude_filter="mekf")
                mekf_seed.append(estimation.score(truth, estimation.run(mekf, calls, t_ticks)))
                bar.update(COST_MEKF_RUN)
            if first is None:
                first = (truth, logs, est, config, calls)
        keys = [k for k in per_seed[0] if k != "seed"]
        result: dict = {k: float(np.mean([s[k] for s in per_seed])) for k in keys}
        result.update(seeds=seeds, source=args.source, per_seed=per_seed)
        assert first is not None
        if not args.no_micropython:
            bar.set_postfix_str("MicroPython")
            log.info("MicroPython: cost of a step")
            result.update(estimation.micropython_costs(first[3], first[4]))
            bar.update(COST_MICROPYTHON)
        if args.compare_attitude:
            result["attitude_filters"] = _compare(args, result, mekf_seed, first, estimation, bar)
    result["targets"] = TARGETS
    result["meets_targets"] = all(result[k] <= v for k, v in TARGETS.items() if k in result)
    if args.plot:
        plot(args.plot, *first[:3])
        result["plot"] = args.plot
    emit(args, result, _text)


def _compare(args, result: dict, mekf_seed: list, first, estimation, bar=progress.QUIET) -> dict:
    """The Mahony filter the estimator flies against a multiplicative EKF
    (``shared/estimator/mekf.py``) in the same estimator: accuracy on the
    same seeds and, unless --no-micropython, floats a step."""
    out = {}
    for name, scores in (("mahony", result["per_seed"]), ("mekf", mekf_seed)):
        out[name] = {k: float(np.mean([s[k] for s in scores]))
                     for k in ("attitude_rms_deg", "tilt_rms_deg", "heading_rms_deg")}
    if not args.no_micropython:
        out["mahony"]["boxed_floats_per_step"] = result["boxed_floats_per_step"]
        out["mahony"]["by_job"] = {k: v["boxed_floats"] for k, v in result["by_job"].items()}
        bar.set_postfix_str("MicroPython, MEKF")
        log.info("MicroPython: cost of a step with the MEKF")
        costs = estimation.micropython_costs(dict(first[3], attitude_filter="mekf"), first[4])
        bar.update(COST_MICROPYTHON)
        out["mekf"]["boxed_floats_per_step"] = costs["boxed_floats_per_step"]
        out["mekf"]["by_job"] = {k: v["boxed_floats"] for k, v in costs["by_job"].items()}
        out["mekf"]["estimated_board_ms_per_step"] = costs["estimated_board_ms_per_step"]
    return out


def _text(r: dict) -> str:
    lines = ["estimator on the standard scenario, seeds %s (%s truth)" % (
        ",".join(str(s) for s in r["seeds"]), r["source"])]
    for key in ("attitude_rms_deg", "tilt_rms_deg", "heading_rms_deg", "depth_rms_m", "vz_rms_mps",
                "horizontal_rms_m", "valid_fraction"):
        target = TARGETS.get(key)
        lines.append("  %-28s %10.4g%s" % (key, r[key], "   (target < %g)" % target if target else ""))
    if "micropython_bytes_per_step" in r:
        for key in ("micropython_bytes_per_step", "boxed_floats_per_step", "estimated_board_ms_per_step",
                    "micropython_us_per_step", "board_ms_per_step_from_timing",
                    "micropython_bytes_all_arrive_cycle"):
            target = TARGETS.get(key)
            lines.append("  %-28s %10.4g%s" % (key, r[key], "   (target <= %g)" % target if target else ""))
        lines.append("  boxed floats by step kind: " + ", ".join(
            "%s %g" % (k, v["boxed_floats"]) for k, v in r["by_job"].items()))
        if r.get("boxed_floats_by_stage"):
            lines.append("  where the floats go:")
            for name, n in r["boxed_floats_by_stage"].items():
                lines.append("    %-74s %5g" % (name, n))
    for name, f in r.get("attitude_filters", {}).items():
        lines.append("  attitude filter %-6s attitude %.3g deg (tilt %.3g, heading %.3g)%s" % (
            name, f["attitude_rms_deg"], f["tilt_rms_deg"], f["heading_rms_deg"],
            ", %g boxed floats a step" % f["boxed_floats_per_step"] if "boxed_floats_per_step" in f else ""))
    lines.append("  meets targets: %s" % ("yes" if r["meets_targets"] else "NO"))
    if r.get("plot"):
        lines.append("  plot: %s" % r["plot"])
    return "\n".join(lines)


def figure(truth, logs, est):
    """Estimates against truth for one run, as a matplotlib figure: roll and
    pitch, yaw (unwrapped, so a heading through 180 deg is no jump), the
    attitude errors, depth and vertical speed, horizontal position with the
    fixes, and the navigation errors. Errors start when the estimate is
    first valid: before, the attitude filter is aligning from whatever it
    started at (up to 180 deg off), which would set the scale."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.sim import estimation
    from roboray.sim.sensors.sampling import interpolate, interpolate_quaternion
    from roboray.sim.truth import quaternion_to_matrix

    est = estimation.Estimates(*(getattr(est, f)[::4] for f in est.__dataclass_fields__))  # 25 Hz is plenty
    t = est.t
    q_true = interpolate_quaternion(truth.t, truth.quaternion, t)
    R = quaternion_to_matrix(q_true)
    roll = np.degrees(np.arctan2(R[:, 2, 1], R[:, 2, 2]))
    pitch = np.degrees(-np.arcsin(np.clip(R[:, 2, 0], -1, 1)))
    yaw_rad = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    yaw = np.degrees(np.unwrap(yaw_rad))
    # the estimate drawn where its wrapped difference puts it, on the same turn as the truth
    yaw_est = yaw + np.degrees(np.angle(np.exp(1j * (est.euler[:, 2] - yaw_rad))))
    pos = interpolate(truth.t, truth.position_ned, t)
    vel = interpolate(truth.t, truth.velocity_ned, t)
    valid = np.flatnonzero(est.status[:, 1] == 1)
    t_valid = float(t[valid[0]]) if valid.size else float(t[0])
    err = estimation.errors(truth, est, since=t_valid)
    fig, ax = plt.subplots(6, 1, figsize=(11, 17), sharex=True)
    for k, (name, true) in enumerate((("roll", roll), ("pitch", pitch))):
        line, = ax[0].plot(t, true, lw=1.0, label=name + " truth")
        ax[0].plot(t, np.degrees(est.euler[:, k]), "--", lw=1.0, color=line.get_color(), label=name + " estimate")
    ax[0].set_ylabel("roll, pitch (deg)")
    ax[0].legend(ncol=2, fontsize=8)
    ax[1].plot(t, yaw, lw=1.0, color="C2", label="yaw truth")
    ax[1].plot(t, yaw_est, "--", lw=1.0, color="C3", label="yaw estimate")
    ax[1].set_ylabel("yaw (deg, unwrapped)")
    ax[1].legend(ncol=2, fontsize=8)
    ax[2].plot(err["t"], np.degrees(err["attitude"]), lw=0.8, label="attitude error")
    ax[2].plot(err["t"], np.degrees(err["tilt"]), lw=0.8, label="tilt error")
    ax[2].plot(err["t"], np.degrees(np.abs(err["heading"])), lw=0.8, label="heading error (magnitude)")
    ax[2].set_ylabel("attitude error (deg)")
    ax[2].set_ylim(bottom=0.0)
    ax[3].plot(t, pos[:, 2], lw=1.0, label="depth truth")
    ax[3].plot(t, est.nav[:, 0], "--", lw=1.0, label="depth estimate")
    ax2 = ax[3].twinx()
    ax2.plot(t, vel[:, 2], color="C2", lw=0.8, label="v_z truth")
    ax2.plot(t, est.nav[:, 1], "--", color="C3", lw=0.8, label="v_z estimate")
    ax[3].set_ylabel("depth (m)")
    ax2.set_ylabel("v_z (m/s)")
    ax[3].invert_yaxis()
    lines, labels = ax[3].get_legend_handles_labels()
    more = ax2.get_legend_handles_labels()
    ax[3].legend(lines + more[0], labels + more[1], loc="lower center", ncol=4, fontsize=8)
    fx = logs.fixes
    for k, name in ((0, "north"), (1, "east")):
        line, = ax[4].plot(t, pos[:, k], lw=1.0, label=name + " truth")
        ax[4].plot(t, est.nav[:, 2 + k], "--", lw=1.0, color=line.get_color(), label=name + " estimate")
        ax[4].plot(fx.t, fx.north if k == 0 else fx.east, ".", ms=3, color=line.get_color(),
                   label=name + " fixes (at measurement time)")
    ax[4].set_ylabel("position (m)")
    ax[4].legend(ncol=3, fontsize=8)
    ax[5].plot(err["t"], 100 * err["depth"], lw=0.8, label="depth error (cm)")
    ax[5].plot(err["t"], 100 * err["vz"], lw=0.8, label="v_z error (cm/s)")
    ax[5].plot(err["t"], 100 * np.hypot(err["north"], err["east"]), lw=0.8, label="horizontal error (cm)")
    ax[5].set_ylabel("navigation error (cm, cm/s)")
    ax[5].set_xlabel("time (s), released at %g s" % estimation.HOLD_S)
    for a in ax:
        a.axvline(estimation.HOLD_S, color="k", lw=0.5, alpha=0.5)
        a.grid(alpha=0.3)
    for a in ax[:2]:
        a.axvspan(float(t[0]), t_valid, color="0.9", lw=0)
    for a in (ax[2], ax[5]):
        a.axvspan(float(t[0]), t_valid, color="0.9", lw=0, label="aligning, not yet valid (no errors drawn)")
        lo, hi = a.dataLim.intervaly
        a.set_ylim(top=lo + 1.45 * (hi - lo))   # room for the legend above the curves
        a.legend(ncol=2, fontsize=8, loc="upper right")
    fig.suptitle("On-board estimator, standard scenario (estimates dashed)")
    fig.tight_layout(rect=(0, 0, 1, 0.985))
    return fig


def plot(path: str, truth, logs, est) -> None:
    """``figure`` written to ``path`` with 64 colours: plenty for line
    plots, and the file a fifth the size."""
    import io

    import matplotlib.pyplot as plt
    from PIL import Image

    fig = figure(truth, logs, est)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=72)
    plt.close(fig)
    buf.seek(0)
    Image.open(buf).convert("RGB").quantize(colors=64).save(path, optimize=True)


def register(sub, bench) -> None:
    p = command(bench, "estimator", do_bench_estimator,
                "the on-board estimator on the standard 60 s scenario: errors against truth, "
                "heap bytes and time of a step on MicroPython")
    p.add_argument("--seed", type=_count, default=0, help="first seed (default 0)")
    p.add_argument("--seeds", type=_count, default=10, help="how many seeds to average (default 10)")
    p.add_argument("--source", choices=("dynamics", "kinematic"), default="dynamics",
                   help="where the truth comes from: dynamics (the vehicle model's descent, the default) or "
                        "kinematic (a prescribed trajectory); roboray.sim.estimation.TRUTH_SOURCES")
    p.add_argument("--no-micropython", action="store_true", help="skip the MicroPython cost figures")
    p.add_argument("--compare-attitude", action="store_true",
                   help="also run the multiplicative EKF in place of the Mahony filter (accuracy and cost)")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="draw estimates against truth for the first seed")
    add_json(p)
