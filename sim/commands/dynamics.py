"""``roboray-sim vehicle``, ``drop`` and ``bench dynamics``."""

from __future__ import annotations

import argparse
import csv
import math
import os
import time

import numpy as np

from roboray.sim import progress
from roboray.tools.cli import CliError, UsageError, add_json, command, emit, floats, number, output_file, positive


# ------------------------------------------------------------ shared options
def wings_deg(text: str) -> list[float]:
    """``S1,S2,S3,S4`` in degrees, each within the servo travel 0..90."""
    values = floats(text, 4, "--wings")
    for v in values:
        if not 0.0 <= v <= 90.0:
            raise argparse.ArgumentTypeError("--wings %r: each angle must be within 0..90 deg" % text)
    return values


def vector3(name: str):
    return lambda text: floats(text, 3, name)


def add_vehicle_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--vehicle", metavar="FILE.py",
                   help="vehicle parameter file (a copy of sim/vehicles/reference.py); default: the reference")
    p.add_argument("--water", choices=("fresh", "sea"), default="fresh",
                   help="fluid density: fresh 1000 kg/m^3 (default) or sea 1025 kg/m^3")


def vehicle_params(args: argparse.Namespace):
    from roboray.sim.vehicle import load_params

    try:
        params = load_params(args.vehicle)
    except (ValueError, SyntaxError, NameError, TypeError) as exc:
        raise CliError("cannot load vehicle %s: %s" % (args.vehicle, exc))
    return params.with_water(args.water)


# ------------------------------------------------------------ vehicle
def do_vehicle(args: argparse.Namespace) -> None:
    from roboray.sim.vehicle import Vehicle

    try:
        vehicle = Vehicle(vehicle_params(args))
    except ValueError as exc:
        raise CliError("vehicle: %s" % exc)
    props = vehicle.properties(np.radians(args.wings))

    def text(p: dict) -> str:
        rows = [
            ("wings", "%s deg" % ", ".join("%g" % w for w in p["wings_deg"])),
            ("mass m_v", "%.4f kg" % p["mass"]),
            ("displaced volume", "%.1f cm^3 (%s water, rho %g)" % (p["displaced_volume"] * 1e6, args.water, p["rho"])),
            ("net weight", "%.4f N (a_w = %.4f m/s^2)" % (p["net_weight"], p["a_w"])),
            ("ell (CB to CG)", "%.2f mm" % (p["ell"] * 1e3)),
            ("m1, m2, m3", "%.4f, %.4f, %.4f kg" % (p["m1"], p["m2"], p["m3"])),
            ("I1, I2, I3", "%.3e, %.3e, %.3e kg m^2" % (p["I1"], p["I2"], p["I3"])),
            ("d1, d2", "%.3e, %.3e kg m" % (p["d1"], p["d2"])),
            ("areas", "centre %.1f cm^2, wing %.1f cm^2" % (p["area_center"] * 1e4, p["area_wing"] * 1e4)),
            ("terminal speed", "%.4f m/s straight down" % p["terminal_speed"]),
        ]
        return "\n".join("%-18s %s" % r for r in rows)

    emit(args, props, text)


