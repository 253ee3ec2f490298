"""``roboray-sim fly``, ``montecarlo``, ``thesis-control`` and ``bench control``."""

from __future__ import annotations

import argparse
import contextlib
import os
import time

import numpy as np

from roboray.sim import progress
from roboray.sim.campaign.options import add_engine_options, at_least, results_file, seed
from roboray.tools.cli import UsageError, add_json, check_target, command, emit, floats, number, output_file, positive

#: Heap bytes a cascade step may allocate on MicroPython (issue 7).
STEP_HEAP_LIMIT = 3200


def _pair(name: str):
    return lambda text: floats(text, 2, name)


def _velocity(text: str) -> list[float]:
    """``VN,VE`` or ``VN,VE,VD`` (m/s; VD <= 0: no descent-speed command)."""
    parts = floats(text, None, "--velocity")
    if len(parts) not in (2, 3):
        raise argparse.ArgumentTypeError("--velocity %r needs VN,VE or VN,VE,VD" % text)
    return parts + [0.0] * (3 - len(parts))


_count = at_least(1)


def add_landing_options(p: argparse.ArgumentParser) -> None:
    """The Monte Carlo landing's own options (montecarlo, sweep)."""
    p.add_argument("--depth", type=positive, default=10.0, help="bottom depth, m (default 10)")
    p.add_argument("--distance", type=positive, default=2.0, help="target distance from the release, m (default 2)")
    p.add_argument("--controller", choices=("cascade", "backstepping"), default="cascade",
                   help="cascade (the flight controller, the default) or backstepping (the thesis's, ch. 4)")
    p.add_argument("--truth", action="store_true", help="true states instead of the estimator's")


# ------------------------------------------------------------------ fly
def do_fly(args: argparse.Namespace) -> None:
    from roboray.sim.flight import FlightSpec, fly

    try:
        spec = FlightSpec(controller=args.controller, mode=args.mode, target=tuple(args.target), depth=args.depth,
                          velocity=tuple(args.velocity), attitude_deg=tuple(args.attitude), truth=args.truth,
                          seed=args.seed, heading_deg=args.heading, max_flight_s=args.max_time)
    except ValueError as exc:
        raise UsageError(str(exc))
    if args.mode == "target":
        check_target(spec.target[0], spec.target[1], spec.depth, spec.start_depth)
    start = time.perf_counter()
    with progress.bar(args, spec.depth - spec.start_depth, "fly") as bar:
        shown = [spec.start_depth]

        def depth(d: float) -> None:
            if d > shown[0] + 0.05:   # the bar measures the fall from the release to the bottom
                bar.update(min(d, spec.depth) - shown[0])
                shown[0] = min(d, spec.depth)

        flight = fly(spec, depth=depth)
    result = dict(flight.metrics)
    result["wall_time_s"] = time.perf_counter() - start
    if args.plot:
        plot_flight(flight, args.plot)
        result["plot"] = args.plot
    emit(args, result, _fly_text)


def _fly_text(r: dict) -> str:
    lines = ["%s controller, %s mode, %s" % (r["controller"], r["mode"], r["estimator"])]
    if r["mode"] == "target":
        if r["landing_error_m"] is not None:
            lines.append("landed %.3f m from the target (%.2f, %.2f) after %.1f s" % (
                r["landing_error_m"], r["target"][0], r["target"][1], r["descent_time_s"]))
        else:
            lines.append("did not reach the bottom in %.1f s" % r["descent_time_s"])
    if r.get("velocity_rms_error_mps") is not None:
        lines.append("velocity error %.4f m/s RMS %s (mean %.3f, %.3f m/s)" % (
            r["velocity_rms_error_mps"], "after settling" if r["settling_time_s"] is not None else
            "over the second half (never settled)", *r["velocity_mean_mps"]))
    if r.get("descent_speed_error") is not None:
        lines.append("descent speed %.3f m/s (%+.1f %% of the command)" % (
            r["descent_speed_mps"], 100 * r["descent_speed_error"]))
    if r.get("attitude_rms_error_deg") is not None:
        lines.append("attitude error %.2f deg RMS (second half)" % r["attitude_rms_error_deg"])
    settle = r.get("settling_time_s")
    lines.append("settling %s, descent %.1f s, max tilt %.1f deg, servo travel %.0f deg" % (
        "%.1f s" % settle if settle is not None else "never", r["descent_time_s"], r["max_tilt_deg"],
        r["servo_travel_deg"]))
    if r.get("plot"):
        lines.append("plot: %s" % r["plot"])
    return "\n".join(lines)


