"""mpremote, the command-line tool, against the virtual board as against a Pico 2.

Each command runs the real ``mpremote`` as a subprocess on the board's
pseudo-terminal, with a time-out, so a hang fails the test instead of
blocking the suite.
"""

from __future__ import annotations

import hashlib
import os
import re
import select
import subprocess
import sys
import time

import pytest
import serial
from mpremote.transport_serial import SerialTransport

from roboray.tools.micropython.virtual_board import IDENTITY, PICO2_FLASH_BYTES, VirtualBoard

pytestmark = pytest.mark.micropython

TIMEOUT_S = 60

# Every byte value, and the serial line's control sequences (Ctrl-C, Ctrl-D,
# mount's 0x18 command byte, a raw-paste request, an error and a banner the
# port would print), for what crosses the line as data.
AWKWARD = (bytes(range(256)) * 4 + b"\x05A\x01\x03\x04\x18\x03OSError: 44\r\n"
           b"MicroPython v1.29.0-6.gabc on 2026-08-25; JS with Emscripten\r\n" + bytes(range(255, -1, -1)))


def mpremote(board: VirtualBoard, *args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mpremote", "connect", board.device, *args],
                          capture_output=True, text=True, timeout=TIMEOUT_S, cwd=cwd)


def ok(board: VirtualBoard, *args: str, cwd=None) -> str:
    proc = mpremote(board, *args, cwd=cwd)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    return proc.stdout


def cpu_s(pid: int) -> float:
    """CPU time the process has used so far (Linux)."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def assert_idle(board: VirtualBoard) -> None:
    """The board's interpreter sits waiting, not spinning a core."""
    pid = board._proc.pid
    before = cpu_s(pid)
    time.sleep(2.0)
    used = cpu_s(pid) - before
    assert used < 0.2, "the idle virtual board used %.2f s of CPU in 2 s" % used


def listing(text: str) -> dict[str, int]:
    """``mpremote ls`` lines as name -> size."""
    out = {}
    for line in text.splitlines()[1:]:
        size, name = line.split()
        out[name] = int(size)
    return out


def test_ls_shows_sizes_at_a_pico_root(tmp_path):
    fs = tmp_path / "fs"
    (fs / "lib").mkdir(parents=True)
    (fs / "empty").mkdir()
    (fs / "a.txt").write_bytes(b"hello\n")
    (fs / "lib" / "big.bin").write_bytes(bytes(5000))
    with VirtualBoard(fs_dir=fs) as board:
        # only the flash's files: none of Emscripten's tmp/ home/ dev/ proc/
        assert listing(ok(board, "ls", ":")) == {"a.txt": 6, "lib/": 0, "empty/": 0}
        assert listing(ok(board, "fs", "ls", ":lib")) == {"big.bin": 5000}
        names, entries, statvfs = eval(ok(board, "exec", "import os\n"
                                          "print(repr((os.listdir('/'), list(os.ilistdir('/lib')), os.statvfs('/'))))"))
        assert sorted(names) == ["a.txt", "empty", "lib"]
        assert entries == [("big.bin", 0x8000, 0, 5000)]  # littlefs's (name, type, inode, size)
        bsize, _, blocks, free = statvfs[:4]
        df = ok(board, "df").splitlines()
    assert df[0].split() == ["filesystem", "size", "used", "avail", "use%", "mounted", "on"]
    assert len(df) == 2  # the flash, mounted at /
    size, used, avail = (int(x) for x in df[1].split()[1:4])
    assert df[1].split()[-1] == "/"
    assert (size, used, avail) == (bsize * blocks, bsize * (blocks - free), bsize * free)
    assert size == PICO2_FLASH_BYTES
    # the superblocks, a block each file, the two folders' metadata
    assert blocks - free == 2 + 1 + 2 + 2 + 2


