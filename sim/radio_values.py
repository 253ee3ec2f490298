"""Radio input that is no finite, reachable number, for every message the
vehicle acts on: the class test of issue 26 item 2
(``tests/test_radio_input_twin.py``) sends these to the twin in flight.

``cases(base)`` walks the endpoint's own table (``shared/mavlink/endpoint.py``
``HANDLERS``, and ``commands.COMMANDS`` for COMMAND_LONG and COMMAND_INT):
for each message, and each command, a valid message (``base``: the target
and position the vehicle holds, so that a field left alone changes nothing)
with one field replaced by each of ``BAD_FLOATS`` (a float field) or
``BAD_INT32`` (an int32 field). A handler added to the table without a
valid message here makes ``cases`` raise: the class stays closed.

What each case must get (``Case.expect``):

- a COMMAND_ACK: a field the command reads (``READS``) refused (not
  ACCEPTED; a NaN where the command keeps a coordinate, ``KEEPS_NAN``,
  accepted), a field it does not read answered as the valid message is;
- a MISSION_ACK (the target item of an upload): INVALID_PARAM5_X,
  INVALID_PARAM6_Y or INVALID_PARAM7 naming x, y or z (a NaN z: the
  vehicle's CTL_DEPTH_M, accepted), the other fields unread: ACCEPTED;
- a PARAM_VALUE carrying the unchanged value;
- no answer (ATT_POS_MOCAP, SET_POSITION_TARGET_LOCAL_NED, streams): the
  state unchanged, which the test checks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional

from pymavlink.dialects.v20 import common as pm

from roboray.shared import modes as M
from roboray.shared.mavlink import commands
from roboray.shared.mavlink.endpoint import HANDLERS

BAD_FLOATS = (math.nan, math.inf, -math.inf, 1e30, -1e30)
BAD_INT32 = (-2 ** 31, 2 ** 31 - 1)
SYS, COMP = 1, 1
#: What COMMAND_INT's x and y are for DO_REPOSITION: metres x 1e4 (INT32_MAX: keep).
_INT_SCALE = 1e4

#: Messages the endpoint acts on that carry no float and no int32 field:
#: nothing there can be a NaN or wrap (their integers are bounded by their width).
NO_NUMBERS = frozenset((pm.MAVLINK_MSG_ID_HEARTBEAT, pm.MAVLINK_MSG_ID_PARAM_REQUEST_LIST,
                        pm.MAVLINK_MSG_ID_PARAM_REQUEST_READ, pm.MAVLINK_MSG_ID_TIMESYNC,
                        pm.MAVLINK_MSG_ID_SETUP_SIGNING, pm.MAVLINK_MSG_ID_RADIO_STATUS, pm.MAVLINK_MSG_ID_SET_MODE,
                        pm.MAVLINK_MSG_ID_REQUEST_DATA_STREAM, pm.MAVLINK_MSG_ID_MISSION_REQUEST,
                        pm.MAVLINK_MSG_ID_MISSION_SET_CURRENT, pm.MAVLINK_MSG_ID_MISSION_REQUEST_LIST,
                        pm.MAVLINK_MSG_ID_MISSION_COUNT, pm.MAVLINK_MSG_ID_MISSION_CLEAR_ALL,
                        pm.MAVLINK_MSG_ID_MISSION_ACK, pm.MAVLINK_MSG_ID_MISSION_REQUEST_INT,
                        pm.MAVLINK_MSG_ID_LOG_REQUEST_LIST, pm.MAVLINK_MSG_ID_LOG_REQUEST_DATA,
                        pm.MAVLINK_MSG_ID_LOG_ERASE, pm.MAVLINK_MSG_ID_LOG_REQUEST_END,
                        pm.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL))

#: The parameters (1-7) each command reads; 5 and 6 are COMMAND_INT's x and y.
READS = {
    # (param2 is compared with the force magic 21196: any other value, a NaN
    # too, is "not forced", as ArduPilot's is_equal: nothing to refuse)
    pm.MAV_CMD_COMPONENT_ARM_DISARM: (1,),
    pm.MAV_CMD_DO_SET_MODE: (1, 2),
    pm.MAV_CMD_DO_SET_STANDARD_MODE: (1,),
    pm.MAV_CMD_DO_REPOSITION: (5, 6, 7),
    pm.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: (1,),
    pm.MAV_CMD_SET_MESSAGE_INTERVAL: (1, 2),
    pm.MAV_CMD_REQUEST_MESSAGE: (1,),
    pm.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: (1,),
    pm.MAV_CMD_GET_HOME_POSITION: (),
    pm.MAV_CMD_DO_SET_MISSION_CURRENT: (1,),
}
#: Parameters where a NaN (COMMAND_INT: INT32_MAX) means "keep": accepted.
KEEPS_NAN = {pm.MAV_CMD_DO_REPOSITION: (5, 6, 7)}


@dataclass
class Case:
    name: str
    msg: Any                      #: the pymavlink message
    answer: Optional[str]         #: COMMAND_ACK, MISSION_ACK, PARAM_VALUE or None
    command: int = -1             #: COMMAND_ACK's command
    expect: Any = None            #: see the module docstring; "as-base": as the valid message's answer


def _params(cmd: int, base: dict) -> list:
    """A valid COMMAND_LONG's param1-7 for ``cmd`` that changes nothing in TARGET flight."""
    n, e, d = base["target"]
    p = {
        pm.MAV_CMD_COMPONENT_ARM_DISARM: [1, 0, 0, 0, 0, 0, 0],          # armed already: ACCEPTED
        pm.MAV_CMD_DO_SET_MODE: [pm.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, M.CUSTOM[M.TARGET], 0, 0, 0, 0, 0],
        pm.MAV_CMD_DO_SET_STANDARD_MODE: [M.STANDARD[M.TARGET], 0, 0, 0, 0, 0, 0],
        pm.MAV_CMD_DO_REPOSITION: [-1, 0, 0, math.nan, n, e, d],           # the same target
        pm.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: [1, 0, 0, 0, 0, 0, 0],      # armed: FAILED
        pm.MAV_CMD_SET_MESSAGE_INTERVAL: [pm.MAVLINK_MSG_ID_SYSTEM_TIME, 1e6, 0, 0, 0, 0, 0],
        pm.MAV_CMD_REQUEST_MESSAGE: [pm.MAVLINK_MSG_ID_HEARTBEAT, 0, 0, 0, 0, 0, 0],
        pm.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: [1, 0, 0, 0, 0, 0, 0],
        pm.MAV_CMD_GET_HOME_POSITION: [0, 0, 0, 0, 0, 0, 0],
        pm.MAV_CMD_DO_SET_MISSION_CURRENT: [1, 0, 0, 0, 0, 0, 0],
    }[cmd]
    return [float(v) for v in p]


