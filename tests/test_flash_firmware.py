"""``roboray-flash firmware`` against folders laid out as boot ROM drives,
and ``deploy``'s note about the board's MicroPython build on the virtual board.

A BOOTSEL drive holds two files, INFO_UF2.TXT and INDEX.HTM; the texts
below are what an RP2350's and an RP2040's boot ROMs serve.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from roboray.tools.boardcheck import package_root
from roboray.tools.flash import firmware as fw
from roboray.tools.flash.firmware import IMAGE, NoDrive, WrongBoard

ROOT = package_root()

RP2350_INFO = "UF2 Bootloader v1.0\r\nModel: Raspberry Pi RP2350\r\nBoard-ID: RP2350\r\n"
RP2040_INFO = "UF2 Bootloader v3.0\r\nModel: Raspberry Pi RP2\r\nBoard-ID: RPI-RP2\r\n"
INDEX = ("<html><head><meta http-equiv=\"refresh\" content=\"0;URL='https://raspberrypi.com/device/RP2?"
         "version=5A09D5312E22'\"/></head><body>Redirecting to <a href='https://raspberrypi.com/device/RP2?"
         "version=5A09D5312E22'>raspberrypi.com</a></body></html>\r\n")


def flash(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.tools.flash.cli", *args],
                          capture_output=True, text=True, timeout=timeout)


def bootsel_drive(parent: Path, info: str, name: str = "RP2350") -> Path:
    drive = parent / name
    drive.mkdir(parents=True)
    (drive / "INFO_UF2.TXT").write_text(info, newline="")
    (drive / "INDEX.HTM").write_text(INDEX, newline="")
    return drive


def listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_writes_the_image_to_an_rp2350_drive(tmp_path):
    drive = bootsel_drive(tmp_path, RP2350_INFO)
    proc = flash("firmware", "--drive", str(drive), "--no-wait")
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in drive.iterdir()) == ["INDEX.HTM", "INFO_UF2.TXT", "ROBORAY.UF2"]
    assert (drive / "ROBORAY.UF2").read_bytes() == IMAGE.read_bytes()
    assert "wrote roboray-pico2.uf2" in proc.stdout and "(Board-ID: RP2350)" in proc.stdout


def test_json_report(tmp_path):
    drive = bootsel_drive(tmp_path, RP2350_INFO)
    proc = flash("firmware", "--drive", str(drive), "--no-wait", "--json")
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["board_id"] == "RP2350" and r["written"] == str(drive / "ROBORAY.UF2")
    assert r["blocks"] == len(IMAGE.read_bytes()) // 512 - 1
    assert r["expected"]["build"] == "ROBORAY_PICO2" and "board" not in r


def test_refuses_an_rp2040_drive_and_writes_nothing(tmp_path):
    drive = bootsel_drive(tmp_path, RP2040_INFO, "RPI-RP2")
    before = listing(drive)
    proc = flash("firmware", "--drive", str(drive), "--no-wait")
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Board-ID: RPI-RP2" in lines[0] and "nothing written" in lines[0]
    assert "Traceback" not in proc.stderr
    assert listing(drive) == before


def test_refuses_a_folder_that_is_no_boot_rom_drive(tmp_path):
    no_board = str(tmp_path / "ttyACM9")  # and no board on USB to send to BOOTSEL
    drive = tmp_path / "drive"
    drive.mkdir()
    proc = flash("firmware", "--drive", str(drive), "--port", no_board, "--no-wait")
    assert proc.returncode == 1 and "no INFO_UF2.TXT" in proc.stderr
    assert list(drive.iterdir()) == []
    proc = flash("firmware", "--drive", str(tmp_path / "absent"), "--port", no_board, "--no-wait")
    assert proc.returncode == 2 and "is not a folder" in proc.stderr


def test_refuses_a_damaged_image_and_writes_nothing(tmp_path):
    drive = bootsel_drive(tmp_path, RP2350_INFO)
    bad = tmp_path / "bad.uf2"
    data = bytearray(IMAGE.read_bytes())
    del data[-512:]
    bad.write_bytes(bytes(data))
    proc = flash("firmware", "--drive", str(drive), "--uf2", str(bad), "--no-wait")
    assert proc.returncode == 1 and "truncated" in proc.stderr and "nothing written" in proc.stderr
    assert "ROBORAY.UF2" not in listing(drive)


def test_refuses_an_image_that_does_not_match_its_checksum(tmp_path):
    drive = bootsel_drive(tmp_path, RP2350_INFO)
    copy = tmp_path / "img" / "roboray-pico2.uf2"
    copy.parent.mkdir()
    blocks = bytearray(IMAGE.read_bytes())
    blocks[600] ^= 1  # a payload byte: still a well-formed UF2
    copy.write_bytes(bytes(blocks))
    (copy.parent / "roboray-pico2.json").write_text(fw.IDENTITY.read_text())
    proc = flash("firmware", "--drive", str(drive), "--uf2", str(copy), "--no-wait")
    assert proc.returncode == 1 and "does not match its checksum" in proc.stderr
    assert "ROBORAY.UF2" not in listing(drive)


def test_an_rp2040_drive_alone_is_refused_by_name(tmp_path):
    media = tmp_path / "media"
    drive = bootsel_drive(media, RP2040_INFO, "RPI-RP2")
    (media / "USBSTICK").mkdir()
    with pytest.raises(WrongBoard, match="RPI-RP2"):
        fw.find_drive([media])
    assert sorted(p.name for p in drive.iterdir()) == ["INDEX.HTM", "INFO_UF2.TXT"]


def test_find_drive(tmp_path):
    media = tmp_path / "media"
    (media / "USBSTICK").mkdir(parents=True)
    assert fw.find_drive([media, tmp_path / "absent"]) is None
    bootsel_drive(media, RP2040_INFO, "RPI-RP2")
    rp2350 = bootsel_drive(media, RP2350_INFO)
    assert fw.find_drive([media]) == rp2350
    bootsel_drive(tmp_path / "run", RP2350_INFO)
    with pytest.raises(NoDrive, match="2 Pico 2 BOOTSEL drives"):
        fw.find_drive([media, tmp_path / "run"])


def test_identity_comparison():
    expected = json.loads(fw.IDENTITY.read_text())
    same = {k: expected[k] for k in ("build", "machine", "version")}
    assert fw.compare_identity(same, expected) is None
    assert fw.build_note(same) is None
    stock = {"build": "RPI_PICO2", "machine": "Raspberry Pi Pico2 with RP2350",
             "version": "v1.29.0 on 2026-07-01", "platform": "rp2"}
    assert "sys.implementation._build is 'RPI_PICO2'" in fw.compare_identity(stock, expected)
    older = dict(same, version="v1.29.0-preview.400.g0123456789 on 2025-11-01")
    assert "os.uname().version" in fw.compare_identity(older, expected)
    note = fw.build_note(stock)
    assert "\n" not in note and note.endswith("install it with `roboray-flash firmware`")


@pytest.mark.micropython
def test_deploy_says_when_the_board_runs_another_build(tmp_path):
    """The virtual board answers as a stock RPI_PICO2 does: deploy goes on
    (stock MicroPython still flies) and says, first and in one line, which
    build it found and the command that installs the RoboRay one."""
    from roboray.tools.micropython.virtual_board import VirtualBoard

    src = tmp_path / "src"
    src.mkdir()
    archive = subprocess.run(["git", "archive", "HEAD", "shared", "firmware"], cwd=ROOT,
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    with VirtualBoard(fs_dir=tmp_path / "fs") as vb:
        proc = flash("deploy", "--port", vb.device, "--src", str(src), "--out", str(tmp_path / "out"),
                     "--no-reset", "--target", "lib", timeout=300)
    assert proc.returncode == 0, proc.stderr
    first = proc.stdout.splitlines()[0]
    assert first.startswith("note: the board runs MicroPython ")
    assert "(RPI_PICO2)" in first and "ROBORAY_PICO2" in first and "`roboray-flash firmware`" in first
    assert "all verified" in proc.stdout


@pytest.mark.micropython
def test_a_running_board_is_sent_to_bootsel_over_the_raw_repl(tmp_path):
    """``Board.bootloader`` runs ``machine.bootloader()`` on the board, as
    ``mpremote bootloader`` does; here a ``machine`` module offered like a
    built-in one records the call in the board's file system."""
    from roboray.tools.flash.board import Board
    from roboray.tools.micropython.virtual_board import VirtualBoard

    machine = tmp_path / "machine.py"
    machine.write_text("import os\n\ndef bootloader():\n"
                       "    with open('/BOOTSEL', 'w') as f:\n        f.write('entered')\n    os.sync()\n")
    fs = tmp_path / "fs"
    with VirtualBoard(fs_dir=fs, modules=[machine]) as vb:
        with Board(vb.device) as board:
            ident = board.identity()
            board.bootloader()
        for _ in range(100):  # the board writes its files back once it waits for input again
            if (fs / "BOOTSEL").exists():
                break
            time.sleep(0.1)
    assert (fs / "BOOTSEL").read_text() == "entered"
    assert ident["build"] == "RPI_PICO2" and ident["machine"] == "Raspberry Pi Pico2 with RP2350"


