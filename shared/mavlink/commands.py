"""COMMAND_LONG and COMMAND_INT, answered with COMMAND_ACK.

``COMMANDS`` maps each command the vehicle carries out to its handler
``handler(ep, p, cmd, payload)``; any other gets UNSUPPORTED. COMMAND_LONG
and COMMAND_INT share the layout of param1-4, param7 (z), the command and
the target; COMMAND_INT's param5/6 are x/y (int32).

Results are ArduPilot's: a refusal by the vehicle's state FAILED, arming an
armed vehicle ACCEPTED, a parameter the command does not know
UNSUPPORTED, and a parameter value that is no number or out of range
DENIED (ArduPilot's answer to a bad value): a float meant as an integer
(a message id, a mode, a mission item) must be finite and whole
(``fields.whole``; ``int(nan)`` raised and ended the link task, and the
ground station heard nothing), a target must pass the mission item's check
(``Mission.check_target``). A refusal's reason is
``modes.REASONS.index(reason)`` in ``result_param2`` (255: another) and a
STATUSTEXT.

- COMPONENT_ARM_DISARM: param1 1 arm, 0 disarm (a flag: the mode stays);
  param2 21196 forces.
- DO_SET_MODE, DO_SET_STANDARD_MODE: ``mode_protocol.py``.
- DO_REPOSITION (our convention, as COMMAND_LONG has no frame: param5
  north, param6 east, param7 down in metres, MAV_FRAME_LOCAL_NED; NaN keeps
  a coordinate; COMMAND_INT in MAV_FRAME_LOCAL_NED only, x and y metres x
  1e4, INT32_MAX keeps).
- PREFLIGHT_REBOOT_SHUTDOWN: param1 1 reboots, refused while armed.
- SET_MESSAGE_INTERVAL: the matching ``SR_*`` rate (``streams.py``).
- REQUEST_MESSAGE: the heartbeat, a telemetry stream, AUTOPILOT_VERSION,
  HOME_POSITION, AVAILABLE_MODES, CURRENT_MODE, now.
- REQUEST_AUTOPILOT_CAPABILITIES, GET_HOME_POSITION.
- DO_SET_MISSION_CURRENT: ``Mission.set_current``.
"""

import struct

from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink import mode_protocol
from roboray.shared.mavlink.fields import whole
from roboray.shared.mavlink.position_input import set_target
from roboray.shared.mavlink.streams import stream_of

_FORCE_MAGIC = 21196       # MAV_CMD_COMPONENT_ARM_DISARM param2: force
_INT32_MAX = 0x7FFFFFFF
_MSGID_MAX = 0xFFFFFF      # message ids are 24 bits
_SEQ_MAX = 0xFFFF
_INTERVAL_MAX_US = 1e9     # SET_MESSAGE_INTERVAL: 1000 s at most (the streams' longest period)
_NAN = float("nan")
_REASON_REBOOT_ARMED = "reboot refused: disarm first"
_REASON_BAD_FRAME = "DO_REPOSITION needs MAV_FRAME_LOCAL_NED (no global position)"


def handle(ep, p):
    """A COMMAND_LONG or COMMAND_INT addressed to us: its handler, or UNSUPPORTED."""
    pl = p.payload
    if not ep._for_us(pl[30], pl[31]):
        return
    ep.commands += 1
    cmd = pl[28] | (pl[29] << 8)
    h = COMMANDS.get(cmd)
    if h is None:
        ep._ack(p, cmd, msg.MAV_RESULT_UNSUPPORTED, 0)
    else:
        h(ep, p, cmd, pl)


def _bad_param(ep, p, cmd, k, v):
    """DENIED: param ``k``'s value ``v`` is no number the command takes."""
    ep._refuse(p, cmd, msg.MAV_RESULT_DENIED, "command %d: param%d %s out of range" % (cmd, k, v))


def arm_disarm(ep, p, cmd, pl):
    arm, force = struct.unpack_from("<2f", pl, 0)
    # ArduPilot's results: arming an armed vehicle (or disarming a disarmed
    # one) is ACCEPTED, a refusal FAILED, another param1 UNSUPPORTED (a NaN
    # too: it is neither); the mode stays either way
    if arm == 1.0:
        result = ep.modes.arm(force == _FORCE_MAGIC)
    elif arm == 0.0:
        result = ep.modes.disarm()
    else:
        ep._ack(p, cmd, msg.MAV_RESULT_UNSUPPORTED, 0)
        return
    ep._ack_result(p, cmd, result)