def plot_flight(flight, path: str, title: str | None = None) -> None:
    """``flight_figure`` written to ``path``."""
    import matplotlib.pyplot as plt

    fig = flight_figure(flight, title)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def flight_figure(flight, title: str | None = None):
    """Top view with the target, depth, horizontal velocity with its set
    point, and the wings, against time, as a matplotlib figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.sim.plots import WING_STYLES, WINGS, plot_series

    spec = flight.spec
    t = flight.t
    fig = plt.figure(figsize=(11, 8))
    grid = fig.add_gridspec(3, 2, width_ratios=(1.0, 1.25))
    ax = fig.add_subplot(grid[:, 0])
    ax.plot(flight.position[:, 1], flight.position[:, 0], lw=1.5, label="true track")
    ax.plot(flight.estimate_nav[:, 3], flight.estimate_nav[:, 2], "--", lw=1.0, label="estimated")
    ax.plot([0.0], [0.0], "ko", label="release")
    if spec.mode == "target":
        ax.add_patch(plt.Circle((spec.target[1], spec.target[0]), 0.25, color="C2", alpha=0.25,
                                label="target, 0.25 m"))
        ax.plot([spec.target[1]], [spec.target[0]], "g+", ms=12)
    if flight.landing_position is not None:
        ax.plot([flight.landing_position[1]], [flight.landing_position[0]], "rx", ms=10, label="landed")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax = fig.add_subplot(grid[0, 1])
    ax.plot(t, flight.position[:, 2], label="depth")
    ax.axhline(spec.depth, color="k", lw=0.8, ls=":", label="bottom")
    ax.invert_yaxis()
    ax.set_ylabel("depth (m)")
    ax.legend(loc="best", fontsize=8)
    ax = fig.add_subplot(grid[1, 1])
    if spec.mode == "attitude":
        # attitude mode holds roll and pitch; its velocity set points are unused zeros, not a goal
        from roboray.sim.dynamics import quat_to_rot

        r = quat_to_rot(flight.quaternion)
        ax.plot(t, np.degrees(np.arctan2(r[:, 2, 1], r[:, 2, 2])), label="roll")
        ax.plot(t, np.degrees(-np.arcsin(np.clip(r[:, 2, 0], -1.0, 1.0))), label="pitch")
        ax.plot(t[[0, -1]], [spec.attitude_deg[0]] * 2, "--", lw=0.8, color="C0", label="set point roll")
        ax.plot(t[[0, -1]], [spec.attitude_deg[1]] * 2, "--", lw=0.8, color="C1", label="set point pitch")
        ax.set_ylabel("attitude (deg)")
    else:
        ax.plot(t, flight.velocity[:, 0], label="v north")
        ax.plot(t, flight.velocity[:, 1], label="v east")
        if flight.setpoints.size:
            ax.plot(t, flight.setpoints[:, 0], "--", lw=0.8, color="C0", label="set point north")
            ax.plot(t, flight.setpoints[:, 1], "--", lw=0.8, color="C1", label="set point east")
        ax.set_ylabel("horizontal velocity (m/s)")
    ax.legend(loc="best", fontsize=8, ncol=2)
    ax = fig.add_subplot(grid[2, 1])
    plot_series(ax, t, np.degrees(flight.wings).T, WINGS, WING_STYLES)   # wings at one angle: one line
    ax.set_ylabel("wing angle (deg)")
    ax.set_xlabel("time since release (s)")
    ax.legend(loc="best", fontsize=8, ncol=4)
    m = flight.metrics
    if title is None:
        title = "%s controller, %s mode (%s)" % (spec.controller, spec.mode, m["estimator"])
        if m.get("landing_error_m") is not None:
            title += ": landed %.2f m from the target" % m["landing_error_m"]
    fig.suptitle(title)
    fig.tight_layout()
    # the right column's labels in one line, clear of the widest tick numbers
    fig.align_ylabels(fig.axes[1:])
    return fig


# ------------------------------------------------------------ montecarlo
def do_montecarlo(args: argparse.Namespace) -> None:
    import json

    from roboray.sim import campaign as C
    from roboray.sim import montecarlo as MC
    from roboray.sim.flight import FlightSpec
    from roboray.tools.jsonround import rounded

    check_target(args.distance, 0.0, args.depth, FlightSpec.start_depth)   # every bearing is as far
    if args.workers is None and args.cluster is None:   # no process started for nothing to do
        args.workers = min(args.runs, os.cpu_count() or 1)
    engine = C.engine_from_args(args)
    from roboray.sim.commands.radio import campaign_link

    link = campaign_link(args)
    try:
        campaign = MC.campaign(args.runs, seed=args.seed, depth=args.depth, distance=args.distance,
                               controller=args.controller, truth=args.truth, link=link, vehicle_file=args.vehicle,
                               params_file=args.params)
    except (OSError, ValueError) as exc:   # the vehicle or parameter file: its own one-line reason
        raise UsageError("montecarlo: %s" % exc)
    notice = C.stderr_notice()
    with contextlib.ExitStack() as stack, C.cli_errors():
        bar = [progress.QUIET]

        def started(total: int, present: int) -> None:
            if present:
                notice("%s: %d of %d runs already there, %d to run" % (args.results, present, total, total - present))
            if present < total:   # the bar counts what is left to run: its ETA is this run's
                bar[0] = stack.enter_context(progress.bar(args, total - present, "montecarlo", unit="flights"))

        outcome = C.run(campaign, engine, results=args.results, done=lambda index: bar[0].update(1),
                        notice=notice, started=started)
    stats = outcome.stats
    result = MC.summary(outcome.rows)
    result.update(workers=stats.get("workers", engine.workers), engine=stats["engine"], wall_time_s=stats["wall_s"],
                  runs_run=stats["ran"], runs_resumed=stats["present"], worker_restarts=stats["restarts"],
                  depth_m=args.depth, distance_m=args.distance, controller=args.controller,
                  model_error=MC.MODEL_ERROR, estimator="truth" if args.truth else "board estimator",
                  **MC.link_params(link))
    result["meets_target"] = bool(result["landing_error_p95_m"] is not None and result["landing_error_p95_m"] <= 0.5
                                  and result["landed"] == result["runs"])
    if args.results:
        result["results_file"] = args.results
        result["summary_file"] = C.summary_path(args.results)
        with open(result["summary_file"], "w") as f:
            json.dump(rounded(result), f, indent=1, sort_keys=True)
            f.write("\n")
    if args.plot:
        _plot_landings(outcome.rows, args.plot, result)
        result["plot"] = args.plot
    emit(args, result, _mc_text)


def _mc_text(r: dict) -> str:
    def f(v):
        return "%.3f" % v if v is not None else "-"

    return "\n".join([
        "%d target landings (%s controller, %s, targets %.1f m away, bottom %.0f m, model errors +-%d %%), "
        "%d landed" % (r["runs"], r["controller"], r["estimator"], r["distance_m"], r["depth_m"],
                       round(100 * r["model_error"]), r["landed"]),
        "landing error p50 %s m, p95 %s m, worst %s m (target p95 <= 0.5 m: %s)" % (
            f(r["landing_error_p50_m"]), f(r["landing_error_p95_m"]), f(r["landing_error_worst_m"]),
            "met" if r["meets_target"] else "NOT met"),
        "%s: %d runs in %.0f s%s" % (r["engine"], r["runs_run"], r["wall_time_s"],
                                     ", %d taken from %s" % (r["runs_resumed"], r["results_file"])
                                     if r["runs_resumed"] else ""),
    ] + (["rows: %s, summary: %s" % (r["results_file"], r["summary_file"])] if r.get("results_file") else [])
      + (["plot: %s" % r["plot"]] if r.get("plot") else []))


def landings_figure(results: list, summary: dict):
    """Landing points (``sim/montecarlo.py``'s rows) relative to their targets, with the requirement (p95
    within 0.5 m) and what these landings achieved, as a matplotlib figure:
    left at the requirement's scale, right close up."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 5.6))
    east, north = [], []
    for r in results:
        if r.get("landing_north_m") is None:
            continue
        east.append(r["landing_east_m"] - r["target_east_m"])
        north.append(r["landing_north_m"] - r["target_north_m"])
    p95 = summary.get("landing_error_p95_m")
    worst = summary.get("landing_error_worst_m") or (max(np.hypot(east, north)) if east else 0.0)
    for ax, lim in ((axes[0], max(0.6, 1.1 * worst)), (axes[1], max(0.02, 1.25 * worst))):
        ax.plot(east, north, "b.", ms=5, label="landings (%d of %d runs)" % (len(east), len(results)))
        ax.add_patch(plt.Circle((0, 0), 0.5, fill=False, ls="--", color="C3", label="required: p95 within 0.5 m"))
        if p95:
            ax.add_patch(plt.Circle((0, 0), p95, fill=False, ls="-", lw=1.5, color="C1", zorder=3,
                                    label="p95 of these landings, %.3f m" % p95))
        ax.plot([0], [0], "g+", ms=14, mew=2, zorder=4, label="target")
        ax.set_aspect("equal")
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_xlabel("east of the target (m)")
        ax.set_ylabel("north of the target (m)")
        ax.grid(True, alpha=0.3)
    axes[0].set_title("against the requirement", fontsize=10)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[1].set_title("close up", fontsize=10)
    fig.suptitle("%d landings: p50 %.3f m, p95 %.3f m" % (summary["runs"], summary["landing_error_p50_m"] or 0.0,
                                                          p95 or 0.0))
    fig.tight_layout()
    return fig