def _command_expect(cmd: int, k: int, v: float) -> Any:
    if k not in READS[cmd]:
        return "as-base"
    if v != v and k in KEEPS_NAN.get(cmd, ()):
        return {pm.MAV_RESULT_ACCEPTED}
    return "refused"


def _commands(base: dict) -> list:
    out = []
    for cmd in commands.COMMANDS:           # (KeyError: a command without a valid message here)
        p = _params(cmd, base)
        name = "COMMAND_LONG %d" % cmd
        out.append(Case(name + " valid", pm.MAVLink_command_long_message(SYS, COMP, cmd, 0, *p),
                        "COMMAND_ACK", cmd, "base"))
        for k in range(1, 8):
            for v in BAD_FLOATS:
                q = list(p)
                q[k - 1] = v
                out.append(Case("%s param%d=%r" % (name, k, v), pm.MAVLink_command_long_message(SYS, COMP, cmd, 0, *q),
                                "COMMAND_ACK", cmd, _command_expect(cmd, k, v)))
        # COMMAND_INT: param1-4 and z floats, x and y int32 (DO_REPOSITION's metres x 1e4)
        x = int(round(p[4] * _INT_SCALE)) if cmd == pm.MAV_CMD_DO_REPOSITION else int(p[4])
        y = int(round(p[5] * _INT_SCALE)) if cmd == pm.MAV_CMD_DO_REPOSITION else int(p[5])
        name = "COMMAND_INT %d" % cmd

        def cint(q, x=x, y=y, cmd=cmd):
            return pm.MAVLink_command_int_message(SYS, COMP, pm.MAV_FRAME_LOCAL_NED, cmd, 0, 0,
                                                  q[0], q[1], q[2], q[3], x, y, q[6])
        out.append(Case(name + " valid", cint(p), "COMMAND_ACK", cmd, "base"))
        for k in (1, 2, 3, 4, 7):
            for v in BAD_FLOATS:
                q = list(p)
                q[k - 1] = v
                out.append(Case("%s param%d=%r" % (name, k, v), cint(q), "COMMAND_ACK", cmd, _command_expect(cmd, k, v)))
        for k in (5, 6):
            for v in BAD_INT32:
                xy = [x, y]
                xy[k - 5] = v
                keep = v == 2 ** 31 - 1 and k in KEEPS_NAN.get(cmd, ())
                out.append(Case("%s %s=%d" % (name, "xy"[k - 5], v), cint(p, xy[0], xy[1]), "COMMAND_ACK", cmd,
                                {pm.MAV_RESULT_ACCEPTED} if keep else
                                ("refused" if k in READS[cmd] else "as-base")))
    return out