def reposition(ep, p, cmd, pl):
    t = ep.t.target_ned
    if p.msgid == msg.MSG_COMMAND_INT:
        # x, y in metres x 1e4 (INT32_MAX: keep), z in metres, local frame only
        if pl[32] != msg.MAV_FRAME_LOCAL_NED:
            ep._refuse(p, cmd, msg.MAV_RESULT_DENIED, _REASON_BAD_FRAME)
            return
        x, y = struct.unpack_from("<2i", pl, 16)
        n = t[0] if x == _INT32_MAX else x * 1e-4
        e = t[1] if y == _INT32_MAX else y * 1e-4
        d = struct.unpack_from("<f", pl, 24)[0]
    else:
        n, e, d = struct.unpack_from("<3f", pl, 16)
        if n != n:
            n = t[0]
        if e != e:
            e = t[1]
    if d != d:
        d = t[2]
    result = set_target(ep, n, e, d)
    if result == msg.MAV_MISSION_ACCEPTED:
        ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
    else:
        # the field at fault: param5 (x), param6 (y) or param7 (z) in result_param2's reason text
        ep._refuse(p, cmd, msg.MAV_RESULT_DENIED, "DO_REPOSITION: " + ep.mission._why)


def reboot(ep, p, cmd, pl):
    what = struct.unpack_from("<f", pl, 0)[0]
    if what != 1.0:
        ep._ack(p, cmd, msg.MAV_RESULT_UNSUPPORTED, 0)
    elif ep.modes.armed:
        ep._refuse(p, cmd, msg.MAV_RESULT_FAILED, _REASON_REBOOT_ARMED)
    else:
        ep.reboot_requested = True
        ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)


def message_interval(ep, p, cmd, pl):
    """param1 the message id, param2 the interval (us; -1 off, 0 the default 4 Hz,
    at most 1e9: 1000 s)."""
    mid, interval_us = struct.unpack_from("<2f", pl, 0)
    k = stream_of(whole(mid, _MSGID_MAX))
    if k < 0:
        ep._ack(p, cmd, msg.MAV_RESULT_DENIED, 0)
        return
    if not -1.0 <= interval_us <= _INTERVAL_MAX_US:     # (NaN fails)
        _bad_param(ep, p, cmd, 2, interval_us)
        return
    rate = 0.0 if interval_us < 0 else (1e6 / interval_us if interval_us > 0 else 4.0)
    err = ep.params.set(ep._p_rates[k], rate)
    ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED if err == 0 else msg.MAV_RESULT_DENIED, err)


def request_message(ep, p, cmd, pl):
    v = struct.unpack_from("<f", pl, 0)[0]
    mid = whole(v, _MSGID_MAX)
    if mid < 0:
        _bad_param(ep, p, cmd, 1, v)
        return
    if mid == msg.MSG_AUTOPILOT_VERSION or mid == msg.MSG_HOME_POSITION:
        ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
        ep._send_once(mid)
        return
    if mid == msg.MSG_AVAILABLE_MODES or mid == msg.MSG_CURRENT_MODE:
        mode_protocol.request_modes(ep, p, cmd, mid, struct.unpack_from("<f", pl, 4)[0])
        return
    k = stream_of(mid) if mid != msg.MSG_HEARTBEAT else -1
    if k < 0 and mid != msg.MSG_HEARTBEAT:
        ep._ack(p, cmd, msg.MAV_RESULT_DENIED, 0)
        return
    ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
    # the answer goes now; the stream goes on a period from here
    if k < 0:
        ep._heartbeat_now()
    else:
        ep._send_stream(k)
    ep._wake = ep.now_ms


def capabilities(ep, p, cmd, pl):
    if struct.unpack_from("<f", pl, 0)[0] != 1.0:
        ep._ack(p, cmd, msg.MAV_RESULT_FAILED, 0)   # (ArduPilot's answer)
        return
    ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
    ep._send_once(msg.MSG_AUTOPILOT_VERSION)


def home_position(ep, p, cmd, pl):
    ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
    ep._send_once(msg.MSG_HOME_POSITION)


def mission_current(ep, p, cmd, pl):
    v = struct.unpack_from("<f", pl, 0)[0]
    seq = whole(v, _SEQ_MAX)
    if seq < 0:
        _bad_param(ep, p, cmd, 1, v)
        return
    why = ep.mission.set_current(seq)
    if why is None:
        ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
    else:
        ep._refuse(p, cmd, msg.MAV_RESULT_FAILED, why)


COMMANDS = {
    msg.MAV_CMD_COMPONENT_ARM_DISARM: arm_disarm,
    msg.MAV_CMD_DO_SET_MODE: mode_protocol.do_set_mode,
    msg.MAV_CMD_DO_SET_STANDARD_MODE: mode_protocol.do_set_standard_mode,
    msg.MAV_CMD_DO_REPOSITION: reposition,
    msg.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: reboot,
    msg.MAV_CMD_SET_MESSAGE_INTERVAL: message_interval,
    msg.MAV_CMD_REQUEST_MESSAGE: request_message,
    msg.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: capabilities,
    msg.MAV_CMD_GET_HOME_POSITION: home_position,
    msg.MAV_CMD_DO_SET_MISSION_CURRENT: mission_current,
}
