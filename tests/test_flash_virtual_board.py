"""What the flashing tool needs of the virtual board: Ctrl-C, statvfs, built-ins."""

from __future__ import annotations

import pytest
import serial
from mpremote.transport_serial import SerialTransport

from roboray.tools.micropython.virtual_board import PICO2_FLASH_BYTES, VirtualBoard

pytestmark = pytest.mark.micropython


def test_ctrl_c_interrupts_a_running_main_py(tmp_path):
    (tmp_path / "main.py").write_text(
        "import time\nn = 0\nwhile True:\n    n += 1\n    time.sleep_ms(5)\n")
    with VirtualBoard(fs_dir=tmp_path) as board:
        port = serial.Serial(board.device, timeout=5)
        port.write(b"\x03")
        seen = port.read_until(b">>> ")
        port.close()
    assert b"KeyboardInterrupt" in seen and seen.endswith(b">>> ")


def test_statvfs_reports_a_pico2_flash_and_what_files_use(tmp_path):
    with VirtualBoard(fs_dir=tmp_path) as board:
        t = SerialTransport(board.device, timeout=10)
        t.enter_raw_repl()
        t.exec("import os")
        empty = t.eval("os.statvfs('/')")
        t.fs_writefile("/blob.bin", bytes(10000))  # three 4 kB blocks
        used = t.eval("os.statvfs('/')")
        t.exit_raw_repl()
        t.close()
    assert empty[:3] == (4096, 4096, PICO2_FLASH_BYTES // 4096)
    assert empty[3] == empty[4] and empty[2] - empty[3] == 2  # superblock pair only
    assert empty[3] - used[3] == 3


def test_builtin_modules_are_importable_but_not_on_the_flash(tmp_path):
    builtins = tmp_path / "builtins"
    builtins.mkdir()
    (builtins / "machine.py").write_text("def unique_id():\n    return b'\\x01\\x02'\n")
    fs = tmp_path / "fs"
    with VirtualBoard(fs_dir=fs, modules=[builtins / "machine.py"]) as board:
        t = SerialTransport(board.device, timeout=10)
        t.enter_raw_repl()
        out = t.exec("import machine, os\nprint(machine.unique_id(), os.listdir('/'))").decode()
        t.exit_raw_repl()
        t.close()
    # a Pico 2's empty flash at the root: no built-ins, none of Emscripten's folders
    assert out.strip() == "b'\\x01\\x02' []"
    assert list(fs.iterdir()) == []  # never synced to the board's flash
    with pytest.raises(ValueError, match="modules: .* is not a .py file"):
        VirtualBoard(modules=[tmp_path / "nowhere.py"])
