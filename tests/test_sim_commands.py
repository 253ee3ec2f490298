"""roboray-sim vehicle, drop and bench dynamics, through the real CLI."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


def sim(*args: str):
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_vehicle_json_has_the_documented_keys():
    proc = sim("vehicle", "--wings", "0,90,0,90", "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("mass", "rho", "cd", "g", "a_w", "displaced_volume", "ell", "m1", "m2", "m3", "I1", "I2",
                "I3", "d1", "d2", "area_center", "area_wing", "terminal_speed"):
        assert key in out, key
    assert out["m2"] == pytest.approx(1.6069, rel=1e-3)
    assert out["ell"] == pytest.approx(0.0171, abs=5e-5)


def test_vehicle_in_sea_water_is_lighter_in_the_water():
    fresh = json.loads(sim("vehicle", "--json").stdout)
    sea = json.loads(sim("vehicle", "--water", "sea", "--json").stdout)
    assert sea["rho"] == 1025.0
    assert sea["terminal_speed"] < fresh["terminal_speed"]
    assert sea["m3"] > fresh["m3"]   # added mass scales with the density


def test_drop_json_plot_and_csv(tmp_path):
    png, table = tmp_path / "drop.png", tmp_path / "drop.csv"
    proc = sim("drop", "--wings", "45,45,45,45", "--tilt-deg", "10", "--duration", "20",
               "--plot", str(png), "--csv", str(table), "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("steady_descent_speed", "horizontal_drift", "duration", "wall_time_s"):
        assert key in out, key
    assert out["steady_descent_speed"] == pytest.approx(out["terminal_speed_analytic"], rel=1e-3)
    assert 0.0 < out["horizontal_drift"] < 0.5
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    rows = table.read_text().splitlines()
    assert rows[0].startswith("t,north,east,down") and len(rows) == 1 + 2001  # header, 0..20 s at 0.01 s


def test_drop_to_the_bottom_stops_there():
    out = json.loads(sim("drop", "--depth", "3", "--duration", "60", "--json").stdout)
    assert out["landed_at_s"] == pytest.approx(3.0 / 0.3, rel=0.05)
    assert out["duration"] == pytest.approx(out["landed_at_s"])


@pytest.mark.parametrize("args, message", [
    (("drop", "--wings", "10,20,30"), "needs 4 numbers"),
    (("drop", "--wings", "10,20,30,95"), "within 0..90"),
    (("drop", "--duration", "-1"), "must be greater than 0"),
    (("vehicle", "--wings", "a,b,c,d"), "not a comma-separated list"),
])
def test_bad_arguments_are_one_line_usage_errors(args, message):
    proc = sim(*args)
    assert proc.returncode == 2
    assert message in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_missing_or_broken_vehicle_file(tmp_path):
    proc = sim("vehicle", "--vehicle", str(tmp_path / "none.py"))
    assert proc.returncode == 1 and "no such file" in proc.stderr
    broken = tmp_path / "broken.py"
    broken.write_text("VEHICLE = 3\n")
    proc = sim("vehicle", "--vehicle", str(broken))
    assert proc.returncode == 1 and "VehicleParams" in proc.stderr and "Traceback" not in proc.stderr


def test_vehicle_file_that_raises_or_holds_nan_is_refused_in_one_line(tmp_path):
    from pathlib import Path

    import roboray.sim.vehicles.reference as ref

    raises = tmp_path / "raises.py"
    raises.write_text("import math\n\nVEHICLE = math.sqrt(-1)\n")
    text = Path(ref.__file__).read_text()
    nan = tmp_path / "nan.py"
    nan.write_text(text.replace("    cd=", "    cd=float('nan'),  # was ", 1))
    negative = tmp_path / "negative.py"
    negative.write_text(text.replace("    cf=", "    cf=-0.1,  # was ", 1))
    for f, message in ((raises, "raises.py:3: ValueError: math domain error"),
                       (nan, "cd must be a finite number, got nan"),
                       (negative, "cf must be >= 0, got -0.1")):
        proc = sim("vehicle", "--vehicle", str(f))
        assert proc.returncode == 1 and proc.stdout == "", proc
        assert message in proc.stderr and len(proc.stderr.splitlines()) == 1, proc.stderr


def test_edited_vehicle_file_is_used(tmp_path):
    from pathlib import Path

    import roboray.sim.vehicles.reference as ref

    mine = tmp_path / "heavy.py"
    mine.write_text(Path(ref.__file__).read_text().replace("cd=1.28,", "cd=2.0,"))
    out = json.loads(sim("vehicle", "--vehicle", str(mine), "--json").stdout)
    assert out["cd"] == 2.0 and out["terminal_speed"] < 0.3


def test_bench_dynamics_reports_figures():
    proc = sim("bench", "dynamics", "--duration", "5", "--batch", "50", "--batch-duration", "0.5", "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["real_time_factor"] > 1 and out["vehicle_seconds_per_second"] > 1
    assert out["dt_s"] == 0.01 and "rk4" in out["integrator"]


def test_drop_takes_negative_vectors():
    proc = sim("drop", "--v0", "-0.1,0,0", "--omega0", "-0.2,0,0", "--current", "-0.05,0,0", "--tilt-deg", "-5",
               "--duration", "2", "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["duration"] == 2.0


def test_bench_estimator_sources_are_the_estimators_and_controllability_depth_is_brackets():
    from roboray.sim import estimation
    from roboray.sim.cli import build_parser

    parser = build_parser()
    bench = next(a for a in parser._subparsers._group_actions[0].choices["bench"]._actions if a.dest != "help"
                 and getattr(a, "choices", None) and "estimator" in a.choices).choices["estimator"]
    source = next(a for a in bench._actions if a.dest == "source")
    assert set(source.choices) == set(estimation.TRUTH_SOURCES) and source.default == "dynamics"
    assert parser.parse_args(["controllability", "--bracket-depth", "2"]).bracket_depth == 2
    proc = sim("controllability", "--depth", "2")
    assert proc.returncode == 2 and "unrecognized arguments: --depth" in proc.stderr
