"""The three console scripts follow the same conventions."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

SCRIPTS = {
    "roboray-sim": "roboray.sim.cli",
    "roboray-ground": "roboray.ground.cli",
    "roboray-flash": "roboray.tools.flash.cli",
}


def run(module: str, *args: str, timeout: float = 120):
    return subprocess.run([sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("script", sorted(SCRIPTS))
def test_help_exits_zero(script):
    proc = run(SCRIPTS[script], "--help")
    assert proc.returncode == 0
    assert script in proc.stdout and "COMMAND" in proc.stdout


@pytest.mark.parametrize("script", sorted(SCRIPTS))
def test_unknown_command_is_a_one_line_usage_error(script):
    proc = run(SCRIPTS[script], "no-such-command")
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(script + ": error:")
    assert "Traceback" not in proc.stderr


def test_bad_number_is_a_one_line_usage_error():
    proc = run("roboray.sim.cli", "bench", "micropython", "--iterations", "many")
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1
    assert "invalid int value: 'many'" in proc.stderr


def test_installed_scripts_are_on_the_path():
    import shutil

    for script in SCRIPTS:
        assert shutil.which(script) or shutil.which(script, path=str(__import__("pathlib").Path(sys.executable).parent))


def test_json_output_is_one_document():
    proc = run("roboray.ground.cli", "ports", "--json")
    assert proc.returncode == 0, proc.stderr
    assert isinstance(json.loads(proc.stdout), list)


@pytest.mark.micropython
def test_bench_micropython_reports_figures():
    proc = run("roboray.sim.cli", "bench", "micropython", "--iterations", "20000", "--json")
    assert proc.returncode == 0, proc.stderr
    figures = json.loads(proc.stdout)
    assert figures["us_per_mul_iteration"] > 0 and figures["us_per_empty_iteration"] > 0
    assert figures["heap_bytes_per_mul"] == 16.0  # one boxed float a multiply, as on an RP2350
    assert figures["rp2350_slowdown"] == pytest.approx(7.2 / figures["us_per_mul_iteration"])


def test_failure_is_one_line_exit_one(tmp_path):
    # a folder where a file is expected: foreseeable, so no traceback
    from roboray.tools.cli import CliError, make_parser, command, run as run_cli

    parser, sub = make_parser("demo", "demo")

    def fail(args):
        open(tmp_path / "missing" / "x.txt")

    def fail2(args):
        raise CliError("the radio is not answering on /dev/ttyUSB0 at 57600 baud")

    command(sub, "open", fail, "open a missing file")
    command(sub, "radio", fail2, "fail")
    assert run_cli(parser, ["open"]) == 1
    assert run_cli(parser, ["radio"]) == 1
