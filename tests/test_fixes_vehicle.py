"""``roboray-ground fixes`` end to end: the real command (a subprocess)
reads real sockets (UDP, TCP either way) and a pseudo-terminal through
pyserial, and relays to the board's MAVLink endpoint running on MicroPython
behind a pseudo-terminal (``PtyVehicle``, what ``demo-vehicle`` serves): the
fix the endpoint holds is the one sent, at the right place and time on the
vehicle's own clock."""

from __future__ import annotations

import json
import math
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import tty

import pytest

from roboray.ground import nmea
from roboray.ground.fixes_geo import Origin
from roboray.ground.vehicle import PtyVehicle

ORIGIN = (63.43, 10.395)


def relay(*args: str, stdout=subprocess.PIPE) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "roboray.ground.cli", "fixes", *args],
                            stdout=stdout, stderr=subprocess.PIPE, text=True)


def ground(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.ground.cli", *args], capture_output=True, text=True,
                          timeout=60)


def _port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def vehicle():
    with PtyVehicle() as v:
        yield v


class Received:
    """What the vehicle's endpoint holds, read with its loop stopped, and
    its clock then: ``now_ms`` was read between ``h0`` and ``h1`` (host
    Unix time)."""

    def __init__(self, v: PtyVehicle) -> None:
        v.stop()
        try:
            mp = v.interpreter
            self.fix = [float(x) for x in mp.eval("list(__ep.fix)")]
            self.time_us = int(mp.eval("__ep.fix_time_us"))
            self.count = int(mp.eval("__ep.fix_count"))
            self.h0 = time.time()
            self.now_ms = int(mp.eval("time.ticks_ms()"))
            self.h1 = time.time()
        finally:
            v.resume()

    def check_time(self, measured_unix: float, uncertainty_ms: float) -> None:
        """The fix's time_usec is ``measured_unix`` on the vehicle's clock."""
        # the vehicle's clock read now_ms at some host time in [h0, h1]
        earliest = self.now_ms / 1000.0 - (self.h1 - measured_unix)
        latest = self.now_ms / 1000.0 - (self.h0 - measured_unix)
        slack = uncertainty_ms / 1000.0 + 0.003    # its clock's ms steps and the exchange's bound
        assert earliest - slack <= self.time_us / 1e6 <= latest + slack, (
            self.time_us / 1e6, earliest, latest, slack)


def _finish(p: subprocess.Popen, stop: threading.Event, timeout: float = 90) -> tuple:
    try:
        out, err = p.communicate(timeout=timeout)
    finally:
        stop.set()
    return out, err


