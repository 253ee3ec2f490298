"""roboray-sim sil through the CLI's own entry point: its JSON, its figure, its errors.

In this process (``roboray.sim.cli.main``), so the dynamics' compiled
kernels load once for the module; ``test_sim_commands.py`` covers the
console script as a separate process.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from roboray.sim.cli import main


@pytest.fixture
def sim(capsys):
    def run(*args: str):
        try:
            code = main(list(args))
        except SystemExit as exc:   # argparse's usage errors
            code = exc.code
        out, err = capsys.readouterr()
        return SimpleNamespace(returncode=code, stdout=out, stderr=err)

    return run


def test_a_target_landing_gives_the_documented_json_and_its_plot(sim, tmp_path):
    png = tmp_path / "landing.png"
    proc = sim("sil", "--scenario", "target-landing", "--interpreter", "cpython", "--target", "0.6,-0.3",
               "--depth", "4", "--plot", str(png), "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("landed", "real_time_factor", "overruns", "landing_error_m", "failsafes", "max_loop_ms",
                "duration_s", "wall_time_s", "modes", "statustext", "landing_point", "target", "console"):
        assert key in out, key
    assert out["landed"] and out["target"] == [0.6, -0.3] and out["bottom_depth_m"] == 4.0
    assert out["landing_error_m"] < 0.25
    # the default twin charges the board's time (the model calibrated on the
    # emulated RP2350): the loop's worst slot is a planned stall (a
    # collection, a flash save), never an overrun
    assert out["failsafes"] == [] and out["overruns"] == 0 and out["max_loop_ms"] > 0.0
    assert out["real_time_factor"] > 1.0
    assert png.stat().st_size > 20000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_text_output_names_the_failsafes_and_their_reports(sim):
    proc = sim("sil", "--interpreter", "cpython", "--depth", "2", "--duration", "14", "--fault", "leak@12")
    assert proc.returncode == 0, proc.stderr
    assert "failsafes: leak at 12." in proc.stdout
    assert "STATUSTEXT 12." in proc.stdout and "Failsafe: leak, FAILSAFE mode" in proc.stdout


@pytest.mark.parametrize("args, code, words", [
    (("--fault", "depth-nack"), 2, "expected NAME@SECONDS"),
    (("--fault", "sonar-nack@3"), 2, "unknown fault 'sonar-nack'"),
    (("--fault", "radio-corrupt:2@3"), 2, "within 0..1"),
    # faults that cannot happen: a flash step beyond a save's, a time after the run's end
    (("--fault", "powercut:7@12"), 2, "a parameter save has 6 flash steps"),
    (("--fault", "powercut:16@12"), 2, "use 1..6"),
    # every bad argument is exit 2, whether argparse or the twin finds it (issue 17)
    (("--duration", "10", "--fault", "watchdog@12"), 2, "at 12 s, but the run ends at 10 s"),
    (("--fault", "leak@120"), 2, "at 120 s, but the run ends at 120 s"),
    (("--speedup", "0"), 2, "--speedup '0'"),
    (("--param", "FS_GCS_TIMEOUT"), 2, "expected NAME=VALUE"),
    (("--param", "NO_SUCH_PARAM=1"), 2, "no such parameter"),
    (("--param", "FS_GCS_TIMEOUT=500"), 2, "out of range"),
    (("--param", "FS_GCS_TIMEOUT=-1"), 2, "out of range"),
    (("--radio", "serial"), 2, "expected pty, udp:PORT"),
    (("--radio", "udp"), 2, "expected pty, udp:PORT"),
    (("--target", "1,2"), 2, "--target applies to target-landing"),
    (("--depth", "0.1"), 2, "deeper than 0.3 m"),
    # the reach, as fly and roboray-ground target check it
    (("--scenario", "target-landing", "--target", "200,0"), 2,
     "target 200.00 m north, 0.00 m east is 200.00 m away, beyond the reach of a glide from 0.05 m deep to a "
     "bottom at 10.0 m: 4.83 m"),
    (("--scenario", "target-landing", "--target", "-1.5,-1", "--depth", "2"), 2, "1.80 m away, beyond the reach"),
    # output paths are checked before the run, not after it
    (("--tlog", "/missing/dir/x.tlog"), 2, "argument --tlog: /missing/dir/x.tlog: no folder /missing/dir"),
    (("--plot", "/missing/dir/x.png"), 2, "argument --plot: /missing/dir/x.png: no folder /missing/dir"),
])
def test_bad_arguments_are_one_line_errors(sim, args, code, words):
    proc = sim("sil", "--interpreter", "cpython", *args)
    assert proc.returncode == code
    lines = [ln for ln in proc.stderr.strip().splitlines() if not ln.startswith("roboray.sim")]
    assert len(lines) == 1 and words in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""


@pytest.mark.parametrize("args, words", [
    (("--repeat", "0"), "--repeat 0: at least 1"),
    (("--count-lines", "--interpreter", "cpython"), "--count-lines counts on MicroPython"),
])
def test_bench_sil_bad_arguments_are_one_line_errors(sim, args, words):
    proc = sim("bench", "sil", *args)
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.strip().splitlines() if not ln.startswith("roboray.sim")]
    assert len(lines) == 1 and words in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""
