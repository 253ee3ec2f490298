"""The README's install order, in a virtual environment of its own.

``pip install .``, a simulator command, then ``pip install -e '.[dev]'``
over it and a command again: numba's cache files once written into the
installed package outlived the first install and shadowed the editable one
(``cannot import name 'faults' from 'roboray.sim.twin' (unknown location)``).
The dependencies come from the test's own environment through a ``.pth``
file and ``--no-deps``, so nothing but the build backend is downloaded.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: What is not source: copied, these would make the build differ from a clone's.
_NOT_SOURCE = shutil.ignore_patterns(".venv", ".git", "build", "dist", "*.egg-info", "__pycache__",
                                     ".pytest_cache", "out", "*.mpy")


def _run(cmd, cwd, env, timeout=900):
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, "%s failed (%d):\n%s\n%s" % (cmd, proc.returncode, proc.stdout[-3000:], proc.stderr[-3000:])
    return proc


@pytest.mark.slow
def test_install_then_editable_install_keeps_every_command_working(tmp_path):
    # A clean checkout of the working tree: one commit, so the build has an
    # identity to carry into the installed package.
    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=_NOT_SOURCE)
    git = ["git", "-c", "user.name=test", "-c", "user.email=test@example.invalid"]
    _run(git + ["init", "-q"], src, None)
    _run(git + ["add", "-A"], src, None)
    _run(git + ["commit", "-q", "-m", "snapshot"], src, None)
    commit = _run(["git", "rev-parse", "HEAD"], src, None).stdout.strip()

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], tmp_path, None)
    py = venv / "bin" / "python"
    site = Path(_run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     tmp_path, None).stdout.strip())
    # This environment's packages, added as a plain path: its own .pth files
    # (the editable finder of the repository's roboray) are not run.
    (site / "zz_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")
    env.pop("ROBORAY_CACHE", None)
    pip = [str(py), "-m", "pip", "install", "-q", "--no-deps"]
    sim = str(venv / "bin" / "roboray-sim")

    _run(pip + ["."], src, env)
    drop = _run([sim, "drop", "--wings", "0,0,90,90", "--duration", "1"], tmp_path, env)
    # The first run compiles the kernels and says so, once, with the time.
    said = [ln for ln in drop.stderr.splitlines() if "compiling" in ln]
    assert len(said) == 1 and re.search(r"about \d+ s", said[0]), drop.stderr
    # ... into the user's cache, not beside the installed modules.
    left = sorted(str(p.relative_to(site)) for p in (site / "roboray").rglob("*")
                  if p.is_file() and p.suffix in (".nbi", ".nbc"))
    assert left == []
    assert list((tmp_path / "cache" / "roboray" / "numba").rglob("*.nbi"))
    again = _run([sim, "drop", "--wings", "0,0,90,90", "--duration", "1"], tmp_path, env)
    assert "compiling" not in again.stderr

    # The installed package knows the build it came from.
    banner = _run([str(py), "-c", "from roboray.sim.twin.runner import build_info; print(build_info()[0])"],
                  tmp_path, env).stdout.strip()
    assert banner == "RoboRay firmware 0.1.0 %s" % commit[:12]

    _run(pip + ["-e", ".[dev]"], src, env)
    helped = _run([sim, "--help"], tmp_path, env)
    assert "usage: roboray-sim" in helped.stdout
    # The editable package is the one imported, its __init__ and all (a
    # leftover folder made roboray.sim a namespace package without it).
    where = _run([str(py), "-c", "import roboray.sim, roboray.sim.twin.faults as f; "
                  "print(roboray.sim.__file__); print(f.__file__)"], tmp_path, env)
    assert where.stdout.split() == [str(src / "sim" / "__init__.py"), str(src / "sim" / "twin" / "faults.py")]


def test_the_package_build_records_the_checkout_and_an_install_reads_it(tmp_path):
    from roboray.tools.flash import buildinfo

    checkout = tmp_path / "checkout"
    (checkout / "firmware").mkdir(parents=True)
    (checkout / "firmware" / "app.py").write_text("x = 1\n")
    git = ["git", "-c", "user.name=test", "-c", "user.email=test@example.invalid"]
    for cmd in (["init", "-q"], ["add", "-A"], ["commit", "-q", "-m", "one"]):
        _run(git + cmd, checkout, None)
    commit = _run(["git", "rev-parse", "HEAD"], checkout, None).stdout.strip()

    installed = tmp_path / "site" / "roboray" / "tools" / "flash"
    assert buildinfo.write_record(checkout, installed) == (commit, False)
    assert buildinfo.recorded_revision(installed) == (commit, False)
    # Not a checkout: git says nothing, so the record answers.
    assert buildinfo.git_revision(installed) == (None, None)
    (checkout / "firmware" / "app.py").write_text("x = 2\n")
    buildinfo.write_record(checkout, installed)
    assert buildinfo.recorded_revision(installed) == (commit, True)
    # A build outside any checkout leaves no stale record behind.
    assert buildinfo.write_record(tmp_path / "site", installed) == (None, None)
    assert buildinfo.recorded_revision(installed) == (None, None)
    (installed / buildinfo.RECORD).write_text('{"commit": "not a commit", "dirty": false}')
    assert buildinfo.recorded_revision(installed) == (None, None)