def _gga(unix: float, lat: float, lon: float, body_only: bool = False) -> str:
    tod = unix % 86400.0
    hh, mm, ss = int(tod // 3600), int(tod % 3600 // 60), tod % 60

    def dm(value: float, digits: int) -> str:
        d = int(abs(value))
        return "%0*d%09.6f" % (digits, d, (abs(value) - d) * 60)

    body = "GPGGA,%02d%02d%06.3f,%s,%s,%s,%s,1,08,0.9,0.00,M,39.5,M,," % (
        hh, mm, ss, dm(lat, 2), "N" if lat >= 0 else "S", dm(lon, 3), "E" if lon >= 0 else "W")
    return body if body_only else nmea.sentence(body)


def test_nmea_over_udp_reaches_the_vehicle_in_metres_at_its_measurement_time(vehicle):
    before = Received(vehicle).count
    port = _port()
    p = relay("udpin:127.0.0.1:%d" % port, "--origin", "%r,%r" % ORIGIN, "--rate-hz", "5", "--count", "3",
              "--json", "--master", vehicle.device)
    stop = threading.Event()
    measured: dict = {}

    def feed() -> None:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        k = 0
        while not stop.is_set():
            k += 1
            t = round(time.time() - 0.1, 3)      # the UGPS measured 0.1 s ago (GGA: to the ms here)
            good = _gga(t, ORIGIN[0] + 1e-5 * k, ORIGIN[1] - 2e-5 * k)
            measured[k] = t
            bad = good[:-2] + "%02X" % (int(good[-2:], 16) ^ 0x55)
            # one datagram with a bad sentence, another sentence type and the fix
            s.sendto(("%s\r\n$GPHDT,68.34,T*3C\r\n%s\r\n" % (bad, good)).encode(), ("127.0.0.1", port))
            stop.wait(0.25)
        s.close()

    threading.Thread(target=feed, daemon=True).start()
    out, err = _finish(p, stop)
    assert p.returncode == 0, err
    r = json.loads(out)
    assert r["out"] == 3 and r["rejected"]["checksum"] >= 3 and r["ignored"]["GPHDT"] >= 3
    assert "rejected (checksum): checksum" in err     # the first of each kind said once, in words
    assert r["origin"] == {"lat_deg": ORIGIN[0], "lon_deg": ORIGIN[1], "from": "--origin"}
    assert r["vehicle_clock"]["via"] == "TIMESYNC" and r["viso_delay_ms"] == 210
    got = Received(vehicle)
    # (at least: the shared vehicle may still have been taking the previous
    # test's last fix when ``before`` was read; r["out"] counts ours exactly)
    assert got.count - before >= 3
    last = r["last_fix"]
    assert got.fix[0] == pytest.approx(last["north_m"], abs=1e-4) and got.fix[1] == pytest.approx(last["east_m"], abs=1e-4)
    assert math.isnan(got.fix[2]) and got.time_us == last["time_usec"]
    k = round(last["north_m"] / (Origin(*ORIGIN).north_east(ORIGIN[0] + 1e-5, ORIGIN[1])[0]))
    assert last["east_m"] == pytest.approx(Origin(*ORIGIN).north_east(ORIGIN[0], ORIGIN[1] - 2e-5 * k)[1], abs=1e-3)
    # the vehicle's clock at the instant GGA's time says
    got.check_time(measured[k], r["vehicle_clock"]["uncertainty_ms"])


def test_json_lines_from_a_tcp_tracker_we_connect_to(vehicle):
    before = Received(vehicle).count
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    port = server.getsockname()[1]
    stop = threading.Event()
    measured: dict = {}

    def serve() -> None:
        conn, _ = server.accept()
        k = 0
        with conn:
            conn.sendall(b"tracker v2 starting\n")     # not JSON: rejected, counted
            while not stop.is_set():
                k += 1
                t = time.time() - 0.04
                measured[k] = t
                line = json.dumps({"stamp": t, "pos": {"x": 0.25 * k, "y": 2.0 + 0.01 * k, "z": 1.5}})
                try:
                    conn.sendall(line.encode() + b"\n")
                except OSError:
                    return
                stop.wait(0.2)

    threading.Thread(target=serve, daemon=True).start()
    p = relay("tcp:127.0.0.1:%d" % port, "--format", "json", "--fields", "t=stamp,north=pos.y,east=-pos.x,down=pos.z",
              "--latency-ms", "15", "--count", "4", "--json", "--master", vehicle.device)
    out, err = _finish(p, stop)
    server.close()
    assert p.returncode == 0, err
    r = json.loads(out)
    assert r["out"] == 4 and r["rejected"] == {"not_json": 1}
    got = Received(vehicle)
    assert got.count - before == 4
    k = round((r["last_fix"]["north_m"] - 2.0) / 0.01)
    assert got.fix[:3] == pytest.approx([2.0 + 0.01 * k, -0.25 * k, 1.5], abs=1e-5)
    got.check_time(measured[k] - 0.015, r["vehicle_clock"]["uncertainty_ms"])


def test_csv_from_a_tracker_that_connects_to_us(vehicle):
    before = Received(vehicle).count
    port = _port(socket.SOCK_STREAM)
    p = relay("tcpin:127.0.0.1:%d" % port, "--count", "2", "--no-hold", "--json", "--master", vehicle.device)
    stop = threading.Event()

    def connect_and_send() -> None:
        while not stop.is_set():
            try:
                conn = socket.create_connection(("127.0.0.1", port), timeout=1)
                break
            except OSError:
                stop.wait(0.2)      # the relay is not listening yet
        else:
            return
        with conn:
            conn.sendall(b"1.0,2.0\n")      # before the header: refused
            conn.sendall(b"north,east,t,down\n")
            k = 0
            while not stop.is_set():
                k += 1
                try:
                    conn.sendall(b"%.3f,%.3f,%.6f,%.2f\n" % (-1.0 * k, 0.5, time.time(), 3.25))
                except OSError:
                    return
                stop.wait(0.6)

    threading.Thread(target=connect_and_send, daemon=True).start()
    out, err = _finish(p, stop)
    assert p.returncode == 0, err
    r = json.loads(out)
    assert r["out"] == 2 and r["rejected"] == {"no_header": 1} and r["ignored"] == {"header": 1}
    assert r["held"] == 0 and r["hold"] is False
    got = Received(vehicle)
    assert got.count - before == 2 and got.fix[1:3] == [0.5, 3.25] and got.fix[0] == r["last_fix"]["north_m"]


def test_nmea_from_a_serial_port_on_a_pseudo_terminal(vehicle):
    before = Received(vehicle).count
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    path = os.ttyname(slave)
    p = relay("%s,9600" % path, "--time", "arrival", "--latency-ms", "30", "--count", "2", "--json",
              "--master", vehicle.device)
    stop = threading.Event()

    def write() -> None:
        k = 0
        while not stop.is_set():
            k += 1
            os.write(master, ("%s\r\n" % _gga(time.time(), ORIGIN[0] - 1e-5 * k, ORIGIN[1])).encode())
            stop.wait(0.6)

    threading.Thread(target=write, daemon=True).start()
    try:
        out, err = _finish(p, stop)
    finally:
        os.close(master)
        os.close(slave)
    assert p.returncode == 0, err
    r = json.loads(out)
    assert r["out"] == 2 and r["source"] == "%s at 9600 baud" % path and r["origin"]["from"] == "the first fix"
    got = Received(vehicle)
    assert got.count - before == 2
    # metres south of the first fix the relay heard
    assert got.fix[0] < 0 and got.fix[0] == pytest.approx(r["last_fix"]["north_m"], abs=1e-4)
    step = -Origin(*ORIGIN).north_east(ORIGIN[0] - 1e-5, ORIGIN[1])[0]     # 1.115 m at 63.4 deg
    assert got.fix[0] == pytest.approx(-step * round(-got.fix[0] / step), abs=3e-3) and abs(got.fix[1]) < 1e-3


def test_ctrl_c_ends_the_relay_with_its_summary(vehicle):
    port = _port()
    p = relay("udpin:127.0.0.1:%d" % port, "--no-hold", "--json", "--master", vehicle.device)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    first = Received(vehicle).count
    try:
        # send until the vehicle holds a fix the relay sent (reading it stops the vehicle a moment)
        deadline = time.monotonic() + 60
        k = 0
        while Received(vehicle).count == first and time.monotonic() < deadline and p.poll() is None:
            k += 1
            s.sendto(b'{"north": %d, "east": 1}\n' % k, ("127.0.0.1", port))
            time.sleep(0.5)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=30)
    finally:
        s.close()
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0, err
    assert "Traceback" not in err
    r = json.loads(out)
    assert r["out"] >= 1 and r["in"] >= r["out"]