def test_identity_is_the_rp2_ports_on_a_pico2(tmp_path):
    code = ("import os, sys\nu = os.uname()\n"
            "print(repr((tuple(u), repr(u), sys.platform, sys.implementation._machine,"
            " sys.implementation._build, sys.version, sys.implementation.version)))")
    with VirtualBoard(fs_dir=tmp_path) as board:
        uname, shown, platform, machine, build, version, impl = eval(ok(board, "exec", code))
        again = eval(ok(board, "exec", code))  # after another soft reset
        port = serial.Serial(board.device, timeout=5)
        port.write(b"\x02")  # the friendly REPL's banner
        banner = port.read_until(b">>> ")
        port.close()
    release = "%d.%d.%d" % impl[:3]
    date = re.search(r" on (\d{4}-\d\d-\d\d)$", uname[3]).group(1)
    assert uname == ("rp2", "rp2", release, "v%s on %s" % (release, date), "Raspberry Pi Pico2 with RP2350")
    assert shown.startswith("(sysname='rp2', nodename='rp2', release=")  # printed as rp2's attrtuple
    assert (platform, machine, build) == ("rp2", IDENTITY["machine"], "RPI_PICO2")
    assert version == "3.4.0; MicroPython v%s on %s" % (release, date)
    assert again[0] == uname and again[2] == "rp2"
    assert ("MicroPython v%s on %s; Raspberry Pi Pico2 with RP2350\r\n" % (release, date)).encode() in banner
    assert b"Emscripten" not in banner


def test_mount_runs_and_writes_host_files_and_leaves_the_board_idle(tmp_path):
    local = tmp_path / "local"
    local.mkdir()
    (local / "hello.py").write_text("GREETING = 'from the host'\n")
    (local / "awkward.bin").write_bytes(AWKWARD)
    code = ("import os, hashlib, binascii, hello\n"
            "print(hello.GREETING, os.getcwd(), sorted(os.listdir('/')))\n"
            "d = open('awkward.bin', 'rb').read()\n"
            "print(binascii.hexlify(hashlib.sha256(d).digest()).decode(), len(d))\n"
            "open('copy.bin', 'wb').write(d)\n"
            "os.mkdir('made')\n")
    with VirtualBoard(fs_dir=tmp_path / "fs") as board:
        ok(board, "fs", "touch", ":on_flash.txt")
        out = ok(board, "mount", str(local), "exec", code)
        after = ok(board, "exec", "import os\nprint(sorted(os.listdir('/')))")
        assert_idle(board)
    lines = out.splitlines()
    assert lines[0] == "Local directory %s is mounted at /remote" % local
    # the mount point is listed at the root as on a Pico, beside the flash's files
    assert lines[1] == "from the host /remote ['on_flash.txt', 'remote']"
    assert lines[2] == "%s %d" % (hashlib.sha256(AWKWARD).hexdigest(), len(AWKWARD))
    assert (local / "copy.bin").read_bytes() == AWKWARD
    assert (local / "made").is_dir()
    assert after.strip() == "['on_flash.txt']"  # the next session's soft reset unmounted it
    assert not (tmp_path / "fs" / "copy.bin").exists()


def test_mount_gives_up_when_the_host_goes_silent(tmp_path):
    local = tmp_path / "local"
    local.mkdir()
    (local / "data.txt").write_text("x" * 1000)
    with VirtualBoard(fs_dir=tmp_path / "fs") as board:
        t = SerialTransport(board.device, baudrate=115200)
        try:
            t.enter_raw_repl()
            t.mount_local(str(local))
            line = t.serial.orig_serial
            t.serial = line  # from here the host serves nothing but one sync byte
            t.exec_raw_no_follow("open('data.txt')")
            assert t.read_until(1, b"\x18", timeout=10).endswith(b"\x18")  # the board asks
            line.write(b"\x18")  # acknowledged, then silence: the host is gone
            said = t.read_until(1, b"\x04>", timeout=10)
        finally:
            t.close()
        # mpremote's board side waits a second for an answer, then gives up, as on a Pico
        assert b"timeout waiting for remote" in said
        assert_idle(board)
        assert ok(board, "exec", "print(6 * 7)").strip() == "42"


