"""The mission protocol from the ground: the vehicle's landing target as a mission.

The vehicle's side is ``shared/mavlink/mission.py``: item 0 is home (the
release point), item 1 the target, a MAV_CMD_NAV_LAND. ``download``,
``upload`` and ``clear`` run MAVLink's operations on a ``Link``
(mavlink.io/en/services/mission.html), with its timeouts and retries:
each request is sent again after ``TIMEOUT_S`` without its answer, up to
``RETRIES`` times; during an upload the vehicle asks for the items (and
asks again itself), so we only answer and wait. A refusal raises
``MissionRefused`` with the MAV_MISSION_RESULT and the vehicle's reason
(the STATUSTEXT that follows its MISSION_ACK).

``target_item`` builds the target as the vehicle reads it (local frame,
metres x ``LOCAL_SCALE`` in MISSION_ITEM_INT), ``target_of`` reads one
back, from a local or a global frame (converted through home at latitude
0, longitude 0 as the vehicle does).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Optional

from roboray.ground.link import Link, LinkError
from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink.mission import HOME_SEQ, LOCAL_SCALE, M_PER_E7, TARGET_SEQ

#: MAVLink's default timeout before a request is sent again (s)...
TIMEOUT_S = 1.5
#: ...and how many times.
RETRIES = 5
#: Our wait for the next request of an upload under way (s): longer than the
#: vehicle's own asking again (1 s, five times) and its cancelling.
UPLOAD_SILENCE_S = 8.0

RESULTS = {
    0: "accepted", 1: "error", 2: "unsupported frame", 3: "unsupported command", 4: "no space",
    5: "invalid", 6: "invalid param1", 7: "invalid param2", 8: "invalid param3", 9: "invalid param4",
    10: "invalid x (north, latitude)", 11: "invalid y (east, longitude)", 12: "invalid z (depth, altitude)",
    13: "invalid sequence", 14: "denied", 15: "cancelled",
}
#: Results that say a value was wrong (the caller's mistake, not the link's).
VALUE_RESULTS = frozenset((5, 6, 7, 8, 9, 10, 11, 12))
_GLOBAL_FRAMES = (msg.MAV_FRAME_GLOBAL, msg.MAV_FRAME_GLOBAL_INT, msg.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                  msg.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
FRAME_NAMES = {msg.MAV_FRAME_GLOBAL: "GLOBAL", msg.MAV_FRAME_LOCAL_NED: "LOCAL_NED",
               msg.MAV_FRAME_GLOBAL_RELATIVE_ALT: "GLOBAL_RELATIVE_ALT", msg.MAV_FRAME_GLOBAL_INT: "GLOBAL_INT",
               msg.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: "GLOBAL_RELATIVE_ALT_INT",
               msg.MAV_FRAME_LOCAL_OFFSET_NED: "LOCAL_OFFSET_NED"}
COMMAND_NAMES = {msg.MAV_CMD_NAV_WAYPOINT: "NAV_WAYPOINT", msg.MAV_CMD_NAV_LAND: "NAV_LAND"}


class MissionRefused(LinkError):
    """The vehicle answered a mission operation with an error."""

    def __init__(self, text: str, result: int) -> None:
        super().__init__(text)
        self.result = result


@dataclass(frozen=True)
class Target:
    """The landing target a mission holds."""

    north_m: float
    east_m: float
    #: The bottom's depth there (m), None: the vehicle's CTL_DEPTH_M.
    down_m: Optional[float]
    frame: int
    #: Latitude and longitude (degrees) when the item is in a global frame.
    latitude: Optional[float] = None
    longitude: Optional[float] = None


def _is(kind: str, seq: Optional[int] = None) -> Callable[[Any], bool]:
    def accept(m: Any) -> bool:
        if m.get_type() == "MISSION_ACK":
            return getattr(m, "mission_type", 0) == 0
        if m.get_type() != kind or getattr(m, "mission_type", 0) != 0:
            return False
        return seq is None or m.seq == seq
    return accept


def _reason(link: Link, timeout: float = 0.5) -> str:
    """The STATUSTEXT that follows a refusal, its chunks joined (MAVLink 2
    sends a text over 50 bytes in chunks of 50 with one ``id``)."""
    parts: list = []
    tid = 0
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = link.wait(lambda m: m.get_type() == "STATUSTEXT" and (not parts or getattr(m, "id", 0) == tid),
                      end - time.monotonic())
        if m is None:
            break
        parts.append(m.text)
        tid = getattr(m, "id", 0)
        if not tid or len(m.text) < 50:
            break
    return "".join(parts)


def _refused(link: Link, ack: Any, what: str) -> MissionRefused:
    """The vehicle's MISSION_ACK error, with its reason (the STATUSTEXT after it)."""
    why = RESULTS.get(ack.type, "result %d" % ack.type)
    reason = _reason(link)
    if reason.startswith("mission: "):
        reason = reason[len("mission: "):]
    return MissionRefused("%s refused: %s%s" % (what, why, " (%s)" % reason if reason else ""), ack.type)


