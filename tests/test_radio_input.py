"""Radio input that is not a finite, reachable number (issue 26 item 2): each
handler refuses it with its protocol's answer before it reaches state.

Unit tests on CPython per handler, one on the MicroPython interpreter; the
class test over every handled message on the twin is
``tests/test_radio_input_twin.py``."""
from __future__ import annotations

import math

from roboray.shared.estimator.horizontal import FIX_REJECTED, Horizontal

INF = float("inf")
NAN = float("nan")


def _settled_filter():
    h = Horizontal(history=80, fix_var=1e-6, pos_psd=1e-6, bias_psd=1e-4, tau=0.0)
    h.set_gain(0.0)
    t = 0
    for k in range(200):
        t += 10000
        h.predict(t, 0.01, (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), 0.3)
        if k % 50 == 0:
            h.update(t, t, 0.0, 0.0)
    return h, t


def test_the_horizontal_filter_never_fuses_a_non_finite_fix():
    """A NaN compares false with the gate (``d2 > g2s``): it was fused and the
    position went NaN. Any number of them, enough to pass the re-acquire
    count, leaves the estimate finite."""
    h, t = _settled_filter()
    for bad in (NAN, INF, -INF):
        for _ in range(10):
            assert h.update(t, t, bad, 0.0) == FIX_REJECTED
            assert h.update(t, t, 0.0, bad) == FIX_REJECTED
    assert all(math.isfinite(v) for v in h.x)
    assert all(math.isfinite(v) for v in h.P)


# ---------------------------------------------------------------- handlers (CPython)
import pytest  # noqa: E402
from pymavlink.dialects.v20 import common as pm  # noqa: E402

from roboray.shared import modes as M  # noqa: E402
from roboray.shared.mavlink.fields import LOCAL_MAX_M  # noqa: E402

BAD = (NAN, INF, -INF, 1e30, -1e30)


def _vehicle():
    from test_mavlink_endpoint import Ground, Vehicle, exchange
    g = Ground()
    v = Vehicle(g)
    exchange(g, v)
    return g, v


def _answers(g, v, kind, n=40):
    from test_mavlink_endpoint import exchange
    return [m for m in exchange(g, v, n) if m.get_type() == kind]


def _cmd(g, v, cmd, *params):
    p = list(params) + [0.0] * (7 - len(params))
    g.mav.command_long_send(1, 1, cmd, 0, *p)
    acks = [a for a in _answers(g, v, "COMMAND_ACK") if a.command == cmd]
    assert len(acks) == 1, "one COMMAND_ACK for command %d %r" % (cmd, params)
    return acks[0]


