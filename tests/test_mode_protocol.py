"""Modes and arming as ground stations know them (issue 17), pymavlink against
the board endpoint on MicroPython behind a pseudo-terminal (``roboray-ground
demo-vehicle``'s ``PtyVehicle``): the names MAVProxy shows (pymavlink's
ArduSub table, as MAVProxy reads it), ``set_mode`` by name for every mode,
arming as a flag that keeps the mode, and the standard modes protocol
(AVAILABLE_MODES, CURRENT_MODE) decoded by pymavlink's development dialect."""

from __future__ import annotations

import math
import os
import time
from typing import Callable

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import development as dev  # noqa: E402

from roboray.ground.vehicle import PtyVehicle  # noqa: E402
from roboray.shared import modes as M  # noqa: E402

SYS, COMP = 1, 1


@pytest.fixture(scope="module")
def vehicle():
    with PtyVehicle() as v:
        yield v


def connect(vehicle, dialect: str):
    c = mavutil.mavlink_connection(vehicle.device, baud=57600, source_system=255, source_component=190,
                                   dialect=dialect, autoreconnect=False)
    c.mav.robust_parsing = True
    c.mav.heartbeat_send(dev.MAV_TYPE_GCS, dev.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    assert c.wait_heartbeat(timeout=10) is not None
    return c


@pytest.fixture()
def mavproxy_view(vehicle):
    """pymavlink with MAVProxy's dialect (ardupilotmega), which lacks the
    standard modes messages: what MAVProxy itself decodes and names."""
    c = connect(vehicle, "ardupilotmega")
    yield c
    back_to_boot(c)
    c.close()


@pytest.fixture()
def gcs(vehicle):
    """pymavlink with the development dialect: AVAILABLE_MODES and CURRENT_MODE."""
    c = connect(vehicle, "development")
    yield c
    back_to_boot(c)
    c.close()


def back_to_boot(c) -> None:
    """Disarmed in PASSIVE, as the next test expects the vehicle."""
    command(c, dev.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    command(c, dev.MAV_CMD_DO_SET_MODE, dev.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, M.CUSTOM[M.PASSIVE])


def wait(c, kind: str, cond: Callable = lambda m: True, timeout: float = 5.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = c.recv_match(type=kind, blocking=True, timeout=end - time.monotonic())
        if m is not None and cond(m):
            return m
    return None


def command(c, cmd: int, *params: float):
    p = list(params) + [0.0] * (7 - len(params))
    c.mav.command_long_send(SYS, COMP, cmd, 0, *p)
    return wait(c, "COMMAND_ACK", lambda m: m.command == cmd)


def heartbeat(c, cond: Callable):
    """The next heartbeat after now that satisfies ``cond``."""
    return wait(c, "HEARTBEAT", lambda m: m.type == dev.MAV_TYPE_SUBMARINE and cond(m))


def set_target(c) -> None:
    a = command(c, dev.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, 2.0, 0.0, math.nan)
    assert a is not None and a.result == dev.MAV_RESULT_ACCEPTED


def test_every_mode_has_a_name_mavproxy_shows_and_is_reached_by_it(mavproxy_view):
    c = mavproxy_view
    mapping = c.mode_mapping()   # what MAVProxy's mode command looks names up in
    assert {M.ARDUSUB_NAMES[m] for m in M.MODES} <= set(mapping)
    assert c.flightmode == "MANUAL"    # PASSIVE, the boot's mode
    set_target(c)
    assert command(c, dev.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == dev.MAV_RESULT_ACCEPTED
    # every mode from every other, by the name MAVProxy shows, armed
    order = [M.ATTITUDE, M.VELOCITY, M.TARGET, M.FAILSAFE, M.PASSIVE, M.TARGET, M.ATTITUDE, M.FAILSAFE,
             M.VELOCITY, M.PASSIVE]
    for m in order:
        name = M.ARDUSUB_NAMES[m]
        c.set_mode(name)     # pymavlink's set_mode_apm: DO_SET_MODE with the name's number, as MAVProxy's "mode"
        a = wait(c, "COMMAND_ACK", lambda x: x.command == dev.MAV_CMD_DO_SET_MODE)
        assert a is not None and a.result == dev.MAV_RESULT_ACCEPTED, (M.NAMES[m], a)
        hb = heartbeat(c, lambda h: h.custom_mode == M.CUSTOM[m])
        assert hb is not None and mavutil.mode_string_v10(hb) == name and c.flightmode == name
        assert hb.base_mode & dev.MAV_MODE_FLAG_SAFETY_ARMED
    # disarmed, each mode too (the checks come at arming)
    assert command(c, dev.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == dev.MAV_RESULT_ACCEPTED
    for m in M.MODES:
        c.set_mode(M.ARDUSUB_NAMES[m])
        assert heartbeat(c, lambda h: h.custom_mode == M.CUSTOM[m] and not h.base_mode & 128) is not None


def test_arming_is_a_flag_and_the_mode_stays(mavproxy_view):
    c = mavproxy_view
    set_target(c)
    c.set_mode("AUTO")
    assert heartbeat(c, lambda h: h.custom_mode == M.CUSTOM[M.TARGET]) is not None
    c.arducopter_arm()       # MAVProxy's "arm throttle"
    c.motors_armed_wait()
    hb = heartbeat(c, lambda h: h.base_mode & dev.MAV_MODE_FLAG_SAFETY_ARMED)
    assert c.flightmode == "AUTO" and hb.system_status == dev.MAV_STATE_ACTIVE
    c.arducopter_disarm()
    c.motors_disarmed_wait()
    hb = heartbeat(c, lambda h: not h.base_mode & dev.MAV_MODE_FLAG_SAFETY_ARMED)
    assert mavutil.mode_string_v10(hb) == "AUTO" and hb.system_status == dev.MAV_STATE_STANDBY
    # an armed vehicle armed again: ACCEPTED (ArduPilot's answer), nothing changes
    assert command(c, dev.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == dev.MAV_RESULT_ACCEPTED
    assert command(c, dev.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == dev.MAV_RESULT_ACCEPTED
    assert heartbeat(c, lambda h: h.base_mode & 128 and h.custom_mode == M.CUSTOM[M.TARGET]) is not None


def test_failsafe_chosen_by_the_operator_is_left_for_any_mode(mavproxy_view):
    c = mavproxy_view
    set_target(c)
    assert command(c, dev.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == dev.MAV_RESULT_ACCEPTED
    c.set_mode("SURFACE")
    assert heartbeat(c, lambda h: h.custom_mode == M.CUSTOM[M.FAILSAFE]) is not None
    hb = heartbeat(c, lambda h: True)
    assert hb.system_status == dev.MAV_STATE_CRITICAL
    c.set_mode("AUTO")
    a = wait(c, "COMMAND_ACK", lambda x: x.command == dev.MAV_CMD_DO_SET_MODE)
    assert a.result == dev.MAV_RESULT_ACCEPTED
    assert heartbeat(c, lambda h: h.custom_mode == M.CUSTOM[M.TARGET]) is not None


def test_available_modes_lists_every_mode_with_its_name(gcs):
    a = command(gcs, dev.MAV_CMD_REQUEST_MESSAGE, dev.MAVLINK_MSG_ID_AVAILABLE_MODES, 0)
    assert a is not None and a.result == dev.MAV_RESULT_ACCEPTED
    got = {}
    while len(got) < len(M.MODES):
        m = wait(gcs, "AVAILABLE_MODES")
        assert m is not None, got
        got[m.mode_index] = m
    assert sorted(got) == [1, 2, 3, 4, 5]
    for i, m in got.items():
        mode = M.MODES[i - 1]
        assert m.number_modes == 5 and m.mode_name == M.NAMES[mode] and m.custom_mode == M.CUSTOM[mode]
        assert m.standard_mode == (dev.MAV_STANDARD_MODE_MISSION if mode == M.TARGET
                                   else dev.MAV_STANDARD_MODE_NON_STANDARD)
        assert m.properties == 0
    # one by its index; an index past the last is refused
    assert command(gcs, dev.MAV_CMD_REQUEST_MESSAGE, dev.MAVLINK_MSG_ID_AVAILABLE_MODES, 4).result == 0
    m = wait(gcs, "AVAILABLE_MODES")
    assert (m.mode_index, m.mode_name) == (4, "TARGET")
    a = command(gcs, dev.MAV_CMD_REQUEST_MESSAGE, dev.MAVLINK_MSG_ID_AVAILABLE_MODES, 6)
    assert a.result == dev.MAV_RESULT_DENIED


def test_current_mode_streams_once_asked_goes_on_a_change_and_keeps_what_the_operator_chose():
    with PtyVehicle() as fresh:
        # MAVProxy's dialect lacks CURRENT_MODE: none comes unasked, so no
        # frame whose sequence number pymavlink cannot read (it counts a loss)
        c = connect(fresh, "ardupilotmega")
        end = time.monotonic() + 4.5
        while time.monotonic() < end:
            m = c.recv_match(blocking=True, timeout=0.2)
            assert m is None or m.get_msgId() >= 0, m
        assert c.mav_loss == 0 and c.mav_count > 60
        c.close()
        gcs = connect(fresh, "development")
        assert wait(gcs, "CURRENT_MODE", timeout=2.5) is None
        assert command(gcs, dev.MAV_CMD_REQUEST_MESSAGE, dev.MAVLINK_MSG_ID_CURRENT_MODE).result == 0
        first = wait(gcs, "CURRENT_MODE", timeout=1.0)
        assert first is not None and first.custom_mode == M.CUSTOM[M.PASSIVE]
        t0 = time.monotonic()
        n = 0
        while time.monotonic() - t0 < 4.1:
            if wait(gcs, "CURRENT_MODE", timeout=0.2) is not None:
                n += 1
        assert 1 <= n <= 3     # 0.5 Hz (with the heartbeat, every other one)
        # disarmed, TARGET is chosen without a target; arming in it is refused (ArduCopter's rule)
        mode = dev.MAV_CMD_DO_SET_MODE
        assert command(gcs, mode, dev.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, M.CUSTOM[M.TARGET]).result == 0
        a = command(gcs, dev.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        assert a.result == dev.MAV_RESULT_FAILED and M.REASONS[a.result_param2] == M.NO_TARGET
        assert command(gcs, mode, dev.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, M.CUSTOM[M.PASSIVE]).result == 0
        set_target(gcs)
        assert command(gcs, dev.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == dev.MAV_RESULT_ACCEPTED
        # the standard mode MISSION is TARGET; CURRENT_MODE says so at once
        assert command(gcs, dev.MAV_CMD_DO_SET_STANDARD_MODE, dev.MAV_STANDARD_MODE_MISSION).result == 0
        sent = time.monotonic()
        m = wait(gcs, "CURRENT_MODE", lambda x: x.custom_mode == M.CUSTOM[M.TARGET], timeout=2.0)
        assert m is not None and time.monotonic() - sent < 0.9
        assert m.standard_mode == dev.MAV_STANDARD_MODE_MISSION and m.intended_custom_mode == M.CUSTOM[M.TARGET]
        a = command(gcs, dev.MAV_CMD_DO_SET_STANDARD_MODE, dev.MAV_STANDARD_MODE_POSITION_HOLD)
        assert a.result == dev.MAV_RESULT_FAILED and M.REASONS[a.result_param2] == M.UNKNOWN_MODE
        # a failsafe's FAILSAFE would leave the intended mode; the operator's changes it
        c2 = command(gcs, dev.MAV_CMD_DO_SET_MODE, dev.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, M.CUSTOM[M.FAILSAFE])
        assert c2.result == 0
        m = wait(gcs, "CURRENT_MODE", lambda x: x.custom_mode == M.CUSTOM[M.FAILSAFE], timeout=2.0)
        assert m.intended_custom_mode == M.CUSTOM[M.FAILSAFE] and m.standard_mode == 0
        gcs.close()


def test_the_mode_frames_are_framed_without_allocating_on_micropython(micropython):
    """The endpoint on the real interpreter: AVAILABLE_MODES (all five asked
    for) and CURRENT_MODE go out one an update, allocating nothing once
    each frame length was sent (the writer's view of it is kept); ids above 255 parse as the
    others do."""
    from test_mavlink_endpoint import _MP_SETUP

    mav = dev.MAVLink(None, 255, 190)
    ask = dev.MAVLink_command_long_message(1, 1, dev.MAV_CMD_REQUEST_MESSAGE, 0,
                                           dev.MAVLINK_MSG_ID_AVAILABLE_MODES, 0, 0, 0, 0, 0, 0).pack(mav)
    micropython.exec(_MP_SETUP)
    micropython.exec("__ep.update(0)\nfor __n in ('ATTITUDE', 'POSITION', 'SENSORS', 'SERVO', 'BATTERY', 'STATUS'):\n"
                     "    __ep.params.set_by_name('SR_' + __n, 0.0)\n__ep._pending = 0\n__ep._mode_sent = 1\n"
                     "__ep._hb_due = 10 ** 8\n__ep._wake = 10 ** 8\n"
                     "def __one():\n    n = __pipe.out\n    __t[0] += 1\n    __ep.update(__t[0])\n"
                     "    __sent.append(__pipe.out - n)\n__sent = []\n")
    # a first pass sends each frame length once: the writer keeps a view of
    # each length it has sent, so the same lengths again allocate nothing
    micropython.exec("__f = %r\n__feed(__f)\nfor __i in range(7):\n    __one()\n"
                     "__ep.modes.request(4)\n__one()\n__ep.modes.request(3)\n__one()" % ask)
    micropython.exec("__feed(__f)\n__sent = []")
    for _ in range(2):   # (alloc_bytes runs the call twice: a warm-up, then the measure)
        assert micropython.alloc_bytes("__one()") == 0, "one update: one frame"
    micropython.exec("for __i in range(6):\n    __one()")
    sizes = micropython.eval("__sent")
    # header and checksum, 11 bytes of numbers, the name (its zeros cut)
    assert sizes[:5] == [12 + 11 + len(M.NAMES[m]) for m in M.MODES]
    assert sizes[5:] == [0] * 5 and micropython.eval("__ep._avail_next") == 0
    # a mode change (TARGET and VELOCITY in turn): CURRENT_MODE at the next update
    micropython.exec("__ep.modes.request(4)\n__one()\n__sent = []")
    assert micropython.alloc_bytes("__ep.modes.request(7 - __ep.modes.mode)\n__one()") == 0
    assert micropython.eval("__sent") == [12 + 5, 12 + 9]   # VELOCITY: 4, 4, 0, its zeros cut
    # parsing the ids above 255 as any other
    setup = ("from roboray.shared.mavlink.parser import Parser\n__p = Parser()\n"
             "def __parse(f):\n    i = 0\n    while i < len(f):\n        i = __p.feed(f, i, len(f))\n"
             "        if __p.ready:\n            return __p.msgid\n    return -1\n")
    micropython.exec(setup)
    low = dev.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav)
    for frame, msgid in ((dev.MAVLink_current_mode_message(0, 3, 3).pack(mav), 436),
                         (dev.MAVLink_available_modes_message(5, 4, 6, 3, 0, b"TARGET").pack(mav), 435)):
        micropython.exec("__fr = memoryview(%r)\n__lo = memoryview(%r)" % (frame, low))
        assert micropython.eval("__parse(__fr)") == msgid
        assert micropython.alloc_bytes("__parse(__fr)") == micropython.alloc_bytes("__parse(__lo)")


def test_mavproxy_names_every_mode_reaches_it_by_name_and_arms_keeping_it(vehicle, tmp_path):
    """MAVProxy itself (from PyPI, headless): ``mode NAME`` with the names it
    shows reaches every mode, ``arm throttle`` and ``disarm`` keep the mode."""
    from test_mission_vehicle import MAVProxy

    mp = MAVProxy(vehicle.device, tmp_path)
    try:
        assert mp.expect(lambda s: "online system 1" in s), mp.seen
        assert mp.expect(lambda s: s.endswith("Mode MANUAL")), mp.seen      # PASSIVE, the boot's mode
        mp.send("long DO_REPOSITION -1 0 0 nan 2 0 nan")                    # the target TARGET needs
        assert mp.expect(lambda s: "DO_REPOSITION: ACCEPTED" in s), mp.seen
        mp.send("arm throttle")
        assert mp.expect(lambda s: "COMPONENT_ARM_DISARM: ACCEPTED" in s), mp.seen
        assert mp.expect(lambda s: s.endswith("ARMED")), mp.seen
        for name in ("STABILIZE", "GUIDED", "AUTO", "SURFACE", "MANUAL", "SURFACE", "AUTO"):
            mp.send("mode %s" % name.lower())
            # (MAVProxy's announcement, after its prompt or after another text on the line)
            assert mp.expect(lambda s: s.endswith("Mode %s" % name)), (name, mp.seen[-6:])
        mp.send("disarm")
        assert mp.expect(lambda s: s.endswith("DISARMED")), mp.seen
        mp.send("status HEARTBEAT")
        hb = mp.expect(lambda s: "HEARTBEAT {" in s)
        # AUTO (custom 3) kept, disarmed: custom mode, stabilise and guided flags, not SAFETY_ARMED
        assert hb is not None and "custom_mode : 3," in hb and "base_mode : 25," in hb, hb
        mp.send("mode TARGET")       # RoboRay's own names are roboray-ground's; MAVProxy takes what it shows
        assert mp.expect(lambda s: "Unknown mode TARGET" in s), mp.seen
        mp.send("mode manual")
        assert mp.expect(lambda s: s.endswith("Mode MANUAL")), mp.seen[-6:]
        assert not [s for s in mp.seen if "Traceback" in s]
    finally:
        mp.close()


def test_watch_counts_no_loss_for_a_message_its_dialect_lacks():
    """roboray-ground's link decodes with common.xml, which lacks CURRENT_MODE:
    pymavlink gives such a frame no header (system 0, sequence 0), and the
    watch screen took that for a sender 255 frames behind."""
    from pymavlink.dialects.v20 import common

    from roboray.ground.watch import State

    tx = dev.MAVLink(None, 1, 1)
    frames = b""
    for i in range(6):
        for m in (dev.MAVLink_heartbeat_message(12, 0, 129, 3, 4, 3), dev.MAVLink_current_mode_message(0, 3, 3)):
            frames += m.pack(tx)
            tx.seq = (tx.seq + 1) % 256   # (what send() counts)
    rx = common.MAVLink(None)
    rx.robust_parsing = True
    msgs = rx.parse_buffer(frames)
    assert [m.get_type() for m in msgs].count("UNKNOWN_436") == 6
    s = State()
    for m in msgs:
        s.update(m, now=0.0)
    assert s.received == 12 and s.mode_name() == "TARGET" and s.armed
    assert s.lost == 5    # each heartbeat's predecessor: the unknown frame, seen but unreadable
