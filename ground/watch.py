"""The ``watch`` screen: the vehicle's state from its telemetry, drawn in place.

``State`` folds messages (pymavlink objects) into the latest values;
``render`` turns it into lines. The CLI redraws them with ANSI cursor
control on a terminal, and prints one summary line a second when stdout is
not a terminal (a pipe, a log file).
"""

from __future__ import annotations

import math
import time
from typing import Any, Optional

from roboray.shared import modes as vehicle_modes

#: Seconds without a heartbeat before the link counts as lost.
LINK_LOST_S = 3.0


class State:
    def __init__(self, lost_after_s: float = LINK_LOST_S) -> None:
        self.lost_after_s = lost_after_s
        self.last_hb = -math.inf
        self.first_hb = -math.inf
        self.mode = -1
        self.armed = False
        self.system_status = 0
        self.att = (math.nan, math.nan, math.nan)
        self.pos = (math.nan, math.nan, math.nan)
        self.vel = (math.nan, math.nan, math.nan)
        self.depth = math.nan
        self.wings = [math.nan] * 4
        self.servo_us = [0] * 4
        self.battery_v = math.nan
        self.battery_pct = -1
        self.failsafe_flags = 0
        self.load_pct = math.nan          # SYS_STATUS load (permille) / 10
        self.worst_slot_ms = math.nan     # NAMED_VALUE_INT SLOT_MAX (us) / 1000
        self.radio: Optional[tuple[int, int, int, int]] = None
        self.received = 0
        self.lost = 0
        self.lost_links = 0
        self.was_lost = False
        self.last_text = ""
        self._seq: dict[tuple[int, int], int] = {}

    def update(self, m: Any, now: Optional[float] = None) -> None:
        now = time.monotonic() if now is None else now
        t = m.get_type()
        self.received += 1
        if m.get_msgId() < 0:
            # a message the dialect lacks: pymavlink gives it no header (system
            # 0, sequence 0), so it says nothing of the sender's sequence
            return
        src = (m.get_srcSystem(), m.get_srcComponent())
        seq = m.get_seq()
        if src in self._seq:
            self.lost += (seq - self._seq[src] - 1) & 0xFF
        self._seq[src] = seq
        if t == "HEARTBEAT" and m.type != 6:
            if self.was_lost:
                self.was_lost = False
            if self.first_hb == -math.inf:
                self.first_hb = now
            self.last_hb = now
            self.mode = m.custom_mode
            self.armed = bool(m.base_mode & 128)
            self.system_status = m.system_status
        elif t == "ATTITUDE":
            self.att = (m.roll, m.pitch, m.yaw)
        elif t == "LOCAL_POSITION_NED":
            self.pos = (m.x, m.y, m.z)
            self.vel = (m.vx, m.vy, m.vz)
        elif t == "NAMED_VALUE_FLOAT":
            name = m.name
            if name == "depth_m":
                self.depth = m.value
            elif name == "SLOT_MAX":  # (as NAMED_VALUE_FLOAT from firmware without NAMED_VALUE_INT)
                self.worst_slot_ms = m.value / 1000.0
            elif name.startswith("wing") and name.endswith("_deg") and name[4:5].isdigit():
                i = int(name[4]) - 1
                if 0 <= i < 4:
                    self.wings[i] = m.value
        elif t == "NAMED_VALUE_INT":
            if m.name == "SLOT_MAX":
                self.worst_slot_ms = m.value / 1000.0
        elif t == "SERVO_OUTPUT_RAW":
            self.servo_us = [m.servo1_raw, m.servo2_raw, m.servo3_raw, m.servo4_raw]
        elif t == "SYS_STATUS":
            self.failsafe_flags = m.errors_count1
            self.load_pct = m.load / 10.0
            if m.voltage_battery not in (0, 0xFFFF):
                self.battery_v = m.voltage_battery / 1000.0
            self.battery_pct = m.battery_remaining
        elif t == "BATTERY_STATUS":
            if m.voltages[0] != 0xFFFF:
                self.battery_v = m.voltages[0] / 1000.0
            self.battery_pct = m.battery_remaining
        elif t == "RADIO_STATUS":
            self.radio = (m.rssi, m.remrssi, m.noise, m.rxerrors)
        elif t == "STATUSTEXT":
            self.last_text = m.text

    def link_ok(self, now: Optional[float] = None) -> bool:
        now = time.monotonic() if now is None else now
        ok = now - self.last_hb < self.lost_after_s
        if not ok and self.last_hb > -math.inf and not self.was_lost:
            self.was_lost = True
            self.lost_links += 1
        return ok

    def mode_name(self) -> str:
        """RoboRay's name of the heartbeat's ``custom_mode`` (``shared/modes.py``)."""
        return "?" if self.mode < 0 else vehicle_modes.custom_name(self.mode)


