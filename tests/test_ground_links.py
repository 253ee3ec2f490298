"""``roboray-ground``'s links end to end: MAVProxy's ``--master`` forms over
real UDP and TCP sockets against the twin (``sil --radio udp:``/``tcp:``)
and the demo vehicle, a TCP connection nobody accepts, and a vehicle whose
port goes away under ``watch``, ``status`` and ``log record`` (exit 3, one
line, nothing of pymavlink's on the terminal)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from roboray.ground.link import EXIT_CLOSED, parse_master
from roboray.ground.vehicle import PtyVehicle
from roboray.tools.cli import UsageError


def ground(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.ground.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def errors(stderr: str) -> list[str]:
    """stderr's lines but the log lines (``roboray.x: ...``)."""
    return [ln for ln in stderr.splitlines() if ln.strip() and not ln.startswith("roboray.")]


@pytest.mark.parametrize("text, opened", [
    ("udp:14551", "udpin:0.0.0.0:14551"),
    ("udpin:14551", "udpin:0.0.0.0:14551"),
    ("udp:127.0.0.1:14551", "udpin:127.0.0.1:14551"),
    ("UDPIN:0.0.0.0:14550", "udpin:0.0.0.0:14550"),
    ("udpout:10.0.0.2:14550", "udpout:10.0.0.2:14550"),
    ("tcp:5760", "tcp:127.0.0.1:5760"),
    ("tcpout:sitl.local:5760", "tcp:sitl.local:5760"),
    ("tcpin:5761", "tcpin:0.0.0.0:5761"),
    ("/dev/ttyUSB0", "/dev/ttyUSB0"),
    ("/dev/ttyUSB0,115200", "/dev/ttyUSB0,115200"),
])
def test_masters_as_mavproxy_takes_them(text, opened):
    assert parse_master(text) == opened


@pytest.mark.parametrize("text, words", [
    ("udp:x", "'x' is not a port (1 to 65535; expected udp:PORT or udp:HOST:PORT)"),
    ("tcp:0", "'0' is not a port"),
    ("udp:1:2:3", "expected udp:PORT or udp:HOST:PORT"),
    ("tcp::5760", "no host before the port"),
    ("udpout:14550", "udpout sends to a host: expected udpout:HOST:PORT"),
])
def test_malformed_masters_are_usage_errors(text, words):
    with pytest.raises(UsageError, match=words.replace("(", r"\(").replace(")", r"\)")):
        parse_master(text)
    r = ground("status", "--master", text)
    lines = errors(r.stderr)
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("roboray-ground: error: --master ")
    assert words in lines[0], r.stderr


def test_a_tcp_port_nobody_listens_on_is_one_line_at_once():
    port = free_port()
    r = ground("status", "--master", "tcp:%d" % port)
    assert r.returncode == 1 and r.stdout == ""
    assert r.stderr == ("roboray-ground: error: cannot connect to tcp:127.0.0.1:%d: connection refused: nothing "
                        "listens there (is the vehicle, its bridge or the twin's --radio tcp:PORT running?)\n" % port)
    assert "sleeping" not in r.stderr + r.stdout


