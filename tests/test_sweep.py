"""Design sweeps (sim/sweep.py, roboray-sim sweep): parameters, sampling,
the per-point tasks, the rows on one and two workers, the summary and the plot."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from roboray.sim import montecarlo as MC
from roboray.sim import sweep as S
from roboray.sim.campaign import read_rows
from roboray.sim.vehicle import load_params


def sim(*args: str, timeout: float = 900):
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


def refused(capsys, *args: str) -> tuple[int, str]:
    """The command's exit status and stderr, run in this process (a usage
    mistake stops before any task runs)."""
    from roboray.sim.cli import main

    try:
        code = main(["sweep", *args])
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    assert out.out == ""
    return code, out.err


# ------------------------------------------------------------ parameters
@pytest.mark.parametrize("param, says", [
    ("wing_span_m=0.08:0.14", "no parameter 'wing_span_m'; vehicle: rho, g, cd"),
    ("CTL_NOPE=1:2", "controller: CTL_FOLD_DEG"),
    ("total_mass=1.2:1.0", "low end 1.2 is above its high end 1"),
    ("total_mass=0.9:x", "is not a number or a range"),
    ("total_mass=1:2:3", "one range"),
    ("total_mass", "give NAME=LO:HI"),
    ("CTL_TGT_K=0:3", "CTL_TGT_K takes 1 to 10"),
    ("wing_height=-0.1:0.2", "wing_height must be > 0"),
    ("total_mass=0.2:1.2", "floats: its weight in water is"),
])
def test_bad_parameter_is_one_line_and_exit_2(capsys, param, says):
    code, err = refused(capsys, "--param", param, "--grid", "2", "--runs", "1", "--workers", "1")
    assert code == 2
    assert says in err
    assert len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("args, says", [
    (["--param", "total_mass=1.0:1.1", "--grid", "1"], "at least 2 points"),
    (["--param", "total_mass=1.0:1.1", "--grid", "3", "--lhs", "3"], "not allowed with argument"),
    (["--param", "total_mass=1.1"], "give at least one a range"),
    (["--param", "total_mass=1.0:1.1", "--param", "total_mass=1.0:1.2"], "given twice"),
    (["--param", "total_mass=1.0:1.1", "--distance", "9"], "beyond the reach"),
    (["--param", "total_mass=1.0:1.1", "--vehicle", "no-such-vehicle.py"], "no such file"),
    (["--param", "total_mass=1.0:1.1", "--param", "cd=1:1.3", "--param", "CTL_TGT_K=1:3", "--grid", "101"],
     "1030301 points x (1 landings + 1) is 2060602 tasks"),
])
def test_other_mistakes_are_one_line(capsys, args, says):
    code, err = refused(capsys, *args, "--runs", "1", "--workers", "1")
    assert code in (1, 2) and says in err, err
    assert code == (1 if "no such" in says else 2)
    assert len(err.strip().splitlines()) == 1, err


def test_every_vehicle_field_and_controller_gain_is_a_parameter():
    base = load_params()
    for name in S.vehicle_names():
        p = S.parse_parameter("%s=%r" % (name, getattr(base, name)))
        assert p.fixed and not p.controller
    for name, (default, lo, hi) in S.controller_defs().items():
        p = S.parse_parameter("%s=%r:%r" % (name, lo, hi))
        assert p.controller and (p.low, p.high) == (lo, hi)
    assert "imu_position" not in S.vehicle_names()   # three numbers, not one


# ------------------------------------------------------------ sampling
def test_grid_is_every_combination_of_evenly_spaced_levels_ends_included():
    params = [S.Parameter("wing_height", 0.12, 0.20), S.Parameter("CTL_TGT_K", 1.0, 3.0),
              S.Parameter("cd", 1.2, 1.2)]
    points = S.grid(params, 3)
    assert len(points) == 9 == S.point_count(params, 3, None)
    assert sorted({p[0] for p in points}) == pytest.approx([0.12, 0.16, 0.20])
    assert sorted({p[1] for p in points}) == [1.0, 2.0, 3.0]
    assert {p[2] for p in points} == {1.2}
    assert len(set(points)) == 9
    assert points == S.grid(params, 3)
    assert points[0] == (0.12, 1.0, 1.2) and points[1] == (0.12, 2.0, 1.2)   # the last parameter fastest


def test_latin_hypercube_has_one_sample_per_stratum_per_parameter_and_is_seeded():
    params = [S.Parameter("wing_height", 0.12, 0.20), S.Parameter("total_mass", 0.7, 1.3),
              S.Parameter("CTL_TGT_K", 1.0, 4.0), S.Parameter("cd", 1.2, 1.2)]
    n = 7
    points = S.latin_hypercube(params, n, seed=4)
    assert len(points) == n
    for k, p in enumerate(params[:3]):
        x = np.array([pt[k] for pt in points])
        assert np.all((x >= p.low) & (x <= p.high))
        strata = np.floor((x - p.low) / (p.high - p.low) * n).astype(int)
        assert sorted(strata) == list(range(n)), p.name   # one in each of the n strata
    assert {pt[3] for pt in points} == {1.2}
    assert S.latin_hypercube(params, n, seed=4) == points
    other = S.latin_hypercube(params, n, seed=5)
    assert other != points
    with pytest.raises(ValueError):
        S.latin_hypercube(params, 1)


# ------------------------------------------------------------ the tasks
def test_a_point_flies_the_montecarlo_draws_on_its_own_vehicle():
    base = load_params()
    draws = MC.draws(3, seed=2, depth=4.0, distance=0.8)
    for d in draws:   # the reference with no value changed: exactly montecarlo's flights
        assert dict(S.perturbed(base, d.errors)) == {**dataclasses.asdict(base), **dict(d.spec.vehicle)}
    params = [S.Parameter("wing_height", 0.15, 0.20), S.Parameter("CTL_TGT_K", 1.0, 3.0)]
    campaign = S.campaign(base, params, S.grid(params, 2), runs=3, seed=2, depth=4.0, distance=0.8,
                          envelope_step_deg=45.0)
    assert len(campaign) == 4 * (1 + 3)
    last = campaign.tasks[3 * 4 + 3]
    assert isinstance(last, S.LandingTask) and last.point == 3 and last.index == 2
    assert dict(last.draw.spec.vehicle)["wing_height"] == 0.20
    assert last.draw.spec.ctl == (("CTL_TGT_K", 3.0),)
    # the draw is the same at every point: target, heading, sensors' seed
    first = campaign.tasks[3]
    assert (first.draw.spec.target, first.draw.spec.heading_deg, first.draw.spec.seed) == \
        (last.draw.spec.target, last.draw.spec.heading_deg, last.draw.spec.seed) == \
        (draws[2].spec.target, draws[2].spec.heading_deg, draws[2].spec.seed)


def test_a_controller_gain_changes_the_flight():
    base = load_params()
    params = [S.Parameter("CTL_FOLD_DEG", 30.0, 45.0)]
    campaign = S.campaign(base, params, S.grid(params, 2), runs=1, depth=3.0, distance=0.5)
    low, high = (S.task_row(campaign.tasks[i]) for i in (1, 3))
    assert (low["CTL_FOLD_DEG"], high["CTL_FOLD_DEG"]) == (30.0, 45.0)
    assert low["landed"] and high["landed"]
    # the fold sets the descent speed (0.36 m/s at 30 deg, 0.44 at 45: shared/control/cascade.py)
    assert low["descent_speed_mps"] < high["descent_speed_mps"] - 0.03


def test_pareto_front_keeps_what_nothing_beats_on_both():
    pts = [{"best_glide_ratio": 0.40, "landing_error_p95_m": 0.02, "landed_fraction": 1.0},
           {"best_glide_ratio": 0.50, "landing_error_p95_m": 0.03, "landed_fraction": 1.0},
           {"best_glide_ratio": 0.45, "landing_error_p95_m": 0.04, "landed_fraction": 1.0},   # beaten by 1
           {"best_glide_ratio": 0.55, "landing_error_p95_m": 0.01, "landed_fraction": 0.5},   # a run lost
           {"best_glide_ratio": 0.50, "landing_error_p95_m": 0.03, "landed_fraction": 1.0}]   # a tie stays
    assert S.pareto(pts) == [0, 1, 3, 4]


# ------------------------------------------------------------ the command
@pytest.fixture(scope="module")
def two_sweeps(tmp_path_factory):
    """The same small sweep (a light and a heavy ballast, two draws each,
    from 2 m) on one process and on two local processes."""
    d = tmp_path_factory.mktemp("sweep")
    out = {}
    for workers in ("1", "2"):
        results = d / ("w%s.csv" % workers)
        proc = sim("sweep", "--param", "total_mass=1.0:1.2", "--grid", "2", "--runs", "2", "--depth", "2",
                   "--distance", "0.5", "--envelope-step", "45", "--workers", workers, "--results", str(results),
                   "--plot", str(d / ("w%s.png" % workers)), "--json")
        assert proc.returncode == 0, proc.stderr
        out[workers] = (results, json.loads(proc.stdout))
    return out


@pytest.mark.slow
def test_rows_are_identical_on_one_and_two_workers(two_sweeps):
    (f1, s1), (f2, s2) = two_sweeps["1"], two_sweeps["2"]
    assert f1.read_bytes() == f2.read_bytes()
    assert s1["points"] == s2["points"]
    assert (s1["workers"], s2["workers"]) == (1, 2)
    head, rows = read_rows(str(f1))
    assert head["kind"] == "sweep"
    assert [(r["kind"], r["point"], r["draw"]) for r in rows] == [
        ("design", 0, None), ("landing", 0, 0), ("landing", 0, 1),
        ("design", 1, None), ("landing", 1, 0), ("landing", 1, 1)]
    assert [r["total_mass"] for r in rows] == [1.0] * 3 + [1.2] * 3


@pytest.mark.slow
def test_a_heavier_ballast_sinks_faster_in_the_rows(two_sweeps):
    results, summary = two_sweeps["1"]
    _, rows = read_rows(str(results))
    light = [r for r in rows if r["point"] == 0]
    heavy = [r for r in rows if r["point"] == 1]
    assert heavy[0]["fall_speed_mps"] > light[0]["fall_speed_mps"] * 1.3
    for a, b in zip(light[1:], heavy[1:]):
        assert (a["seed"], a["target_north_m"], a["heading_deg"]) == (b["seed"], b["target_north_m"],
                                                                     b["heading_deg"])
        assert a["landed"] and b["landed"]
        assert b["descent_speed_mps"] > a["descent_speed_mps"] * 1.3
        assert b["descent_time_s"] < a["descent_time_s"]
    # the summary is the rows' statistics, one entry a point
    for entry, mine in zip(summary["points"], (light, heavy)):
        stats = MC.summary(mine[1:])
        assert entry["values"] == {"total_mass": mine[0]["total_mass"]}
        assert entry["landing_error_p95_m"] == pytest.approx(stats["landing_error_p95_m"])
        assert entry["landed_fraction"] == 1.0 and entry["runs"] == 2
        assert entry["best_glide_ratio"] == pytest.approx(mine[0]["best_glide_ratio"])
    assert json.loads(open(str(results).replace(".csv", ".summary.json")).read())["points"][1]["point"] == 1


@pytest.mark.slow
def test_a_sweep_resumes_from_its_results_file(two_sweeps, tmp_path):
    whole = two_sweeps["1"][0].read_bytes()
    cut = tmp_path / "cut.csv"
    lines = whole.split(b"\n")
    cut.write_bytes(b"\n".join(lines[:-4]) + b"\n" + lines[-4][:10])   # two rows gone, a third torn
    proc = sim("sweep", "--param", "total_mass=1.0:1.2", "--grid", "2", "--runs", "2", "--depth", "2",
               "--distance", "0.5", "--envelope-step", "45", "--workers", "1", "--results", str(cut), "--json")
    assert proc.returncode == 0, proc.stderr
    assert "cut short" in proc.stderr and "3 of 6 tasks already there" in proc.stderr
    assert json.loads(proc.stdout)["tasks_run"] == 3
    assert cut.read_bytes() == whole
    other = sim("sweep", "--param", "total_mass=1.0:1.3", "--grid", "2", "--runs", "2", "--depth", "2",
                "--distance", "0.5", "--workers", "1", "--results", str(cut))
    assert other.returncode == 1 and "another sweep campaign" in other.stderr
    assert cut.read_bytes() == whole


# ------------------------------------------------------------ the figure
def _result(parameters, values, glide, p95):
    points = []
    for i, (v, g, e) in enumerate(zip(values, glide, p95)):
        points.append({"point": i, "values": dict(zip([p[0] for p in parameters], v)), "best_glide_ratio": g,
                       "two_up_glide_ratio": g, "landing_error_p50_m": e / 2, "landing_error_p95_m": e,
                       "landing_error_worst_m": e * 1.2, "landed_fraction": 1.0})
    front = S.pareto(points)
    for k, p in enumerate(points):
        p["pareto"] = k in front
    return {"points": points, "pareto": front, "parameters": parameters, "vehicle": "buildable.py",
            "runs_per_point": 8, "depth_m": 10.0, "distance_m": 2.0, "release_depth_m": 0.1}


def test_figure_of_one_parameter_plots_error_and_reach_against_it(tmp_path):
    result = _result([["wing_height", 0.12, 0.20]], [(0.12,), (0.16,), (0.20,)], [0.40, 0.45, 0.47],
                     [0.03, 0.02, 0.025])
    fig = S.figure(result)
    top, bottom = fig.axes[:2]
    assert top.get_ylabel() == "landing error (cm)"
    assert bottom.get_xlabel() == "wing_height (m)"
    assert "buildable.py" in fig.get_suptitle() and "8 landings each" in fig.get_suptitle()
    y = top.lines[0].get_ydata()
    assert list(y) == pytest.approx([3.0, 2.0, 2.5])
    path = tmp_path / "one.png"
    S.plot(result, str(path))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_figure_of_two_parameters_is_reach_against_p95_with_the_front(tmp_path):
    result = _result([["wing_height", 0.12, 0.20], ["CTL_TGT_K", 1.0, 4.0], ["cd", 1.28, 1.28]],
                     [(0.12, 1.0, 1.28), (0.20, 1.0, 1.28), (0.12, 4.0, 1.28), (0.20, 4.0, 1.28)],
                     [0.40, 0.47, 0.40, 0.47], [0.02, 0.03, 0.04, 0.025])
    fig = S.figure(result)
    ax = fig.axes[0]
    assert ax.get_xlabel().startswith("reach") and ax.get_xlabel().endswith("(m)")
    assert ax.get_ylabel() == "landing error p95 (cm)"
    assert fig.axes[1].get_ylabel() == "wing_height (m)"   # the colour bar
    assert "held: cd = 1.28" in ax.get_title()
    assert [p["point"] for p in result["points"] if p["pareto"]] == [0, 3]
    path = tmp_path / "two.png"
    S.plot(result, str(path))
    assert path.stat().st_size > 10000