@pytest.mark.micropython
def test_a_board_running_micropython_becomes_the_drive_it_is_flashed_through(tmp_path):
    """No drive yet, a board on the port: ``firmware`` reads which build it
    runs, sends it to BOOTSEL over the raw REPL and writes the image once its
    drive is there. The board's ``machine.bootloader()`` here leaves a mark
    in its file system, and this test, standing in for the host's automounter,
    mounts the drive (a folder with INFO_UF2.TXT) when it sees the mark."""
    import threading

    from roboray.tools.micropython.virtual_board import VirtualBoard

    machine = tmp_path / "machine.py"
    machine.write_text("import os\n\ndef bootloader():\n"
                       "    with open('/BOOTSEL', 'w') as f:\n        f.write('entered')\n    os.sync()\n")
    fs, media = tmp_path / "fs", tmp_path / "media"
    drive = media / "RP2350"
    stop = threading.Event()

    def automount():
        while not stop.is_set():
            if (fs / "BOOTSEL").exists():
                bootsel_drive(media, RP2350_INFO)
                return
            time.sleep(0.05)

    with VirtualBoard(fs_dir=fs, modules=[machine]) as vb:
        mounter = threading.Thread(target=automount, daemon=True)
        mounter.start()
        try:
            proc = flash("firmware", "--drive", str(drive), "--port", vb.device, "--no-wait", "--json",
                         "--drive-timeout", "60")
        finally:
            stop.set()
            mounter.join()
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["bootloader_from"] == vb.device and r["board_before"]["build"] == "RPI_PICO2"
    assert (drive / "ROBORAY.UF2").read_bytes() == IMAGE.read_bytes()


