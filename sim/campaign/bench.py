"""What the engines cost (``roboray-sim bench campaign``).

The same campaign of short landings runs on this process, on two local
processes and on a two-worker Dask LocalCluster. For each: the time to
bring the workers up (the engine's start and one warm-up task a worker:
imports and numba's cached kernels), then the campaign's wall time, its
runs per second, and the overhead per run, the engine's core-seconds not
spent on a task's own CPU::

    overhead_per_run = (wall_s * workers - task_cpu_s) / runs

(``task_cpu_s``: each task's own thread CPU time, measured where it ran).
On a machine whose cores other jobs share, that overhead holds the time
the tasks waited for a core, so the engine's own part is given apart::

    engine_overhead_per_run = (wall_s * workers - task_wall_s) / runs

(a worker's time outside any task: pickling, queues, the scheduler, the
idle tail, and waiting for a core; ``task_wall_s`` each task's time from
start to end where it ran), and what no other job can inflate, the CPU
the engine itself spent (this process and every process it started, less
the tasks' own)::

    engine_cpu_per_run = (cpu of the process tree - task_cpu_s) / runs

The rows must be the same on every engine. One standard landing (10 m, a
target 2 m away: ``montecarlo``'s default) is flown here for its CPU time,
which with the engine's CPU gives the worked estimate of a 10,000-landing
study (100 design points x 100 draws) on N cores of a cluster whose cores
are its own::

    T(N) = ceil(10000 / N) * (cpu_per_landing_s + engine_cpu_per_run_s) + start_s

N cores as N single-threaded workers, each landing on one of them; the
overhead and start are the Dask cluster's, the engine a study of that size
runs on.
"""

from __future__ import annotations

import math
import os
import time
from typing import Callable

from roboray.sim.campaign.engines import DaskCluster, Engine, InProcess, ProcessPool, call
from roboray.sim.campaign.runner import Campaign, run

STUDY_LANDINGS = 10_000
STUDY_CORES = (2, 16, 64)


def warm(module: str) -> int:
    """A worker's first task: the campaign's module imported (a task's
    function is unpickled, so imported, before its clock starts) and the
    compiled dynamics loaded, so that the campaign measures landings."""
    import importlib
    import os

    import numpy as np

    from roboray.sim.dynamics import Model

    importlib.import_module(module)

    model = Model(None)   # the reference vehicle
    x = model.state()
    model.step(x, np.zeros((1, 4)), 0.005)
    return os.getpid()


def standard_landing_cpu_s() -> float:
    """One default ``montecarlo`` landing's CPU time, here."""
    from roboray.sim import montecarlo as MC

    draw = MC.draws(1, seed=0)[0]
    return call(MC.landing_row, 0, draw)[2]


def tree_cpu_s() -> float:
    """CPU seconds of this process and every process it started, alive."""
    import psutil

    me = psutil.Process()
    total = sum(me.cpu_times()[:2])
    for child in me.children(recursive=True):
        try:
            total += sum(child.cpu_times()[:2])
        except psutil.Error:   # gone between the listing and the reading
            pass
    return total


def measure(engine: Engine, campaign: Campaign, done: Callable[[int], None]) -> tuple[dict, list]:
    t0 = time.perf_counter()
    with engine:
        run(Campaign("warm", {}, [campaign.fn.__module__] * max(1, engine.workers), warm), engine)
        start_s = time.perf_counter() - t0
        cpu0 = tree_cpu_s()
        out = run(campaign, engine, done=done)
        engine_cpu = tree_cpu_s() - cpu0 - out.stats["task_cpu_s"]
    s = out.stats
    runs = len(campaign)
    return {
        "engine": s["engine"], "workers": s["workers"], "start_s": start_s, "wall_s": s["wall_s"],
        "runs": runs, "runs_per_s": runs / s["wall_s"], "task_cpu_s": s["task_cpu_s"],
        "task_cpu_per_run_s": s["task_cpu_s"] / runs, "task_wall_per_run_s": s["task_wall_s"] / runs,
        "overhead_per_run_s": (s["wall_s"] * s["workers"] - s["task_cpu_s"]) / runs,
        "engine_overhead_per_run_s": (s["wall_s"] * s["workers"] - s["task_wall_s"]) / runs,
        # below zero only by the clocks' resolution (a process's CPU in ticks)
        "engine_cpu_per_run_s": max(0.0, engine_cpu) / runs,
    }, out.rows


def bench(runs: int = 4, depth: float = 1.0, distance: float = 0.3, dask: bool = True,
          done: Callable[[str], None] = lambda part: None, notice: Callable[[str], None] = lambda line: None) -> dict:
    """The figures above; ``done(part)`` as each landing ends."""
    from roboray.sim import montecarlo as MC

    load0 = os.getloadavg()[0]
    campaign = MC.campaign(runs, seed=0, depth=depth, distance=distance)
    engines = [("1 local process", InProcess()), ("2 local processes", ProcessPool(2, notice=notice))]
    if dask:
        engines.append(("Dask LocalCluster, 2 workers", DaskCluster("local:2", notice=notice)))
    by_engine = {}
    reference = None
    identical = True
    for name, engine in engines:
        figures, rows = measure(engine, campaign, lambda i, name=name: done(name))
        by_engine[name] = figures
        if reference is None:
            reference = rows
        identical = identical and rows == reference
    cpu = standard_landing_cpu_s()
    done("standard landing")
    base = by_engine.get("Dask LocalCluster, 2 workers") or by_engine["2 local processes"]
    per = cpu + max(0.0, base["engine_cpu_per_run_s"])
    study = {
        "landings": STUDY_LANDINGS,
        "cpu_per_landing_s": cpu,
        "engine_cpu_per_run_s": base["engine_cpu_per_run_s"],
        "start_s": base["start_s"],
        "engine": base["engine"],
        "formula": ("T(N) = ceil(%d / N) * (cpu_per_landing_s + engine_cpu_per_run_s) + start_s"
                    % STUDY_LANDINGS),
        "by_cores": {},
    }
    for n in STUDY_CORES:
        t = math.ceil(STUDY_LANDINGS / n) * per + base["start_s"]
        study["by_cores"][str(n)] = {"seconds": t, "hours": t / 3600.0}
    return {
        "campaign": {"runs": runs, "depth_m": depth, "distance_m": distance},
        # other jobs' share of the cores: what the wall-time figures carry
        "load_average_1min": [load0, os.getloadavg()[0]],
        "engines": by_engine,
        "rows_identical": bool(identical),
        "study": study,
    }
