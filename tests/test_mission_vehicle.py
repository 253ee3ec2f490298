"""The landing target as a mission, end to end against ``roboray-ground
demo-vehicle`` (the board endpoint on MicroPython behind a pseudo-terminal):
pymavlink's mission helpers and ``mavwp``, ``roboray-ground wp``, and
MAVProxy itself (``wp load``, ``wp list``, ``wp clear``), all on real time."""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable, Optional

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil, mavwp  # noqa: E402
from pymavlink.dialects.v20 import common as pm  # noqa: E402

from roboray.ground.vehicle import PtyVehicle  # noqa: E402
from roboray.shared.mavlink import mission as MI  # noqa: E402

# mavwp builds its items with mavutil's dialect: MAVLink 2's common, as the ground's link sets it
mavutil.set_dialect("common")

SYS, COMP = 1, 1
WAYPOINTS = "QGC WPL 110\n0\t0\t1\t16\t0\t0\t0\t0\t0\t0\t0\t1\n1\t1\t1\t21\t0\t0\t0\t0\t2.5\t-1.0\t8\t1\n"


@pytest.fixture(scope="module")
def vehicle():
    with PtyVehicle() as v:
        yield v


@pytest.fixture()
def gcs(vehicle):
    c = mavutil.mavlink_connection(vehicle.device, baud=57600, source_system=255, source_component=190,
                                   dialect="common", autoreconnect=False)
    c.mav.robust_parsing = True
    assert c.wait_heartbeat(timeout=10) is not None
    yield c
    c.close()


