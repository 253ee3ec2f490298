"""Position input: ATT_POS_MOCAP (a position fix) and
SET_POSITION_TARGET_LOCAL_NED (a target), and the target check every way a
target comes in shares (DO_REPOSITION in ``commands.py``, mission items in
``mission.py``).

Both messages come as streams without an answer of their own: what is
refused is dropped, counted (``Endpoint.fixes_refused``,
``targets_refused``) and told by one STATUSTEXT every ``REFUSAL_TEXT_MS``
(ArduPilot's way with a bad stream: no flood of texts at 20 Hz).

- ATT_POS_MOCAP: x, y, z (m, NED from the release point) finite, north and
  east within ``fields.LOCAL_MAX_M`` (where a target can be), z NaN (not
  measured: the twin's fixes and a surface radio's, the depth sensor gives
  depth) or within ``FIX_UP_M`` above the surface and CTL_DEPTH_M's
  maximum below it; the
  quaternion's components within +-1. A NaN fused made the position NaN, the controller
  failed and the vehicle went to FAILSAFE.
- SET_POSITION_TARGET_LOCAL_NED (position bits, MAV_FRAME_LOCAL_NED): the
  mission item's check (``Mission.check_target``): finite, reachable by a
  glide to the bottom, a bottom between the surface and 300 m.

Allocation: a refusal formats its text (once per ``REFUSAL_TEXT_MS``);
an accepted frame unpacks one tuple and boxes its floats.
"""

import struct

from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink.fields import LOCAL_MAX_M

#: A fix's z may be this far above the surface (m): the antenna's height
#: and a fix's noise at the surface (a fix of the vehicle in the air is wrong).
FIX_UP_M = 2.0
#: A refusal of a streamed message is told by STATUSTEXT at most this often (ms).
REFUSAL_TEXT_MS = 5000

# a unit quaternion's components are within +-1 (some slack for a sender's rounding)
_Q_MAX = 1.01
_TICKS_MASK = 0x3FFFFFFF
_TICKS_HALF = 0x20000000


def handle_att_pos_mocap(ep, p):
    """ATT_POS_MOCAP: the fix into ``ep.fix`` and to ``ep.on_fix``, when it is
    a place the vehicle can be."""
    v = struct.unpack_from("<Q7f", p.payload, 0)
    x = v[5]
    y = v[6]
    z = v[7]
    deepest = ep.params.maximum(ep.mission._p_depth)
    # (x - x is NaN for NaN and the infinities; NaN fails every comparison)
    if not (-LOCAL_MAX_M <= x <= LOCAL_MAX_M and -LOCAL_MAX_M <= y <= LOCAL_MAX_M
            and (z != z or -FIX_UP_M <= z <= deepest) and -_Q_MAX <= v[1] <= _Q_MAX and -_Q_MAX <= v[2] <= _Q_MAX
            and -_Q_MAX <= v[3] <= _Q_MAX and -_Q_MAX <= v[4] <= _Q_MAX):
        ep.fixes_refused += 1
        if _may_tell(ep):
            ep.send_text(msg.MAV_SEVERITY_WARNING, "ATT_POS_MOCAP refused: x %.1f y %.1f z %.1f q %.2f (%d)"
                         % (x, y, z, v[1], ep.fixes_refused))
        return
    f = ep.fix
    f[0] = x
    f[1] = y
    f[2] = z
    f[3] = v[1]
    f[4] = v[2]
    f[5] = v[3]
    f[6] = v[4]
    ep.fix_time_us = v[0]
    ep.fix_count += 1
    if ep.on_fix is not None:
        ep.on_fix(f)


def handle_set_position_target(ep, p):
    """SET_POSITION_TARGET_LOCAL_NED with the position bits of type_mask (1, 2,
    4) clear in MAV_FRAME_LOCAL_NED: the target, checked as a mission item's."""
    pl = p.payload
    if not ep._for_us(pl[50], pl[51]):
        return
    if (pl[48] & 7) != 0 or pl[52] != msg.MAV_FRAME_LOCAL_NED:
        return
    x, y, z = struct.unpack_from("<3f", pl, 4)
    if set_target(ep, x, y, z) != msg.MAV_MISSION_ACCEPTED:
        ep.targets_refused += 1
        if _may_tell(ep):
            ep.send_text(msg.MAV_SEVERITY_WARNING, "SET_POSITION_TARGET refused: " + ep.mission._why)


#: A velocity setpoint's components at most (m/s): ten times the vehicle's
#: fastest glide (~1 m/s). Beyond, the controller's squares leave float32
#: (1e30 squared is inf, inf - inf NaN) and the controller fails.
VELOCITY_MAX = 10.0


def velocity_ok(ep, vx, vy, vz):
    """Whether a velocity setpoint (SET_POSITION_TARGET_LOCAL_NED's velocity
    bits, ``firmware/link.py``'s VehicleEndpoint) can be flown: each
    component finite and within ``VELOCITY_MAX``. Refused: counted in
    ``ep.targets_refused`` and told as a target is."""
    if -VELOCITY_MAX <= vx <= VELOCITY_MAX and -VELOCITY_MAX <= vy <= VELOCITY_MAX \
            and -VELOCITY_MAX <= vz <= VELOCITY_MAX:    # (NaN fails)
        return True
    ep.targets_refused += 1
    if _may_tell(ep):
        ep.send_text(msg.MAV_SEVERITY_WARNING, "velocity setpoint refused: %s %s %s m/s (at most %.0f)"
                     % (vx, vy, vz, VELOCITY_MAX))
    return False


def set_target(ep, n, e, d):
    """The target ``n``, ``e``, ``d`` when ``Mission.check_target`` takes it:
    MAV_MISSION_ACCEPTED, else the INVALID_PARAMn naming the field at fault
    (the target unchanged; ``ep.mission._why`` says why)."""
    result = ep.mission.check_target(n, e, d)
    if result == msg.MAV_MISSION_ACCEPTED:
        ep._set_target(n, e, d)
    return result


def _may_tell(ep):
    """Whether a stream refusal may be told now (one each REFUSAL_TEXT_MS)."""
    last = ep._input_text_ms
    now = ep.now_ms
    if last >= 0 and ((now - last + _TICKS_HALF) & _TICKS_MASK) - _TICKS_HALF < REFUSAL_TEXT_MS:
        return False
    ep._input_text_ms = now
    return True
