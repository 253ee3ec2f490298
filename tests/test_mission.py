"""The mission protocol on the vehicle (``shared/mavlink/mission.py``), driven
by pymavlink as a ground station would, on the endpoint's own clock: the
transport is a pair of byte queues, time advances 10 ms an update, so the
protocol's timeouts and retries are counted exactly. On MicroPython the same
protocol runs within the allocation bound of the endpoint's handling."""

from __future__ import annotations

import math
import os

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil, mavwp  # noqa: E402
from pymavlink.dialects.v20 import common as pm  # noqa: E402

from roboray.shared import modes as M  # noqa: E402
from roboray.shared import param_defs  # noqa: E402
from roboray.shared.mavlink import mission as MI  # noqa: E402
from roboray.shared.mavlink.endpoint import Endpoint  # noqa: E402
from roboray.shared.mavlink.telemetry import Telemetry  # noqa: E402
from roboray.shared.params import ParamTable  # noqa: E402

# mavwp builds its items with mavutil's dialect: MAVLink 2's common, as the ground's link sets it
mavutil.set_dialect("common")

SYS, COMP = 1, 1
LOCAL = pm.MAV_FRAME_LOCAL_NED


class Pipe:
    def __init__(self):
        self.to_vehicle = bytearray()
        self.from_vehicle = bytearray()

    def read_into(self, buf):
        n = min(len(buf), len(self.to_vehicle))
        buf[:n] = self.to_vehicle[:n]
        del self.to_vehicle[:n]
        return n

    def write(self, buf):
        self.from_vehicle += bytes(buf)


class Ground:
    """pymavlink at ``sysid``/190 on the pipe."""

    def __init__(self, pipe, sysid=255):
        self.pipe = pipe
        self.mav = pm.MAVLink(self, sysid, 190)
        self.rx = pm.MAVLink(None)
        self.rx.robust_parsing = True

    def write(self, data):
        self.pipe.to_vehicle += data

    def received(self):
        msgs = self.rx.parse_buffer(bytearray(self.pipe.from_vehicle)) or []
        self.pipe.from_vehicle.clear()
        return [m for m in msgs if m.get_type() != "BAD_DATA"]