def test_status_line_on_a_terminal_then_the_summary(vehicle):
    port = _port()
    master, slave = os.openpty()
    p = relay("udpin:127.0.0.1:%d" % port, "--duration", "6", "--master", vehicle.device, stdout=slave)
    os.close(slave)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    screen = b""
    k = 0
    try:
        while p.poll() is None:
            k += 1
            s.sendto(b'{"north": %f, "east": 0.5}\n{"north": 1}\n' % (0.01 * k), ("127.0.0.1", port))
            time.sleep(0.3)
        p.communicate(timeout=30)
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:
                break
            if not chunk:
                break
            screen += chunk
    finally:
        s.close()
        os.close(master)
    text = screen.decode()
    assert p.returncode == 0
    # redrawn in place: a carriage return, the line, the rest of the old one erased
    status = re.findall(r"\rfixes in (\d+) out (\d+) rejected (\d+) dropped \d+ \| last: age [0-9.]+ s, [0-9.]+ s ago "
                        r"\| clock TIMESYNC \+-[0-9.]+ ms\x1b\[K", text)
    assert len(status) >= 3 and int(status[-1][1]) >= 1 and int(status[-1][2]) >= 1
    summary = text.split("\x1b[K")[-1]
    assert summary.startswith("relayed ") and "rejected " in summary and "missing" in summary