def _plot_landings(results: list, path: str, summary: dict) -> None:
    import matplotlib.pyplot as plt

    fig = landings_figure(results, summary)
    fig.savefig(path, dpi=90)
    plt.close(fig)


# --------------------------------------------------------- thesis-control
def do_thesis_control(args: argparse.Namespace) -> None:
    from roboray.sim.analysis.authority import authority
    from roboray.sim.thesis_runs import thesis_run

    start = time.perf_counter()
    with progress.bar(args, 3 + len(args.kv2), "thesis-control", unit="runs") as bar:
        def thesis(spin: float, **kw):
            out = thesis_run(spin, duration=args.duration, **kw)
            bar.update(1)
            return out

        uncontrolled = thesis(0.5, control=False)
        run1 = thesis(0.5)
        still = thesis(0.0, control=False)
        runs2 = {kv2: thesis(0.0, kv2=kv2) for kv2 in args.kv2}

    def moved(run, base) -> dict:
        d = run["position"][-1] - base["position"][-1]
        return {"along_y_c_m": float(d[1]), "across_m": float(d[0]), "asked_m": 0.3 * float(run["t"][-1]),
                "wing_range_deg": [float(np.degrees(run["wings"].min())), float(np.degrees(run["wings"].max()))],
                "wing_travel_deg": float(np.degrees(np.abs(np.diff(run["wings"], axis=0)).sum()))}

    result = {
        "duration_s": args.duration,
        "run1_spin_0.5": moved(run1, uncontrolled),
        "run2_no_spin": {("kv2=%g" % k): moved(r, still) for k, r in runs2.items()},
        "authority": authority(),
        "wall_time_s": time.perf_counter() - start,
    }
    if args.plot:
        _plot_thesis(args.plot, uncontrolled, run1, still, runs2)
        result["plot"] = args.plot
    emit(args, result, _thesis_text)


