"""The landing target as a mission in the twin: the firmware on MicroPython,
its radio emulated at 57,600 baud behind a pseudo-terminal (``--radio
pty``), the world simulated. pymavlink, as a second ground station, waits
until the vehicle flies to the scripted target in TARGET, is refused a clear
while it does, moves the target by a mission upload, reads it back, and
hears MISSION_ITEM_REACHED when the vehicle lands, on the mission's target."""

from __future__ import annotations

import math
import threading
import time

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as pm

from roboray.sim.twin.runner import Options, Twin

SYS, COMP = 1, 1
#: The mission's target (m north, east; the bottom's depth): the scenario's is 2 m north.
TARGET = (1.0, 1.0, 10.0)


def _until(c, accept, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = c.recv_match(blocking=True, timeout=min(0.5, max(0.01, end - time.monotonic())))
        if m is not None and accept(m):
            return m
    return None


def _operate(device: str, got: dict, done: threading.Event) -> None:
    c = mavutil.mavlink_connection(device, baud=57600, source_system=255, source_component=191, dialect="common")
    c.mav.robust_parsing = True
    try:
        assert c.wait_heartbeat(timeout=60) is not None, "no heartbeat"
        # flying to the scripted target: MISSION_CURRENT says the mission runs (TARGET, armed)
        cur = _until(c, lambda m: m.get_type() == "MISSION_CURRENT" and m.mission_mode == 1 and m.mission_state == 3,
                     60)
        assert cur is not None, "never in TARGET"
        got["flying"] = (cur.seq, cur.total)
        c.mav.mission_clear_all_send(SYS, COMP, 0)
        ack = _until(c, lambda m: m.get_type() == "MISSION_ACK", 5)
        got["clear"] = None if ack is None else ack.type
        # move the target: home and a NAV_LAND, as the vehicle asks for them
        items = [pm.MAVLink_mission_item_int_message(SYS, COMP, 0, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_WAYPOINT,
                                                     0, 1, 0, 0, 0, 0, 0, 0, 0.0, 0),
                 pm.MAVLink_mission_item_int_message(SYS, COMP, 1, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_LAND, 1, 1,
                                                     0, 0, 0, 0, int(TARGET[0] * 1e7), int(TARGET[1] * 1e7),
                                                     TARGET[2], 0)]
        c.mav.mission_count_send(SYS, COMP, len(items), 0)
        while True:
            m = _until(c, lambda m: m.get_type() in ("MISSION_REQUEST_INT", "MISSION_ACK"), 10)
            assert m is not None, "upload: the vehicle fell silent"
            if m.get_type() == "MISSION_ACK":
                got["upload"] = m.type
                break
            c.mav.send(items[m.seq])
        c.mav.mission_request_list_send(SYS, COMP, 0)
        count = _until(c, lambda m: m.get_type() == "MISSION_COUNT", 5)
        c.mav.mission_request_int_send(SYS, COMP, 1, 0)
        item = _until(c, lambda m: m.get_type() == "MISSION_ITEM_INT" and m.seq == 1, 5)
        c.mav.mission_ack_send(SYS, COMP, 0, 0)
        got["download"] = (count.count, item.command, item.frame, item.x, item.y, item.z)
        reached = _until(c, lambda m: m.get_type() == "MISSION_ITEM_REACHED", 120)
        got["reached"] = None if reached is None else reached.seq
        done_ = _until(c, lambda m: m.get_type() == "MISSION_CURRENT", 5)
        got["after"] = None if done_ is None else done_.mission_state
    except Exception as exc:  # reported by the test's assertions
        got["error"] = repr(exc)
    finally:
        c.close()
        done.set()


def test_a_mission_moves_the_target_in_flight_and_the_landing_reaches_it():
    got: dict = {}
    done = threading.Event()

    def on_radio(radio):
        threading.Thread(target=_operate, args=(radio.device, got, done), daemon=True).start()

    twin = Twin(Options(scenario="target-landing", radio="pty", speedup=4.0), on_radio=on_radio)
    report = twin.run()
    assert done.wait(30)
    assert "error" not in got, got
    assert got["flying"] == (1, 1)                                  # the scripted target is item 1
    assert got["clear"] == pm.MAV_MISSION_DENIED                     # not while TARGET flies to it
    assert got["upload"] == pm.MAV_MISSION_ACCEPTED
    assert got["download"] == (2, pm.MAV_CMD_NAV_LAND, pm.MAV_FRAME_LOCAL_NED, 10000000, 10000000, 10.0)
    assert got["reached"] == 1 and got["after"] == 5                 # COMPLETE
    assert report["landed"]
    north, east = report["landing_point"]
    assert math.hypot(north - TARGET[0], east - TARGET[1]) < 0.25, report["landing_point"]
    # told after the touchdown, not before (the vehicle held at the surface before the release)
    reached = [t for t, _, text in report["statustext"] if text == "Reached target: mission item 1"]
    assert len(reached) == 1
    assert report["landed_at_s"] <= reached[0] <= report["landed_at_s"] + 1.5
