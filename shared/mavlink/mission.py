"""The mission protocol on the vehicle: the landing target as a mission.

Ground stations read and set the landing target with the MAVLink mission
protocol (mavlink.io/en/services/mission.html): MAVProxy's ``wp list``,
``wp load`` and ``wp clear``, pymavlink's ``mavwp``, QGroundControl's plan,
``roboray-ground wp``. The endpoint (``endpoint.py``) hands this module
every mission message and calls ``tick`` while an upload waits for an item;
the firmware calls ``reached()`` when the vehicle lands in TARGET.

The mission has ArduPilot's shape: item 0 is home, the release point
(HOME_POSITION's, the origin of every local position), item 1 the target,
a ``MAV_CMD_NAV_LAND``: TARGET lands at that point on the bottom. A mission
is home alone (no target: MISSION_COUNT 1, as ArduPilot's empty mission)
or home and the target (``CAPACITY`` 2). Home is sent, never taken: an
upload's item 0 is accepted whatever it says, since no upload moves the
release point. One exception, for a ground station that does not put home
first (QGroundControl with a generic autopilot): a one-item upload whose
item is a NAV_LAND is the target.

One target: an accepted mission sets ``Telemetry.target_ned`` through the
endpoint's ``_set_target``, as DO_REPOSITION and SET_POSITION_TARGET_LOCAL_NED
do (``target_count`` counts every setting, clearing included), and a
download reads it there. Whatever set it last is what a ground station
downloads.

The target item (its NAV_LAND's x, y, z):

- ``MAV_FRAME_LOCAL_NED``: x metres north, y metres east of the release
  point, z the bottom's depth there in metres (down positive). In
  MISSION_ITEM (floats) the metres as they are; in MISSION_ITEM_INT x and
  y are metres x 1e7 (``LOCAL_SCALE``), as MAVProxy and QGroundControl
  encode every frame's x and y (MAVLink's text says x 1e4 for local
  frames; no ground station we serve does that, and MAVProxy's ``wp
  load`` of a local-frame file sends x 1e7).
- a global frame (``GLOBAL``, ``GLOBAL_INT``, ``GLOBAL_RELATIVE_ALT``,
  ``GLOBAL_RELATIVE_ALT_INT``): converted through home, which has no
  global position and sits at latitude 0, longitude 0, altitude 0 (as
  HOME_POSITION says): north = latitude x ``M_PER_E7`` per 1e-7 degree,
  east = longitude the same (ArduPilot's flat-earth scaling,
  LOCATION_SCALING_FACTOR, with the longitude's cosine 1 at home's
  latitude), and the bottom's depth = -z (altitude above home, which is at
  the surface; AMSL is the same with home at altitude 0). Degrees in
  MISSION_ITEM, degrees x 1e7 in MISSION_ITEM_INT.
- z = 0 or NaN: no depth given, the vehicle's ``CTL_DEPTH_M`` is the
  bottom (as a target without one).

A download shows the target in the frame of the upload that set it, or
``MAV_FRAME_LOCAL_NED`` when something else set it last; home goes in the
matching frame (``MAV_FRAME_GLOBAL`` at 0, 0, 0 beside a global target),
as a NAV_WAYPOINT as ArduPilot sends it.

Operations (MAVLink's, with ArduPilot's answers where it has one):

- download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT ->
  MISSION_ITEM_INT, MISSION_REQUEST (deprecated) -> MISSION_ITEM, for any
  item at any time (no state); a sequence number beyond the mission:
  MISSION_ACK ``MAV_MISSION_INVALID_SEQUENCE``;
- upload: MISSION_COUNT -> MISSION_REQUEST_INT for each item in turn ->
  MISSION_ACK. An item out of sequence is dropped and the expected one
  asked again; without it for ``ITEM_TIMEOUT_MS`` it is asked again, up to
  ``RETRIES`` times, then the upload ends with ``OPERATION_CANCELLED``.
  The target changes only when the whole mission is in and valid. Beyond
  ``CAPACITY``: ``NO_SPACE``; an upload from a second ground station while
  one is in progress: ``DENIED``; a MISSION_ACK from the uploader ends it
  (the ground cancelled). Its last item sent again after our ACK (the ACK
  was lost) is acknowledged again; another item outside an upload gets
  ``MAV_MISSION_ERROR``;
- MISSION_CLEAR_ALL, and an upload of no items or of home alone, clear
  the target; refused (``DENIED``, with a STATUSTEXT) while the vehicle is
  armed in TARGET, flying to it (ArduPilot keeps a running mission too);
- MISSION_SET_CURRENT and MAV_CMD_DO_SET_MISSION_CURRENT (``set_current``;
  the command is acknowledged by the endpoint, ACCEPTED or FAILED as
  ArduPilot's): 1 with a target is MISSION_CURRENT at once; another number
  a STATUSTEXT saying why not;
- MISSION_CURRENT goes with the status stream (``SR_STATUS``, ArduPilot's
  EXTENDED_STATUS group) and after every change: seq 1 and total 1 with a
  target (ArduPilot's total leaves home out), seq 0 and total 65535
  without; ``mission_state`` NO_MISSION, NOT_STARTED, ACTIVE (armed in
  TARGET), PAUSED (flown, then left), COMPLETE (landed on it);
  ``mission_mode`` 1 in TARGET, 2 otherwise;
- ``reached()``: MISSION_ITEM_REACHED 1 at the landing, once a target.

Mission types: fence and rally have nothing here (AUTOPILOT_VERSION claims
neither): their list is empty (MISSION_COUNT 0), an upload of items
``UNSUPPORTED``, an upload of none and a clear ``ACCEPTED``, a request for an
item ``INVALID_SEQUENCE``. Other types (and ALL, except in MISSION_CLEAR_ALL,
which clears the target): ``UNSUPPORTED``.

Refusals of an item, each with a STATUSTEXT saying why: another command
than NAV_LAND ``UNSUPPORTED``; another frame ``UNSUPPORTED_FRAME``; no x
or y (NaN, INT32_MAX) ``INVALID_PARAM5_X``/``INVALID_PARAM6_Y``; a depth
above the surface or below ``CTL_DEPTH_M``'s maximum (300 m, the depth
sensor's range) ``INVALID_PARAM7``; a target beyond the reach of a glide
from the surface to its bottom (the best glide ratio of the controller's
allocation table, 0.49, times the bottom's depth: ``roboray-ground
target``'s check) ``INVALID_PARAM5_X`` when north is the larger part of
the distance, else ``INVALID_PARAM6_Y``.

Allocation: state in attributes and one ``array('f')`` made here; handling
a frame unpacks one tuple and boxes its floats (as the endpoint's handling
does); the status stream's MISSION_CURRENT, ``tick`` and asking again
allocate nothing once each frame length was sent (the writer keeps its view)
(``tests/test_mission.py`` measures them on MicroPython).
Refusal texts are formatted when they are sent.
"""