def _thesis_text(r: dict) -> str:
    a = r["run1_spin_0.5"]
    lines = ["sec. 5.2.1 (spin 0.5 rad/s, K = I): moved %+.3f m along +y_c in %.0f s relative to the uncontrolled "
             "fall (asked: %.1f m); wings %.1f..%.1f deg" % (a["along_y_c_m"], r["duration_s"], a["asked_m"],
                                                            *a["wing_range_deg"])]
    for name, b in r["run2_no_spin"].items():
        lines.append("sec. 5.2.2 (no spin, %s): moved %+.3f m along +y_c (asked %.1f m); wings %.1f..%.1f deg"
                     % (name, b["along_y_c_m"], b["asked_m"], *b["wing_range_deg"]))
    lines.append("why: " + r["authority"]["explanation"])
    if r.get("plot"):
        lines.append("plot: %s" % r["plot"])
    return "\n".join(lines)


def _plot_thesis(path: str, uncontrolled, run1, still, runs2) -> None:
    import matplotlib.pyplot as plt

    fig = thesis_figure(uncontrolled, run1, still, runs2)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def thesis_figure(uncontrolled, run1, still, runs2):
    """Sec. 5.2's runs (cf. figs. 5.12-5.15), as a matplotlib figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.sim.plots import WING_STYLES, WINGS

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    ax = axes[0, 0]
    ax.plot(uncontrolled["t"], uncontrolled["velocity"][:, 0], lw=0.8, label="north, uncontrolled")
    ax.plot(uncontrolled["t"], uncontrolled["velocity"][:, 1], lw=0.8, label="east (+y_c), uncontrolled")
    ax.plot(run1["t"], run1["velocity"][:, 0], "--", lw=0.8, label="north, controlled")
    ax.plot(run1["t"], run1["velocity"][:, 1], "--", lw=0.8, label="east (+y_c), controlled")
    ax.set_ylabel("velocity (m/s)")
    ax.set_title("sec. 5.2.1: spin 0.5 rad/s, K = I (cf. fig. 5.12)", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1, 0]
    for k in range(4):
        ax.plot(run1["t"], np.degrees(run1["wings"][:, k]), lw=0.8, ls=WING_STYLES[k], label=WINGS[k])
    ax.set_ylabel("wing angle (deg), cf. fig. 5.13")
    ax.set_xlabel("time (s)")
    ax.legend(fontsize=7, ncol=4)
    ax = axes[0, 1]
    ax.plot(still["t"], 0.3 * still["t"], "k:", lw=0.8, label="asked: 0.3 m/s along +y_c")
    for kv2, run in runs2.items():
        ax.plot(run["t"], run["position"][:, 1] - still["position"][:, 1], lw=1.0, label="K_v2 = %g" % kv2)
    ax.set_ylabel("+y_c displacement (m)")
    ax.set_title("sec. 5.2.2: no spin, K re-weighted (cf. fig. 5.14)", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1, 1]
    for kv2, run in runs2.items():
        ax.plot(run["t"], np.degrees(run["wings"][:, 1]), lw=0.8, label="wing 2, K_v2 = %g" % kv2)
    ax.set_ylabel("wing 2 (deg), cf. fig. 5.15")
    ax.set_xlabel("time (s)")
    ax.legend(fontsize=7)
    fig.suptitle("The thesis's backstepping controller in the model (true states)")
    fig.tight_layout()
    return fig


# --------------------------------------------------------- bench control
def do_bench_control(args: argparse.Namespace) -> None:
    from roboray.sim import controller_costs as F

    parts = ["MicroPython"] + list(F.BENCH_FLIGHTS) + ["backstepping", ""]
    upcoming = iter(parts[1:])
    with progress.bar(args, len(parts) - 1, "bench control") as bar:
        bar.set_postfix_str(parts[0])

        def done(part: str) -> None:
            bar.set_postfix_str(next(upcoming), refresh=False)   # what runs next
            bar.update(1)

        result = F.micropython_costs(steps=args.steps, done=done)
    result["limit_bytes"] = STEP_HEAP_LIMIT
    result["within_limit"] = bool(result["cascade"]["heap_bytes_per_step"] <= STEP_HEAP_LIMIT)
    emit(args, result, _bench_text)


def _bench_text(r: dict) -> str:
    c = r["cascade"]
    b = r["backstepping"]
    lines = ["cascade step on %s: %d heap bytes at most (%g boxed floats; limit %d: %s), %.0f us here, "
             "about %.2f ms on an RP2350" % (r["interpreter"], c["heap_bytes_per_step"], c["boxed_floats_per_step"],
                                            r["limit_bytes"], "ok" if r["within_limit"] else "EXCEEDED",
                                            c["us_per_step"], c["board_ms_per_step"])]
    for mode, m in c["by_mode"].items():
        lines.append("  %-16s %5d bytes, %.0f us" % (mode, m["heap_bytes"], m["us_per_step"]))
    lines.append("backstepping step: %d heap bytes, %.0f us here, about %.1f ms on an RP2350"
                 % (b["heap_bytes_per_step"], b["us_per_step"], b["board_ms_per_step"]))
    return "\n".join(lines)


def register(sub, bench) -> None:
    p = command(sub, "fly", do_fly, "a closed-loop flight: dynamics, sensors, board estimator and controller")
    p.add_argument("--controller", choices=("cascade", "backstepping"), default="cascade",
                   help="cascade (the flight controller) or backstepping (the thesis's, ch. 4)")
    p.add_argument("--mode", choices=("velocity", "target", "attitude"), default="target",
                   help="what the controller holds: target (land on --target, the default), velocity (hold "
                        "--velocity) or attitude (hold --attitude)")
    p.add_argument("--target", type=_pair("--target"), default=[2.0, 0.0], metavar="N,E",
                   help="target mode: metres north and east of the release point, within the reach (best glide "
                        "ratio 0.49 times the depth; default 2,0)")
    p.add_argument("--depth", type=positive, default=10.0, metavar="D", help="bottom depth, m (default 10)")
    p.add_argument("--velocity", type=_velocity, default=[0.10, 0.0, 0.0], metavar="VN,VE[,VD]",
                   help="velocity mode: m/s north, east, and descent speed (VD <= 0: none; default 0.10,0)")
    p.add_argument("--attitude", type=_pair("--attitude"), default=[0.0, 0.0], metavar="ROLL,PITCH",
                   help="attitude mode: roll and pitch, degrees (default 0,0)")
    p.add_argument("--heading", type=number, default=0.0, metavar="DEG",
                   help="heading at release (wing 1 from north), deg (default 0)")
    p.add_argument("--truth", action="store_true", help="feed the controller the true state, not the estimator's")
    p.add_argument("--seed", type=seed, default=0, help="sensor noise seed (default 0)")
    p.add_argument("--max-time", type=positive, default=60.0, metavar="S",
                   help="longest flight after release, s (default 60)")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot the track, depth, velocity and wings")
    add_json(p)

    p = command(sub, "montecarlo", do_montecarlo, "target landings under random model and sensor errors")
    p.add_argument("--runs", type=_count, default=100, help="number of flights (default 100)")
    add_engine_options(p, "flights")
    p.add_argument("--seed", type=seed, default=0, help="seed of the draws (default 0)")
    add_landing_options(p)
    from roboray.sim.commands.radio import add_link_options

    p.add_argument("--water", choices=("fresh", "sea"), default="fresh",
                   help="fresh (default) or sea water: sea brings the radio link (fixes stop a decimetre down)")
    add_link_options(p, ground=False)
    p.add_argument("--vehicle", metavar="FILE.py",
                   help="the truth's vehicle file, the model errors drawn around it (default: the reference)")
    p.add_argument("--params", metavar="FILE.parm",
                   help="the firmware's parameter file (roboray-ground param save's format): the flights use its "
                        "descent model (DR_*, e.g. from roboray-sim identify --params-out) and controller gains (CTL_*)")
    p.add_argument("--results", type=results_file, metavar="FILE.csv|FILE.parquet",
                   help="one row a run (its drawn errors and outcomes), written as each lands, and the summary "
                        "beside it (FILE.summary.json); run again, the same command continues from the rows there")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot the landing points around their targets")
    add_json(p)

    p = command(sub, "thesis-control", do_thesis_control,
                "the thesis's sec. 5.2 runs of its backstepping controller, and why it cannot steer")
    p.add_argument("--duration", type=positive, default=60.0, help="simulated seconds per run (default 60)")
    p.add_argument("--kv2", type=lambda t: floats(t, None, "--kv2"), default=[1.0, 10.0, 100.0],
                   metavar="K1,K2,...", help="K weights on the y_c velocity for sec. 5.2.2 (default 1,10,100)")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot the runs (cf. figs. 5.12-5.15)")
    add_json(p)

    p = command(bench, "control", do_bench_control, "heap bytes and time of a controller step on MicroPython")
    p.add_argument("--steps", type=_count, default=200, help="steps measured per mode (default 200)")
    add_json(p)
