"""``roboray-sim sweep``: a design sweep over vehicle-file parameters and
controller gains (``sim/sweep.py``), run as one campaign."""

from __future__ import annotations

import argparse
import contextlib
import os

from roboray.sim import progress
from roboray.sim.campaign.options import add_engine_options, at_least, results_file, seed
from roboray.sim.commands.control import add_landing_options
from roboray.tools.cli import UsageError, add_json, check_target, command, emit, output_file, positive


#: A campaign's tasks are made and held at once (a grid grows as N^k).
MAX_TASKS = 1_000_000


def _parameter(text: str):
    from roboray.sim.sweep import parse_parameter

    try:
        return parse_parameter(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


_count = at_least(2, "%r: at least 2 points are a sweep")
_runs = at_least(1)


def do_sweep(args: argparse.Namespace) -> None:
    import json

    from roboray.sim import campaign as C
    from roboray.sim import sweep as S
    from roboray.sim.commands.dynamics import vehicle_params
    from roboray.sim.flight import FlightSpec
    from roboray.tools.jsonround import rounded

    check_target(args.distance, 0.0, args.depth, FlightSpec.start_depth)   # every bearing is as far
    base = vehicle_params(args)
    parameters = args.param
    try:
        S.check_parameters(parameters, base)
    except ValueError as exc:
        raise UsageError(str(exc))
    levels = args.grid if args.grid is not None or args.lhs is not None else 5
    if all(p.fixed for p in parameters):
        raise UsageError("every --param holds one value: give at least one a range LO:HI to sweep")
    count = S.point_count(parameters, levels, args.lhs)
    if count * (args.runs + 1) > MAX_TASKS:
        raise UsageError("%d points x (%d landings + 1) is %d tasks, more than the %d one campaign holds: fewer "
                         "levels or parameters, or --lhs" % (count, args.runs, count * (args.runs + 1), MAX_TASKS))
    points = S.latin_hypercube(parameters, args.lhs, args.seed) if args.lhs is not None else S.grid(parameters, levels)
    sampling = "lhs" if args.lhs is not None else "grid"
    try:
        S.check_points(base, parameters, points)
    except ValueError as exc:
        raise UsageError(str(exc))
    # the file's name, not its path: the digest of its numbers is what a
    # resume must match, from whichever folder the command runs
    vehicle = os.path.basename(args.vehicle) if args.vehicle else "reference"
    from roboray.sim.commands.radio import campaign_link

    engine = C.engine_from_args(args)
    campaign = S.campaign(base, parameters, points, args.runs, seed=args.seed, depth=args.depth,
                          distance=args.distance, controller=args.controller, truth=args.truth,
                          envelope_step_deg=args.envelope_step, vehicle=vehicle + ("" if args.water == "fresh"
                                                                                    else ", sea water"),
                          sampling=sampling, link=campaign_link(args))
    notice = C.stderr_notice()
    with contextlib.ExitStack() as stack, C.cli_errors():
        bar = [progress.QUIET]

        def started(total: int, present: int) -> None:
            if present:
                notice("%s: %d of %d tasks already there, %d to run" % (args.results, present, total,
                                                                         total - present))
            if present < total:
                bar[0] = stack.enter_context(progress.bar(args, total - present, "sweep", unit="tasks"))

        outcome = C.run(campaign, engine, results=args.results, done=lambda index: bar[0].update(1),
                        notice=notice, started=started)
    stats = outcome.stats
    result = {"vehicle": vehicle, "vehicle_file": args.vehicle,
              "water": args.water, "parameters": [p.spec() for p in parameters], "sampling": sampling,
              "sampling_size": levels if sampling == "grid" else args.lhs,
              "seed": args.seed, "runs_per_point": args.runs, "depth_m": args.depth, "distance_m": args.distance,
              "release_depth_m": FlightSpec.start_depth, "controller": args.controller,
              "estimator": "truth" if args.truth else "board estimator", "model_error": S.MC.MODEL_ERROR,
              "envelope_step_deg": args.envelope_step}
    result["base_values"] = S.base_values(base, parameters)
    result.update(S.summary(outcome.rows, parameters, args.depth))
    result.update(tasks=stats["tasks"], tasks_run=stats["ran"], tasks_resumed=stats["present"],
                  engine=stats["engine"], workers=stats.get("workers", engine.workers), wall_time_s=stats["wall_s"],
                  task_cpu_s=stats["task_cpu_s"], worker_restarts=stats["restarts"])
    if args.results:
        result["results_file"] = args.results
        result["summary_file"] = C.summary_path(args.results)
    if args.plot:
        S.plot(result, args.plot)
        result["plot"] = args.plot
    if args.results:
        with open(result["summary_file"], "w") as f:
            json.dump(rounded(result), f, indent=1, sort_keys=True)
            f.write("\n")
    emit(args, result, _text)


def _text(r: dict) -> str:
    def f(v, fmt="%.3f"):
        return fmt % v if v is not None else "-"

    names = [p[0] for p in r["parameters"]]
    lines = ["design sweep of the %s vehicle (%s, %d points), %d landings a point from %g m onto targets %g m away "
             "(%s controller, %s):" % (r["vehicle"], r["sampling"], len(r["points"]), r["runs_per_point"],
                                       r["depth_m"], r["distance_m"], r["controller"], r["estimator"])]
    head = "%-5s " % "point" + " ".join("%12s" % n[:12] for n in names) + \
        " %8s %8s %8s %7s %8s %8s %8s %7s %8s" % ("fall m/s", "fold m/s", "glide", "reach m", "p50 m", "p95 m",
                                                    "worst m", "landed", "tilt deg")
    lines.append(head)
    for p in r["points"]:
        lines.append("%-5s " % ("%d%s" % (p["point"], "*" if p["pareto"] else ""))
                     + " ".join("%12.5g" % p["values"][n] for n in names)
                     + " %8s %8s %8s %7s %8s %8s %8s %7s %8s" % (
                         f(p["fall_speed_mps"]), f(p["fold_descent_mps"]), f(p["best_glide_ratio"]),
                         f(p["reach_m"], "%.2f"), f(p["landing_error_p50_m"]), f(p["landing_error_p95_m"]),
                         f(p["landing_error_worst_m"]), "%d/%d" % (p["landed"], p["runs"]),
                         f(p["max_tilt_deg"], "%.1f")))
    lines.append("* on the Pareto front (no other point reaches farther with a smaller p95 landing error)")
    lines.append("%s: %d tasks run in %.0f s%s" % (r["engine"], r["tasks_run"], r["wall_time_s"],
                                                   ", %d taken from %s" % (r["tasks_resumed"], r["results_file"])
                                                   if r["tasks_resumed"] else ""))
    if r.get("results_file"):
        lines.append("rows: %s, summary: %s" % (r["results_file"], r["summary_file"]))
    if r.get("plot"):
        lines.append("plot: %s" % r["plot"])
    return "\n".join(lines)


def register(sub, bench) -> None:
    from roboray.sim.commands.dynamics import add_vehicle_options
    from roboray.sim.sweep import ENVELOPE_STEP_DEG

    p = command(sub, "sweep", do_sweep, "design sweep: trims, reach and landing statistics over vehicle-file "
                                        "parameters and controller gains")
    p.add_argument("--param", type=_parameter, action="append", required=True, metavar="NAME=LO:HI",
                   help="a VehicleParams field (e.g. wing_height=0.12:0.20, total_mass) or a controller gain "
                        "(e.g. CTL_TGT_K=1:4) and its range; NAME=VALUE holds it at VALUE; repeat for more")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--grid", type=_count, metavar="N", help="N levels per parameter, every combination "
                                                              "(default 5)")
    how.add_argument("--lhs", type=_count, metavar="N", help="N Latin-hypercube points (seeded by --seed)")
    p.add_argument("--runs", type=_runs, default=20, help="Monte Carlo landings per point (default 20)")
    add_engine_options(p, "design points and landings")
    p.add_argument("--seed", type=seed, default=0, help="seed of the Latin hypercube and the draws (default 0)")
    add_landing_options(p)
    p.add_argument("--envelope-step", type=positive, default=ENVELOPE_STEP_DEG, metavar="DEG",
                   help="grid step of each point's envelope search, deg (default %g, refined locally)"
                   % ENVELOPE_STEP_DEG)
    add_vehicle_options(p)
    from roboray.sim.commands.radio import add_link_options

    add_link_options(p, ground=False)
    p.add_argument("--results", type=results_file, metavar="FILE.csv|FILE.parquet",
                   help="one row a task (kind design or landing, the point's values, its trims or the landing), "
                        "written as each ends, and the summary beside it (FILE.summary.json); run again, the same "
                        "command continues from the rows there")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot the trade-off the sweep found")
    add_json(p)