def test_sources_that_cannot_be_opened_say_so_in_one_line():
    r = ground("fixes", "/dev/ttyNOPE9", "--master", "/dev/ttyNOPE8")
    assert r.returncode == 1 and r.stderr.strip() == (
        "roboray-ground: error: source /dev/ttyNOPE9: no such port: is it plugged in? "
        "(roboray-ground ports lists them)")
    r = ground("fixes", "tcp:127.0.0.1:%d" % _port(socket.SOCK_STREAM), "--master", "/dev/ttyNOPE8")
    assert r.returncode == 1 and "connection refused: is the tracker serving" in r.stderr
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        r = ground("fixes", "udpin:127.0.0.1:%d" % busy.getsockname()[1], "--master", "/dev/ttyNOPE8")
    assert r.returncode == 1 and "the address is in use" in r.stderr
    # the source is fine, the vehicle's port is not
    r = ground("fixes", "udpin:127.0.0.1:%d" % _port(), "--master", "/dev/ttyNOPE8")
    assert r.returncode == 1 and "no such port /dev/ttyNOPE8" in r.stderr
    for args in (("ftp:x:1",), ("udpin:1", "--fields", "up=z"), ("udpin:1", "--origin", "91,0"),
                 ("udpin:1", "--columns", "t,x,y"), ("udpin:1", "--latency-ms", "-5"), ("udpin:1", "--count", "0")):
        r = ground("fixes", *args, "--master", "/dev/ttyNOPE8")
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, (args, r.stderr)


def test_a_vehicle_that_signs_takes_the_relayed_fixes_signed_with_its_key():
    from roboray.shared.mavlink.signing import key_from_passphrase

    with PtyVehicle(key=key_from_passphrase("deep water")) as v:
        port = _port()
        p = relay("udpin:127.0.0.1:%d" % port, "--count", "2", "--json", "--key", "deep water", "--master", v.device)
        stop = threading.Event()

        def feed() -> None:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                k = 0
                while not stop.is_set():
                    k += 1
                    s.sendto(b'{"t": %.6f, "north": %d, "east": -1}\n' % (time.time() - 0.02, k), ("127.0.0.1", port))
                    stop.wait(0.6)

        threading.Thread(target=feed, daemon=True).start()
        out, err = _finish(p, stop)
        assert p.returncode == 0, err
        r = json.loads(out)
        assert r["out"] == 2 and r["vehicle_clock"]["via"] == "TIMESYNC"
        got = Received(v)
        assert got.count == 2 and got.fix[:2] == [r["last_fix"]["north_m"], -1.0]
        # nothing was refused as unsigned or wrongly signed
        v.stop()
        try:
            assert v.interpreter.eval("__ep.unsigned") == 0 and v.interpreter.eval("__signing.bad") == 0
        finally:
            v.resume()
