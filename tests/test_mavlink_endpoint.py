"""The vehicle endpoint, driven by pymavlink as a ground station would.

On CPython the transport is a pair of byte queues; on MicroPython the same
endpoint handles frames within the allocation bound the benchmark reports.
"""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as pm

from roboray.shared import modes as M
from roboray.shared import param_defs
from roboray.shared.mavlink import messages
from roboray.shared.mavlink.endpoint import Endpoint
from roboray.shared.mavlink.signing import Signing, key_from_passphrase
from roboray.shared.mavlink.telemetry import Telemetry
from roboray.shared.params import ParamTable

KEY = key_from_passphrase("endpoint")
#: What carries SLOT_MAX: NAMED_VALUE_INT once the generated table has it.
SLOT_TYPE = "NAMED_VALUE_INT" if hasattr(messages, "MSG_NAMED_VALUE_INT") else "NAMED_VALUE_FLOAT"


class Pipe:
    """The transport: ``to_vehicle`` is read by the endpoint, ``from_vehicle`` written."""

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
    def __init__(self, key=None, sysid=255):
        self.pipe = Pipe()
        self.mav = pm.MAVLink(self, sysid, 190)
        self.rx = pm.MAVLink(None)
        self.rx.robust_parsing = True
        if key is not None:
            for m in (self.mav, self.rx):
                m.signing.secret_key = key
                m.signing.link_id = 1
                m.signing.timestamp = 10**12
            self.mav.signing.sign_outgoing = True

    def write(self, data):  # pymavlink's file object
        self.pipe.to_vehicle += data

    def received(self):
        msgs = self.rx.parse_buffer(bytearray(self.pipe.from_vehicle)) or []
        self.pipe.from_vehicle.clear()
        return [m for m in msgs if m.get_type() != "BAD_DATA"]


class Vehicle:
    def __init__(self, ground, key=None, checks=None):
        self.params = ParamTable(param_defs.PARAMS)
        self.modes = M.Modes(checks)
        self.tel = Telemetry()
        self.ep = Endpoint(ground.pipe, self.params, self.modes, self.tel, Signing(key) if key else None)
        self.now = 0

    def step(self, ms=10, n=1):
        for _ in range(n):
            self.now += ms
            self.ep.update(self.now)


def exchange(g, v, n=20):
    # one frame's work an update: a frame received is parsed in one, handled
    # (and answered) in the next; with frames due, sending takes every other turn
    v.step(n=n)
    return g.received()


def acks(msgs):
    return [m for m in msgs if m.get_type() == "COMMAND_ACK"]


def test_heartbeat_names_a_generic_submarine_and_streams_follow_their_rates():
    g = Ground()
    v = Vehicle(g)
    msgs = []
    for _ in range(400):  # 4 s in 10 ms steps
        v.step()
        msgs += g.received()
    count = {}
    for m in msgs:
        count[m.get_type()] = count.get(m.get_type(), 0) + 1
    hb = [m for m in msgs if m.get_type() == "HEARTBEAT"][0]
    assert (hb.type, hb.autopilot, hb.custom_mode, hb.base_mode) == (pm.MAV_TYPE_SUBMARINE, pm.MAV_AUTOPILOT_GENERIC,
                                                                     M.CUSTOM[M.PASSIVE], 1)
    assert 4 <= count["HEARTBEAT"] <= 5
    assert 15 <= count["ATTITUDE"] <= 17          # SR_ATTITUDE 4 Hz
    assert 7 <= count["LOCAL_POSITION_NED"] <= 9  # SR_POSITION 2 Hz
    assert 1 <= count["BATTERY_STATUS"] <= 3      # SR_BATTERY 0.5 Hz
    assert "POSITION_TARGET_LOCAL_NED" not in count  # no target yet
    # a rate change takes effect
    v.params.set_by_name("SR_ATTITUDE", 0.0)
    g.received()
    msgs = []
    for _ in range(200):
        v.step()
        msgs += g.received()
    assert not [m for m in msgs if m.get_type() == "ATTITUDE"]


