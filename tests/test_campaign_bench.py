"""``bench campaign``'s figures (sim/campaign/bench.py), on local processes:
the rows the same on each engine, the overheads from their definitions,
the study's estimate from its formula."""

from __future__ import annotations

import math

from roboray.sim.campaign import bench


def test_bench_figures_follow_their_formulas():
    parts: list = []
    r = bench.bench(runs=2, dask=False, done=parts.append)
    assert r["rows_identical"] is True
    assert parts.count("1 local process") == 2 and parts.count("2 local processes") == 2
    assert parts[-1] == "standard landing"
    for name, e in r["engines"].items():
        assert e["runs"] == 2 and e["workers"] == (1 if name == "1 local process" else 2)
        assert math.isclose(e["runs_per_s"], 2 / e["wall_s"])
        assert math.isclose(e["overhead_per_run_s"], (e["wall_s"] * e["workers"] - e["task_cpu_s"]) / 2)
        assert e["task_cpu_per_run_s"] > 0 and e["task_wall_per_run_s"] >= e["task_cpu_per_run_s"] * 0.99
        assert e["start_s"] > 0
    s = r["study"]
    assert s["engine"] == "2 local processes" and s["landings"] == 10000
    assert s["cpu_per_landing_s"] > r["engines"]["1 local process"]["task_cpu_per_run_s"]   # 10 m, not 1 m
    for n in bench.STUDY_CORES:
        want = math.ceil(10000 / n) * (s["cpu_per_landing_s"] + max(0.0, s["engine_cpu_per_run_s"])) + s["start_s"]
        assert math.isclose(s["by_cores"][str(n)]["seconds"], want)
