"""``roboray-sim bench campaign``: what the campaign engines cost here."""

from __future__ import annotations

import argparse

from roboray.sim import progress
from roboray.tools.cli import add_json, command, emit, positive


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("%r is not a whole number" % text)
    if value < 2 or value % 2:
        raise argparse.ArgumentTypeError("%r must be an even number, at least 2 (two workers share them)" % text)
    return value


def do_bench_campaign(args: argparse.Namespace) -> None:
    from roboray.sim.campaign import bench, cli_errors, stderr_notice
    from roboray.tools.cli import check_target

    check_target(args.distance, 0.0, args.depth, 0.1)
    engines = 3 if not args.no_dask else 2
    with progress.bar(args, engines * args.runs + 1, "bench campaign", unit="landings") as bar, cli_errors():
        def done(part: str) -> None:
            bar.set_postfix_str(part, refresh=False)
            bar.update(1)

        result = bench.bench(runs=args.runs, depth=args.depth, distance=args.distance, dask=not args.no_dask,
                             done=done, notice=stderr_notice())
    emit(args, result, _text)


def _text(r: dict) -> str:
    c = r["campaign"]
    lines = ["%d landings from %g m onto targets %g m away, on each engine (rows identical: %s; load average "
             "%.1f, %.1f)" % (c["runs"], c["depth_m"], c["distance_m"], "yes" if r["rows_identical"] else "NO",
                              *r["load_average_1min"])]
    for name, e in r["engines"].items():
        lines.append("  %-29s %6.3f runs/s, overhead %5.2f s a run (outside tasks %5.2f s, engine CPU %5.3f s), "
                     "start %5.1f s; a task %.2f s CPU in %.2f s"
                     % (name, e["runs_per_s"], e["overhead_per_run_s"], e["engine_overhead_per_run_s"],
                        e["engine_cpu_per_run_s"], e["start_s"], e["task_cpu_per_run_s"], e["task_wall_per_run_s"]))
    s = r["study"]
    lines.append("a %d-landing study (100 design points x 100 draws): %s" % (s["landings"], s["formula"]))
    lines.append("  cpu_per_landing_s %.2f (a 10 m landing here), engine_cpu_per_run_s %.3f and start_s %.1f (%s)"
                 % (s["cpu_per_landing_s"], s["engine_cpu_per_run_s"], s["start_s"], s["engine"]))
    for n, t in s["by_cores"].items():
        lines.append("  on %3s cores: %8.0f s = %6.2f h" % (n, t["seconds"], t["hours"]))
    return "\n".join(lines)


def register(sub, bench) -> None:
    p = command(bench, "campaign", do_bench_campaign,
                "runs per second and overhead of the campaign engines; a 10,000-landing study's time on N cores")
    p.add_argument("--runs", type=_count, default=4, help="short landings on each engine, even (default 4)")
    p.add_argument("--depth", type=positive, default=1.0, help="their bottom depth, m (default 1)")
    p.add_argument("--distance", type=positive, default=0.3, help="their target distance, m (default 0.3)")
    p.add_argument("--no-dask", action="store_true", help="local processes only (no Dask LocalCluster)")
    add_json(p)
