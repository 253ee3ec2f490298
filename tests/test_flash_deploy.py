"""``roboray-flash deploy`` and ``status`` on the virtual board.

Everything here goes through the real pyserial on a pseudo-terminal and
mpremote's ``SerialTransport`` to the real MicroPython interpreter.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import serial
from mpremote.transport_serial import SerialTransport

from roboray.tools.boardcheck import package_root
from roboray.tools.flash import manifest
from roboray.tools.flash.board import TMP_SUFFIX, Board
from roboray.tools.flash.build import build
from roboray.tools.flash.deploy import deploy, status
from roboray.tools.flash.errors import AppDidNotStart, IncompatibleBoard, NotEnoughSpace, ShadowedModule
from roboray.tools.micropython.virtual_board import VirtualBoard, twin_builtins

pytestmark = pytest.mark.micropython

ROOT = package_root()


def flash(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.tools.flash.cli", *args],
                          capture_output=True, text=True, timeout=timeout)


def snapshot(fs_dir: Path) -> dict[str, bytes]:
    """The board's files as the host sees them. The virtual board's process
    may still be finishing a rename of the deploy's last atomic write (a
    ``.~new`` file) when the host lists the folder, on a loaded machine:
    such a file, or one gone between listing and reading, is not kept."""
    out = {}
    for p in sorted(fs_dir.rglob("*")):
        if p.name.endswith(".~new"):
            continue
        try:
            if p.is_file():
                out[p.relative_to(fs_dir).as_posix()] = p.read_bytes()
        except FileNotFoundError:
            continue
    return out


def board_exec(device: str, code: str) -> str:
    t = SerialTransport(device, timeout=10)
    try:
        t.enter_raw_repl()
        out = t.exec(code).decode()
        t.exit_raw_repl()
    finally:
        t.close()
    return out


def modules_of(b) -> list[str]:
    """Importable module names of a build (not main.py, not the missing app)."""
    names = []
    for path in b.files:
        if path.startswith("/lib/") and path.endswith(".mpy"):
            names.append(path[len("/lib/"):-len(".mpy")].replace("/", ".").replace(".__init__", ""))
    return sorted(names)


@pytest.fixture(scope="module")
def committed_src(tmp_path_factory) -> Path:
    """The committed board code (others' work in progress cannot break these tests)."""
    dest = tmp_path_factory.mktemp("src")
    archive = subprocess.run(["git", "archive", "HEAD", "shared", "firmware"], cwd=ROOT,
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


@pytest.fixture(scope="module")
def deployed(committed_src, tmp_path_factory) -> dict:
    """A board file system holding one deployment of the committed code.

    The first deployment: onto a board where another program runs, which
    the deployment must stop (Ctrl-C) to reach the REPL, as on a Pico.
    """
    work = tmp_path_factory.mktemp("deployed")
    fs = work / "fs"
    fs.mkdir()
    (fs / "main.py").write_text("import time\nwhile True:\n    time.sleep_ms(10)\n")
    b = build(work / "out", src_root=committed_src)
    with VirtualBoard(fs_dir=fs, modules=twin_builtins()) as vb:
        with Board(vb.device) as board:
            report = deploy(board, b, reset=False)
        imported = board_exec(vb.device, "import %s\nprint('ok')" % ", ".join(modules_of(b)))
    return {"src": committed_src, "out": work / "out", "fs": fs, "build": b, "report": report,
            "imported": imported, "fs_after": snapshot(fs)}


@pytest.fixture
def board(deployed, tmp_path):
    """A fresh virtual board already holding the deployment, and its own source tree.

    A bare Pico 2: the twin's ``machine`` (when it exists), nothing on the buses.
    """
    shutil.copytree(deployed["fs"], tmp_path / "fs")
    shutil.copytree(deployed["src"], tmp_path / "src")
    shutil.copytree(deployed["out"], tmp_path / "out")
    with VirtualBoard(fs_dir=tmp_path / "fs", modules=twin_builtins()) as vb:
        vb.src = tmp_path / "src"
        vb.out = tmp_path / "out"
        yield vb


# --------------------------------------------------------------- copying
def test_first_deploy_copies_everything_and_interrupts_the_running_program(deployed):
    b, report, fs = deployed["build"], deployed["report"], deployed["fs_after"]
    assert deployed["imported"].strip() == "ok"
    assert report["files_copied"] == len(b.files) and report["files_unchanged"] == 0
    assert report["bytes_sent"] == sum(e["size"] for e in b.files.values())
    assert report["verified"] is True and report["manifest"] == "no manifest on the board"
    for path, entry in b.files.items():
        assert hashlib.sha256(fs[path.lstrip("/")]).hexdigest() == entry["sha256"]
    on_board = json.loads(fs[manifest.BOARD_PATH.lstrip("/")])
    assert on_board["complete"] is True and on_board["files"] == b.files
    assert not [p for p in fs if p.endswith(TMP_SUFFIX)]


def test_unchanged_changed_and_deleted_sources(board):
    foreign = Path(board.fs_dir) / "lib/roboray/notes.txt"  # not ours: must survive
    b = build(board.out, src_root=board.src)
    with Board(board.device) as bd:
        bd.exec("f = open('/lib/roboray/notes.txt', 'w')\nf.write('mine')\nf.close()", "test setup")
        again = deploy(bd, b, reset=False)
    assert (again["files_copied"], again["files_removed"], again["bytes_sent"]) == (0, 0, 0)
    assert again["files_unchanged"] == len(b.files) and again["verified"] is True
    assert again["wire_bytes"] < sum(e["size"] for e in b.files.values())  # no content, only commands

    quat = board.src / "shared" / "quat.py"
    quat.write_text(quat.read_text() + "\n_DEPLOYED_CHANGE = 1\n")
    b = build(board.out, src_root=board.src)
    with Board(board.device) as bd:
        one = deploy(bd, b, reset=False)
    assert one["copied"] == ["/lib/roboray/shared/quat.mpy"] and one["files_removed"] == 0
    assert one["bytes_sent"] == b.files["/lib/roboray/shared/quat.mpy"]["size"]
    assert board_exec(board.device, "import roboray.shared.quat as q\nprint(q._DEPLOYED_CHANGE)").strip() == "1"

    before = snapshot(Path(board.fs_dir))
    (board.src / "shared" / "modes.py").unlink()
    b = build(board.out, src_root=board.src)
    with Board(board.device) as bd:
        gone = deploy(bd, b, reset=False)
    assert gone["removed"] == ["/lib/roboray/shared/modes.mpy"] and gone["files_copied"] == 0
    after = snapshot(Path(board.fs_dir))
    assert set(before) - set(after) == {"lib/roboray/shared/modes.mpy"}
    assert foreign.read_text() == "mine"


def test_dry_run_changes_nothing(board):
    quat = board.src / "shared" / "quat.py"
    quat.write_text(quat.read_text() + "\n_DRY = 1\n")
    before = snapshot(Path(board.fs_dir))
    proc = flash("deploy", "--port", board.device, "--src", str(board.src), "--out", str(board.out),
                 "--dry-run", "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["dry_run"] is True and report["copied"] == ["/lib/roboray/shared/quat.mpy"]
    assert report["bytes_sent"] == 0 and report["bytes_to_send"] > 0
    assert snapshot(Path(board.fs_dir)) == before


def test_status_compares_the_board_with_the_build(board):
    quat = board.src / "shared" / "quat.py"
    quat.write_text(quat.read_text() + "\n_STATUS = 1\n")
    proc = flash("status", "--port", board.device, "--src", str(board.src), "--out", str(board.out), "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["differ"] == ["/lib/roboray/shared/quat.mpy"] and report["missing"] == []
    assert report["up_to_date"] is False and report["board"]["complete"] is True
    assert report["same"] == report["build"]["files"] - 1
    text = flash("status", "--port", board.device, "--src", str(board.src), "--out", str(board.out))
    assert "  differs  /lib/roboray/shared/quat.mpy" in text.stdout


# ---------------------------------------------------------- interruption
def test_a_killed_deploy_leaves_importable_modules_and_the_next_one_completes(board):
    old = build(board.out, src_root=board.src)
    # Three changed modules; the first (in copy order) large enough that
    # the kill lands while it is on the wire.
    big = board.src / "shared" / "mavlink" / "crc.py"
    big.write_text(big.read_text() + "\n_PAD = %r\n" % ("0123456789abcdef" * 2048))
    for name in ("quat.py", "params.py"):
        f = board.src / "shared" / name
        f.write_text(f.read_text() + "\n_NEW = 1\n")
    new = build(board.out, src_root=board.src)
    changed = sorted(p for p in new.files if new.files[p] != old.files.get(p))
    assert changed == ["/lib/roboray/shared/mavlink/crc.mpy", "/lib/roboray/shared/params.mpy",
                       "/lib/roboray/shared/quat.mpy"]

    proc = subprocess.Popen([sys.executable, "-m", "roboray.tools.flash.cli", "deploy", "--port", board.device,
                             "--src", str(board.src), "--out", str(board.out), "--no-reset"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if "copy 1/3 /lib/roboray/shared/mavlink/crc.mpy" in line:
            time.sleep(0.3)
            proc.send_signal(signal.SIGKILL)
            break
    proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL, "".join(seen)

    fs = Path(board.fs_dir)
    time.sleep(0.2)  # the board mirrors its flash after each input chunk
    # Every module on the board is whole: the old version or the new one.
    for path, entry in new.files.items():
        data = (fs / path.lstrip("/")).read_bytes()
        assert hashlib.sha256(data).hexdigest() in (entry["sha256"], old.files[path]["sha256"]), path
    quat_now = hashlib.sha256((fs / "lib/roboray/shared/quat.mpy").read_bytes()).hexdigest()
    assert quat_now == old.files["/lib/roboray/shared/quat.mpy"]["sha256"]  # not reached: still the old one
    pending = json.loads((fs / manifest.BOARD_PATH.lstrip("/")).read_text())
    assert pending["complete"] is False
    assert board_exec(board.device, "import %s\nprint('ok')" % ", ".join(modules_of(new))).strip() == "ok"

    proc = flash("deploy", "--port", board.device, "--src", str(board.src), "--out", str(board.out),
                 "--no-reset", "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["verified"] is True and report["manifest"] == "the last deployment did not finish"
    assert report["files_hashed_on_board"] == len(new.files)
    assert "/lib/roboray/shared/quat.mpy" in report["copied"] and set(report["copied"]) <= set(changed)
    assert not list(fs.rglob("*" + TMP_SUFFIX))
    for path, entry in new.files.items():
        assert hashlib.sha256((fs / path.lstrip("/")).read_bytes()).hexdigest() == entry["sha256"]
    assert json.loads((fs / manifest.BOARD_PATH.lstrip("/")).read_text())["complete"] is True


def test_a_file_the_flash_stores_wrong_is_refused_and_the_old_one_kept(deployed, tmp_path):
    """The board reads every file back before it replaces the old one: a
    flash that stores a bit wrong fails the deployment with the file named,
    the board still runs the old version, and the next deployment (the flash
    behaving again) completes."""
    for part in ("fs", "src", "out"):
        shutil.copytree(deployed[part], tmp_path / part)
    src, out, fs = tmp_path / "src", tmp_path / "out", tmp_path / "fs"
    quat = src / "shared" / "quat.py"
    quat.write_text(quat.read_text() + "\n_FLAKY = 1\n")
    new = build(out, src_root=src)
    target = "/lib/roboray/shared/quat.mpy"
    old_sha = deployed["build"].files[target]["sha256"]
    assert new.files[target]["sha256"] != old_sha
    with VirtualBoard(fs_dir=fs, modules=twin_builtins(), bad_writes=(target, 1)) as vb:
        proc = flash("deploy", "--port", vb.device, "--src", str(src), "--out", str(out), "--no-reset")
        assert proc.returncode != 0
        err = proc.stderr.strip().splitlines()
        assert "hash mismatch after copying %s" % target in err[-1] and "Traceback" not in proc.stderr
        time.sleep(0.2)  # the board mirrors its flash after each input chunk
        assert hashlib.sha256((fs / target.lstrip("/")).read_bytes()).hexdigest() == old_sha
        assert not list(fs.rglob("*" + TMP_SUFFIX))
        assert json.loads((fs / manifest.BOARD_PATH.lstrip("/")).read_text())["complete"] is False
        assert board_exec(vb.device, "import roboray.shared.quat as q\nprint(hasattr(q, '_FLAKY'))").strip() == "False"

        proc = flash("deploy", "--port", vb.device, "--src", str(src), "--out", str(out), "--no-reset", "--json")
        assert proc.returncode == 0, proc.stderr
        report = json.loads(proc.stdout)
        assert report["verified"] is True and target in report["copied"]
        time.sleep(0.2)
        for path, entry in new.files.items():
            assert hashlib.sha256((fs / path.lstrip("/")).read_bytes()).hexdigest() == entry["sha256"], path


def test_a_build_for_another_mpy_version_is_refused_before_copying(board):
    """The board reports the .mpy version its MicroPython loads; a build
    from another mpy-cross (here: the manifest of one made for .mpy 5) is
    refused with what to do, and nothing on the board changes."""
    quat = board.src / "shared" / "quat.py"
    quat.write_text(quat.read_text() + "\n_OTHER = 1\n")
    b = build(board.out, src_root=board.src)
    b.manifest["mpy_version"] = "5.0"
    before = snapshot(Path(board.fs_dir))
    with Board(board.device) as bd:
        with pytest.raises(IncompatibleBoard, match=r"loads \.mpy version 6, this build is \.mpy 5\.0.*--source"):
            deploy(bd, b, reset=False)
    time.sleep(0.2)
    assert snapshot(Path(board.fs_dir)) == before


# ------------------------------------------------------------- start-up
def _app(src: Path, body: str) -> None:
    (src / "firmware" / "app.py").write_text(
        "from roboray.firmware import build_info\n\n\ndef main():\n    print(build_info.BANNER)\n" + body)


def test_the_reset_confirms_the_version_the_application_reports(board):
    _app(board.src, "    print('IMU not answering on I2C0 at 0x6a')\n")
    b = build(board.out, src_root=board.src)
    with Board(board.device) as bd:
        report = deploy(bd, b, start_timeout_s=10)
    assert report["started"] is True and report["app_state"] == "exited"
    assert report["app_output"].splitlines() == [b.banner, "IMU not answering on I2C0 at 0x6a"]

    # An application that keeps running is interrupted by the next deployment.
    _app(board.src, "    import time\n    while True:\n        time.sleep_ms(20)\n")
    b = build(board.out, src_root=board.src)
    with Board(board.device) as bd:
        report = deploy(bd, b, start_timeout_s=10)
    assert report["app_state"] == "running" and report["copied"] == ["/lib/roboray/firmware/app.mpy"]
    with Board(board.device) as bd:
        assert deploy(bd, b, reset=False)["files_copied"] == 0


def test_a_crash_after_the_start_up_line_fails_the_deploy(board):
    _app(board.src, "    raise OSError(5)\n")
    proc = flash("deploy", "--port", board.device, "--src", str(board.src), "--out", str(board.out))
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1] == (
        "roboray-flash: error: the application started (RoboRay firmware %s unknown) and then crashed: "
        "OSError: [Errno 5] EIO" % build(board.out, src_root=board.src).manifest["version"])


def test_a_missing_application_is_reported_not_hidden(board):
    (board.src / "firmware" / "app.py").unlink(missing_ok=True)
    with Board(board.device) as bd:
        with pytest.raises(AppDidNotStart, match="ImportError: no module named 'roboray.firmware.app'"):
            deploy(bd, build(board.out, src_root=board.src), start_timeout_s=10)


def test_the_firmware_starts_with_its_clear_error_without_hardware(board):
    # The real application (committed) on a bare Pico 2: nothing answers on its buses.
    if not (board.src / "firmware" / "app.py").is_file() or not twin_builtins():
        pytest.skip("firmware/app.py or sim/twin's machine.py (other issues) is not committed yet")
    b = build(board.out, src_root=board.src)
    with Board(board.device) as bd:
        report = deploy(bd, b, start_timeout_s=20)
    lines = report["app_output"].splitlines()
    assert report["files_copied"] == 0 and report["started"] is True and lines[0] == b.banner
    assert "Traceback" not in report["app_output"] and len(lines) >= 2  # its own error, not a crash


# --------------------------------------------------------------- errors
def test_a_missing_port_is_a_one_line_error(committed_src, tmp_path):
    out = tmp_path / "missing" / "x" / "y"
    proc = flash("deploy", "--port", "/dev/no-such-board", "--src", str(committed_src), "--out", str(out))
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1] == (
        "roboray-flash: error: no such port: /dev/no-such-board (is the board plugged in? --port auto finds it)")
    # said before anything was built: nothing written where --out pointed
    assert not (tmp_path / "missing").exists()


def test_a_busy_port_is_a_one_line_error(board):
    holder = serial.Serial(board.device, exclusive=True)
    try:
        proc = flash("status", "--port", board.device, "--src", str(board.src), "--out", str(board.out))
    finally:
        holder.close()
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("roboray-flash: error: port %s is busy" % board.device)


def test_a_silent_board_is_a_one_line_error(committed_src, tmp_path):
    master, slave = os.openpty()  # a port nobody answers on
    device = os.ttyname(slave)
    try:
        proc = flash("deploy", "--port", device, "--src", str(committed_src), "--out", str(tmp_path / "out"),
                     "--timeout", "1")
    finally:
        os.close(master)
        os.close(slave)
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr.strip().splitlines()[-1].startswith(
        "roboray-flash: error: the board on %s is not answering: no MicroPython REPL within 1 s" % device)


def test_not_enough_space_is_found_before_copying(committed_src, tmp_path):
    b = build(tmp_path / "out", src_root=committed_src)
    with VirtualBoard(fs_dir=tmp_path / "fs", flash_bytes=64 * 1024) as vb:
        with Board(vb.device) as bd:
            with pytest.raises(NotEnoughSpace, match=r"not enough space on the board: copying needs \d+ kB, \d+ kB free of 64 kB"):
                deploy(bd, b, reset=False)
    assert snapshot(tmp_path / "fs") == {}


def test_a_foreign_py_that_would_hide_a_module_is_refused(board):
    with Board(board.device) as bd:
        bd.exec("f = open('/lib/roboray/shared/quat.py', 'w')\nf.write('OLD = 1')\nf.close()", "test setup")
        with pytest.raises(ShadowedModule, match=r"/lib/roboray/shared/quat.py on the board was not written by roboray-flash"):
            deploy(bd, build(board.out, src_root=board.src), reset=False)
