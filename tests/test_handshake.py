"""What a modern ground station asks at connect, answered (issue 17): pymavlink
against the board endpoint on MicroPython behind a pseudo-terminal
(``roboray-ground demo-vehicle``'s ``PtyVehicle``), one test a message."""

from __future__ import annotations

import os
import time
from typing import Callable, Optional

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as pm  # noqa: E402

from roboray.ground.vehicle import PtyVehicle  # noqa: E402
from roboray.shared import modes as M  # noqa: E402
from roboray.shared.mavlink import commands  # noqa
from roboray.shared.mavlink import endpoint as E  # noqa: E402

SYS, COMP = 1, 1


@pytest.fixture(scope="module")
def vehicle():
    with PtyVehicle() as v:
        yield v


@pytest.fixture()
def gcs(vehicle):
    """pymavlink as a ground station at 255/190, MAVLink 2."""
    c = mavutil.mavlink_connection(vehicle.device, baud=57600, source_system=255, source_component=190,
                                   dialect="common", autoreconnect=False)
    c.mav.robust_parsing = True
    c.mav.heartbeat_send(pm.MAV_TYPE_GCS, pm.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    assert c.recv_match(type="HEARTBEAT", blocking=True, timeout=10) is not None
    yield c
    c.close()


def wait(c, kind: str, cond: Callable = lambda m: True, timeout: float = 5.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = c.recv_match(type=kind, blocking=True, timeout=end - time.monotonic())
        if m is not None and cond(m):
            return m
    return None


def ack(c, command: int, timeout: float = 5.0):
    return wait(c, "COMMAND_ACK", lambda m: m.command == command, timeout)


def command(c, cmd: int, *params: float):
    p = list(params) + [0.0] * (7 - len(params))
    c.mav.command_long_send(SYS, COMP, cmd, 0, *p)
    return ack(c, cmd)


def param(c, name: str) -> Optional[float]:
    c.mav.param_request_read_send(SYS, COMP, name.encode(), -1)
    m = wait(c, "PARAM_VALUE", lambda m: m.param_id == name)
    return None if m is None else m.param_value


def test_autopilot_version_by_request_message_and_by_capabilities(gcs):
    for ask in (lambda: command(gcs, pm.MAV_CMD_REQUEST_MESSAGE, pm.MAVLINK_MSG_ID_AUTOPILOT_VERSION),
                lambda: command(gcs, pm.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1)):
        a = ask()
        assert a is not None and a.result == pm.MAV_RESULT_ACCEPTED
        v = wait(gcs, "AUTOPILOT_VERSION")
        assert v is not None
        caps = v.capabilities
        for bit in (pm.MAV_PROTOCOL_CAPABILITY_MAVLINK2, pm.MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
                    pm.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT,
                    pm.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED,
                    pm.MAV_PROTOCOL_CAPABILITY_MISSION_INT, pm.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT):
            assert caps & bit
        # no fence or rally points, no FTP, no global setpoints: not claimed
        for bit in (pm.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE, pm.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY,
                    pm.MAV_PROTOCOL_CAPABILITY_FTP, pm.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT):
            assert not caps & bit
        # no build_info on the test interpreter: version unknown, said as 0
        assert v.flight_sw_version == 0 and bytes(v.flight_custom_version) == bytes(8)
    # param1 other than 1 is ArduPilot's FAILED
    assert command(gcs, pm.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 0).result == pm.MAV_RESULT_FAILED


def test_version_from_the_build():
    class Box:
        set_version = E.Endpoint.set_version
    b = Box()
    b.set_version("0.1.0", "ba4ae25be6f8")
    assert b.sw_version == (0 << 24 | 1 << 16 | 0 << 8 | pm.FIRMWARE_VERSION_TYPE_OFFICIAL)
    assert b.sw_hash == b"ba4ae25b"
    b.set_version("1.12.3rc1", "ba4ae25be6f8-dirty")
    assert b.sw_version == (1 << 24 | 12 << 16 | 3 << 8 | pm.FIRMWARE_VERSION_TYPE_DEV)
    b.set_version("unknown", "unknown")
    assert b.sw_version == pm.FIRMWARE_VERSION_TYPE_DEV and b.sw_hash == bytes(8)


def test_command_int_is_acknowledged(gcs):
    # DO_REPOSITION as QGroundControl sends it, in the local frame: x, y in m x 1e4
    # (2.80 m away: within a glide's reach to a 6 m bottom, 0.49 x 6 m)
    gcs.mav.command_int_send(SYS, COMP, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_DO_REPOSITION, 0, 0,
                             -1, 0, 0, float("nan"), 25000, -12500, 6.0)
    a = ack(gcs, pm.MAV_CMD_DO_REPOSITION)
    assert a is not None and a.result == pm.MAV_RESULT_ACCEPTED
    assert a.target_system == 255 and a.target_component == 190
    assert command(gcs, pm.MAV_CMD_REQUEST_MESSAGE, pm.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED).result == 0
    t = wait(gcs, "POSITION_TARGET_LOCAL_NED")
    assert t is not None and (t.x, t.y, t.z) == pytest.approx((2.5, -1.25, 6.0))
    # a global frame: no global position here, refused with the reason (a long
    # one, told in STATUSTEXT chunks)
    gcs.mav.command_int_send(SYS, COMP, pm.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, pm.MAV_CMD_DO_REPOSITION, 0, 0,
                             -1, 0, 0, float("nan"), 473977420, 85455940, 10.0)
    assert ack(gcs, pm.MAV_CMD_DO_REPOSITION).result == pm.MAV_RESULT_DENIED
    # another command by COMMAND_INT: answered as by COMMAND_LONG
    gcs.mav.command_int_send(SYS, COMP, 0, pm.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    assert ack(gcs, pm.MAV_CMD_GET_HOME_POSITION).result == pm.MAV_RESULT_ACCEPTED
    gcs.mav.command_int_send(SYS, COMP, 0, pm.MAV_CMD_NAV_LAND, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    assert ack(gcs, pm.MAV_CMD_NAV_LAND).result == pm.MAV_RESULT_UNSUPPORTED


def test_long_statustext_goes_in_chunks(gcs):
    gcs.mav.command_int_send(SYS, COMP, pm.MAV_FRAME_GLOBAL_INT, pm.MAV_CMD_DO_REPOSITION, 0, 0,
                             -1, 0, 0, float("nan"), 1, 1, 1.0)
    first = wait(gcs, "STATUSTEXT", lambda m: m.id != 0)
    assert first is not None and first.chunk_seq == 0 and len(first.text) == 50
    chunks = [first]
    while len(chunks[-1].text) == 50:
        m = wait(gcs, "STATUSTEXT", lambda m: m.id == first.id)
        assert m is not None and m.chunk_seq == len(chunks)
        chunks.append(m)
    assert "".join(m.text for m in chunks) == commands._REASON_BAD_FRAME
    assert first.severity == pm.MAV_SEVERITY_WARNING


def test_set_mode_message_is_acknowledged_as_ardupilot_does(vehicle, gcs):
    assert command(gcs, pm.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == pm.MAV_RESULT_ACCEPTED
    try:
        gcs.mav.set_mode_send(SYS, pm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, M.CUSTOM[M.ATTITUDE])
        a = ack(gcs, pm.MAVLINK_MSG_ID_SET_MODE)   # ArduPilot's: the ACK's command is 11
        assert a is not None and a.result == pm.MAV_RESULT_ACCEPTED
        assert wait(gcs, "HEARTBEAT", lambda m: m.custom_mode == M.CUSTOM[M.ATTITUDE]) is not None
        gcs.mav.set_mode_send(SYS, 0, M.CUSTOM[M.PASSIVE])   # no CUSTOM_MODE_ENABLED
        assert ack(gcs, pm.MAVLINK_MSG_ID_SET_MODE).result == pm.MAV_RESULT_DENIED
        gcs.mav.set_mode_send(SYS, pm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 200)   # no such mode
        a = ack(gcs, pm.MAVLINK_MSG_ID_SET_MODE)
        assert a.result == pm.MAV_RESULT_FAILED and M.REASONS[a.result_param2] == M.UNKNOWN_MODE
        # arming an armed vehicle is accepted (ArduPilot), and changes nothing
        assert command(gcs, pm.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == pm.MAV_RESULT_ACCEPTED
        assert wait(gcs, "HEARTBEAT", lambda m: m.custom_mode == M.CUSTOM[M.ATTITUDE]) is not None
        # a param1 neither 0 nor 1
        assert command(gcs, pm.MAV_CMD_COMPONENT_ARM_DISARM, 2).result == pm.MAV_RESULT_UNSUPPORTED
    finally:
        assert command(gcs, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == pm.MAV_RESULT_ACCEPTED
        gcs.mav.set_mode_send(SYS, pm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, M.CUSTOM[M.PASSIVE])
        assert ack(gcs, pm.MAVLINK_MSG_ID_SET_MODE).result == pm.MAV_RESULT_ACCEPTED
    # disarming a disarmed vehicle too
    assert command(gcs, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == pm.MAV_RESULT_ACCEPTED


def _rate(c, kind: str, seconds: float = 3.0) -> float:
    c.recv_match(blocking=False)
    n = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        m = c.recv_match(type=kind, blocking=True, timeout=end - time.monotonic())
        if m is not None:
            n += 1
    return n / seconds


def test_request_data_stream_sets_the_stream_groups(gcs):
    try:
        # EXTRA1 is the attitude, POSITION the position
        gcs.mav.request_data_stream_send(SYS, COMP, pm.MAV_DATA_STREAM_EXTRA1, 10, 1)
        gcs.mav.request_data_stream_send(SYS, COMP, pm.MAV_DATA_STREAM_POSITION, 0, 0)
        assert param(gcs, "SR_ATTITUDE") == 10.0 and param(gcs, "SR_POSITION") == 0.0
        assert 7.0 < _rate(gcs, "ATTITUDE") < 13.0
        assert _rate(gcs, "LOCAL_POSITION_NED", 1.5) == 0.0
        # ALL: every group; beyond a rate's limit, the limit
        gcs.mav.request_data_stream_send(SYS, COMP, pm.MAV_DATA_STREAM_ALL, 20, 1)
        assert [param(gcs, n) for n in E._STREAM_PARAMS] == [20.0, 20.0, 20.0, 20.0, 10.0, 10.0]
        gcs.mav.request_data_stream_send(SYS, COMP, pm.MAV_DATA_STREAM_ALL, 0, 0)
        assert [param(gcs, n) for n in E._STREAM_PARAMS] == [0.0] * 6
        assert _rate(gcs, "ATTITUDE", 1.5) == 0.0
    finally:
        for name, hz in zip(E._STREAM_PARAMS, (4.0, 2.0, 1.0, 2.0, 0.5, 1.0)):
            gcs.mav.param_set_send(SYS, COMP, name.encode(), hz, pm.MAV_PARAM_TYPE_REAL32)
            assert wait(gcs, "PARAM_VALUE", lambda m: m.param_id == name and m.param_value == hz) is not None


def test_home_position_is_the_release_point(gcs):
    for ask in (lambda: command(gcs, pm.MAV_CMD_GET_HOME_POSITION),
                lambda: command(gcs, pm.MAV_CMD_REQUEST_MESSAGE, pm.MAVLINK_MSG_ID_HOME_POSITION)):
        assert ask().result == pm.MAV_RESULT_ACCEPTED
        h = wait(gcs, "HOME_POSITION")
        assert h is not None
        assert (h.x, h.y, h.z) == (0.0, 0.0, 0.0) and list(h.q) == [1.0, 0.0, 0.0, 0.0]
        assert (h.latitude, h.longitude, h.altitude) == (0, 0, 0)


def test_sys_status_fence_healthy_and_no_drops_from_two_grounds_sharing_an_identity(vehicle, gcs):
    # a second program at the same 255/190 (the CLI beside the twin's ground):
    # its sequence numbers jump the first one's, and nothing is lost
    other = mavutil.mavlink_connection(vehicle.device, baud=57600, source_system=255, source_component=190,
                                       dialect="common", autoreconnect=False)
    try:
        other.mav.seq = 128
        for i in range(40):
            (gcs if i % 2 else other).mav.heartbeat_send(pm.MAV_TYPE_GCS, pm.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            time.sleep(0.02)
        assert command(gcs, pm.MAV_CMD_REQUEST_MESSAGE, pm.MAVLINK_MSG_ID_SYS_STATUS).result == 0
        s = wait(gcs, "SYS_STATUS")
        assert s is not None and s.drop_rate_comm == 0
        # MAVProxy reads a clear fence health bit as "fence breach": set without a fence
        g = pm.MAV_SYS_STATUS_GEOFENCE
        assert s.onboard_control_sensors_health & g and not s.onboard_control_sensors_present & g
        assert not s.onboard_control_sensors_enabled & g
    finally:
        other.close()
