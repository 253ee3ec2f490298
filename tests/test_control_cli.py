"""roboray-sim fly, montecarlo, thesis-control and bench control, through the CLI."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from roboray.sim import cli


def run(capsys, *args: str) -> dict:
    assert cli.main(list(args)) == 0
    return json.loads(capsys.readouterr().out)


def test_fly_reports_the_issue_keys_and_plots(capsys, tmp_path):
    png = tmp_path / "fly.png"
    out = run(capsys, "fly", "--mode", "target", "--target", "0.5,-0.5", "--depth", "4", "--truth", "--plot",
              str(png), "--json")
    for key in ("landing_error_m", "velocity_rms_error_mps", "settling_time_s", "descent_time_s", "max_tilt_deg",
                "servo_travel_deg"):
        assert key in out, key
    assert out["estimator"] == "truth" and out["landed"]
    assert out["landing_error_m"] < 0.25
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 20_000


def test_fly_velocity_text_output(capsys):
    assert cli.main(["fly", "--mode", "velocity", "--velocity", "0,0.08", "--depth", "4", "--truth"]) == 0
    text = capsys.readouterr().out
    assert "velocity error" in text and "m/s RMS" in text


@pytest.mark.parametrize("args, code, message", [
    (("fly", "--target", "9,0", "--depth", "10"), 2, "beyond the reach"),
    (("fly", "--target", "-1.5,-4.6"), 2, "target -1.50 m north, -4.60 m east is 4.84 m away, beyond the reach"),
    (("fly", "--depth", "0.3"), 2, "at least 0.5 m below the release depth"),
    (("montecarlo", "--distance", "5"), 2, "beyond the reach of a glide from 0.10 m deep to a bottom at 10.0 m"),
    (("fly", "--target", "1"), 2, "--target"),
    (("fly", "--velocity", "a,b"), 2, "--velocity"),
    (("montecarlo", "--runs", "0"), 2, "at least 1"),
])
def test_bad_requests_get_one_line(capsys, args, code, message):
    try:
        got = cli.main(list(args))
    except SystemExit as exc:   # argparse's usage error
        got = exc.code
    err = capsys.readouterr().err
    assert got == code
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_a_target_beyond_reach_is_one_line_and_exit_2_in_a_real_process():
    proc = subprocess.run([sys.executable, "-m", "roboray.sim.cli", "fly", "--target", "0,-7", "--depth", "5"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr == ("roboray-sim: error: target 0.00 m north, -7.00 m east is 7.00 m away, beyond the reach "
                           "of a glide from 0.10 m deep to a bottom at 5.0 m: 2.38 m (best glide ratio 0.49)\n")


def test_fly_takes_negative_values_in_every_option(capsys):
    out = run(capsys, "fly", "--mode", "target", "--target", "-0.6,-0.4", "--depth", "3", "--heading", "-30",
              "--truth", "--max-time", "20", "--json")
    assert out["target"] == [-0.6, -0.4] and out["landed"] and out["landing_error_m"] < 0.25
    out = run(capsys, "fly", "--mode", "velocity", "--velocity", "-0.05,-0.02", "--depth", "2", "--truth",
              "--max-time", "10", "--json")
    assert out["mode"] == "velocity"
    out = run(capsys, "fly", "--mode", "attitude", "--attitude", "-5,-2.5", "--depth", "2", "--truth",
              "--max-time", "5", "--json")
    assert out["mode"] == "attitude"


def test_montecarlo_reports_percentiles(capsys, tmp_path):
    runs = tmp_path / "runs.csv"
    out = run(capsys, "montecarlo", "--runs", "2", "--workers", "1", "--depth", "3", "--distance", "0.5",
              "--truth", "--results", str(runs), "--json")
    for key in ("landing_error_p50_m", "landing_error_p95_m", "landing_error_worst_m", "runs", "landed"):
        assert key in out, key
    assert out["runs"] == out["landed"] == 2
    assert out["landing_error_p50_m"] <= out["landing_error_p95_m"] <= out["landing_error_worst_m"] < 0.5
    lines = runs.read_text().splitlines()
    assert len(lines) == 4 and lines[1].startswith("run,seed,") and "added_mass_error" in lines[1]   # the model errors
    assert json.loads((tmp_path / "runs.summary.json").read_text())["runs"] == 2


def test_thesis_control_reports_the_runs_and_why(capsys):
    out = run(capsys, "thesis-control", "--duration", "5", "--kv2", "10", "--json")
    assert set(out["run2_no_spin"]) == {"kv2=10"}
    assert abs(out["run1_spin_0.5"]["along_y_c_m"]) < 0.05
    assert "reaction" in out["authority"]["explanation"]