def test_mount_survives_a_soft_reset_in_mpremotes_repl(tmp_path):
    local = tmp_path / "local"
    local.mkdir()
    (local / "hello.py").write_text("print('hello from', __name__)\n")
    with VirtualBoard(fs_dir=tmp_path / "fs") as board:
        master, slave = os.openpty()  # mpremote's REPL wants a terminal
        proc = subprocess.Popen([sys.executable, "-m", "mpremote", "connect", board.device, "mount", str(local)],
                                stdin=slave, stdout=slave, stderr=slave, start_new_session=True)
        os.close(slave)
        seen = b""

        def until(text: bytes) -> None:
            nonlocal seen
            end = time.monotonic() + TIMEOUT_S
            while text not in seen:
                assert time.monotonic() < end, "waited for %r; got %r" % (text, seen[-300:])
                if select.select([master], [], [], 0.2)[0]:
                    seen += os.read(master, 4096)

        try:
            until(b">>> ")
            os.write(master, b"import hello\r")
            until(b"hello from hello")
            seen = b""
            os.write(master, b"\x04")  # Ctrl-D: soft reset, which mpremote follows with a remount
            until(b"Remount local directory")
            until(b">>> ")
            os.write(master, b"import os; print(os.getcwd(), 'hello.py' in os.listdir())\r")
            until(b"/remote True")
            os.write(master, b"\x1d")  # Ctrl-]: leave
            assert proc.wait(timeout=TIMEOUT_S) == 0
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
            os.close(master)
        assert b"MPY: soft reboot" in seen


def test_fs_commands_and_errors_as_on_a_pico(tmp_path):
    tree = tmp_path / "tree"
    (tree / "sub").mkdir(parents=True)
    (tree / "one.txt").write_text("one\n")
    (tree / "sub" / "awkward.bin").write_bytes(AWKWARD)
    fs = tmp_path / "fs"
    with VirtualBoard(fs_dir=fs) as board:
        ok(board, "fs", "cp", "-r", str(tree), ":")
        assert (fs / "tree" / "sub" / "awkward.bin").read_bytes() == AWKWARD  # written back to the host folder
        assert ok(board, "fs", "cat", ":tree/one.txt") == "one\n"
        ok(board, "fs", "cp", ":tree/sub/awkward.bin", str(tmp_path / "back.bin"))
        assert (tmp_path / "back.bin").read_bytes() == AWKWARD
        ok(board, "fs", "mkdir", ":made")
        again = mpremote(board, "fs", "mkdir", ":made")
        assert again.returncode == 1 and "mkdir: made: File exists." in again.stderr
        missing = mpremote(board, "fs", "cat", ":nope")
        assert missing.returncode == 1 and "cat: nope: No such file or directory." in missing.stderr
        ok(board, "fs", "rm", "-r", ":tree")
        assert listing(ok(board, "ls")) == {"made/": 0}
        errors = mpremote(board, "exec", "import os, errno\ntry:\n    os.stat('/nope')\nexcept OSError as e:\n"
                          "    print(e.errno == errno.ENOENT)\nos.mkdir('/made/x')\nos.rmdir('/made')")
    assert not (fs / "tree").exists() and (fs / "made").is_dir()
    # the interpreter's own errno numbers, as a board prints them (not Emscripten's 44, 55)
    assert errors.returncode == 1
    assert errors.stdout.splitlines()[0] == "True" and errors.stdout.splitlines()[-1] == "OSError: 39"


def test_exec_eval_run_resume_and_soft_reset(tmp_path):
    fs = tmp_path / "fs"
    fs.mkdir()
    (fs / "main.py").write_text("open('ran.txt', 'a').write('x')\n")
    (tmp_path / "prog.py").write_text("import sys\nprint('running on', sys.platform)\n")
    with VirtualBoard(fs_dir=fs) as board:
        assert ok(board, "run", str(tmp_path / "prog.py")) == "running on rp2\n"
        assert ok(board, "eval", "6 * 7") == "42\n"
        failed = mpremote(board, "exec", "1 / 0")
        assert failed.returncode == 1 and failed.stdout.splitlines()[-1] == "ZeroDivisionError: divide by zero"
        ok(board, "exec", "kept = 41")
        assert ok(board, "resume", "eval", "kept + 1") == "42\n"  # no soft reset: the globals stay
        gone = mpremote(board, "eval", "kept")  # a soft reset first: they are gone
        assert gone.returncode == 1 and gone.stdout.splitlines()[-1] == "NameError: name 'kept' isn't defined"
        assert ok(board, "exec", "kept = 1", "soft-reset", "eval", "'kept' in globals()") == "False\n"
        ran = ok(board, "fs", "cat", ":ran.txt")
    # main.py ran once, at power-on: a soft reset in the raw REPL runs boot.py only, as on a board
    assert ran == "x"


