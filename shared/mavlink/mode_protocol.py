"""Mode changes and the standard modes protocol.

SET_MODE and MAV_CMD_DO_SET_MODE (custom mode: ``shared/modes.CUSTOM``,
ArduSub's numbers; acknowledged with command 11 for SET_MODE, as
ArduPilot), MAV_CMD_DO_SET_STANDARD_MODE, and the AVAILABLE_MODES /
CURRENT_MODE requests (REQUEST_MESSAGE 435/436: param2 0 every mode, one a
turn, else the mode of that index from 1). A float parameter that is not a
whole number in range (NaN, an infinity, 1e30) is refused with COMMAND_ACK
DENIED before it is converted: ``int(nan)`` raised and ended the link task.
"""

import struct

from roboray.shared import modes as M
from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink.fields import whole

_REASON_BAD_MODE_FLAGS = "DO_SET_MODE needs MAV_MODE_FLAG_CUSTOM_MODE_ENABLED"
_CUSTOM_MAX = 0xFFFF        # custom modes are small numbers; beyond: no mode


def handle_set_mode(ep, p):
    """SET_MODE (no target component: the system's autopilot answers, as ArduPilot's)."""
    pl = p.payload
    if pl[4] == ep.sysid:
        ep.commands += 1
        custom = pl[0] | (pl[1] << 8) | (pl[2] << 16) | (pl[3] << 24)
        set_mode(ep, p, msg.MSG_SET_MODE, pl[5], custom)


def do_set_mode(ep, p, cmd, pl):
    """MAV_CMD_DO_SET_MODE: param1 the base mode flags, param2 the custom mode."""
    base, custom = struct.unpack_from("<2f", pl, 0)
    b = whole(base, 255)
    c = whole(custom, _CUSTOM_MAX)
    if b < 0 or c < 0:
        ep._refuse(p, cmd, msg.MAV_RESULT_DENIED, "DO_SET_MODE: param%d %s is no mode" % (
            1 if b < 0 else 2, base if b < 0 else custom))
        return
    set_mode(ep, p, cmd, b, c)


def do_set_standard_mode(ep, p, cmd, pl):
    """MAV_CMD_DO_SET_STANDARD_MODE (the specification's answer to a standard
    mode we lack: FAILED; to a param1 that is no number: DENIED)."""
    v = struct.unpack_from("<f", pl, 0)[0]
    s = whole(v, 255)
    if s < 0:
        ep._refuse(p, cmd, msg.MAV_RESULT_DENIED, "DO_SET_STANDARD_MODE: param1 %s is no mode" % v)
        return
    ep._ack_result(p, cmd, ep.modes.request(M.from_standard(s)))


def set_mode(ep, p, cmd, base, custom):
    """DO_SET_MODE or SET_MODE (``cmd`` 11, the id ArduPilot acknowledges it with)."""
    if not base & msg.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
        ep._refuse(p, cmd, msg.MAV_RESULT_DENIED, _REASON_BAD_MODE_FLAGS)
        return
    ep._ack_result(p, cmd, ep.modes.request(M.from_custom(custom)))


def request_modes(ep, p, cmd, mid, param2):
    """REQUEST_MESSAGE of CURRENT_MODE, or of AVAILABLE_MODES: param2 0
    every mode, else the one of that index (from 1); they go out paced,
    one a turn, as stream frames do. Either starts CURRENT_MODE's stream."""
    n = len(M.MODES)
    i = 0
    if mid == msg.MSG_AVAILABLE_MODES:
        i = whole(param2, n)
        if i < 0:
            ep._refuse(p, cmd, msg.MAV_RESULT_DENIED, "AVAILABLE_MODES: param2 %s; 0 or a mode index 1-%d"
                       % (param2, n))
            return
    ep._modes_asked = True
    ep._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
    if mid == msg.MSG_CURRENT_MODE:
        ep._pending |= ep.F_CURRENT_MODE
        return
    ep._avail_next = i if i else 1
    ep._avail_last = i if i else n
    ep._pending |= ep.F_AVAILABLE