def _sil(*args: str) -> subprocess.Popen:
    """The twin on a radio, lingering after a short scenario until SIGINT:
    the test, not the machine's load, says when the vehicle goes."""
    return subprocess.Popen([sys.executable, "-m", "roboray.sim.cli", "sil", "--interpreter", "cpython",
                             "--duration", "2", "--linger", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _radio_line(proc: subprocess.Popen) -> str:
    """The twin's 'radio: ...' line (its first on stderr)."""
    assert proc.stderr is not None
    line = proc.stderr.readline()
    assert line.startswith("radio: "), line
    return line


def _end(sil: subprocess.Popen) -> str:
    """Ctrl-C the lingering twin; its stderr. It exits 0 (the scenario had ended)."""
    sil.send_signal(signal.SIGINT)
    _, err = sil.communicate(timeout=120)
    assert sil.returncode == 0, err
    return err


def test_udp_port_alone_listens_for_the_twin_as_mavproxy_does():
    port = free_port(socket.SOCK_DGRAM)
    sil = _sil("--radio", "udp:%d" % port)
    try:
        assert "--master udp:%d" % port in _radio_line(sil)
        r = ground("status", "--master", "udp:%d" % port, "--json", "--timeout", "60")
        assert r.returncode == 0, r.stderr
        status = json.loads(r.stdout)
        assert status["source"] == "udpin:0.0.0.0:%d" % port and status["system"] == 1 and status["frames"] > 5
        # answers go back to the port the vehicle sent from: a request is served
        r = ground("param", "get", "FS_GCS_TIMEOUT", "--master", "udpin:127.0.0.1:%d" % port, "--json")
        assert r.returncode == 0 and json.loads(r.stdout) == {"FS_GCS_TIMEOUT": 5.0}, r.stderr
    finally:
        _end(sil)


def test_tcp_to_the_twin_as_to_sitl_and_the_end_closes_the_link():
    port = free_port()
    sil = _sil("--radio", "tcp:%d" % port)
    try:
        assert "--master tcp:127.0.0.1:%d" % port in _radio_line(sil)
        r = ground("status", "--master", "tcp:%d" % port, "--json", "--timeout", "60")
        assert r.returncode == 0, r.stderr
        assert json.loads(r.stdout)["source"] == "tcp:127.0.0.1:%d" % port
        # the next ground station takes the line the first one left, and
        # sees the link close when the run ends
        watch, lines, seen = _start("watch", "--master", "tcp:127.0.0.1:%d" % port, "--plain")
        assert seen.wait(120), lines
    finally:
        _end(sil)
    err = watch.stderr.read()
    watch.wait(timeout=60)
    assert watch.returncode == EXIT_CLOSED, err
    assert errors(err) == ["roboray-ground: error: link closed: the vehicle closed the TCP connection "
                           "(tcp:127.0.0.1:%d)" % port]
    assert any("disarmed" in ln or "ARMED" in ln for ln in lines), lines
    assert "EOF" not in "\n".join(lines) + err


def test_tcpin_waits_for_the_vehicle_to_connect():
    """A vehicle (the demo vehicle behind a bridge) connects to the ground
    station listening on ``tcpin:PORT``."""
    import serial

    port = free_port()
    stop = threading.Event()
    errors_seen: list = []

    def bridge(device: str) -> None:
        line = serial.Serial(device, 57600, timeout=0)
        sock = None
        try:
            while sock is None and not stop.is_set():
                try:
                    sock = socket.create_connection(("127.0.0.1", port), timeout=1)
                except OSError:
                    time.sleep(0.1)
            if sock is None:
                return
            sock.setblocking(False)
            while not stop.is_set():
                data = line.read(4096)
                if data:
                    sock.sendall(data)
                try:
                    up = sock.recv(4096)
                except BlockingIOError:
                    up = None
                if up == b"":
                    return
                if up:
                    line.write(up)
                time.sleep(0.005)
        except (ConnectionResetError, BrokenPipeError):
            pass    # the ground station left when its command was done
        except Exception as exc:  # reported by the assertion below
            errors_seen.append(repr(exc))
        finally:
            line.close()
            if sock is not None:
                sock.close()

    with PtyVehicle() as vehicle:
        t = threading.Thread(target=bridge, args=(vehicle.device,), daemon=True)
        t.start()
        try:
            r = ground("status", "--master", "tcpin:%d" % port, "--json", "--timeout", "20")
        finally:
            stop.set()
            t.join(timeout=10)
    assert r.returncode == 0, r.stderr
    status = json.loads(r.stdout)
    assert status["source"] == "tcpin:0.0.0.0:%d" % port and status["system"] == 1 and status["frames"] > 5
    assert not errors_seen, errors_seen


def _start(*args: str) -> tuple[subprocess.Popen, list, threading.Event]:
    """A long-running ground command, its stdout lines read as they come."""
    proc = subprocess.Popen([sys.executable, "-m", "roboray.ground.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    lines: list = []
    seen = threading.Event()

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line.rstrip("\n"))
            if "waiting" not in line:
                seen.set()

    threading.Thread(target=read, daemon=True).start()
    return proc, lines, seen


def _holds(proc: subprocess.Popen, device: str) -> bool:
    """Whether the process has ``device`` open."""
    fds = "/proc/%d/fd" % proc.pid
    try:
        return any(os.readlink(os.path.join(fds, fd)) == device for fd in os.listdir(fds))
    except OSError:
        return False


def test_a_port_that_goes_away_ends_watch_status_and_log_record_with_exit_3(tmp_path):
    log = tmp_path / "cut.tlog"
    # one vehicle each: readers sharing a serial line would share its bytes
    vehicles = [PtyVehicle().start() for _ in range(3)]
    devices = [v.device for v in vehicles]
    try:
        watch, watch_lines, watch_seen = _start("watch", "--master", devices[0], "--plain")
        status, status_lines, _ = _start("status", "--master", devices[1], "--listen", "600")
        record, record_lines, _ = _start("log", "record", str(log), "--master", devices[2])
        # a loaded machine may take seconds to start the CLIs: pull the
        # ports only once each holds its own, and watch and the record
        # have had the vehicle
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not (
                all(_holds(p, d) for p, d in zip((watch, status, record), devices))
                and watch_seen.is_set() and log.exists() and log.stat().st_size > 0):
            time.sleep(0.2)
        assert watch_seen.is_set(), watch_lines
        time.sleep(1.0)
    finally:
        for v in vehicles:
            v.close()   # the radio's USB plug pulled, the twin's pseudo-terminal closed
    for proc, lines, device in zip((watch, status, record), (watch_lines, status_lines, record_lines), devices):
        want = "roboray-ground: error: link closed: the vehicle's port went away (%s)" % device
        err = proc.stderr.read()    # stdout is the reader thread's
        proc.wait(timeout=60)
        out = "\n".join(lines)
        assert proc.returncode == EXIT_CLOSED, (proc.args, err)
        assert errors(err) == [want], (proc.args, err)
        assert "is dead" not in out + err and "Traceback" not in err and "Errno" not in err
    assert any("disarmed" in ln or "ARMED" in ln for ln in watch_lines)
    # what was recorded before the port went away reads whole
    r = ground("tlog", "dump", str(log), "--json")
    assert r.returncode == 0 and len(r.stdout.splitlines()) > 5, r.stderr