def test_reset_restarts_the_board_as_from_power_on(tmp_path):
    builtins = tmp_path / "builtins"
    builtins.mkdir()
    (builtins / "machine.py").write_text("def reset():\n    raise RuntimeError('the virtual board restarts')\n")
    fs = tmp_path / "fs"
    fs.mkdir()
    (fs / "main.py").write_text(
        "try:\n    n = int(open('boots.txt').read())\nexcept OSError:\n    n = 0\n"
        "open('boots.txt', 'w').write(str(n + 1))\nprint('main.py, boot', n + 1)\n")
    with VirtualBoard(fs_dir=fs, modules=[builtins / "machine.py"]) as board:
        board.wait_for_boot(1)
        ok(board, "exec", "kept = 1")
        ok(board, "resume", "reset")  # mpremote's: machine.reset() after 100 ms, then it exits
        # as after a Pico's reset, wait for it to be back before talking to
        # it: sent sooner, the next command's Ctrl-C interrupts the pending
        # reset, or the reset drops its raw-REPL request and mpremote (which
        # reads a pseudo-terminal without a time-out) waits for ever
        board.wait_for_boot(2)
        boots = ok(board, "resume", "exec", "print(open('boots.txt').read(), 'kept' in globals())")
        soft = ok(board, "exec", "import machine\nmachine.soft_reset()")
        after_soft = ok(board, "resume", "fs", "cat", ":boots.txt")
        port = serial.Serial(board.device, timeout=5)
        port.write(b"\x02")  # the friendly REPL
        port.read_until(b">>> ")
        port.write(b"import machine; machine.reset()\r\n")
        hard = port.read_until(b">>> ")
        board.wait_for_boot(3)
        port.write(b"import sys; sys.exit()\r")
        exited = port.read_until(b">>> ")
        port.close()
        final = ok(board, "fs", "cat", ":boots.txt")
    assert boots.split() == ["2", "False"]  # main.py ran again, the REPL's globals are gone
    assert soft == "" and after_soft == "2"  # a soft reset from the raw REPL: main.py not run
    # from the friendly REPL: machine.reset() says nothing of a soft reboot, runs main.py, shows the banner
    assert b"main.py, boot 3" in hard and b"soft reboot" not in hard
    assert b"Raspberry Pi Pico2 with RP2350\r\n" in hard and hard.endswith(b"\r\n>>> ")
    assert hard.count(b">>> ") == 1  # the reset lost what was left of the line (the \n), as USB would
    # sys.exit() in the friendly REPL: a soft reboot, which runs main.py
    assert b"MPY: soft reboot\r\n" in exited and b"main.py, boot 4" in exited
    assert final == "4" and board.boots == 3  # power-on and two machine.reset()s


def test_a_program_reads_stdin_and_ctrl_c_interrupts_the_wait(tmp_path):
    with VirtualBoard(fs_dir=tmp_path) as board:
        port = serial.Serial(board.device, timeout=10)
        port.write(b"\x02")
        port.read_until(b">>> ")
        port.write(b"import sys; print(sys.stdin.buffer.read(5))\r")
        port.read_until(b"read(5))\r\n")
        port.write(b"ab")
        time.sleep(0.3)
        port.write(b"\x00\xffz")
        read = port.read_until(b">>> ")
        port.write(b"sys.stdin.buffer.read(1)\r")
        port.read_until(b"read(1)\r\n")
        time.sleep(0.3)
        port.write(b"\x03")
        interrupted = port.read_until(b">>> ")
        # input(), which the port answers with NULs for ever, reads the line as rp2's readline
        port.write(b"name = input('name? ')\r")
        prompt = port.read_until(b"\r\nname? ")
        port.write(b"bobx\x7f\xc3\xa9\r")
        echoed = port.read_until(b">>> ")
        port.write(b"print(repr(name))\r")
        named = port.read_until(b">>> ")
        port.close()
        assert_idle(board)
    assert read.startswith(b"b'ab\\x00\\xffz'")  # it waited for all five bytes, binary ones included
    assert b"KeyboardInterrupt" in interrupted
    assert prompt.endswith(b"')\r\nname? ") and echoed == b"bobx\x08 \x08\xc3\xa9\r\n>>> "
    assert "'bobé'".encode() in named
