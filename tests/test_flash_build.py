"""``roboray-flash build``: board paths, manifest, revision, incremental compiles."""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from roboray.tools.boardcheck import MPY_ARCH, package_root
from roboray.tools.flash import buildinfo
from roboray.tools.flash.build import MAIN_PATH, MAIN_SOURCE, build
from roboray.tools.flash.errors import BuildError

ROOT = package_root()


@pytest.fixture(scope="module")
def committed_src(tmp_path_factory) -> Path:
    """The committed board code (others' work in progress cannot break these tests)."""
    dest = tmp_path_factory.mktemp("src")
    archive = subprocess.run(["git", "archive", "HEAD", "shared", "firmware"], cwd=ROOT,
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


@pytest.fixture
def src(committed_src, tmp_path) -> Path:
    dest = tmp_path / "src"
    shutil.copytree(committed_src, dest)
    return dest


def test_board_code_is_compiled_to_its_board_paths_with_a_manifest(src, tmp_path):
    out = tmp_path / "out"
    b = build(out, src_root=src)
    files = b.files
    py_sources = sorted(src.rglob("*.py"))
    assert len(files) == len(py_sources) + 2  # + build_info and /main.py
    assert "/lib/roboray/shared/quat.mpy" in files and "/lib/roboray/shared/__init__.mpy" in files
    assert "/lib/roboray/firmware/build_info.mpy" in files
    for path, entry in files.items():
        data = (out / "board" / path.lstrip("/")).read_bytes()
        assert entry == {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}
        if path.endswith(".mpy"):
            assert data[:2] == b"M\x06"  # .mpy version 6, what MicroPython 1.29 loads
    assert (out / "board" / "main.py").read_text() == MAIN_SOURCE
    on_disk = json.loads((out / "manifest.json").read_text())
    assert on_disk == b.manifest
    assert b.manifest["version"] == importlib.metadata.version("roboray")
    assert b.manifest["revision"] == "unknown" and b.manifest["dirty"] is None  # not a checkout
    assert b.manifest["compiler"].endswith("-march=" + MPY_ARCH)
    assert b.manifest["banner"] == "RoboRay firmware %s unknown" % b.manifest["version"]


def test_build_info_carries_the_start_up_line(src, tmp_path):
    out = tmp_path / "out"
    b = build(out, src_root=src, source=True)
    namespace: dict = {}
    exec((out / "board/lib/roboray/firmware/build_info.py").read_text(), namespace)
    assert namespace["BANNER"] == b.banner == buildinfo.banner(namespace["VERSION"], namespace["REVISION"])
    assert buildinfo.BANNER_RE.match(b.banner).groups() == (namespace["VERSION"], "unknown")
    assert buildinfo.banner("0.1.0", "ba4ae25be6f8-dirty") == "RoboRay firmware 0.1.0 ba4ae25be6f8-dirty"
    assert buildinfo.revision_label("ba4ae25be6f8a2a2e2b2a47a1405b68dce4be899", True) == "ba4ae25be6f8-dirty"
    with pytest.raises(ValueError):
        buildinfo.banner("0.1 beta", "x")


def test_a_build_of_the_checkout_records_its_revision(tmp_path):
    def head() -> str:
        return subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()

    before = head()
    b = build(tmp_path / "out", source=True)  # the installed board code: this checkout
    after = head()
    m = b.manifest
    assert m["revision"] in (before, after) and len(m["revision"]) == 40
    assert isinstance(m["dirty"], bool)
    assert m["banner"].endswith(" " + m["revision"][:12] + ("-dirty" if m["dirty"] else ""))
    assert "/lib/roboray/shared/quat.py" in m["files"] and m["compiler"] == "source"


def test_only_what_changed_is_compiled_again(src, tmp_path):
    out = tmp_path / "out"
    first = build(out, src_root=src)
    assert len(first.compiled) == len(first.files)
    again = build(out, src_root=src)
    assert again.compiled == [] and again.manifest == first.manifest

    quat = src / "shared" / "quat.py"
    quat.write_text(quat.read_text() + "\n_CHANGED = 1\n")
    changed = build(out, src_root=src)
    assert changed.compiled == ["/lib/roboray/shared/quat.mpy"]
    assert changed.files["/lib/roboray/shared/quat.mpy"] != first.files["/lib/roboray/shared/quat.mpy"]

    (src / "shared" / "quat.py").unlink()
    removed = build(out, src_root=src)
    assert removed.compiled == [] and removed.removed == ["/lib/roboray/shared/quat.mpy"]
    assert not (out / "board/lib/roboray/shared/quat.mpy").exists()
    assert "/lib/roboray/shared/quat.mpy" not in removed.files

    # An output altered in the build folder is compiled again, not trusted.
    init = out / "board/lib/roboray/shared/__init__.mpy"
    init.write_bytes(b"garbage")
    mended = build(out, src_root=src)
    assert mended.compiled == ["/lib/roboray/shared/__init__.mpy"]
    assert mended.files == removed.files


def test_source_mode_copies_the_py_files(src, tmp_path):
    b = build(tmp_path / "out", src_root=src, source=True)
    assert b.files["/lib/roboray/shared/quat.py"]["sha256"] == hashlib.sha256((src / "shared/quat.py").read_bytes()).hexdigest()
    assert not [p for p in b.files if p.endswith(".mpy")]
    assert b.manifest["mpy_version"] is None
    assert MAIN_PATH in b.files


def test_code_that_does_not_compile_is_a_one_line_error(src, tmp_path):
    (src / "shared" / "broken.py").write_text("x = 1\ndef f(:\n")
    with pytest.raises(BuildError) as info:
        build(tmp_path / "out", src_root=src)
    assert "shared/broken.py:2: SyntaxError" in str(info.value) and "\n" not in str(info.value)
    proc = subprocess.run([sys.executable, "-m", "roboray.tools.flash.cli", "build", "--src", str(src),
                           "--out", str(tmp_path / "out")], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("roboray-flash: error: mpy-cross cannot compile ")


def test_a_generated_module_in_the_source_is_refused(src, tmp_path):
    (src / "firmware" / "build_info.py").write_text("VERSION = 'mine'\n")
    with pytest.raises(BuildError, match="build generates that module"):
        build(tmp_path / "out", src_root=src)


def test_cli_build_prints_its_summary_as_json(src, tmp_path):
    proc = subprocess.run([sys.executable, "-m", "roboray.tools.flash.cli", "build", "--src", str(src),
                           "--out", str(tmp_path / "out"), "--json"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout)
    assert summary["files"] == summary["compiled"] and summary["reused"] == 0
    assert summary["banner"].startswith("RoboRay firmware ")