@pytest.mark.parametrize("bad", BAD)
def test_a_float_meant_as_an_integer_that_is_no_number_is_denied(bad):
    """Each command parameter the firmware converts to an integer: a NaN
    raised in int() (no COMMAND_ACK, the link task ended); now DENIED and
    nothing changed."""
    g, v = _vehicle()
    mode = v.modes.mode
    custom = float(pm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
    for cmd, params in ((pm.MAV_CMD_DO_SET_MODE, (bad, 19.0)),
                        (pm.MAV_CMD_DO_SET_MODE, (custom, bad)),
                        (pm.MAV_CMD_DO_SET_STANDARD_MODE, (bad,)),
                        (pm.MAV_CMD_SET_MESSAGE_INTERVAL, (bad, 100000.0)),
                        (pm.MAV_CMD_SET_MESSAGE_INTERVAL, (float(pm.MAVLINK_MSG_ID_ATTITUDE), bad)),
                        (pm.MAV_CMD_REQUEST_MESSAGE, (bad,)),
                        (pm.MAV_CMD_REQUEST_MESSAGE, (435.0, bad)),
                        (pm.MAV_CMD_DO_SET_MISSION_CURRENT, (bad,))):
        a = _cmd(g, v, cmd, *params)
        assert a.result == pm.MAV_RESULT_DENIED, (cmd, params, a.result)
    assert v.modes.mode == mode
    assert v.params.get(v.params.index("SR_ATTITUDE")) == 4.0
    # the link still answers
    assert _cmd(g, v, pm.MAV_CMD_REQUEST_MESSAGE, float(pm.MAVLINK_MSG_ID_HEARTBEAT)).result == pm.MAV_RESULT_ACCEPTED


def test_a_target_by_command_is_checked_as_a_mission_item_is():
    """DO_REPOSITION took a bottom above the surface and a target 1000 m away
    (which then downloaded as 141.0 m): DENIED now, the target kept."""
    g, v = _vehicle()
    assert _cmd(g, v, pm.MAV_CMD_DO_REPOSITION, -1, 0, 0, NAN, 1.0, 0.5, 6.0).result == pm.MAV_RESULT_ACCEPTED
    for n, e, d in ((1000.0, 0.0, 6.0), (0.0, 1000.0, 6.0), (1.0, 0.5, -5.0), (1.0, 0.5, 1e30), (INF, 0.0, 6.0),
                    (0.0, -INF, 6.0), (1e30, 0.0, 6.0), (0.0, 0.0, INF), (3.0, 0.0, 6.0)):
        a = _cmd(g, v, pm.MAV_CMD_DO_REPOSITION, -1, 0, 0, NAN, n, e, d)
        assert a.result == pm.MAV_RESULT_DENIED, (n, e, d)
        assert list(v.tel.target_ned) == [1.0, 0.5, 6.0]
    # COMMAND_INT: x, y in m x 1e4; the int32 limits
    for x in (-2**31, 2**31 - 2):
        g.mav.command_int_send(1, 1, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, NAN, x, 0, 6.0)
        assert [a.result for a in _answers(g, v, "COMMAND_ACK")] == [pm.MAV_RESULT_DENIED]
    assert list(v.tel.target_ned) == [1.0, 0.5, 6.0]


def test_a_streamed_target_or_fix_that_is_no_place_is_dropped_counted_and_told_once():
    g, v = _vehicle()
    fixes = []
    v.ep.on_fix = lambda f: fixes.append(list(f))
    g.mav.set_position_target_local_ned_send(0, 1, 1, pm.MAV_FRAME_LOCAL_NED, 0xFF8, 1.0, 0.5, 6.0,
                                             0, 0, 0, 0, 0, 0, 0, 0)
    g.mav.att_pos_mocap_send(1, [1.0, 0.0, 0.0, 0.0], 0.5, -0.25, 2.0)
    _answers(g, v, "STATUSTEXT")
    assert list(v.tel.target_ned) == [1.0, 0.5, 6.0] and len(fixes) == 1
    k = 0
    for bad in BAD:
        for i in range(3):
            xyz = [0.5, -0.25, 6.0]
            xyz[i] = bad
            g.mav.set_position_target_local_ned_send(0, 1, 1, pm.MAV_FRAME_LOCAL_NED, 0xFF8, *xyz,
                                                     0, 0, 0, 0, 0, 0, 0, 0)
            k += 1
            if i == 2 and bad != bad:
                continue    # (a fix's z NaN: not measured, taken below)
            xyz[2] = 2.0 if i != 2 else bad
            g.mav.att_pos_mocap_send(1, [1.0, 0.0, 0.0, 0.0], *xyz)
        g.mav.att_pos_mocap_send(1, [bad, 0.0, 0.0, 0.0], 0.5, -0.25, 2.0)
    g.mav.set_position_target_local_ned_send(0, 1, 1, pm.MAV_FRAME_LOCAL_NED, 0xFF8, 0.0, 0.0, -5.0,
                                             0, 0, 0, 0, 0, 0, 0, 0)
    texts = _answers(g, v, "STATUSTEXT", 200)
    assert list(v.tel.target_ned) == [1.0, 0.5, 6.0] and len(fixes) == 1
    assert v.ep.targets_refused == k + 1 and v.ep.fixes_refused == k - 1 + len(BAD)
    # one text (in chunks of 50 bytes) within REFUSAL_TEXT_MS (5 s; these 2 s)
    assert len({t.id for t in texts}) == 1
    assert "".join(t.text for t in texts) == "SET_POSITION_TARGET refused: the target needs finite x and y"
    assert all(math.isfinite(x) for x in v.ep.fix)
    # the twin's fixes and a surface radio's have no z (NaN): taken
    g.mav.att_pos_mocap_send(1, [1.0, 0.0, 0.0, 0.0], 0.25, 0.5, NAN)
    _answers(g, v, "STATUSTEXT")
    assert fixes[-1][:2] == [0.25, 0.5] and len(fixes) == 2


@pytest.mark.parametrize("bad", (NAN, INF, -INF))
def test_a_parameter_set_to_no_number_answers_the_unchanged_value(bad):
    g, v = _vehicle()
    g.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", bad, pm.MAV_PARAM_TYPE_REAL32)
    from test_mavlink_endpoint import exchange
    msgs = exchange(g, v, 40)
    values = [m for m in msgs if m.get_type() == "PARAM_VALUE"]
    texts = [m.text for m in msgs if m.get_type() == "STATUSTEXT"]
    before = v.params.get(v.params.index("FS_GCS_TIMEOUT"))
    assert math.isfinite(before)
    assert [(p.param_id, p.param_value) for p in values] == [("FS_GCS_TIMEOUT", before)]
    assert texts and texts[0].startswith("FS_GCS_TIMEOUT: ")


def _upload(g, v, item):
    from test_mavlink_endpoint import exchange
    g.mav.mission_count_send(1, 1, 2, 0)
    exchange(g, v)
    g.mav.mission_item_int_send(1, 1, 0, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0)
    exchange(g, v)
    g.mav.send(item)
    return [a.type for a in _answers(g, v, "MISSION_ACK")]


def test_a_mission_item_names_the_field_at_fault():
    g, v = _vehicle()
    cases = []
    for x, y, z, want in ((NAN, 0.0, 6.0, pm.MAV_MISSION_INVALID_PARAM5_X),
                          (0.0, INF, 6.0, pm.MAV_MISSION_INVALID_PARAM6_Y),
                          (1e30, 0.0, 6.0, pm.MAV_MISSION_INVALID_PARAM5_X),
                          (0.0, 1000.0, 6.0, pm.MAV_MISSION_INVALID_PARAM6_Y),
                          (0.0, 0.0, -5.0, pm.MAV_MISSION_INVALID_PARAM7),
                          (0.0, 0.0, INF, pm.MAV_MISSION_INVALID_PARAM7)):
        cases.append((pm.MAVLink_mission_item_message(1, 1, 1, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_LAND,
                                                      0, 1, 0, 0, 0, 0, x, y, z, 0), want))
    for x, want in ((-2**31, pm.MAV_MISSION_INVALID_PARAM5_X), (2**31 - 2, pm.MAV_MISSION_INVALID_PARAM5_X)):
        cases.append((pm.MAVLink_mission_item_int_message(1, 1, 1, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_LAND,
                                                          0, 1, 0, 0, 0, 0, x, 0, 6.0, 0), want))
    for item, want in cases:
        assert _upload(g, v, item) == [want]
        assert not v.tel.has_target


def test_the_farthest_local_target_downloads_as_it_is():
    """x * 1e7 in 32 bits: a target is held within LOCAL_MAX_M, so what a
    download gives back is what was set (1000 m read 141.0 m)."""
    from roboray.shared.mavlink.mission import LOCAL_SCALE
    assert LOCAL_MAX_M * LOCAL_SCALE < 2**31 - 1
    g, v = _vehicle()
    v.ep.mission.ratio = 0.0    # (no reach check: the encoding's limit alone)
    ok = _cmd(g, v, pm.MAV_CMD_DO_REPOSITION, -1, 0, 0, NAN, LOCAL_MAX_M, -LOCAL_MAX_M, 6.0)
    assert ok.result == pm.MAV_RESULT_ACCEPTED
    g.mav.mission_request_int_send(1, 1, 1, 0)
    item = _answers(g, v, "MISSION_ITEM_INT")[0]
    assert (item.x / LOCAL_SCALE, item.y / LOCAL_SCALE) == pytest.approx((LOCAL_MAX_M, -LOCAL_MAX_M), abs=1e-4)
    assert _cmd(g, v, pm.MAV_CMD_DO_REPOSITION, -1, 0, 0, NAN, 215.0, 0.0, 6.0).result == pm.MAV_RESULT_DENIED


_MP_PIPE = """
from roboray.shared import param_defs, modes
from roboray.shared.params import ParamTable
from roboray.shared.mavlink.endpoint import Endpoint
from roboray.shared.mavlink.telemetry import Telemetry
class __Pipe:
    def __init__(self):
        self.data = b''
        self.pos = 0
        self.out = bytearray()
    def read_into(self, buf):
        n = min(len(self.data) - self.pos, len(buf))
        buf[0:n] = self.data[self.pos:self.pos + n]
        self.pos += n
        return n
    def write(self, buf):
        self.out.extend(buf)
__pipe = __Pipe()
__ep = Endpoint(__pipe, ParamTable(param_defs.PARAMS), modes.Modes(), Telemetry())
__fixes = []
__ep.on_fix = lambda f: __fixes.append(f[0])
def __run(frames, n):
    __pipe.data = frames
    __pipe.pos = 0
    for i in range(n):
        __ep.update(1000 + i * 10)
"""


def test_the_board_interpreter_refuses_the_same(micropython):
    """The handlers' checks on MicroPython (its float is 32-bit on the
    board's build, NaN and the infinities behave as CPython's): a NaN
    mode, a NaN message id, a far target and a NaN fix."""
    mav = pm.MAVLink(None, 255, 190)
    frames = b"".join(m.pack(mav) for m in (
        pm.MAVLink_command_long_message(1, 1, pm.MAV_CMD_DO_SET_MODE, 0, 1.0, NAN, 0, 0, 0, 0, 0),
        pm.MAVLink_command_long_message(1, 1, pm.MAV_CMD_REQUEST_MESSAGE, 0, INF, 0, 0, 0, 0, 0, 0),
        pm.MAVLink_command_long_message(1, 1, pm.MAV_CMD_DO_REPOSITION, 0, -1, 0, 0, NAN, 1000.0, 0.0, 6.0),
        pm.MAVLink_att_pos_mocap_message(1, [1.0, 0.0, 0.0, 0.0], NAN, 0.0, 2.0),
        pm.MAVLink_att_pos_mocap_message(1, [1.0, 0.0, 0.0, 0.0], 0.5, 0.0, 2.0),
        pm.MAVLink_param_set_message(1, 1, b"FS_GCS_TIMEOUT", -INF, pm.MAV_PARAM_TYPE_REAL32)))
    micropython.exec(_MP_PIPE)
    micropython.exec("__run(%r, 60)" % frames)
    out = bytes(micropython.eval("bytes(__pipe.out)"))
    rx = pm.MAVLink(None)
    msgs = [m for m in rx.parse_buffer(bytearray(out)) or [] if m.get_type() != "BAD_DATA"]
    acks = [(a.command, a.result) for a in msgs if a.get_type() == "COMMAND_ACK"]
    assert acks == [(pm.MAV_CMD_DO_SET_MODE, pm.MAV_RESULT_DENIED), (pm.MAV_CMD_REQUEST_MESSAGE, pm.MAV_RESULT_DENIED),
                    (pm.MAV_CMD_DO_REPOSITION, pm.MAV_RESULT_DENIED)]
    assert micropython.eval("__fixes") == [0.5] and micropython.eval("__ep.fixes_refused") == 1
    assert micropython.eval("__ep.t.has_target") is False
    values = [(m.param_id, m.param_value) for m in msgs if m.get_type() == "PARAM_VALUE"]
    assert values == [("FS_GCS_TIMEOUT", micropython.eval("__ep.params.get(__ep.params.index('FS_GCS_TIMEOUT'))"))]
    assert math.isfinite(values[0][1])


def test_demo_vehicle_answers_a_nan_command_and_keeps_serving():
    """``roboray-ground demo-vehicle`` (``ground/vehicle.py``'s PtyVehicle on
    the MicroPython interpreter) exited on a COMMAND_LONG with a NaN mode:
    the endpoint's int(nan) raised out of its loop."""
    import time

    from pymavlink import mavutil

    from roboray.ground.vehicle import PtyVehicle

    with PtyVehicle() as v:
        c = mavutil.mavlink_connection(v.device, baud=57600, source_system=255, source_component=190,
                                       dialect="common")
        try:
            assert c.wait_heartbeat(timeout=30) is not None
            results = []
            for cmd, p1, p2 in ((pm.MAV_CMD_DO_SET_MODE, 1.0, NAN), (pm.MAV_CMD_REQUEST_MESSAGE, NAN, 0.0),
                                (pm.MAV_CMD_SET_MESSAGE_INTERVAL, 30.0, INF),
                                (pm.MAV_CMD_REQUEST_MESSAGE, float(pm.MAVLINK_MSG_ID_HEARTBEAT), 0.0)):
                c.mav.command_long_send(1, 1, cmd, 0, p1, p2, 0, 0, 0, 0, 0)
                end = time.monotonic() + 10
                a = None
                while a is None and time.monotonic() < end:
                    m = c.recv_match(type="COMMAND_ACK", blocking=True, timeout=1)
                    if m is not None and m.command == cmd:
                        a = m
                results.append(None if a is None else a.result)
            assert results == [pm.MAV_RESULT_DENIED] * 3 + [pm.MAV_RESULT_ACCEPTED]
            assert v.error is None
        finally:
            c.close()


def test_the_class_walk_covers_every_handled_message():
    """``sim/radio_values.py`` walks the endpoint's own table: a message the
    endpoint acts on is either given cases for each float and int32 field,
    or has none of either (checked against pymavlink's definition)."""
    from roboray.shared.mavlink import commands
    from roboray.shared.mavlink.endpoint import HANDLERS
    from roboray.sim import radio_values as R

    for mid in HANDLERS:
        types = pm.mavlink_map[mid].fieldtypes
        if mid in R.NO_NUMBERS:
            assert "float" not in types and "int32_t" not in types, pm.mavlink_map[mid].msgname
        else:
            assert mid in R._BUILDERS, pm.mavlink_map[mid].msgname
    cases = R.cases({"target": (2.0, 0.0, 10.0), "position": (0.0, 0.0)})
    kinds = {type(c.msg).__name__ for c in cases}
    for mid in HANDLERS:
        if mid not in R.NO_NUMBERS:
            assert any(c.msg.id == mid for c in cases), pm.mavlink_map[mid].msgname
    assert {c.command for c in cases if c.answer == "COMMAND_ACK"} == set(commands.COMMANDS)
    assert len(kinds) == 7


def test_the_sil_report_names_a_failsafe_without_a_monitor_bit():
    """"controller failed" puts the vehicle in FAILSAFE without a failsafe
    monitor bit: the report's ``failsafes`` stayed empty."""
    from types import SimpleNamespace

    from roboray.sim.twin.runner import Twin

    twin = SimpleNamespace(failsafe_log=[{"name": "leak", "t": 30.0}],
                           mode_log=[(9.6, "TARGET"), (20.2, "FAILSAFE"), (25.0, "TARGET"), (30.0, "FAILSAFE"),
                                     (40.0, "FAILSAFE")])
    texts = [(20.9, 2, "controller failed: FAILSAFE mode"), (30.1, 2, "Failsafe: leak, FAILSAFE mode")]
    assert Twin._failsafes(twin, texts) == [{"name": "controller failed", "t": 20.2}, {"name": "leak", "t": 30.0},
                                            {"name": "unexplained", "t": 40.0}]


def test_every_case_of_the_class_walk_on_the_cpython_endpoint():
    """The twin test's cases (``sim/radio_values.py``) against the endpoint
    alone, armed in TARGET: each answer as the case expects, the target
    and the mode kept."""
    from test_mavlink_endpoint import exchange

    from roboray.sim import radio_values as R

    g, v = _vehicle()
    assert _cmd(g, v, pm.MAV_CMD_DO_REPOSITION, -1, 0, 0, NAN, 2.0, 0.0, 10.0).result == pm.MAV_RESULT_ACCEPTED
    assert _cmd(g, v, pm.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == pm.MAV_RESULT_ACCEPTED
    assert _cmd(g, v, pm.MAV_CMD_DO_SET_MODE, 1, M.CUSTOM[M.TARGET]).result == pm.MAV_RESULT_ACCEPTED
    before = v.params.get(v.params.index("FS_GCS_TIMEOUT"))
    base_result = {}
    wrong = []
    for case in R.cases({"target": (2.0, 0.0, 10.0), "position": (0.1, 0.0)}):
        if case.answer == "MISSION_ACK":
            g.mav.mission_count_send(1, 1, 2, 0)
            g.mav.mission_item_int_send(1, 1, 0, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                        0, 0, 0, 0, 0, 0, 0, 0)
            exchange(g, v)
        g.mav.send(case.msg)
        msgs = exchange(g, v, 40)
        if case.answer is None:
            continue
        got = [m for m in msgs if m.get_type() == case.answer and (case.command < 0 or m.command == case.command)]
        if case.answer == "COMMAND_ACK":
            r = got[0].result if got else None
        elif case.answer == "MISSION_ACK":
            r = got[-1].type if got else None
        else:
            r = got[0].param_value if got else None
        e = case.expect
        key = (case.name.split()[0], case.command)
        if e == "base":
            base_result[key] = r
            ok = r is not None
        elif e == "as-base":
            ok = r == base_result[key]
        elif e == "refused":
            ok = r is not None and r != pm.MAV_RESULT_ACCEPTED
        elif e == "unchanged":
            ok = r == before
        else:
            ok = r in e
        if not ok:
            wrong.append((case.name, r, e))
    assert not wrong, "\n".join(map(repr, wrong))
    assert list(v.tel.target_ned) == [2.0, 0.0, 10.0]
    assert v.modes.mode == M.TARGET and v.modes.armed


def test_a_velocity_setpoint_beyond_the_vehicle_is_refused():
    """The firmware's VehicleEndpoint took any finite velocity: 1e30 m/s
    squared is inf in float32, and the controller's inf - inf a NaN."""
    from test_mavlink_endpoint import Ground, exchange

    from roboray.firmware.link import VehicleEndpoint
    from roboray.shared import param_defs
    from roboray.shared.mavlink.position_input import VELOCITY_MAX
    from roboray.shared.mavlink.telemetry import Telemetry
    from roboray.shared.params import ParamTable

    class V:
        def __init__(self, g):
            self.ep = VehicleEndpoint(g.pipe, ParamTable(param_defs.PARAMS), M.Modes(None), Telemetry())
            self.now = 0

        def step(self, ms=10, n=1):
            for _ in range(n):
                self.now += ms
                self.ep.update(self.now)

    g = Ground()
    v = V(g)
    g.mav.set_position_target_local_ned_send(0, 1, 1, pm.MAV_FRAME_LOCAL_NED, 0x0DC7, 0, 0, 0, 0.2, -0.1, 0.3,
                                             0, 0, 0, 0, 0)
    exchange(g, v)
    assert list(v.ep.velocity_ned) == pytest.approx([0.2, -0.1, 0.3]) and v.ep.velocity_count == 1
    for bad in BAD + (VELOCITY_MAX * 1.01,):
        for i in range(3):
            vel = [0.0, 0.0, 0.0]
            vel[i] = bad
            g.mav.set_position_target_local_ned_send(0, 1, 1, pm.MAV_FRAME_LOCAL_NED, 0x0DC7, 0, 0, 0, *vel,
                                                     0, 0, 0, 0, 0)
    texts = [m for m in exchange(g, v, 100) if m.get_type() == "STATUSTEXT"]
    assert v.ep.velocity_count == 1 and list(v.ep.velocity_ned) == pytest.approx([0.2, -0.1, 0.3])
    assert v.ep.targets_refused == 3 * (len(BAD) + 1) and len({t.id for t in texts}) == 1
    assert texts[0].text.startswith("velocity setpoint refused")