def _f(x: float, fmt: str) -> str:
    return "   --" if x != x else fmt % x


def _pct(x: float) -> str:
    return "--" if x != x else "%.1f%%" % x


def render(s: State, source: str, now: Optional[float] = None) -> list[str]:
    """The screen as lines (no colour codes, so tests and pipes can read it)."""
    now = time.monotonic() if now is None else now
    ok = s.link_ok(now)
    deg = 180.0 / math.pi
    total = s.received + s.lost
    loss = 100.0 * s.lost / total if total else 0.0
    if s.last_hb == -math.inf:
        link = "waiting for heartbeat"
    elif ok:
        link = "ok"
    else:
        link = "LINK LOST (%.0f s since last heartbeat)" % (now - s.last_hb)
    lines = [
        "RoboRay  %s  link: %s" % (source, link),
        "mode %-9s %s   %s" % (s.mode_name(), "ARMED" if s.armed else "disarmed",
                               ("failsafe flags 0x%04x" % s.failsafe_flags) if s.failsafe_flags else ""),
        "attitude  roll %s  pitch %s  yaw %s deg" % (
            _f(s.att[0] * deg, "%6.1f"), _f(s.att[1] * deg, "%6.1f"), _f(s.att[2] * deg, "%6.1f")),
        "depth     %s m   vertical speed %s m/s" % (_f(s.depth, "%6.2f"), _f(s.vel[2], "%6.3f")),
        "position  N %s  E %s m   velocity N %s  E %s m/s" % (
            _f(s.pos[0], "%6.2f"), _f(s.pos[1], "%6.2f"), _f(s.vel[0], "%6.3f"), _f(s.vel[1], "%6.3f")),
        "wings     %s deg   (%s us)" % (
            " ".join(_f(w, "%5.1f") for w in s.wings), " ".join("%4d" % u for u in s.servo_us)),
        "battery   %s V  %s" % (_f(s.battery_v, "%5.2f"), ("%d%%" % s.battery_pct) if s.battery_pct >= 0 else "--"),
        "loop      load %s   worst slot %s ms" % (_pct(s.load_pct), _f(s.worst_slot_ms, "%.1f").strip()),
        "link      %d frames, %d lost (%.1f%%), %d dropouts%s" % (
            s.received, s.lost, loss, s.lost_links,
            ("   radio rssi %d/%d noise %d rxerr %d" % s.radio) if s.radio else ""),
    ]
    if s.last_text:
        lines.append("message   %s" % s.last_text)
    return lines


def one_line(s: State, now: Optional[float] = None) -> str:
    """The plain-output form: one line a second when stdout is not a terminal."""
    now = time.monotonic() if now is None else now
    ok = s.link_ok(now)
    deg = 180.0 / math.pi
    if s.last_hb == -math.inf:
        return "waiting for heartbeat"
    if not ok:
        return "LINK LOST (%.0f s since last heartbeat)" % (now - s.last_hb)
    return ("%s %s depth %s m vz %s m/s roll %s pitch %s yaw %s deg wings %s batt %s V "
            "load %s worst slot %s ms lost %d") % (
        s.mode_name(), "ARMED" if s.armed else "disarmed", _f(s.depth, "%.2f"), _f(s.vel[2], "%.3f"),
        _f(s.att[0] * deg, "%.1f"), _f(s.att[1] * deg, "%.1f"), _f(s.att[2] * deg, "%.1f"),
        "/".join(_f(w, "%.0f") for w in s.wings), _f(s.battery_v, "%.2f"),
        _pct(s.load_pct), _f(s.worst_slot_ms, "%.1f").strip(), s.lost)