def _mission(base: dict) -> list:
    n, e, d = base["target"]
    out = []
    fields = ("param1", "param2", "param3", "param4", "x", "y", "z")
    named = {"x": pm.MAV_MISSION_INVALID_PARAM5_X, "y": pm.MAV_MISSION_INVALID_PARAM6_Y, "z": pm.MAV_MISSION_INVALID_PARAM7}
    for as_int in (False, True):
        for f in fields:
            bad = BAD_INT32 if as_int and f in ("x", "y") else BAD_FLOATS
            for v in bad:
                vals = {"param1": 0.0, "param2": 0.0, "param3": 0.0, "param4": 0.0,
                        "x": int(round(n * 1e7)) if as_int else n, "y": int(round(e * 1e7)) if as_int else e, "z": d}
                vals[f] = v
                args = (SYS, COMP, 1, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_LAND, 0, 1, vals["param1"], vals["param2"],
                        vals["param3"], vals["param4"], vals["x"], vals["y"], vals["z"], 0)
                m = pm.MAVLink_mission_item_int_message(*args) if as_int else pm.MAVLink_mission_item_message(*args)
                if f not in named or (f == "z" and v != v):
                    want = pm.MAV_MISSION_ACCEPTED      # unread, or no depth given: CTL_DEPTH_M's
                else:
                    want = named[f]
                out.append(Case("%s %s=%r" % (m.get_type(), f, v), m, "MISSION_ACK", -1, {want}))
    return out


def _streams(base: dict) -> list:
    n, e, d = base["target"]
    pn, pe = base["position"]
    out = []
    names = ("x", "y", "z", "vx", "vy", "vz", "afx", "afy", "afz", "yaw", "yaw_rate")
    for i, f in enumerate(names):
        for v in BAD_FLOATS:
            vals = [n, e, d] + [0.0] * 8
            vals[i] = v
            out.append(Case("SET_POSITION_TARGET_LOCAL_NED %s=%r" % (f, v),
                            pm.MAVLink_set_position_target_local_ned_message(0, SYS, COMP, pm.MAV_FRAME_LOCAL_NED,
                                                                             0xFF8, *vals), None))
    for i, f in enumerate(("vx", "vy", "vz")):      # a velocity setpoint (velocity bits only)
        for v in BAD_FLOATS:
            vel = [0.0, 0.0, 0.0]
            vel[i] = v
            out.append(Case("SET_POSITION_TARGET_LOCAL_NED velocity %s=%r" % (f, v),
                            pm.MAVLink_set_position_target_local_ned_message(0, SYS, COMP, pm.MAV_FRAME_LOCAL_NED,
                                                                             0x0DC7, 0.0, 0.0, 0.0, *vel,
                                                                             0.0, 0.0, 0.0, 0.0, 0.0), None))
    for f in ("q0", "q1", "q2", "q3", "x", "y", "z"):
        for v in BAD_FLOATS:
            q = [1.0, 0.0, 0.0, 0.0]
            xyz = [pn, pe, math.nan]
            if f[0] == "q":
                q[int(f[1])] = v
            else:
                xyz["xyz".index(f)] = v
            out.append(Case("ATT_POS_MOCAP %s=%r" % (f, v), pm.MAVLink_att_pos_mocap_message(0, q, *xyz), None))
    return out


def _params_set(base: dict) -> list:
    return [Case("PARAM_SET FS_GCS_TIMEOUT=%r" % v,
                 pm.MAVLink_param_set_message(SYS, COMP, b"FS_GCS_TIMEOUT", v, pm.MAV_PARAM_TYPE_REAL32),
                 "PARAM_VALUE", -1, "unchanged") for v in BAD_FLOATS]


_BUILDERS = {
    pm.MAVLINK_MSG_ID_COMMAND_LONG: _commands,      # (COMMAND_INT's cases with them)
    pm.MAVLINK_MSG_ID_COMMAND_INT: None,
    pm.MAVLINK_MSG_ID_MISSION_ITEM: _mission,       # (MISSION_ITEM_INT's with them)
    pm.MAVLINK_MSG_ID_MISSION_ITEM_INT: None,
    pm.MAVLINK_MSG_ID_SET_POSITION_TARGET_LOCAL_NED: _streams,   # (ATT_POS_MOCAP's with them)
    pm.MAVLINK_MSG_ID_ATT_POS_MOCAP: None,
    pm.MAVLINK_MSG_ID_PARAM_SET: _params_set,
}


def cases(base: dict) -> list:
    """Every case for the vehicle's table; ``base``: {"target": (n, e, d), "position": (n, e)}.
    Raises KeyError for a handled message with numbers and no cases here."""
    out = []
    for mid in sorted(HANDLERS):
        if mid in NO_NUMBERS:
            continue
        build = _BUILDERS[mid]      # (KeyError: a new handler to give cases)
        if build is not None:
            out += build(base)
    return out
