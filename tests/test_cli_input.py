"""Bad input on the command line: one line naming it and exit 2, never a
traceback (issue 26 item 9)."""

from __future__ import annotations

import subprocess
import sys

import pytest


def _sim(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", *args], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("command", [["montecarlo", "--runs", "2"], ["sweep"], ["sil"], ["fly"]])
def test_a_negative_seed_is_refused_in_one_line(command):
    proc = _sim(*command, "--seed", "-5")
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert "a seed is a whole number >= 0" in proc.stderr.strip().splitlines()[-1]


def test_a_board_fs_that_is_a_file_is_refused_before_the_run(tmp_path):
    existing = tmp_path / "flash.img"
    existing.write_bytes(b"x")
    proc = _sim("sil", "--board-fs", str(existing), "--duration", "1")
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1].endswith("exists and is not a folder (see roboray-sim sil --help)")


def test_bench_board_writes_the_landing_error_as_sil_does():
    from roboray.sim.commands.board import _metres

    assert _metres(0.012345678901234) == "0.012"
    assert _metres(None) == "none (no landing)"