def wait(c, kind: str, cond: Callable = lambda m: True, timeout: float = 5.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = c.recv_match(type=kind, blocking=True, timeout=end - time.monotonic())
        if m is not None and cond(m):
            return m
    return None


def mission_of(c) -> list:
    """Download with pymavlink's helpers (MISSION_REQUEST: MISSION_ITEMs back)."""
    c.waypoint_request_list_send()
    count = wait(c, "MISSION_COUNT")
    assert count is not None
    items = []
    for seq in range(count.count):
        c.waypoint_request_send(seq)
        m = wait(c, "MISSION_ITEM", lambda m: m.seq == seq)
        assert m is not None, seq
        items.append(m)
    c.mav.mission_ack_send(SYS, COMP, pm.MAV_MISSION_ACCEPTED)
    return items


def test_pymavlink_helpers_and_mavwp_download_upload_and_clear(gcs, tmp_path):
    c = gcs
    c.waypoint_clear_all_send()
    assert wait(c, "MISSION_ACK").type == pm.MAV_MISSION_ACCEPTED
    assert [(m.seq, m.command) for m in mission_of(c)] == [(0, pm.MAV_CMD_NAV_WAYPOINT)]
    # a waypoint file through mavwp, uploaded as the vehicle asks for each item
    path = tmp_path / "target.waypoints"
    path.write_text(WAYPOINTS)
    loader = mavwp.MAVWPLoader(SYS, COMP)
    loader.load(str(path))
    c.waypoint_count_send(loader.count())
    while True:
        m = c.recv_match(type=["MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True, timeout=5)
        assert m is not None
        if m.get_type() == "MISSION_ACK":
            assert m.type == pm.MAV_MISSION_ACCEPTED
            break
        c.mav.send(loader.wp(m.seq))
    home, target = mission_of(c)
    assert (home.frame, home.x, home.y) == (pm.MAV_FRAME_LOCAL_NED, 0.0, 0.0)
    assert (target.command, target.frame, target.x, target.y, target.z, target.current) == (
        pm.MAV_CMD_NAV_LAND, pm.MAV_FRAME_LOCAL_NED, 2.5, -1.0, 8.0, 1)
    # the same target as DO_REPOSITION's: the position target stream shows it
    c.mav.command_long_send(SYS, COMP, pm.MAV_CMD_REQUEST_MESSAGE, 0, pm.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED,
                            0, 0, 0, 0, 0, 0)
    t = wait(c, "POSITION_TARGET_LOCAL_NED")
    assert (t.x, t.y, t.z) == (2.5, -1.0, 8.0)
    # the current item is the target, in the status stream
    assert wait(c, "MISSION_CURRENT", lambda m: m.seq == 1 and m.total == 1, timeout=3) is not None
    # no fence here
    c.mav.mission_request_list_send(SYS, COMP, pm.MAV_MISSION_TYPE_FENCE)
    fence = wait(c, "MISSION_COUNT", lambda m: m.mission_type == pm.MAV_MISSION_TYPE_FENCE)
    assert fence is not None and fence.count == 0
    c.mav.mission_count_send(SYS, COMP, 4, pm.MAV_MISSION_TYPE_FENCE)
    ack = wait(c, "MISSION_ACK", lambda m: m.mission_type == pm.MAV_MISSION_TYPE_FENCE)
    assert ack is not None and ack.type == pm.MAV_MISSION_UNSUPPORTED
    c.waypoint_clear_all_send()
    assert wait(c, "MISSION_ACK").type == pm.MAV_MISSION_ACCEPTED
    assert len(mission_of(c)) == 1


def test_a_partial_upload_is_asked_again_then_cancelled_and_loses_nothing(gcs):
    c = gcs
    c.mav.command_long_send(SYS, COMP, pm.MAV_CMD_DO_REPOSITION, 0, -1, 0, 0, 0, 1.0, 2.0, 0.0)
    assert wait(c, "COMMAND_ACK", lambda m: m.command == pm.MAV_CMD_DO_REPOSITION).result == 0
    c.mav.mission_count_send(SYS, COMP, 2, 0)
    r = wait(c, "MISSION_REQUEST_INT")
    assert r is not None and r.seq == 0
    c.mav.mission_item_int_send(SYS, COMP, 0, pm.MAV_FRAME_GLOBAL, pm.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                0, 0, 0, 0, 0, 0, 0.0, 0)
    asked = 0
    end = time.monotonic() + (MI.RETRIES + 3) * MI.ITEM_TIMEOUT_MS / 1000.0
    ack = None
    while time.monotonic() < end and ack is None:
        m = c.recv_match(type=["MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True, timeout=1.0)
        if m is None:
            continue
        if m.get_type() == "MISSION_ACK":
            ack = m
        else:
            assert m.seq == 1
            asked += 1
    assert ack is not None and ack.type == pm.MAV_MISSION_OPERATION_CANCELLED
    assert asked == MI.RETRIES + 1       # asked, then asked again five times
    _, target = mission_of(c)            # the target from before the upload
    assert (target.x, target.y) == (1.0, 2.0)


def ground(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.ground.cli", *args],
                          capture_output=True, text=True, timeout=timeout)


def test_roboray_ground_wp_lists_sets_and_clears(vehicle):
    d = vehicle.device
    r = ground("wp", "clear", "--master", d)
    assert (r.returncode, r.stdout.strip()) == (0, "mission cleared: no target"), r.stderr
    r = ground("wp", "list", "--master", d)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == ["0  home    NAV_WAYPOINT  LOCAL_NED  the release point",
                                     "no target: the mission is home alone"]
    r = ground("wp", "set", "-2", "1.5", "--master", d)      # negative numbers are values
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ("mission set: target -2.00 m north, 1.50 m east (2.50 m away), on the vehicle's "
                                "own bottom depth (CTL_DEPTH_M)")
    r = ground("wp", "list", "--master", d, "--json")
    out = json.loads(r.stdout)
    assert out["count"] == 2 and out["target"]["north_m"] == -2.0 and out["target"]["east_m"] == 1.5
    assert out["target"]["down_m"] is None and out["items"][1]["command"] == "NAV_LAND"
    r = ground("wp", "set", "3", "3", "--down", "12", "--master", d)
    assert r.returncode == 0 and "bottom at 12.0 m (--down)" in r.stdout, r.stderr
    r = ground("wp", "list", "--master", d)
    assert r.stdout.splitlines()[1] == ("1  target  NAV_LAND      LOCAL_NED  3.00 m north, 3.00 m east (4.24 m away), "
                                        "bottom at 12.0 m")
    # beyond the reach of the vehicle's own bottom (CTL_DEPTH_M 10 m: 4.85 m): the vehicle says so, exit 2
    r = ground("wp", "set", "6", "0", "--master", d)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, r.stderr
    assert r.stderr.strip() == (
        "roboray-ground: error: mission upload refused: invalid x (north, latitude) (target 6.00 m north, "
        "0.00 m east is 6.00 m away, beyond the reach of a glide to a bottom at 10.0 m (CTL_DEPTH_M): 4.85 m "
        "(best glide ratio 0.49))")
    assert "3.00 m north, 3.00 m east" in ground("wp", "list", "--master", d).stdout    # kept
    # centimetres typed as metres: refused before the link opens
    r = ground("wp", "set", "200", "100", "--master", "/dev/ttyNOPE0")
    assert r.returncode == 2 and "223.61 m away, beyond the reach" in r.stderr
    for args in (("wp", "set", "1"), ("wp", "list", "x"), ("wp", "clear", "--down", "3"), ("wp", "set", "a", "1")):
        r = ground(*args, "--master", "/dev/ttyNOPE0")
        assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, (args, r.stderr)
    r = ground("wp", "clear", "--master", d)
    assert r.returncode == 0


class MAVProxy:
    """MAVProxy (from PyPI) headless on the vehicle's pseudo-terminal, fed
    commands on stdin; its output read line by line."""

    def __init__(self, device: str, state: Path) -> None:
        exe = Path(sys.executable).with_name("mavproxy.py")
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.p = subprocess.Popen([sys.executable, str(exe), "--master", device, "--baudrate", "57600",
                                   "--nowait", "--state-basedir", str(state), "--aircraft", "roboray"],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  text=True, cwd=str(state), env=env)
        self.lines: queue.Queue = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.p.stdout is not None
        for line in self.p.stdout:
            self.lines.put(line.rstrip("\n"))

    def send(self, command: str) -> None:
        assert self.p.stdin is not None
        self.p.stdin.write(command + "\n")
        self.p.stdin.flush()

    def expect(self, test: Callable[[str], bool], timeout: float = 20.0) -> Optional[str]:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                line = self.lines.get(timeout=0.2)
            except queue.Empty:
                continue
            self.seen.append(line)
            if test(line):
                return line
        return None

    def close(self) -> None:
        try:
            self.send("exit")
            self.p.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.p.kill()
            self.p.wait()


def test_mavproxy_loads_lists_and_clears_the_target(vehicle, tmp_path):
    (tmp_path / "target.txt").write_text(WAYPOINTS)
    mp = MAVProxy(vehicle.device, tmp_path)
    try:
        assert mp.expect(lambda s: "online system 1" in s), mp.seen
        mp.send("wp load %s" % (tmp_path / "target.txt"))
        assert mp.expect(lambda s: "Got MISSION_ACK: TYPE_MISSION: ACCEPTED" in s), mp.seen
        mp.send("wp list")
        assert mp.expect(lambda s: s.startswith("Requesting 2 waypoints") or "Requesting 2 waypoints" in s), mp.seen
        assert mp.expect(lambda s: s.startswith("16 ")) == (
            "16 1 0.0000000000 0.0000000000 0.000000 p1=0.0 p2=0.0 p3=0.0 p4=0.0 cur=0 auto=1")
        assert mp.expect(lambda s: s.startswith("21 ")) == (
            "21 1 2.5000000000 -1.0000000000 8.000000 p1=0.0 p2=0.0 p3=0.0 p4=0.0 cur=1 auto=1")
        mp.send("wp clear")
        assert mp.expect(lambda s: "Got MISSION_ACK: TYPE_MISSION: ACCEPTED" in s), mp.seen
        mp.send("wp list")
        assert mp.expect(lambda s: "Requesting 1 waypoints" in s), mp.seen
        assert mp.expect(lambda s: s.startswith("16 ")) is not None
        assert not [s for s in mp.seen if "Traceback" in s or "Unexpected" in s]
    finally:
        mp.close()