def _ask(link: Link, send: Callable[[], None], accept: Callable[[Any], bool], timeout: float, what: str) -> Any:
    """Send until an answer ``accept`` takes comes: RETRIES more times, ``timeout`` s apart."""
    for _ in range(RETRIES + 1):
        send()
        m = link.wait(accept, timeout)
        if m is not None:
            return m
    raise LinkError("no answer to %s from %s after %d tries %g s apart%s"
                    % (what, link.describe(), RETRIES + 1, timeout, link._unkeyed()))


def download(link: Link, timeout: float = TIMEOUT_S) -> list:
    """The mission's items (MISSION_ITEM_INT messages, in order)."""
    mav = link.mav
    ts, tc = link.target_system, link.target_component
    link.ready()
    link.texts.clear()
    count = _ask(link, lambda: mav.mission_request_list_send(ts, tc, 0), _is("MISSION_COUNT"), timeout,
                 "MISSION_REQUEST_LIST")
    if count.get_type() == "MISSION_ACK":
        raise _refused(link, count, "mission download")
    items = []
    for seq in range(count.count):
        item = _ask(link, lambda: mav.mission_request_int_send(ts, tc, seq, 0), _is("MISSION_ITEM_INT", seq),
                    timeout, "MISSION_REQUEST_INT %d" % seq)
        if item.get_type() == "MISSION_ACK":
            raise _refused(link, item, "mission item %d" % seq)
        items.append(item)
    mav.mission_ack_send(ts, tc, msg.MAV_MISSION_ACCEPTED, 0)
    return items


def upload(link: Link, items: list, timeout: float = TIMEOUT_S) -> None:
    """Send a mission (MISSION_ITEM_INT messages) as the vehicle asks for its items."""
    mav = link.mav
    ts, tc = link.target_system, link.target_component
    link.ready()
    link.texts.clear()
    wanted = _is("MISSION_REQUEST_INT")
    old = _is("MISSION_REQUEST")

    def answer(m: Any) -> bool:
        return wanted(m) or old(m)

    m = _ask(link, lambda: mav.mission_count_send(ts, tc, len(items), 0), answer, timeout, "MISSION_COUNT")
    while True:
        if m.get_type() == "MISSION_ACK":
            if m.type != msg.MAV_MISSION_ACCEPTED:
                raise _refused(link, m, "mission upload")
            return
        if not 0 <= m.seq < len(items):
            raise LinkError("the vehicle asked for item %d of a mission of %d" % (m.seq, len(items)))
        item = items[m.seq]
        item.target_system, item.target_component = ts, tc
        mav.send(item)
        m = link.wait(answer, UPLOAD_SILENCE_S)
        if m is None:
            raise LinkError("mission upload: %s fell silent for %g s" % (link.describe(), UPLOAD_SILENCE_S))


def clear(link: Link, timeout: float = TIMEOUT_S) -> None:
    """MISSION_CLEAR_ALL: no target."""
    mav = link.mav
    ts, tc = link.target_system, link.target_component
    link.ready()
    link.texts.clear()
    ack = _ask(link, lambda: mav.mission_clear_all_send(ts, tc, 0), _is("MISSION_ACK"), timeout,
               "MISSION_CLEAR_ALL")
    if ack.type != msg.MAV_MISSION_ACCEPTED:
        raise _refused(link, ack, "mission clear")


def target_item(north: float, east: float, down: Optional[float] = None) -> list:
    """Home and the target, as the vehicle reads them (MISSION_ITEM_INT, local frame)."""
    from pymavlink.dialects.v20 import common as mavlink

    local = msg.MAV_FRAME_LOCAL_NED
    home = mavlink.MAVLink_mission_item_int_message(0, 0, HOME_SEQ, local, msg.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                                    0, 0, 0, 0, 0, 0, 0.0, 0)
    land = mavlink.MAVLink_mission_item_int_message(0, 0, TARGET_SEQ, local, msg.MAV_CMD_NAV_LAND, 1, 1,
                                                    0, 0, 0, 0, int(round(north * LOCAL_SCALE)),
                                                    int(round(east * LOCAL_SCALE)), float(down or 0.0), 0)
    return [home, land]


def target_of(items: list) -> Optional[Target]:
    """The target of a downloaded mission (its NAV_LAND), None without one."""
    lands = [m for m in items if m.command == msg.MAV_CMD_NAV_LAND]
    if not lands:
        return None
    m = lands[-1]
    if m.frame in _GLOBAL_FRAMES:
        depth = -m.z
        return Target(m.x * M_PER_E7, m.y * M_PER_E7, depth if depth > 0 else None, m.frame,
                      m.x * 1e-7, m.y * 1e-7)
    return Target(m.x / LOCAL_SCALE, m.y / LOCAL_SCALE, m.z if m.z > 0 and math.isfinite(m.z) else None, m.frame)


def describe_item(m: Any) -> dict:
    """One item as plain values (for JSON and the listing)."""
    return {"seq": m.seq, "command": COMMAND_NAMES.get(m.command, str(m.command)),
            "frame": FRAME_NAMES.get(m.frame, str(m.frame)), "x": m.x, "y": m.y, "z": m.z,
            "current": bool(m.current)}
