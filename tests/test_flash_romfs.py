"""``roboray-flash deploy`` into the Pico 2's ROMFS partition.

The image is the real ``mpremote`` ROMFS image of the build's ``/lib``,
loaded into the emulated RP2350's partition (MicroPython's own ROMFS
reader; skipped without ``qemu-system-arm``); the target choice runs the
real mpremote transport against the virtual board (the WebAssembly port,
which has no ROMFS partition: ``auto`` deploys to ``/lib``).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from roboray.tools.boardcheck import package_root
from roboray.tools.flash import romfs
from roboray.tools.flash.build import build
from roboray.tools.micropython import rp2350_emu
from roboray.tools.micropython.virtual_board import VirtualBoard, twin_builtins

ROOT = package_root()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A build of the committed board code."""
    dest = tmp_path_factory.mktemp("src")
    archive = subprocess.run(["git", "archive", "HEAD", "shared", "firmware"], cwd=ROOT,
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest, build(tmp_path_factory.mktemp("out"), src_root=dest)


def test_image_holds_the_build_lib(built):
    from mpremote.romfs import VfsRomWriter

    _, b = built
    img = romfs.image(b)
    assert img.startswith(VfsRomWriter.ROMFS_HEADER)
    assert len(img) <= rp2350_emu.ROMFS_BYTES
    assert romfs.lib_files(b) and all(p.startswith("/lib/") for p in romfs.lib_files(b))
    assert "/main.py" in b.files and "/main.py" not in romfs.lib_files(b)
    assert romfs.image(b) == img  # the same build, the same image (no rewrite)


@pytest.mark.skipif(not rp2350_emu.available(), reason="qemu-system-arm or the emulated RP2350's image missing")
def test_image_runs_in_place_on_the_emulated_pico2(built):
    _, b = built
    code = ("import sys\nfrom roboray.firmware import build_info\nfrom roboray.shared.mavlink import parser\n"
            "print('BANNER', build_info.BANNER)\nprint('FILE', parser.__file__)\n")
    with tempfile.TemporaryDirectory() as d:
        status, out = rp2350_emu.run(code, cwd=d, romfs=romfs.image(b), timeout=120)
    assert status == 0, out
    assert "BANNER " + b.banner in out
    assert "FILE /rom/lib/roboray/shared/mavlink/parser.mpy" in out


def flash(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.tools.flash.cli", *args],
                          capture_output=True, text=True, timeout=300)


@pytest.mark.micropython
def test_target_auto_deploys_to_lib_and_romfs_says_why_not(built, tmp_path):
    src, _ = built
    out = tmp_path / "out"
    with VirtualBoard(fs_dir=tmp_path / "fs", modules=twin_builtins()) as vb:
        auto = flash("deploy", "--port", vb.device, "--src", str(src), "--out", str(out), "--dry-run", "--json")
        only = flash("deploy", "--port", vb.device, "--src", str(src), "--out", str(out), "--target", "romfs")
    assert auto.returncode == 0, auto.stderr
    report = json.loads(auto.stdout)
    assert report["target"] == "lib" and "no ROMFS partition" in report["romfs_unavailable"]
    assert report["files_copied"] > 0 and report["dry_run"] is True
    assert only.returncode != 0
    assert "no ROMFS partition" in only.stderr and "--target lib" in only.stderr
    assert "Traceback" not in only.stderr
    assert list((tmp_path / "fs").rglob("*.mpy")) == []
    # the text: why once, and no advice to do what auto has done already
    with VirtualBoard(fs_dir=tmp_path / "fs2", modules=twin_builtins()) as vb:
        text = flash("deploy", "--port", vb.device, "--src", str(src), "--out", str(out), "--dry-run")
    assert text.returncode == 0, text.stderr
    said = (text.stdout + text.stderr).count("no ROMFS partition")
    assert said == 1, text.stdout + text.stderr
    assert "--target lib" not in text.stdout + text.stderr
    assert "no ROMFS: the board on %s has no ROMFS partition 0" % vb.device in text.stdout