import math
import struct
from array import array

from roboray.shared import modes as M
from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink.fields import LOCAL_MAX_M

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

try:    # the reach check's glide ratio, from the controller's table
    from roboray.shared.control.allocation_table import RATIO_MAX as _RATIO_MAX
except ImportError:  # a firmware without a controller flies no TARGET: no reach to check
    _RATIO_MAX = None

#: An upload asks for an item again after this long without it (ms): ArduPilot's
#: second (MAVLink suggests 250 ms; a 57,600-baud radio's round trip beside the
#: streams is 100-300 ms)...
ITEM_TIMEOUT_MS = const(1000)
#: ...this many times, then cancels.
RETRIES = const(5)
#: Items a mission holds: home and the target.
CAPACITY = const(2)
HOME_SEQ = const(0)
TARGET_SEQ = const(1)
#: Metres per 1e-7 degree of latitude (and of longitude at home's latitude, 0):
#: ArduPilot's LOCATION_SCALING_FACTOR (a sphere of 6378100 m).
M_PER_E7 = 0.011131884502145034
#: A local frame's x and y in MISSION_ITEM_INT: metres x 1e7 (MAVProxy's and
#: QGroundControl's encoding of every frame).
LOCAL_SCALE = 1e7

# MISSION_CURRENT.mission_state (MISSION_STATE) and mission_mode
STATE_NO_MISSION = const(1)
STATE_NOT_STARTED = const(2)
STATE_ACTIVE = const(3)
STATE_PAUSED = const(4)
STATE_COMPLETE = const(5)
_IN_MISSION_MODE = const(1)
_SUSPENDED = const(2)