def test_each_stream_goes_out_on_its_period_across_the_clock_wrap_requests_and_rate_changes():
    mask = (1 << 30) - 1
    g = Ground()
    v = Vehicle(g)
    v.now = (1 << 30) - 2995          # the millisecond clock wraps 3 s in
    sent = {}

    def run(steps):
        for _ in range(steps):
            v.step()
            for m in g.received():
                sent.setdefault(m.get_type(), []).append(v.now & mask)

    def gaps(name, since=0):
        t = [x for x in sent[name] if (x - since) & mask < 1 << 29]
        return [(b - a) & mask for a, b in zip(t, t[1:])]

    def on_period(name, period, since=0, late=0):
        # one frame goes out an update, so frames due together go one after
        # the other (the lower the stream's number, the sooner); the due
        # times stay on the period, so the gaps average it
        g = gaps(name, since)
        return g and all(period - late <= x <= period + late for x in g) and \
            abs(sum(g) / len(g) - period) <= late / len(g)

    run(600)                            # 6 s
    assert set(gaps("HEARTBEAT")) == {1000}                  # first whenever it is due
    assert on_period("ATTITUDE", 250, late=20)               # second: behind the heartbeat at most
    assert on_period("SCALED_IMU", 1000, late=300) and on_period("BATTERY_STATUS", 2000, late=300)
    assert sent["HEARTBEAT"][0] == 5 and sent["ATTITUDE"][0] == 15   # due from tick 0: the first updates past it
    # asked for, a stream goes out with the answer, and then on its period from there
    g.mav.command_long_send(1, 1, pm.MAV_CMD_REQUEST_MESSAGE, 0, pm.MAVLINK_MSG_ID_BATTERY_STATUS, 0, 0, 0, 0, 0, 0)
    before = v.now & mask
    run(500)
    # parsed in an update, handled (and answered) in the next, a send's turn perhaps between
    asked = [t for t in sent["BATTERY_STATUS"] if 0 < (t - before) & mask <= 30]
    assert len(asked) == 1 and on_period("BATTERY_STATUS", 2000, since=asked[0], late=300)
    # a new rate counts from the due time already set; a stream switched
    # back on is overdue, so it goes out at once (behind what else is due)
    v.params.set_by_name("SR_SENSORS", 5.0)
    v.params.set_by_name("SR_STATUS", 0.0)
    run(300)
    assert on_period("SCALED_IMU", 200, since=sent["SCALED_IMU"][-10], late=300)
    run(7)
    v.params.set_by_name("SR_STATUS", 1.0)
    switched = v.now & mask
    run(10)
    assert 0 < (sent["SYS_STATUS"][-1] - switched) & mask <= 100
    # a ground station appearing is answered with a heartbeat as soon as its own is handled
    run(7)
    before = v.now & mask
    g.mav.heartbeat_send(pm.MAV_TYPE_GCS, pm.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    run(3)
    assert 0 < (sent["HEARTBEAT"][-1] - before) & mask <= 30 and (sent["HEARTBEAT"][-1] - 5) % 1000 != 0


def test_telemetry_carries_the_state_the_firmware_fills():
    g = Ground()
    v = Vehicle(g)
    t = v.tel
    t.q[0], t.q[3] = math.cos(0.25), math.sin(0.25)  # yaw 0.5 rad
    t.pos_ned[2] = 3.5
    t.vel_ned[2] = 0.12
    t.env[0] = 3.4
    t.servo_deg[2] = 33.0
    t.battery[0] = 7.4
    t.failsafe_flags = 0x5
    msgs = []
    for _ in range(120):
        v.step()
        msgs += g.received()
    last = {m.get_type(): m for m in msgs}
    assert last["ATTITUDE"].yaw == pytest.approx(0.5, abs=1e-6)
    assert last["LOCAL_POSITION_NED"].z == pytest.approx(3.5) and last["LOCAL_POSITION_NED"].vz == pytest.approx(0.12)
    named = {m.name: m.value for m in msgs if m.get_type() == "NAMED_VALUE_FLOAT"}
    assert named["depth_m"] == pytest.approx(3.4) and named["wing3_deg"] == pytest.approx(33.0)
    assert last["SYS_STATUS"].voltage_battery == 7400 and last["SYS_STATUS"].errors_count1 == 5


def test_position_covariance_is_the_upper_triangle_with_the_variances_on_its_diagonal():
    g = Ground()
    v = Vehicle(g)
    t = v.tel
    t.pos_ned[0], t.pos_ned[1], t.pos_ned[2] = 1.5, -2.0, 3.5
    t.vel_ned[2] = 0.12
    t.var_ned[0], t.var_ned[1], t.var_ned[2], t.var_ned[3] = 0.25, 0.5, 0.01, 0.02
    t.var_dz[0], t.var_dz[1] = 0.0004, 0.0009
    msgs = []
    for _ in range(250):
        v.step()
        msgs += g.received()
    cov = [m for m in msgs if m.get_type() == "LOCAL_POSITION_NED_COV"]
    assert cov, "no LOCAL_POSITION_NED_COV in 2.5 s"
    m = cov[-1]
    assert (m.x, m.y, m.z, m.vz) == pytest.approx((1.5, -2.0, 3.5, 0.12))
    assert all(math.isnan(a) for a in (m.ax, m.ay, m.az))
    assert m.estimator_type == pm.MAV_ESTIMATOR_TYPE_AUTOPILOT
    # the 9x9's upper triangle row by row: row i starts at 9i - i(i-1)/2
    diagonal = [9 * i - i * (i - 1) // 2 for i in range(9)]
    assert diagonal == [0, 9, 17, 24, 30, 35, 39, 42, 44]
    c = m.covariance
    assert [c[k] for k in diagonal[:6]] == pytest.approx([0.25, 0.5, 0.0004, 0.01, 0.02, 0.0009])
    assert all(math.isnan(c[k]) for k in diagonal[6:])      # accelerations: not estimated
    assert all(c[k] == 0.0 for k in range(45) if k not in diagonal)


def test_status_carries_the_loop_load_and_the_worst_slot_since_the_last_report():
    g = Ground()
    v = Vehicle(g)
    v.tel.load_permille = 431
    msgs = []
    for _ in range(150):
        v.step()
        msgs += g.received()
    # no slot times from a loop yet: SYS_STATUS goes out, SLOT_MAX does not
    assert [m.load for m in msgs if m.get_type() == "SYS_STATUS"] == [431, 431]
    assert not [m for m in msgs if getattr(m, "name", None) == "SLOT_MAX"]
    slots = []

    def run(ms, slot_us):
        # the firmware raises slot_max_us every slot (firmware/link.py)
        for _ in range(ms // 10):
            if slot_us > v.ep.slot_max_us:
                v.ep.slot_max_us = slot_us
            v.step()
            for m in g.received():
                if m.get_type() == SLOT_TYPE and m.name == "SLOT_MAX":
                    slots.append((m.name, m.value, m.time_boot_ms))
                elif m.get_type() == "SYS_STATUS":
                    slots.append(("load", m.load, v.now))

    run(1000, 4100)
    run(10, 9800)          # one long slot...
    run(2000, 4200)        # ...shows in the next report only
    assert [s[:2] for s in slots] == [("load", 431), ("SLOT_MAX", 4100), ("load", 431), ("SLOT_MAX", 9800),
                                      ("load", 431), ("SLOT_MAX", 4200)]
    # right behind SYS_STATUS (and SYSTEM_TIME, one frame an update), 1 Hz
    t = [s[2] for s in slots]
    assert all(0 < b - a <= 60 for a, b in zip(t[::2], t[1::2])) and t[2] - t[0] == t[4] - t[2] == 1000
    assert v.ep.slot_max_us == 4200          # raised again since the last report


def test_parameter_protocol_list_read_and_set():
    g = Ground()
    v = Vehicle(g)
    g.mav.param_request_list_send(1, 1)
    msgs = exchange(g, v, n=3 * v.params.count())   # a value an update, behind the streams
    values = {m.param_id: m for m in msgs if m.get_type() == "PARAM_VALUE"}
    assert len(values) == v.params.count() == values["FS_GCS_TIMEOUT"].param_count
    assert sorted(m.param_index for m in values.values()) == list(range(v.params.count()))
    assert values["FS_GCS_ENABLE"].param_type == pm.MAV_PARAM_TYPE_UINT8
    # read by name and by index
    g.mav.param_request_read_send(1, 1, b"FS_EKF_THRESH", -1)
    g.mav.param_request_read_send(1, 1, b"", 0)
    got = [m.param_id for m in exchange(g, v) if m.get_type() == "PARAM_VALUE"]
    assert got == ["FS_EKF_THRESH", v.params.name(0)]
    # a good set is echoed with the new value
    g.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", 9.5, pm.MAV_PARAM_TYPE_REAL32)
    echo = [m for m in exchange(g, v) if m.get_type() == "PARAM_VALUE"]
    assert echo[0].param_value == 9.5 and v.params.get(v.params.index("FS_GCS_TIMEOUT")) == 9.5
    # a bad one is echoed unchanged, with the reason in a STATUSTEXT
    g.mav.param_set_send(1, 1, b"FS_GCS_ENABLE", 1.5, pm.MAV_PARAM_TYPE_UINT8)
    g.mav.param_set_send(1, 1, b"SERIAL_BAUD", 9600, pm.MAV_PARAM_TYPE_INT32)
    g.mav.param_set_send(1, 1, b"NO_SUCH_PARAM", 1, pm.MAV_PARAM_TYPE_INT32)
    msgs = exchange(g, v)
    echo = [(m.param_id, m.param_value) for m in msgs if m.get_type() == "PARAM_VALUE"]
    assert echo == [("FS_GCS_ENABLE", 1.0), ("SERIAL_BAUD", 57600.0)]
    texts = [m.text for m in msgs if m.get_type() == "STATUSTEXT"]
    assert texts == ["FS_GCS_ENABLE: wrong type", "SERIAL_BAUD: read only", "PARAM_SET: unknown parameter"]
    # for another system: ignored
    g.mav.param_set_send(7, 1, b"FS_GCS_TIMEOUT", 3.0, pm.MAV_PARAM_TYPE_REAL32)
    assert not [m for m in exchange(g, v) if m.get_type() == "PARAM_VALUE"]


def test_commands_are_acknowledged_with_reasons():
    class Checks:
        leak = True

        def arming_check(self):
            return M.LEAK if self.leak else None

    checks = Checks()
    g = Ground()
    v = Vehicle(g, checks=checks)
    g.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    msgs = exchange(g, v)
    ack = acks(msgs)[0]
    assert ack.result == pm.MAV_RESULT_FAILED and M.REASONS[ack.result_param2] == M.LEAK
    assert ack.target_system == 255 and ack.target_component == 190
    assert "leak detected" in [m.text for m in msgs if m.get_type() == "STATUSTEXT"]
    checks.leak = False
    g.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    assert acks(exchange(g, v))[0].result == pm.MAV_RESULT_ACCEPTED and v.modes.mode == M.PASSIVE
    # set mode: TARGET after a target; the target shows in telemetry
    g.mav.command_long_send(1, 1, pm.MAV_CMD_DO_REPOSITION, 0, -1, 0, 0, math.nan, 2.0, -1.0, math.nan, )
    assert acks(exchange(g, v))[0].result == pm.MAV_RESULT_ACCEPTED
    assert list(v.tel.target_ned) == [2.0, -1.0, 0.0] and v.tel.has_target
    g.mav.command_long_send(1, 1, pm.MAV_CMD_DO_SET_MODE, 0, 1, M.CUSTOM[M.TARGET], 0, 0, 0, 0, 0)
    assert acks(exchange(g, v))[0].result == pm.MAV_RESULT_ACCEPTED and v.modes.mode == M.TARGET
    g.mav.command_long_send(1, 1, pm.MAV_CMD_DO_SET_MODE, 0, 0, M.CUSTOM[M.PASSIVE], 0, 0, 0, 0, 0)
    assert acks(exchange(g, v))[0].result == pm.MAV_RESULT_DENIED  # no CUSTOM_MODE_ENABLED
    # reboot refused while armed, accepted when disarmed
    g.mav.command_long_send(1, 1, pm.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0, 0, 0, 0, 0, 0)
    assert acks(exchange(g, v))[0].result == pm.MAV_RESULT_FAILED and not v.ep.reboot_requested
    g.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    g.mav.command_long_send(1, 1, pm.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0, 0, 0, 0, 0, 0)
    assert [a.result for a in acks(exchange(g, v))] == [pm.MAV_RESULT_ACCEPTED] * 2 and v.ep.reboot_requested
    # message interval sets the stream rate; unknown commands are unsupported
    g.mav.command_long_send(1, 1, pm.MAV_CMD_SET_MESSAGE_INTERVAL, 0, pm.MAVLINK_MSG_ID_ATTITUDE, 100000, 0, 0, 0, 0, 0)
    g.mav.command_long_send(1, 1, 31000, 0, 0, 0, 0, 0, 0, 0, 0)
    assert [a.result for a in acks(exchange(g, v))] == [pm.MAV_RESULT_ACCEPTED, pm.MAV_RESULT_UNSUPPORTED]
    assert v.params.get(v.params.index("SR_ATTITUDE")) == pytest.approx(10.0)


def test_target_mocap_timesync_and_radio_status():
    fixes = []
    g = Ground()
    v = Vehicle(g)
    v.ep.on_fix = lambda f: fixes.append(list(f))
    # (within a glide's reach of the 3 m bottom: 0.49 x 3 m)
    g.mav.set_position_target_local_ned_send(0, 1, 1, pm.MAV_FRAME_LOCAL_NED, 0xFF8, 1.0, 0.5, 3.0, 0, 0, 0, 0, 0, 0, 0, 0)
    g.mav.att_pos_mocap_send(123456, [1.0, 0.0, 0.0, 0.0], 0.5, -0.25, 2.0)
    g.mav.timesync_send(0, 987654321)
    g.mav.radio_status_send(80, 70, 50, 30, 20, 3, 0)
    msgs = exchange(g, v)
    assert list(v.tel.target_ned) == [1.0, 0.5, 3.0]
    assert fixes == [[0.5, -0.25, 2.0, 1.0, 0.0, 0.0, 0.0]] and v.ep.fix_time_us == 123456 and v.ep.fix_count == 1
    ts = [m for m in msgs if m.get_type() == "TIMESYNC"]
    assert ts and ts[0].ts1 == 987654321 and ts[0].tc1 > 0
    assert list(v.ep.radio) == [80, 70, 50, 30, 20, 3, 0]  # rssi remrssi txbuf noise remnoise rxerrors fixed


def test_with_a_key_only_signed_frames_and_radio_status_get_through():
    v_key = KEY
    g_unsigned = Ground()
    v = Vehicle(g_unsigned, key=v_key)
    g_unsigned.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    g_unsigned.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", 9.5, pm.MAV_PARAM_TYPE_REAL32)
    g_unsigned.mav.radio_status_send(80, 70, 50, 30, 20, 3, 0)  # the radio's own, unsigned
    msgs = exchange(g_unsigned, v)
    assert not acks(msgs) and not v.modes.armed and v.ep.rejected == 2 and v.ep.radio_count == 1
    assert v.params.get(v.params.index("FS_GCS_TIMEOUT")) == 5.0
    # wrong key: rejected too
    g_wrong = Ground(key=key_from_passphrase("wrong"))
    v.ep.transport = g_wrong.pipe
    g_wrong.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    exchange(g_wrong, v)
    assert not v.modes.armed and v.ep.rejected == 3
    # the right key: accepted, and the vehicle's answer is signed
    g = Ground(key=KEY)
    v.ep.transport = g.pipe
    g.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    msgs = exchange(g, v)
    assert v.modes.armed and acks(msgs)[0].result == 0 and acks(msgs)[0].get_signed()
    # a replayed frame is refused
    g2 = Ground(key=KEY)
    v.ep.transport = g2.pipe
    g2.mav.signing.timestamp = 10**12  # the same timestamp as g's command: a replay
    g2.mav.command_long_send(1, 1, pm.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    exchange(g2, v)
    assert v.modes.armed and v.ep.rejected == 4


_MP_SETUP = """
import struct
from roboray.shared import param_defs, modes
from roboray.shared.params import ParamTable
from roboray.shared.mavlink.endpoint import Endpoint
from roboray.shared.mavlink.telemetry import Telemetry
class __Pipe:
    def __init__(self):
        self.data = b''
        self.pos = 0
        self.out = 0
    def read_into(self, buf):
        n = len(self.data) - self.pos
        if n > len(buf):
            n = len(buf)
        for i in range(n):
            buf[i] = self.data[self.pos + i]
        self.pos += n
        return n
    def write(self, buf):
        self.out += len(buf)
__pipe = __Pipe()
__ep = Endpoint(__pipe, ParamTable(param_defs.PARAMS), modes.Modes(), Telemetry())
__t = [0]
def __feed(frame):
    __pipe.data = frame
    __pipe.pos = 0
    h = __ep.handled
    for _ in range(4):      # parsed in one update, handled in the next (an answer's turn perhaps first)
        __t[0] += 1
        __ep.update(__t[0])
        if __ep.handled != h:
            break
"""


def test_endpoint_handles_frames_within_the_allocation_bound_on_micropython(micropython):
    """Receiving, handling and answering one frame: at most 512 heap bytes."""
    mav = pm.MAVLink(None, 255, 190)
    frames = {
        "heartbeat": pm.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav),
        "param_set": pm.MAVLink_param_set_message(1, 1, b"FS_GCS_TIMEOUT", 7.0, 9).pack(mav),
        "command": pm.MAVLink_command_long_message(1, 1, pm.MAV_CMD_DO_SET_MODE, 0, 1, 1, 0, 0, 0, 0, 0).pack(mav),
        "mocap": pm.MAVLink_att_pos_mocap_message(5, [1, 0, 0, 0], 1.0, 2.0, 3.0).pack(mav),
    }
    micropython.exec(_MP_SETUP)
    # no streams: what is measured is receiving, handling and answering
    micropython.exec("__ep.update(0)\nfor __n in ('ATTITUDE', 'POSITION', 'SENSORS', 'SERVO', 'BATTERY', 'STATUS'):\n"
                     "    __ep.params.set_by_name('SR_' + __n, 0.0)\n__ep._pending = 0")
    for name, frame in frames.items():
        micropython.exec("__f = %r" % frame)
        used = micropython.alloc_bytes("__feed(__f)")
        assert used <= 512, "%s: %d bytes" % (name, used)
    assert micropython.eval("__ep.handled") >= 8
    assert micropython.eval("__ep.fix[2]") == 3.0
