"""``roboray-sim bench estimator``: figures, plot, and one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


# a guard against a hang, not a speed test: a fresh clone compiles the
# dynamics kernels first (~70-85 s alone), and a loaded 2-core machine
# runs the bench several times slower
def run(*args: str, timeout: float = 900):
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", "bench", "estimator", *args],
                          capture_output=True, text=True, timeout=timeout)


def test_bench_reports_the_errors_and_draws_the_plot(tmp_path):
    png = tmp_path / "estimator.png"
    proc = run("--seed", "1", "--seeds", "1", "--no-micropython", "--json", "--plot", str(png))
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    for key in ("attitude_rms_deg", "depth_rms_m", "vz_rms_mps", "horizontal_rms_m"):
        assert 0.0 < result[key] < result["targets"][key]
    assert result["seeds"] == [1] and result["per_seed"][0]["seed"] == 1
    assert result["meets_targets"] is True
    assert png.stat().st_size > 20000 and png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args,message", [
    (["--seeds", "0"], "--seeds must be at least 1"),
    (["--seeds", "-2"], "must be >= 0"),
    (["--seed", "x"], "is not a whole number"),
    (["--plot", "out.pdf"], "must name a .png file"),
    (["--source", "wind-tunnel"], "argument --source: invalid choice: 'wind-tunnel' (choose from 'dynamics', 'kinematic')"),
])
def test_bad_arguments_are_one_line_usage_errors(args, message, capsys):
    from roboray.sim.cli import main

    try:
        code = main(["bench", "estimator", *args, "--no-micropython"])
    except SystemExit as exc:  # argparse's own usage errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0]
    assert "Traceback" not in err