# ------------------------------------------------------------ drop
def do_drop(args: argparse.Namespace) -> None:
    from roboray.sim.dynamics import Bottom, Current, Model, quat_from_axis_angle
    from roboray.sim.simulate import simulate

    params = vehicle_params(args)
    bottom = Bottom(depth=args.depth) if args.depth is not None else None
    current = Current(velocity=tuple(args.current)) if args.current is not None else None
    try:
        model = Model(params, current=current, bottom=bottom)
    except ValueError as exc:
        raise CliError("vehicle: %s" % exc)
    wings = np.radians(args.wings)
    v0 = args.v0 if args.v0 is not None else [0.0, 0.0, 0.0]
    attitude = quat_from_axis_angle([0.0, 1.0, 0.0], math.radians(args.tilt_deg))
    x0 = model.state(attitude=attitude, velocity=v0, rates=args.omega0 or (0.0, 0.0, 0.0), wings=wings)
    run = simulate(model, x0, args.duration, dt=args.dt, stop_when_landed=bottom is not None)
    vel = run.velocity_ned()[:, 0]
    tail = max(1, int(round(min(5.0, 0.1 * run.t[-1]) / run.dt)))
    drift = float(np.hypot(*run.x[-1, 0, :2]))
    from roboray.sim.truth import quaternion_to_matrix

    tilt = np.degrees(np.arccos(np.clip(quaternion_to_matrix(run.x[:, 0, 3:7])[:, 2, 2], -1, 1)))
    result = {
        "wings_deg": list(args.wings),
        "duration": float(run.t[-1]),
        "steady_descent_speed": float(vel[-tail:, 2].mean()),
        "horizontal_drift": drift,
        "final_position_ned": run.x[-1, 0, :3].tolist(),
        "max_tilt_deg": float(tilt.max()),
        "final_spin_rate": float(run.nu[-1, 0, 5]),
        "landed_at_s": None if np.isnan(run.landed_at[0]) else float(run.landed_at[0]),
        "terminal_speed_analytic": model.vehicles[0].terminal_speed(wings),
        "wall_time_s": run.wall_time_s,
        "real_time_factor": float(run.t[-1] / run.wall_time_s) if run.wall_time_s > 0 else None,
        "integrator": "rk4, dt %g s" % run.dt,
    }
    if args.csv:
        write_csv(args.csv, run)
        result["csv"] = args.csv
    if args.plot:
        from roboray.sim.plots import plot_drop

        plot_drop(run, args.plot, "drop: wings %s deg, tilt %g deg" % (",".join("%g" % w for w in args.wings),
                                                                        args.tilt_deg))
        result["plot"] = args.plot

    def text(r: dict) -> str:
        lines = ["descent speed %.4f m/s (analytic straight-down %.4f m/s)" % (
                     r["steady_descent_speed"], r["terminal_speed_analytic"]),
                 "drift %.3f m after %.1f s, max tilt %.2f deg" % (r["horizontal_drift"], r["duration"], r["max_tilt_deg"])]
        if r["landed_at_s"] is not None:
            lines.append("touched the bottom at %.2f s" % r["landed_at_s"])
        lines.append("%.2f s wall, %.0fx real time" % (r["wall_time_s"], r["real_time_factor"] or 0))
        return "\n".join(lines)

    emit(args, result, text)


def write_csv(path: str, run) -> None:
    vel = run.velocity_ned()[:, 0]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "north", "east", "down", "qw", "qx", "qy", "qz", "v_north", "v_east", "v_down",
                    "V1", "V2", "V3", "W1", "W2", "W3", "s1_deg", "s2_deg", "s3_deg", "s4_deg",
                    "fx_imu", "fy_imu", "fz_imu", "depth_sensor"])
        for k in range(len(run.t)):
            x = run.x[k, 0]
            w.writerow(["%.4f" % run.t[k]] + ["%.9g" % v for v in (
                *x[0:7], *vel[k], *run.nu[k, 0], *np.degrees(x[13:17]), *run.specific_force_imu[k, 0],
                run.depth_sensor[k, 0])])


# ------------------------------------------------------------ bench
#: Seconds of one core each part takes at dt 0.01 s: the progress bar's weights.
COST_LOAD_S = 1.0           #: loading the compiled kernels
COST_SINGLE_S = 1.2e-3      #: a simulated second of one vehicle
COST_BATCH_S = 5e-4         #: a simulated second of a vehicle in a batch, one core