_TICKS_MASK = const(0x3FFFFFFF)   # the endpoint's millisecond clock wraps at 2**30
_TICKS_HALF = const(0x20000000)
_INT32_MAX = const(0x7FFFFFFF)
_NO_TOTAL = const(0xFFFF)         # MISSION_CURRENT.total without a mission
_MISSION = const(0)               # MAV_MISSION_TYPE_MISSION
# MISSION_ITEM(_INT) payload offsets (wire order)
_ITEM_X = const(16)
_ITEM_SEQ = const(28)
_ITEM_CMD = const(30)
_ITEM_FRAME = const(34)
_ITEM_TYPE = const(37)

_FLYING = "mission: cannot clear the target while TARGET flies to it (change mode first)"
_BUSY = "mission: another ground station is uploading a mission"
_TOO_MANY = "mission: %d items; this vehicle holds home and one target (2)"


class Mission:
    """The mission protocol of one endpoint (``ep``: its writer, telemetry,
    modes, parameters and ``_set_target``).

    ``receiving`` is True while an upload waits for items (the endpoint
    calls ``tick(now_ms)`` then); ``frame`` is the frame the target was
    last uploaded in. Counters: ``lists`` (MISSION_COUNTs sent for a
    download), ``uploads`` (accepted), ``refusals``, ``cancelled``
    (uploads that timed out).
    """

    def __init__(self, ep):
        self.ep = ep
        self._p_depth = ep.params.index("CTL_DEPTH_M")
        if self._p_depth < 0:
            raise ValueError("params must declare CTL_DEPTH_M (a target's default bottom)")
        #: The best glide ratio (0: no controller, no reach check).
        self.ratio = float(max(_RATIO_MAX)) if _RATIO_MAX is not None else 0.0
        self.frame = msg.MAV_FRAME_LOCAL_NED
        self._own = -1         # ep.target_count when the mission last set or cleared the target
        self._reached = -1     # ep.target_count of the target landed on
        self._flown = -1       # ep.target_count of the target TARGET flew to
        self.receiving = False
        self._up_sys = -1      # the uploading ground station
        self._up_comp = -1
        self._up_count = 0
        self._up_next = 0      # the item asked for
        self._up_tries = 0     # times it was asked again
        self._up_due = 0       # when it is asked again (ms ticks)
        self._new = array("f", [0.0, 0.0, 0.0])   # the uploaded target, until the upload completes
        self._new_set = False
        self._new_frame = msg.MAV_FRAME_LOCAL_NED
        self._why = ""         # a refused item's reason, for the STATUSTEXT after the ACK
        self._done_sys = -1    # the last completed upload: its ground and last item
        self._done_comp = -1
        self._done_seq = -1
        self.lists = 0
        self.uploads = 0
        self.refusals = 0
        self.cancelled = 0

    # ------------------------------------------------------------ state
    def count(self):
        """Items in the mission: home, and the target when there is one."""
        return CAPACITY if self.ep.t.has_target else 1

    def shown_frame(self):
        """The frame a download shows the target in."""
        return self.frame if self._own == self.ep.target_count else msg.MAV_FRAME_LOCAL_NED

    def state(self):
        """MISSION_CURRENT's ``mission_state``."""
        ep = self.ep
        if not ep.t.has_target:
            return STATE_NO_MISSION
        k = ep.target_count
        if self._reached == k:
            return STATE_COMPLETE
        m = ep.modes
        if m.armed and m.mode == M.TARGET:
            self._flown = k
            return STATE_ACTIVE
        return STATE_PAUSED if self._flown == k else STATE_NOT_STARTED

    # --------------------------------------------------------- handling
    def handle(self, p):
        """A mission message the endpoint received (others are ignored)."""
        mid = p.msgid
        pl = p.payload
        ep = self.ep
        if mid == msg.MSG_MISSION_REQUEST_INT or mid == msg.MSG_MISSION_REQUEST:
            if ep._for_us(pl[2], pl[3]):
                self._request(p, pl[0] | (pl[1] << 8), pl[4], mid == msg.MSG_MISSION_REQUEST_INT)
        elif mid == msg.MSG_MISSION_ITEM_INT or mid == msg.MSG_MISSION_ITEM:
            if ep._for_us(pl[32], pl[33]):
                self._item(p, pl, mid == msg.MSG_MISSION_ITEM_INT)
        elif mid == msg.MSG_MISSION_REQUEST_LIST:
            if ep._for_us(pl[0], pl[1]):
                self._list(p, pl[2])
        elif mid == msg.MSG_MISSION_COUNT:
            if ep._for_us(pl[2], pl[3]):
                self._count(p, pl[0] | (pl[1] << 8), pl[4])
        elif mid == msg.MSG_MISSION_CLEAR_ALL:
            if ep._for_us(pl[0], pl[1]):
                self._clear_all(p, pl[2])
        elif mid == msg.MSG_MISSION_ACK:
            # from the uploader during an upload: it ended it on its side
            if (ep._for_us(pl[0], pl[1]) and self.receiving and pl[3] == _MISSION
                    and p.sysid == self._up_sys and p.compid == self._up_comp):
                self.receiving = False
        elif mid == msg.MSG_MISSION_SET_CURRENT:
            if ep._for_us(pl[2], pl[3]):
                self._set_current(pl[0] | (pl[1] << 8))

    def _list(self, p, mtype):
        if mtype == _MISSION:
            n = self.count()
            self.lists += 1
        elif mtype == msg.MAV_MISSION_TYPE_FENCE or mtype == msg.MAV_MISSION_TYPE_RALLY:
            n = 0
        else:
            self._ack(p.sysid, p.compid, msg.MAV_MISSION_UNSUPPORTED, mtype)
            return
        w = self.ep.writer
        struct.pack_into(msg.MISSION_COUNT_FMT, w.buf, w.payload, n, p.sysid, p.compid, mtype)
        self.ep._send(msg.MSG_MISSION_COUNT)

    def _request(self, p, seq, mtype, as_int):
        if mtype != _MISSION:
            fenced = mtype == msg.MAV_MISSION_TYPE_FENCE or mtype == msg.MAV_MISSION_TYPE_RALLY
            self._ack(p.sysid, p.compid,
                      msg.MAV_MISSION_INVALID_SEQUENCE if fenced else msg.MAV_MISSION_UNSUPPORTED, mtype)
        elif seq >= self.count():
            self._ack(p.sysid, p.compid, msg.MAV_MISSION_INVALID_SEQUENCE, mtype)
        else:
            self._send_item(p.sysid, p.compid, seq, as_int)

    def _send_item(self, sysid, compid, seq, as_int):
        ep = self.ep
        frame = self.shown_frame()
        glob = frame != msg.MAV_FRAME_LOCAL_NED
        if seq == HOME_SEQ:
            cmd = msg.MAV_CMD_NAV_WAYPOINT
            n = e = d = 0.0
            current = 0
            if glob:
                frame = msg.MAV_FRAME_GLOBAL
        else:
            g = ep.t.target_ned
            n = g[0]
            e = g[1]
            d = g[2]
            cmd = msg.MAV_CMD_NAV_LAND
            current = 1
        z = (0.0 - d) if glob else d       # altitude above home (the surface), or depth
        w = ep.writer
        if as_int:
            scale = 1.0 / M_PER_E7 if glob else LOCAL_SCALE
            struct.pack_into(msg.MISSION_ITEM_INT_FMT, w.buf, w.payload, 0.0, 0.0, 0.0, 0.0,
                             int(round(n * scale)), int(round(e * scale)), z, seq, cmd, sysid, compid,
                             frame, current, 1, _MISSION)
            ep._send(msg.MSG_MISSION_ITEM_INT)
        else:
            scale = 1e-7 / M_PER_E7 if glob else 1.0    # degrees, or metres
            struct.pack_into(msg.MISSION_ITEM_FMT, w.buf, w.payload, 0.0, 0.0, 0.0, 0.0,
                             n * scale, e * scale, z, seq, cmd, sysid, compid, frame, current, 1, _MISSION)
            ep._send(msg.MSG_MISSION_ITEM)

    def _count(self, p, count, mtype):
        """MISSION_COUNT: an upload starts."""
        if mtype != _MISSION:
            fenced = mtype == msg.MAV_MISSION_TYPE_FENCE or mtype == msg.MAV_MISSION_TYPE_RALLY
            ok = fenced and count == 0      # none held, none given
            self._ack(p.sysid, p.compid, msg.MAV_MISSION_ACCEPTED if ok else msg.MAV_MISSION_UNSUPPORTED, mtype)
            return
        if self.receiving and (p.sysid != self._up_sys or p.compid != self._up_comp):
            self._refuse(p.sysid, p.compid, msg.MAV_MISSION_DENIED, _BUSY)
            return
        self.receiving = False
        if count > CAPACITY:
            self._refuse(p.sysid, p.compid, msg.MAV_MISSION_NO_SPACE, _TOO_MANY % count)
            return
        if count == 0:      # an empty mission: as a clear
            self._clear(p.sysid, p.compid, mtype)
            return
        self.receiving = True
        self._up_sys = p.sysid
        self._up_comp = p.compid
        self._up_count = count
        self._up_next = 0
        self._up_tries = 0
        self._new_set = False
        self._done_seq = -1
        self._ask(self.ep.now_ms)

    def _ask(self, now):
        """MISSION_REQUEST_INT for the item the upload waits for."""
        w = self.ep.writer
        struct.pack_into(msg.MISSION_REQUEST_INT_FMT, w.buf, w.payload, self._up_next, self._up_sys,
                         self._up_comp, _MISSION)
        self.ep._send(msg.MSG_MISSION_REQUEST_INT)
        self._up_due = (now + ITEM_TIMEOUT_MS) & _TICKS_MASK

    def tick(self, now):
        """While an upload waits: ask again when the item is late, cancel after RETRIES."""
        if ((now - self._up_due) & _TICKS_MASK) >= _TICKS_HALF:
            return      # not yet due (the wrapped difference is negative)
        if self._up_tries >= RETRIES:
            self.receiving = False
            self.cancelled += 1
            self._ack(self._up_sys, self._up_comp, msg.MAV_MISSION_OPERATION_CANCELLED, _MISSION)
            self.ep.send_text(msg.MAV_SEVERITY_WARNING, "mission upload cancelled: no item %d (%d requests)"
                              % (self._up_next, RETRIES + 1))
            return
        self._up_tries += 1
        self._ask(now)

    def _item(self, p, pl, as_int):
        if pl[_ITEM_TYPE] != _MISSION:
            return      # a late fence or rally item of another transfer
        seq = pl[_ITEM_SEQ] | (pl[_ITEM_SEQ + 1] << 8)
        if not self.receiving or p.sysid != self._up_sys or p.compid != self._up_comp:
            if p.sysid == self._done_sys and p.compid == self._done_comp and seq == self._done_seq:
                # our ACK was lost and the ground sent its last item again
                self._ack(p.sysid, p.compid, msg.MAV_MISSION_ACCEPTED, _MISSION)
            else:
                self._ack(p.sysid, p.compid, msg.MAV_MISSION_ERROR, _MISSION)
            return
        if seq != self._up_next:
            self._ask(self.ep.now_ms)   # out of sequence: dropped, the expected one asked again
            return
        result = self._take(pl, as_int, seq)
        if result != msg.MAV_MISSION_ACCEPTED:
            self.receiving = False
            self._refuse(p.sysid, p.compid, result, self._why)
            return
        seq += 1
        if seq < self._up_count:
            self._up_next = seq
            self._up_tries = 0
            self._ask(self.ep.now_ms)
            return
        self._complete()

    def _take(self, pl, as_int, seq):
        """Check item ``seq`` and keep its target; a MAV_MISSION_RESULT (``_why`` says why not)."""
        cmd = pl[_ITEM_CMD] | (pl[_ITEM_CMD + 1] << 8)
        if seq == HOME_SEQ and not (self._up_count == 1 and cmd == msg.MAV_CMD_NAV_LAND):
            return msg.MAV_MISSION_ACCEPTED     # home: the release point, which no upload moves
        if cmd != msg.MAV_CMD_NAV_LAND:
            self._why = "mission item %d: command %d; the target is a NAV_LAND (21)" % (seq, cmd)
            return msg.MAV_MISSION_UNSUPPORTED
        frame = pl[_ITEM_FRAME]
        local = frame == msg.MAV_FRAME_LOCAL_NED
        if not local and frame != msg.MAV_FRAME_GLOBAL and frame != msg.MAV_FRAME_GLOBAL_INT \
                and frame != msg.MAV_FRAME_GLOBAL_RELATIVE_ALT and frame != msg.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT:
            self._why = "mission item %d: frame %d; use LOCAL_NED (1) or a global frame" % (seq, frame)
            return msg.MAV_MISSION_UNSUPPORTED_FRAME
        if as_int:
            x, y, z = struct.unpack_from("<iif", pl, _ITEM_X)
            if x == _INT32_MAX or y == _INT32_MAX:
                self._why = "mission item %d: the target needs x and y" % seq
                return msg.MAV_MISSION_INVALID_PARAM5_X if x == _INT32_MAX else msg.MAV_MISSION_INVALID_PARAM6_Y
            scale = 1.0 / LOCAL_SCALE if local else M_PER_E7
        else:
            x, y, z = struct.unpack_from("<fff", pl, _ITEM_X)
            scale = 1.0 if local else 1e7 * M_PER_E7     # metres, or degrees
        n = x * scale
        e = y * scale
        d = 0.0 if z != z else (z if local else 0.0 - z)
        result = self.check_target(n, e, d)
        if result != msg.MAV_MISSION_ACCEPTED:
            why = self._why
            if why.startswith("target "):       # where the target is: said of the mission
                self._why = "mission: " + why
            else:
                self._why = "mission item %d: %s%s" % (seq, why, "" if local or result != msg.MAV_MISSION_INVALID_PARAM7
                                                         else " (-z: z is the altitude above home)")
            return result
        g = self._new
        g[0] = n
        g[1] = e
        g[2] = d
        self._new_set = True
        self._new_frame = frame
        return msg.MAV_MISSION_ACCEPTED

    def check_target(self, n, e, d):
        """Whether a target ``n`` north, ``e`` east (m) over a bottom ``d`` m
        deep (0: CTL_DEPTH_M's) can be flown to: MAV_MISSION_ACCEPTED, or the
        INVALID_PARAMn naming the field at fault (``_why`` says why). Every
        way a target comes in (a mission item, DO_REPOSITION,
        SET_POSITION_TARGET_LOCAL_NED) goes through it."""
        if n - n != 0.0 or e - e != 0.0:    # NaN or infinite (x - x is NaN then)
            self._why = "the target needs finite x and y"
            return msg.MAV_MISSION_INVALID_PARAM5_X if n - n != 0.0 else msg.MAV_MISSION_INVALID_PARAM6_Y
        params = self.ep.params
        deepest = params.maximum(self._p_depth)
        if not 0.0 <= d <= deepest:         # (NaN fails too)
            self._why = "bottom at %.1f m; 0 (CTL_DEPTH_M) to %.0f m below the surface" % (d, deepest)
            return msg.MAV_MISSION_INVALID_PARAM7
        # MISSION_ITEM_INT carries local x and y as metres x 1e7 in 32 bits:
        # beyond LOCAL_MAX_M a download would wrap (1000 m read 141.0 m)
        if not -LOCAL_MAX_M <= n <= LOCAL_MAX_M or not -LOCAL_MAX_M <= e <= LOCAL_MAX_M:
            self._why = "target %.1f m north, %.1f m east; a local target is within %.1f m" % (n, e, LOCAL_MAX_M)
            return msg.MAV_MISSION_INVALID_PARAM5_X if abs(n) >= abs(e) else msg.MAV_MISSION_INVALID_PARAM6_Y
        bottom = d if d > 0.0 else params.get(self._p_depth)
        reach = self.ratio * bottom
        dist = math.sqrt(n * n + e * e)
        if self.ratio > 0.0 and dist > reach:
            self._why = ("target %.2f m north, %.2f m east is %.2f m away, beyond the reach of a glide "
                         "to a bottom at %.1f m%s: %.2f m (best glide ratio %.2f)"
                         % (n, e, dist, bottom, "" if d > 0.0 else " (CTL_DEPTH_M)", reach, self.ratio))
            return msg.MAV_MISSION_INVALID_PARAM5_X if abs(n) >= abs(e) else msg.MAV_MISSION_INVALID_PARAM6_Y
        return msg.MAV_MISSION_ACCEPTED

    def _complete(self):
        """The last item is in: the new mission replaces the old."""
        ep = self.ep
        sysid = self._up_sys
        compid = self._up_comp
        self.receiving = False
        if self._new_set:
            g = self._new
            ep._set_target(g[0], g[1], g[2])
            self.frame = self._new_frame
            self._own = ep.target_count
        elif not self._clear_target():
            self._refuse(sysid, compid, msg.MAV_MISSION_DENIED, _FLYING)
            return
        self._done_sys = sysid
        self._done_comp = compid
        self._done_seq = self._up_count - 1
        self.uploads += 1
        self._ack(sysid, compid, msg.MAV_MISSION_ACCEPTED, _MISSION)
        self.send_current()

    def _clear_target(self):
        """No target any more; False (nothing changed) while TARGET flies to it."""
        ep = self.ep
        m = ep.modes
        if m.armed and m.mode == M.TARGET:
            return False
        ep.t.has_target = False
        ep.target_count += 1     # (what keeps the dive's state across a reset saves on it)
        self._own = ep.target_count
        self.frame = msg.MAV_FRAME_LOCAL_NED
        return True

    def _clear(self, sysid, compid, mtype):
        if not self._clear_target():
            self._refuse(sysid, compid, msg.MAV_MISSION_DENIED, _FLYING)
            return
        self._ack(sysid, compid, msg.MAV_MISSION_ACCEPTED, mtype)
        self.send_current()

    def _clear_all(self, p, mtype):
        if mtype == _MISSION or mtype == msg.MAV_MISSION_TYPE_ALL:
            self._clear(p.sysid, p.compid, mtype)
        elif mtype == msg.MAV_MISSION_TYPE_FENCE or mtype == msg.MAV_MISSION_TYPE_RALLY:
            self._ack(p.sysid, p.compid, msg.MAV_MISSION_ACCEPTED, mtype)    # none held
        else:
            self._ack(p.sysid, p.compid, msg.MAV_MISSION_UNSUPPORTED, mtype)

    def _set_current(self, seq):
        why = self.set_current(seq)
        if why is not None:
            self.ep.send_text(msg.MAV_SEVERITY_WARNING, why)

    def set_current(self, seq):
        """MISSION_SET_CURRENT, MAV_CMD_DO_SET_MISSION_CURRENT: only the target
        (item 1) can be current, and is; None when it is (MISSION_CURRENT
        sent), else why not."""
        has = self.ep.t.has_target
        if seq == TARGET_SEQ and has:
            self.send_current()
            return None
        if seq == HOME_SEQ:
            return "mission: item 0 is home (the release point); the target is item 1"
        return "mission: no item %d; the mission is home (0)%s" % (seq, " and the target (1)" if has else ", no target")

    # ---------------------------------------------------------- sending
    def _ack(self, sysid, compid, result, mtype):
        w = self.ep.writer
        struct.pack_into(msg.MISSION_ACK_FMT, w.buf, w.payload, sysid, compid, result, mtype)
        self.ep._send(msg.MSG_MISSION_ACK)

    def _refuse(self, sysid, compid, result, why):
        self.refusals += 1
        self._ack(sysid, compid, result, _MISSION)
        self.ep.send_text(msg.MAV_SEVERITY_WARNING, why)

    def send_current(self):
        """MISSION_CURRENT (the status stream's, and after every change)."""
        ep = self.ep
        has = ep.t.has_target
        w = ep.writer
        struct.pack_into(msg.MISSION_CURRENT_FMT, w.buf, w.payload, TARGET_SEQ if has else HOME_SEQ,
                         1 if has else _NO_TOTAL, self.state(),
                         _IN_MISSION_MODE if ep.modes.mode == M.TARGET else _SUSPENDED)
        ep._send(msg.MSG_MISSION_CURRENT)

    def reached(self):
        """The vehicle landed in TARGET: MISSION_ITEM_REACHED 1 and MISSION_CURRENT
        COMPLETE, once a target; False when there is none or it was said."""
        ep = self.ep
        k = ep.target_count
        if not ep.t.has_target or self._reached == k:
            return False
        self._reached = k
        w = ep.writer
        struct.pack_into(msg.MISSION_ITEM_REACHED_FMT, w.buf, w.payload, TARGET_SEQ)
        ep._send(msg.MSG_MISSION_ITEM_REACHED)
        self.send_current()
        ep.send_text(msg.MAV_SEVERITY_INFO, "Reached target: mission item 1")
        return True
