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


# ------------------------------------------------------- CLI conventions (issue 17)
def _parsers():
    from roboray.ground.cli import build_parser as ground
    from roboray.sim.cli import build_parser as sim
    from roboray.tools.flash.cli import build_parser as flash

    return sim(), ground(), flash()


@pytest.mark.parametrize("argv, dest, value", [
    (("fly", "--target", "-1.5,-1"), "target", [-1.5, -1.0]),
    (("fly", "--velocity", "-0.1,0"), "velocity", [-0.1, 0.0, 0.0]),
    (("fly", "--attitude", "-5,0"), "attitude", [-5.0, 0.0]),
    (("fly", "--heading", "-1e1"), "heading", -10.0),
    (("sil", "--target", "-1.5,-1"), "target", [-1.5, -1.0]),
    (("drop", "--v0", "-0.1,0,0"), "v0", [-0.1, 0.0, 0.0]),
    (("drop", "--omega0", "-.2,-1,-3e-1"), "omega0", [-0.2, -1.0, -0.3]),
    (("drop", "--current", "-0.05,0,0"), "current", [-0.05, 0.0, 0.0]),
    (("stability", "--v2", "-0.3"), "v2", -0.3),
    (("thesis-control", "--kv2", "-1,10"), "kv2", [-1.0, 10.0]),
])
def test_negative_numbers_in_every_sim_option(argv, dest, value):
    sim, _, _ = _parsers()
    assert getattr(sim.parse_args(list(argv)), dest) == value


def test_negative_numbers_in_ground_and_flash():
    _, ground, flash = _parsers()
    args = ground.parse_args(["target", "-2", "-1.5e0", "--master", "x"])
    assert (args.north, args.east) == (-2.0, -1.5)
    args = ground.parse_args(["target", "-.5", "1"])
    assert (args.north, args.east) == (-0.5, 1.0)


@pytest.mark.parametrize("module, argv, words", [
    # a negative value reaches the option's own check instead of "expected one argument"
    ("roboray.tools.flash.cli", ("deploy", "--timeout", "-1"), "argument --timeout: '-1' must be greater than 0"),
    ("roboray.ground.cli", ("target", "1", "0", "--down", "-10"), "argument --down: '-10' must be greater than 0"),
    ("roboray.sim.cli", ("drop", "--depth", "-2.5"), "argument --depth: '-2.5' must be greater than 0"),
    ("roboray.sim.cli", ("fly", "--target", "-1.5,-x"), "--target '-1.5,-x' is not a comma-separated list"),
    # the same kind of mistake, the same exit code: 2 for a bad argument
    ("roboray.sim.cli", ("sil", "--radio", "udp"), "--radio 'udp': expected pty, udp:PORT"),
    ("roboray.sim.cli", ("sil", "--speedup", "0"), "--speedup '0'"),
    ("roboray.ground.cli", ("mode", "HOVER", "--master", "/dev/ttyNOPE0"), "unknown mode 'HOVER'"),
])
def test_bad_arguments_are_exit_2_with_one_line(module, argv, words):
    proc = run(module, *argv)
    lines = [ln for ln in proc.stderr.strip().splitlines() if not ln.startswith("roboray.")]
    assert proc.returncode == 2 and len(lines) == 1 and words in lines[0], proc.stderr


@pytest.mark.parametrize("argv, words", [
    (("fly",), ["--mode {velocity,target,attitude}", "what the controller holds", "within the reach"]),
    (("montecarlo",), ["cascade (the flight controller, the default)"]),
    (("bench", "sil"), ["seeds every random stream of the drop"]),
    (("bench", "estimator"), ["dynamics (the vehicle model's descent, the default)"]),
    (("controllability",), ["--bracket-depth N", "Lie brackets nested up to N deep"]),
    (("sil",), ["NAME[:ARG]@SECONDS", "radio-corrupt[:P]", "battery-sag[:V]", "powercut[:N]", "overload[:US]"]),
])
def test_sim_help_says_what_each_option_does(argv, words, capsys):
    sim, _, _ = _parsers()
    with pytest.raises(SystemExit):
        sim.parse_args([*argv, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for w in words:
        assert w in text, (argv, w)


@pytest.mark.parametrize("argv, words", [
    (("disarm",), ["this vehicle never refuses to disarm, so it changes nothing"]),
    (("mode",), ["NAME the mode, in any case: PASSIVE, ATTITUDE", "MANUAL, STABILIZE, GUIDED, AUTO or SURFACE"]),
    (("target",), ["NORTH metres north of the release point", "EAST metres east", "--down D the bottom's depth",
                   "CTL_DEPTH_M"]),
    (("status",), ["before or after the command", "auto: the one SiK radio", "$ROBORAY_MASTER"]),
])
def test_ground_help_says_what_each_option_does(argv, words, capsys):
    _, ground, _ = _parsers()
    with pytest.raises(SystemExit):
        ground.parse_args([*argv, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for w in words:
        assert w in text, (argv, w)


def test_every_option_has_help():
    """No option or positional without a help line, in the three CLIs."""
    import argparse

    missing = []

    def walk(parser, path):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, path + [name])
            elif (action.help is None and not isinstance(action, (argparse._HelpAction, argparse._VersionAction))
                  and not (not action.option_strings and action.choices)):   # its usage lists the choices
                missing.append(" ".join(path + [action.option_strings[0] if action.option_strings else action.dest]))

    for prog, parser in zip(("roboray-sim", "roboray-ground", "roboray-flash"), _parsers()):
        walk(parser, [prog])
    assert missing == []


def test_the_reach_check_is_one_function():
    from roboray.tools.cli import UsageError, best_glide_ratio, check_target, glide_reach

    assert best_glide_ratio() == pytest.approx(0.4854, abs=1e-4)
    assert glide_reach(10.0, 0.1) == pytest.approx(0.4854 * 9.9, abs=1e-3)
    assert check_target(3.0, -4.0, 10.5) == 5.0
    with pytest.raises(UsageError, match="target 3.00 m north, -4.00 m east is 5.00 m away, beyond the reach"):
        check_target(3.0, -4.0, 10.0)
    assert UsageError.exit_code == 2