@pytest.mark.micropython
def test_after_the_copy_the_board_is_checked_for_the_build_written(tmp_path):
    """Without ``--no-wait`` the tool finds the board back on its port and
    compares the build it reports with the image's identity. The virtual
    board reports a stock RPI_PICO2 build: the RoboRay image's check fails in
    one line; an image whose identity is that build's passes."""
    from roboray.tools.flash.board import Board
    from roboray.tools.micropython.virtual_board import VirtualBoard

    with VirtualBoard(fs_dir=tmp_path / "fs") as vb:
        proc = flash("firmware", "--drive", str(bootsel_drive(tmp_path / "a", RP2350_INFO)), "--port", vb.device)
        assert proc.returncode == 1
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "running MicroPython" in lines[0] and "not the image written" in lines[0]
        assert "sys.implementation._build is 'RPI_PICO2', the image's is 'ROBORAY_PICO2'" in lines[0]

        with Board(vb.device) as board:
            stock = board.identity()
        img = tmp_path / "stock" / "stock.uf2"
        img.parent.mkdir()
        img.write_bytes(IMAGE.read_bytes())
        ident = dict(json.loads(fw.IDENTITY.read_text()), build=stock["build"], machine=stock["machine"],
                     version=stock["version"])
        img.with_suffix(".json").write_text(json.dumps(ident))
        drive = bootsel_drive(tmp_path / "b", RP2350_INFO)
        proc = flash("firmware", "--drive", str(drive), "--uf2", str(img), "--port", vb.device)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "%s is back: MicroPython %s, %s (%s), the build written" % (
        vb.device, stock["version"], stock["machine"], stock["build"])