def threads(text: str) -> int:
    """A whole number of threads, at least 1."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("--threads %r: not a whole number" % text)
    if n < 1:
        raise argparse.ArgumentTypeError("--threads %r: at least 1" % text)
    return n


def _batch_run(batch, xb, args, every: int, nthreads: int):
    """One timed batch run on ``nthreads`` of numba's threads: the run and
    the CPU seconds every thread of the process spent on it."""
    import numba

    from roboray.sim.simulate import simulate

    numba.set_num_threads(nthreads)
    cpu = time.process_time()
    run = simulate(batch, xb, args.batch_duration, dt=args.dt, record_every=every)
    return run, time.process_time() - cpu


def do_bench_dynamics(args: argparse.Namespace) -> None:
    import numba

    from roboray.sim import kernels
    from roboray.sim.dynamics import Model, quat_from_axis_angle
    from roboray.sim.simulate import simulate

    cap = numba.config.NUMBA_NUM_THREADS
    nthreads = cap if args.threads is None else args.threads
    if nthreads > cap:
        raise UsageError("--threads %d: numba runs at most %d threads here (NUMBA_NUM_THREADS)" % (nthreads, cap))
    if args.batch < 1:
        raise UsageError("--batch %d: at least 1 vehicle" % args.batch)
    counts = [1] if nthreads == 1 else [1, nthreads]
    dt = args.dt
    steps = 0.01 / dt
    single_cost = COST_SINGLE_S * args.duration * steps
    batch_cost = COST_BATCH_S * args.batch * args.batch_duration * steps * args.repeat
    total = COST_LOAD_S + single_cost + sum(batch_cost / n for n in counts)
    with progress.bar(args, total, "bench dynamics") as bar:
        single = Model(None)
        wings = np.radians([45.0, 30.0, 60.0, 20.0])
        x0 = single.state(attitude=quat_from_axis_angle([0, 1, 0], 0.17), velocity=(0.05, 0, 0.3), wings=wings)
        batch = Model(None, n=args.batch)
        xb = np.repeat(x0, args.batch, axis=0)
        every = max(1, int(round(args.batch_record / dt)))
        # The first calls compile the kernels, or load them from numba's
        # cache: timed apart, never in a figure.
        t0 = time.perf_counter()
        simulate(single, x0, 1.0, dt=dt)
        simulate(batch, xb, 2 * dt * every, dt=dt, record_every=every)
        warm = time.perf_counter() - t0
        cached = kernels.advance_from_cache()
        bar.update(COST_LOAD_S)
        bar.set_postfix_str("one vehicle")
        numba.set_num_threads(1)
        run = simulate(single, x0, args.duration, dt=dt)
        bar.update(single_cost)
        figures, finals = {}, {}
        for n in counts:
            bar.set_postfix_str("a batch of %d on %d thread%s" % (args.batch, n, "s" if n > 1 else ""))
            _batch_run(batch, xb, args, every, n)        # the thread pool started and warm
            rates, cpus = [], []
            for _ in range(args.repeat):
                brun, cpu = _batch_run(batch, xb, args, every, n)
                rates.append(args.batch * args.batch_duration / brun.wall_time_s)
                cpus.append(cpu / (args.batch * args.batch_duration))
                bar.update(batch_cost / n / args.repeat)
            figures[n] = (max(rates), float(np.median(rates)), min(cpus))
            finals[n] = brun.x[-1]
        numba.set_num_threads(cap)
    best, median, cpu = figures[nthreads]
    result = {
        "integrator": "rk4 (servo solved exactly over each step)",
        "dt_s": dt,
        "simulated_s": args.duration,
        "real_time_factor": args.duration / run.wall_time_s,
        "batch_size": args.batch,
        "batch_simulated_s": args.batch_duration,
        "batch_recorded_every_s": every * dt,
        "threads": nthreads,
        "threading_layer": numba.threading_layer(),
        "repeats": args.repeat,
        "vehicle_seconds_per_second": best,
        "vehicle_seconds_per_second_median": median,
        "vehicle_seconds_per_second_1_thread": figures[1][0],
        "vehicle_seconds_per_second_1_thread_median": figures[1][1],
        "speedup": best / figures[1][0],
        "cpu_us_per_vehicle_second": cpu * 1e6,
        "identical_across_threads": all(np.array_equal(finals[1], f) for f in finals.values()),
        "compile_s": warm,
        "kernels_from_cache": cached,
        "load_average_1min": os.getloadavg()[0],
    }

    def text(r: dict) -> str:
        return "\n".join([
            "one vehicle: %.0fx real time" % r["real_time_factor"],
            "batch of %d: %.0f vehicle-s/s on %d thread%s (median %.0f), %.0f on 1 (median %.0f): %.2fx" % (
                r["batch_size"], r["vehicle_seconds_per_second"], r["threads"], "s" if r["threads"] > 1 else "",
                r["vehicle_seconds_per_second_median"], r["vehicle_seconds_per_second_1_thread"],
                r["vehicle_seconds_per_second_1_thread_median"], r["speedup"]),
            "%.0f us of CPU a vehicle-second; %s threading layer; results identical across thread counts: %s" % (
                r["cpu_us_per_vehicle_second"], r["threading_layer"], r["identical_across_threads"]),
            "kernels %s in %.2f s (not in the figures); load average %.2f" % (
                "loaded from cache" if r["kernels_from_cache"] else "compiled", r["compile_s"],
                r["load_average_1min"]),
        ])

    emit(args, result, text)


def register(sub, bench) -> None:
    p = command(sub, "vehicle", do_vehicle, "properties of a wing configuration (masses, ell, inertia, terminal speed)")
    p.add_argument("--wings", type=wings_deg, default=[0.0] * 4, metavar="S1,S2,S3,S4",
                   help="wing deflections in degrees, 0 = flat, 90 = folded up (default 0,0,0,0)")
    add_vehicle_options(p)
    add_json(p)

    p = command(sub, "drop", do_drop, "an uncontrolled descent with fixed wings")
    p.add_argument("--wings", type=wings_deg, default=[0.0] * 4, metavar="S1,S2,S3,S4",
                   help="wing deflections in degrees (default 0,0,0,0)")
    p.add_argument("--duration", type=positive, default=60.0, metavar="T", help="simulated seconds (default 60)")
    p.add_argument("--v0", type=vector3("--v0"), metavar="V1,V2,V3",
                   help="initial body velocity, m/s (default at rest)")
    p.add_argument("--omega0", type=vector3("--omega0"), metavar="W1,W2,W3",
                   help="initial body rates, rad/s (default 0,0,0)")
    p.add_argument("--tilt-deg", type=number, default=0.0, help="initial tilt about y_c, degrees (default 0)")
    p.add_argument("--depth", type=positive, help="put the tank bottom at this depth, m (default: none)")
    p.add_argument("--current", type=vector3("--current"), metavar="N,E,D", help="uniform water current, m/s")
    p.add_argument("--dt", type=positive, default=0.01, help="integration step, s (default 0.01)")
    p.add_argument("--csv", type=output_file, metavar="FILE", help="write the trajectory as CSV")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot velocities, rates, positions and wings")
    add_vehicle_options(p)
    add_json(p)

    p = command(bench, "dynamics", do_bench_dynamics,
                "speed of the dynamics: one vehicle, and a batch on 1 and on N threads")
    p.add_argument("--dt", type=positive, default=0.01, help="integration step, s (default 0.01)")
    p.add_argument("--duration", type=positive, default=60.0, help="simulated seconds, one vehicle (default 60)")
    p.add_argument("--batch", type=int, default=1000, help="vehicles in the batch (default 1000)")
    p.add_argument("--batch-duration", type=positive, default=5.0, help="simulated seconds, batch (default 5)")
    p.add_argument("--batch-record", type=positive, default=0.1,
                   help="the batch keeps one state every this many seconds (default 0.1)")
    p.add_argument("--threads", type=threads, metavar="N",
                   help="threads for the batch (default: numba's, one a core); 1 thread is measured too")
    p.add_argument("--repeat", type=int, default=3, metavar="K",
                   help="timed batch runs on each thread count: the best and the median are reported (default 3)")
    add_json(p)