class Vehicle:
    def __init__(self):
        self.pipe = Pipe()
        self.params = ParamTable(param_defs.PARAMS)
        for name in ("SR_ATTITUDE", "SR_POSITION", "SR_SENSORS", "SR_SERVO", "SR_BATTERY", "SR_STATUS"):
            self.params.set_by_name(name, 0.0)   # only what the tests ask for
        self.modes = M.Modes()
        self.tel = Telemetry()
        self.ep = Endpoint(self.pipe, self.params, self.modes, self.tel)
        self.mission = self.ep.mission
        self.now = 0

    def run(self, ground, ms=200):
        """``ms`` of updates (10 ms each); what the vehicle sent, decoded."""
        out = []
        for _ in range(ms // 10):
            self.now += 10
            self.ep.update(self.now)
            out += ground.received()
        return out


@pytest.fixture()
def v():
    return Vehicle()


@pytest.fixture()
def g(v):
    return Ground(v.pipe)


def of(msgs, kind):
    return [m for m in msgs if m.get_type() == kind]


def one(msgs, kind):
    found = of(msgs, kind)
    assert len(found) == 1, [m.get_type() for m in msgs]
    return found[0]


def land(seq=1, x=0, y=0, z=0.0, frame=LOCAL, cmd=pm.MAV_CMD_NAV_LAND):
    return pm.MAVLink_mission_item_int_message(SYS, COMP, seq, frame, cmd, 0, 1, 0, 0, 0, 0, x, y, z, 0)


def home():
    return pm.MAVLink_mission_item_int_message(SYS, COMP, 0, pm.MAV_FRAME_GLOBAL, pm.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                               0, 0, 0, 0, 0, 0, 0.0, 0)


def upload(v, g, items, count=None):
    """MAVLink's upload: MISSION_COUNT, then each item the vehicle asks for; the MISSION_ACK."""
    g.mav.mission_count_send(SYS, COMP, len(items) if count is None else count, 0)
    for _ in range(10):
        msgs = v.run(g)
        acks = of(msgs, "MISSION_ACK")
        if acks:
            return acks[-1], msgs
        req = one(msgs, "MISSION_REQUEST_INT")
        g.mav.send(items[req.seq])
    raise AssertionError("no MISSION_ACK")


def download(v, g, as_int=True):
    g.mav.mission_request_list_send(SYS, COMP, 0)
    count = one(v.run(g), "MISSION_COUNT")
    items = []
    for seq in range(count.count):
        (g.mav.mission_request_int_send if as_int else g.mav.mission_request_send)(SYS, COMP, seq, 0)
        items.append(one(v.run(g), "MISSION_ITEM_INT" if as_int else "MISSION_ITEM"))
    g.mav.mission_ack_send(SYS, COMP, 0, 0)
    assert not of(v.run(g), "MISSION_ACK")   # the ground's ACK ends it: nothing answers
    return items


def test_download_is_home_alone_then_home_and_the_target(v, g):
    items = download(v, g)
    assert len(items) == 1
    h = items[0]
    assert (h.seq, h.command, h.frame, h.x, h.y, h.z, h.current, h.autocontinue) == (
        0, pm.MAV_CMD_NAV_WAYPOINT, LOCAL, 0, 0, 0.0, 0, 1)
    g.mav.mission_request_int_send(SYS, COMP, 1, 0)   # beyond the mission
    assert one(v.run(g), "MISSION_ACK").type == pm.MAV_MISSION_INVALID_SEQUENCE
    # DO_REPOSITION sets the target: the mission's item 1 is it
    g.mav.command_long_send(SYS, COMP, pm.MAV_CMD_DO_REPOSITION, 0, -1, 0, 0, 0, 2.0, -1.25, 10.0)
    assert one(v.run(g), "COMMAND_ACK").result == pm.MAV_RESULT_ACCEPTED
    h, t = download(v, g)
    assert (t.seq, t.command, t.frame, t.x, t.y, t.z, t.current) == (
        1, pm.MAV_CMD_NAV_LAND, LOCAL, 20000000, -12500000, 10.0, 1)
    # MISSION_REQUEST (deprecated) is answered with MISSION_ITEM: metres as they are
    h, t = download(v, g, as_int=False)
    assert (t.command, t.frame, t.x, t.y, t.z) == (pm.MAV_CMD_NAV_LAND, LOCAL, 2.0, -1.25, 10.0)
    assert v.mission.lists == 3


def test_an_upload_sets_the_one_target_that_every_setter_shares(v, g):
    ack, msgs = upload(v, g, [home(), land(x=25000000, y=-10000000, z=8.0)])
    assert (ack.type, ack.mission_type, ack.target_system, ack.target_component) == (0, 0, 255, 190)
    cur = one(msgs, "MISSION_CURRENT")   # told at once: a new current item
    assert (cur.seq, cur.total, cur.mission_state) == (1, 1, MI.STATE_NOT_STARTED)
    assert list(v.tel.target_ned) == [2.5, -1.0, 8.0] and v.tel.has_target and v.ep.target_count == 1
    assert v.mission.uploads == 1
    # SET_POSITION_TARGET_LOCAL_NED moves the same target: the download says so
    g.mav.set_position_target_local_ned_send(0, SYS, COMP, LOCAL, 0xFF8, 1.5, 0.5, 6.0, 0, 0, 0, 0, 0, 0, 0, 0)
    v.run(g)
    _, t = download(v, g)
    assert (t.frame, t.x, t.y, t.z) == (LOCAL, 15000000, 5000000, 6.0)


def test_pymavlinks_mavwp_loads_a_waypoint_file_and_uploads_it(v, g, tmp_path):
    path = tmp_path / "target.waypoints"
    path.write_text("QGC WPL 110\n0\t0\t0\t16\t0\t0\t0\t0\t0\t0\t0\t1\n"
                    "1\t1\t1\t21\t0\t0\t0\t0\t-1.75\t0.5\t12\t1\n")
    loader = mavwp.MAVWPLoader(SYS, COMP)
    loader.load(str(path))
    assert loader.count() == 2
    ack, _ = upload(v, g, [loader.wp(i) for i in range(loader.count())])   # MISSION_ITEMs: floats
    assert ack.type == pm.MAV_MISSION_ACCEPTED
    assert list(v.tel.target_ned) == [-1.75, 0.5, 12.0]


def test_a_global_frame_goes_through_home_at_latitude_0_longitude_0(v, g):
    # 180e-7 deg north, 90e-7 deg west, 9 m below home (the surface)
    ack, _ = upload(v, g, [home(), land(x=180, y=-90, z=-9.0, frame=pm.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)])
    assert ack.type == pm.MAV_MISSION_ACCEPTED
    n, e, d = v.tel.target_ned
    assert (n, e, d) == pytest.approx((180 * MI.M_PER_E7, -90 * MI.M_PER_E7, 9.0), abs=1e-6)
    assert n == pytest.approx(2.0037, abs=1e-4)
    h, t = download(v, g)     # shown in the frame it came in, exactly
    assert (h.frame, h.x, h.y, h.z) == (pm.MAV_FRAME_GLOBAL, 0, 0, 0.0)
    assert (t.frame, t.x, t.y, t.z) == (pm.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 180, -90, -9.0)
    _, t = download(v, g, as_int=False)
    assert (t.x, t.y) == pytest.approx((180e-7, -90e-7), rel=1e-6)
    # degrees in a MISSION_ITEM (MAVProxy's wp file, QGC's plan)
    item = pm.MAVLink_mission_item_message(SYS, COMP, 1, pm.MAV_FRAME_GLOBAL, pm.MAV_CMD_NAV_LAND, 0, 1,
                                           0, 0, 0, 0, 0.0000100, 0.0000200, 0.0)
    ack, _ = upload(v, g, [home(), item])
    assert ack.type == pm.MAV_MISSION_ACCEPTED
    assert list(v.tel.target_ned)[:2] == pytest.approx([100 * MI.M_PER_E7, 200 * MI.M_PER_E7], abs=1e-5)
    assert v.tel.target_ned[2] == 0.0      # no depth given: the vehicle's CTL_DEPTH_M
    # DO_REPOSITION sets it last: shown in the local frame
    g.mav.command_long_send(SYS, COMP, pm.MAV_CMD_DO_REPOSITION, 0, -1, 0, 0, 0, 1.0, 1.0, 0.0)
    v.run(g)
    _, t = download(v, g)
    assert (t.frame, t.x, t.y) == (LOCAL, 10000000, 10000000)


def refused(v, g, item, result, text):
    before = (list(v.tel.target_ned), v.tel.has_target, v.ep.target_count)
    ack, msgs = upload(v, g, [home(), item])
    assert (ack.type, ack.mission_type) == (result, 0)
    said = "".join(m.text for m in of(msgs, "STATUSTEXT"))
    assert text in said, said
    assert (list(v.tel.target_ned), v.tel.has_target, v.ep.target_count) == before   # nothing lost
    assert not v.mission.receiving


def test_refusals_say_why_and_keep_the_target(v, g):
    ack, _ = upload(v, g, [home(), land(x=10000000, y=10000000)])
    assert ack.type == 0
    # beyond the reach of a glide to CTL_DEPTH_M (10 m): 0.49 x 10 = 4.85 m, north the larger part
    refused(v, g, land(x=60000000, y=10000000), pm.MAV_MISSION_INVALID_PARAM5_X,
            "target 6.00 m north, 1.00 m east is 6.08 m away, beyond the reach of a glide to a bottom at 10.0 m "
            "(CTL_DEPTH_M): 4.85 m (best glide ratio 0.49)")
    refused(v, g, land(x=10000000, y=-50000000), pm.MAV_MISSION_INVALID_PARAM6_Y, "5.10 m away")
    refused(v, g, land(x=30000000, z=4.0), pm.MAV_MISSION_INVALID_PARAM5_X, "bottom at 4.0 m: 1.94 m")
    refused(v, g, land(z=-1.0), pm.MAV_MISSION_INVALID_PARAM7, "bottom at -1.0 m; 0 (CTL_DEPTH_M) to 300 m")
    refused(v, g, land(z=301.0), pm.MAV_MISSION_INVALID_PARAM7, "bottom at 301.0 m")
    refused(v, g, land(z=5.0, frame=pm.MAV_FRAME_GLOBAL_INT), pm.MAV_MISSION_INVALID_PARAM7,
            "(-z: z is the altitude above home)")
    refused(v, g, land(cmd=pm.MAV_CMD_NAV_WAYPOINT), pm.MAV_MISSION_UNSUPPORTED,
            "mission item 1: command 16; the target is a NAV_LAND (21)")
    refused(v, g, land(frame=pm.MAV_FRAME_LOCAL_OFFSET_NED), pm.MAV_MISSION_UNSUPPORTED_FRAME, "frame 7")
    refused(v, g, land(x=0x7FFFFFFF), pm.MAV_MISSION_INVALID_PARAM5_X, "the target needs x and y")
    nan = pm.MAVLink_mission_item_message(SYS, COMP, 1, LOCAL, pm.MAV_CMD_NAV_LAND, 0, 1, 0, 0, 0, 0,
                                          1.0, math.nan, 0.0)
    refused(v, g, nan, pm.MAV_MISSION_INVALID_PARAM6_Y, "finite x and y")
    assert v.mission.refusals == 10
    # more than home and one target: no room, said before any item is asked for
    g.mav.mission_count_send(SYS, COMP, 3, 0)
    msgs = v.run(g)
    assert one(msgs, "MISSION_ACK").type == pm.MAV_MISSION_NO_SPACE and not of(msgs, "MISSION_REQUEST_INT")
    # a deeper bottom given with the target: further within reach (0.49 x 20 m)
    ack, _ = upload(v, g, [home(), land(x=60000000, z=20.0)])
    assert ack.type == 0 and list(v.tel.target_ned) == [6.0, 0.0, 20.0]


def requests(msgs, seq):
    return len([m for m in msgs if m.get_type() == "MISSION_REQUEST_INT" and m.seq == seq])


def test_a_late_item_is_asked_again_five_times_then_the_upload_is_cancelled(v, g):
    g.mav.mission_count_send(SYS, COMP, 2, 0)
    assert requests(v.run(g), 0) == 1
    g.mav.send(home())
    msgs = v.run(g, 100)
    assert requests(msgs, 1) == 1
    # silence: item 1 is asked again every ITEM_TIMEOUT_MS, RETRIES times, then the upload ends
    msgs = v.run(g, MI.ITEM_TIMEOUT_MS * MI.RETRIES)
    assert requests(msgs, 1) == MI.RETRIES and not of(msgs, "MISSION_ACK")
    msgs = v.run(g, MI.ITEM_TIMEOUT_MS + 100)
    ack = one(msgs, "MISSION_ACK")
    assert (ack.type, ack.target_system, ack.target_component) == (pm.MAV_MISSION_OPERATION_CANCELLED, 255, 190)
    assert "mission upload cancelled: no item 1 (6 requests)" in [m.text for m in of(msgs, "STATUSTEXT")]
    assert not v.mission.receiving and v.mission.cancelled == 1 and not v.tel.has_target
    assert not of(v.run(g, 3000), "MISSION_REQUEST_INT")
    # the item coming now is no upload's: an error
    g.mav.send(land(x=10000000))
    assert one(v.run(g), "MISSION_ACK").type == pm.MAV_MISSION_ERROR and not v.tel.has_target
    # a lost request, answered when asked again: accepted
    g.mav.mission_count_send(SYS, COMP, 2, 0)
    v.run(g)
    g.mav.send(home())
    assert requests(v.run(g, 100), 1) == 1
    msgs = v.run(g, MI.ITEM_TIMEOUT_MS)
    assert requests(msgs, 1) == 1
    g.mav.send(land(x=10000000))
    assert one(v.run(g), "MISSION_ACK").type == pm.MAV_MISSION_ACCEPTED and v.tel.target_ned[0] == 1.0


def test_out_of_sequence_items_a_lost_ack_a_second_ground_and_a_cancel(v, g):
    g.mav.mission_count_send(SYS, COMP, 2, 0)
    v.run(g)
    g.mav.send(land(x=10000000))       # item 1 before item 0: dropped, item 0 asked again
    msgs = v.run(g)
    assert requests(msgs, 0) == 1 and not of(msgs, "MISSION_ACK")
    # a second ground station meanwhile: refused, the upload goes on
    other = Ground(v.pipe, sysid=254)
    other.mav.mission_count_send(SYS, COMP, 2, 0)
    msgs = v.run(g)
    ack = one(msgs, "MISSION_ACK")
    assert (ack.type, ack.target_system) == (pm.MAV_MISSION_DENIED, 254)
    g.mav.send(home())
    assert requests(v.run(g), 1) == 1
    g.mav.send(land(x=10000000))
    assert one(v.run(g), "MISSION_ACK").type == pm.MAV_MISSION_ACCEPTED
    # our ACK lost: the ground sends its last item again and hears it again
    g.mav.send(land(x=10000000))
    assert one(v.run(g), "MISSION_ACK").type == pm.MAV_MISSION_ACCEPTED and v.ep.target_count == 1
    # the ground cancels its upload with a MISSION_ACK: no more requests
    g.mav.mission_count_send(SYS, COMP, 2, 0)
    v.run(g)
    g.mav.mission_ack_send(SYS, COMP, pm.MAV_MISSION_OPERATION_CANCELLED, 0)
    v.run(g)
    assert not v.mission.receiving and not of(v.run(g, 3000), "MISSION_REQUEST_INT")
    assert v.tel.target_ned[0] == 1.0


def test_clearing_and_its_refusal_while_target_flies_to_it(v, g):
    def has():
        return v.tel.has_target

    assert upload(v, g, [home(), land(x=10000000)])[0].type == 0
    g.mav.mission_clear_all_send(SYS, COMP, 0)
    msgs = v.run(g)
    assert one(msgs, "MISSION_ACK").type == 0 and not has()
    assert (one(msgs, "MISSION_CURRENT").seq, one(msgs, "MISSION_CURRENT").total) == (0, 65535)
    assert len(download(v, g)) == 1
    # an empty upload and home alone clear it too (MAVLink's and ArduPilot's empty mission)
    for items in ([], [home()]):
        assert upload(v, g, [home(), land(x=10000000)])[0].type == 0 and has()
        assert upload(v, g, items)[0].type == 0 and not has()
    # one NAV_LAND alone (a ground that does not put home first) is the target
    assert upload(v, g, [land(seq=0, x=-10000000, z=5.0)])[0].type == 0
    assert has() and list(v.tel.target_ned) == [-1.0, 0.0, 5.0]
    # armed in TARGET: the target cannot be taken away, but may be moved
    assert v.modes.arm()[0] and v.modes.request(M.TARGET)[0]
    count = v.ep.target_count
    g.mav.mission_clear_all_send(SYS, COMP, 0)
    msgs = v.run(g)
    assert one(msgs, "MISSION_ACK").type == pm.MAV_MISSION_DENIED
    assert "mission: cannot clear the target while TARGET flies to it (change mode first)" == "".join(
        m.text for m in of(msgs, "STATUSTEXT"))
    assert upload(v, g, [])[0].type == pm.MAV_MISSION_DENIED
    assert upload(v, g, [home()])[0].type == pm.MAV_MISSION_DENIED
    assert has() and v.ep.target_count == count
    assert upload(v, g, [home(), land(x=20000000)])[0].type == 0 and v.tel.target_ned[0] == 2.0
    assert v.modes.disarm()[0]
    g.mav.mission_clear_all_send(SYS, COMP, pm.MAV_MISSION_TYPE_ALL)   # ALL: the mission too
    ack = one(v.run(g), "MISSION_ACK")
    assert (ack.type, ack.mission_type) == (0, pm.MAV_MISSION_TYPE_ALL) and not has()


def test_fence_and_rally_are_empty_and_other_types_unsupported(v, g):
    assert upload(v, g, [home(), land(x=10000000)])[0].type == 0
    for kind in (pm.MAV_MISSION_TYPE_FENCE, pm.MAV_MISSION_TYPE_RALLY):
        g.mav.mission_request_list_send(SYS, COMP, kind)
        c = one(v.run(g), "MISSION_COUNT")
        assert (c.count, c.mission_type) == (0, kind)
        g.mav.mission_request_int_send(SYS, COMP, 0, kind)
        ack = one(v.run(g), "MISSION_ACK")
        assert (ack.type, ack.mission_type) == (pm.MAV_MISSION_INVALID_SEQUENCE, kind)
        g.mav.mission_count_send(SYS, COMP, 3, kind)
        msgs = v.run(g)
        assert (one(msgs, "MISSION_ACK").type, one(msgs, "MISSION_ACK").mission_type) == (
            pm.MAV_MISSION_UNSUPPORTED, kind)
        assert not of(msgs, "MISSION_REQUEST_INT")
        for ask in (lambda: g.mav.mission_count_send(SYS, COMP, 0, kind),
                    lambda: g.mav.mission_clear_all_send(SYS, COMP, kind)):
            ask()
            ack = one(v.run(g), "MISSION_ACK")
            assert (ack.type, ack.mission_type) == (pm.MAV_MISSION_ACCEPTED, kind)
    assert v.tel.has_target      # the mission's target untouched
    g.mav.mission_request_list_send(SYS, COMP, 7)
    assert one(v.run(g), "MISSION_ACK").type == pm.MAV_MISSION_UNSUPPORTED


def test_mission_current_streams_with_the_status_and_follows_the_dive(v, g):
    v.params.set_by_name("SR_STATUS", 1.0)
    msgs = v.run(g, 2000)
    cur = of(msgs, "MISSION_CURRENT")
    status = len(of(msgs, "SYS_STATUS"))    # each followed by MISSION_CURRENT (the last may be on its way)
    assert len(cur) >= 2 and status - 1 <= len(cur) <= status
    assert (cur[0].seq, cur[0].total, cur[0].mission_state, cur[0].mission_mode) == (0, 65535, MI.STATE_NO_MISSION, 2)
    v.params.set_by_name("SR_STATUS", 0.0)
    v.run(g)

    def current():
        g.mav.command_long_send(SYS, COMP, pm.MAV_CMD_REQUEST_MESSAGE, 0, pm.MAVLINK_MSG_ID_MISSION_CURRENT,
                                0, 0, 0, 0, 0, 0)
        c = one(v.run(g), "MISSION_CURRENT")
        return c.seq, c.mission_state, c.mission_mode

    assert not v.mission.reached()      # nothing to reach
    assert upload(v, g, [home(), land(x=10000000)])[0].type == 0
    assert current() == (1, MI.STATE_NOT_STARTED, 2)
    assert v.modes.arm()[0] and v.modes.request(M.TARGET)[0]
    assert current() == (1, MI.STATE_ACTIVE, 1)
    assert v.modes.request(M.PASSIVE)[0]
    assert current() == (1, MI.STATE_PAUSED, 2)
    assert v.modes.request(M.TARGET)[0]
    # the firmware's touchdown: reached once
    assert v.mission.reached() and not v.mission.reached()
    msgs = v.run(g)
    assert one(msgs, "MISSION_ITEM_REACHED").seq == 1
    assert one(msgs, "MISSION_CURRENT").mission_state == MI.STATE_COMPLETE
    assert "Reached target: mission item 1" in [m.text for m in of(msgs, "STATUSTEXT")]
    # a new target: not started
    assert upload(v, g, [home(), land(x=20000000)])[0].type == 0
    assert current() == (1, MI.STATE_ACTIVE, 1)
    assert v.modes.disarm()[0]
    # the current item set: only the target's number is one
    g.mav.mission_set_current_send(SYS, COMP, 1)
    assert one(v.run(g), "MISSION_CURRENT").seq == 1
    g.mav.mission_set_current_send(SYS, COMP, 0)
    msgs = v.run(g)
    assert not of(msgs, "MISSION_CURRENT")
    assert "".join(m.text for m in of(msgs, "STATUSTEXT")) == (
        "mission: item 0 is home (the release point); the target is item 1")
    g.mav.command_long_send(SYS, COMP, pm.MAV_CMD_DO_SET_MISSION_CURRENT, 0, 1, 0, 0, 0, 0, 0, 0)
    msgs = v.run(g)
    assert one(msgs, "COMMAND_ACK").result == pm.MAV_RESULT_ACCEPTED and one(msgs, "MISSION_CURRENT").seq == 1
    g.mav.command_long_send(SYS, COMP, pm.MAV_CMD_DO_SET_MISSION_CURRENT, 0, 5, 0, 0, 0, 0, 0, 0)
    msgs = v.run(g)
    assert one(msgs, "COMMAND_ACK").result == pm.MAV_RESULT_FAILED
    assert "".join(m.text for m in of(msgs, "STATUSTEXT")) == (
        "mission: no item 5; the mission is home (0) and the target (1)")


_MP_SETUP = """
from roboray.shared import param_defs, modes
from roboray.shared.params import ParamTable
from roboray.shared.mavlink.endpoint import Endpoint
from roboray.shared.mavlink.telemetry import Telemetry
class __Pipe:
    def __init__(self):
        self.data = b''
        self.pos = 0
        self.out = bytearray(4096)
        self.n = 0
    def read_into(self, buf):
        n = len(self.data) - self.pos
        if n > len(buf):
            n = len(buf)
        for i in range(n):
            buf[i] = self.data[self.pos + i]
        self.pos += n
        return n
    def write(self, buf):
        k = len(buf)
        if self.n + k <= len(self.out):
            self.out[self.n:self.n + k] = buf
            self.n += k
__pipe = __Pipe()
__params = ParamTable(param_defs.PARAMS)
for __s in ('ATTITUDE', 'POSITION', 'SENSORS', 'SERVO', 'BATTERY', 'STATUS'):
    __params.set_by_name('SR_' + __s, 0.0)
__ep = Endpoint(__pipe, __params, modes.Modes(), Telemetry())
__t = [0]
def __feed(frame):
    __pipe.data = frame
    __pipe.pos = 0
    h = __ep.handled
    for _ in range(4):
        __t[0] += 10
        __ep.update(__t[0])
        if __ep.handled != h:
            break
def __sent():
    b = bytes(__pipe.out[:__pipe.n])
    __pipe.n = 0
    return b
"""


def test_the_protocol_on_micropython_within_the_endpoints_allocation_bound(micropython):
    """An upload and a download on the real interpreter: handling a mission
    frame (and answering it) allocates at most 512 bytes, as any frame
    (tests/test_mavlink_endpoint.py); the status stream's MISSION_CURRENT and
    an upload's asking again no more than the frame's view. (The measurement runs each frame twice: a
    repeated frame is a ground station's retry, which the protocol expects.)"""
    mav = pm.MAVLink(None, 255, 190)
    rx = pm.MAVLink(None)
    micropython.exec(_MP_SETUP)
    micropython.exec("__ep.update(0)\n__ep._pending = 0\n__sent()")

    def feed(frame, name):
        micropython.exec("__f = %r" % bytes(frame))
        used = micropython.alloc_bytes("__feed(__f)")
        assert used <= 512, "%s: %d bytes" % (name, used)
        return [m for m in rx.parse_buffer(bytearray(micropython.eval("__sent()"))) or []
                if m.get_type().startswith("MISSION")]

    out = feed(pm.MAVLink_mission_count_message(SYS, COMP, 2, 0).pack(mav), "count")
    assert [(m.get_type(), m.seq) for m in out] == [("MISSION_REQUEST_INT", 0)] * 2   # the upload started again
    # the upload waits for item 0: a look at the clock costs nothing, asking again
    # the 16-byte view of the frame written that every frame sent costs
    assert micropython.eval("__ep.mission.receiving") is True
    assert micropython.alloc_bytes("__ep.mission.tick(__t[0])") == 0
    assert micropython.alloc_bytes("__ep.mission._up_due = __t[0]\n__ep.mission.tick(__t[0])") <= 16
    micropython.eval("__sent()")
    out = feed(home().pack(mav), "home")      # item 0, then item 0 again: item 1 asked for twice
    assert [(m.get_type(), m.seq) for m in out] == [("MISSION_REQUEST_INT", 1)] * 2
    out = feed(land(x=-12500000, y=30000000, z=9.5).pack(mav), "target")
    assert [m.get_type() for m in out] == ["MISSION_ACK", "MISSION_CURRENT", "MISSION_ACK"]   # then a resent item
    assert {m.type for m in out if m.get_type() == "MISSION_ACK"} == {pm.MAV_MISSION_ACCEPTED}
    assert micropython.eval("list(__ep.t.target_ned)") == [-1.25, 3.0, 9.5]
    assert micropython.eval("(__ep.mission.uploads, __ep.target_count)") == [1, 1]
    assert micropython.alloc_bytes("__ep.mission.send_current()") <= 16
    micropython.eval("__sent()")
    out = feed(pm.MAVLink_mission_request_list_message(SYS, COMP, 0).pack(mav), "list")
    assert {(m.get_type(), m.count) for m in out} == {("MISSION_COUNT", 2)}
    out = feed(pm.MAVLink_mission_request_int_message(SYS, COMP, 1, 0).pack(mav), "request")
    assert {(m.get_type(), m.x, m.y, m.z) for m in out} == {("MISSION_ITEM_INT", -12500000, 30000000, 9.5)}
    out = feed(pm.MAVLink_mission_clear_all_message(SYS, COMP, 0).pack(mav), "clear")
    assert {(m.get_type(), getattr(m, "type", None)) for m in out} == {("MISSION_ACK", 0), ("MISSION_CURRENT", None)}
    assert micropython.eval("__ep.t.has_target") is False
