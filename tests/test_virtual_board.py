"""The virtual board answers host tools through a real pseudo-terminal."""

from __future__ import annotations

import errno
import subprocess
import sys

import pytest
import serial
from mpremote.transport_serial import SerialTransport

from roboray.tools.micropython.virtual_board import VirtualBoard

pytestmark = pytest.mark.micropython


def test_mpremote_transport_exec_write_read(tmp_path):
    with VirtualBoard(fs_dir=tmp_path) as board:
        t = SerialTransport(board.device, baudrate=115200)
        try:
            t.enter_raw_repl()  # default soft_reset=True: the virtual board reboots like a board
            assert t.exec("import sys\nprint(sys.implementation.name, 6 * 7)").strip() == b"micropython 42"
            payload = bytes(range(256)) * 40  # > one raw-REPL chunk, binary-safe
            t.fs_mkdir("/lib")
            t.fs_writefile("/lib/blob.bin", payload)
            assert t.fs_readfile("/lib/blob.bin") == payload
            assert t.fs_exists("/lib/blob.bin")
            with pytest.raises(OSError) as info:
                t.fs_stat("/no/such/file")
            assert info.value.errno == errno.ENOENT  # a board's 2, not Emscripten's 44
            # a soft reboot keeps the file system, as flash does
            t.exit_raw_repl()
            t.enter_raw_repl(soft_reset=True)
            assert t.fs_readfile("/lib/blob.bin") == payload
            t.exit_raw_repl()
        finally:
            t.close()
    assert (tmp_path / "lib" / "blob.bin").read_bytes() == payload


def test_file_system_survives_a_restart(tmp_path):
    with VirtualBoard(fs_dir=tmp_path) as board:
        t = SerialTransport(board.device)
        t.enter_raw_repl()
        t.fs_writefile("/main_state.txt", b"kept")
        t.exit_raw_repl()
        t.close()
    with VirtualBoard(fs_dir=tmp_path) as board:
        t = SerialTransport(board.device)
        t.enter_raw_repl()
        assert t.fs_readfile("/main_state.txt") == b"kept"
        t.exit_raw_repl()
        t.close()


def test_boot_runs_main_py_in_the_friendly_repl(tmp_path):
    (tmp_path / "main.py").write_text("print('app started', 1 + 2)\n")
    with VirtualBoard(fs_dir=tmp_path) as board:
        port = serial.Serial(board.device, timeout=5)
        port.write(b"\r\n")
        seen = port.read_until(b">>> ")
        port.close()
    assert b"app started 3" in seen


def test_cli_prints_device_path_first(tmp_path):
    proc = subprocess.Popen(
        [sys.executable, "-m", "roboray.tools.flash.cli", "virtual-board", "--fs", str(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        device = proc.stdout.readline().strip()
        assert device.startswith("/dev/")
        t = SerialTransport(device)
        t.enter_raw_repl()
        assert t.exec("print(1 + 1)").strip() == b"2"
        t.exit_raw_repl()
        t.close()
    finally:
        proc.terminate()
        assert proc.wait(timeout=15) == 0
