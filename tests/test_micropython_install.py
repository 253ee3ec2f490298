"""A machine without Node.js or npm gets one line naming what to install."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys


def run_without(tmp_path, keep: list[str], *args: str):
    """Run ``roboray-sim`` with a PATH holding only the named tools."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in keep:
        os.symlink(shutil.which(tool), bin_dir / tool)
    env = dict(os.environ, PATH=str(bin_dir), ROBORAY_CACHE=str(tmp_path / "cache"))
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", *args], capture_output=True, text=True,
                          env=env, timeout=120)


def test_missing_node_is_one_line_naming_it(tmp_path):
    proc = run_without(tmp_path, [], "bench", "micropython", "--iterations", "10")
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert "node not found" in lines[0] and "install Node.js" in lines[0]


def test_missing_npm_is_one_line_naming_it(tmp_path):
    proc = run_without(tmp_path, ["node"], "bench", "micropython", "--iterations", "10")
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "npm not found" in lines[0]
    assert not (tmp_path / "cache" / "micropython-wasm-1.29.0-6").exists()   # nothing half-installed
