"""The twin's ground side: an operator, the tracker relay, the record.

``Ground`` speaks MAVLink with pymavlink (the ecosystem's codec, as
``roboray-ground`` does), on the twin's virtual clock:

- the **tracker relay**: each position fix of the world's tracker goes to
  the vehicle as ATT_POS_MOCAP when it arrives (a tracker's latency after
  its measurement), as the ground station relays its tracker's fixes;
- the **operator**: the scenario's script (arm, set a target, change mode,
  set a velocity, set parameters), each command repeated every second until
  its COMMAND_ACK (or PARAM_VALUE) comes back or five tries failed, and a
  GCS heartbeat every second while no ground station of a person is
  attached (``heartbeats``);
- the **record**: every frame in both directions goes to the tlog (MAVProxy's
  format: 8-byte big-endian microseconds, then the frame) stamped with the
  virtual time, so a seed gives the same file byte for byte; decoded, the
  vehicle's STATUSTEXTs, heartbeats, SYS_STATUS and position estimates are
  kept for the run's report.

Signing (``key``): the ground signs what it sends and checks what it
hears, as ``roboray-ground --key`` does. Its signing clock is the virtual
time from ``SIGNING_TS0`` (the twin's epoch plus the vehicle's boot margin,
where the runner's key record puts the vehicle's clock at boot), never
behind the newest timestamp the vehicle signed (pymavlink's rule: after a
reset the vehicle's clock restarts ahead of the saved one, and the ground
follows it).

Bytes: ``take()`` returns what the ground sends now; ``receive(data)`` takes
what the vehicle sent. Messages from a person's ground station are
forwarded by the runner, not by this class (``record_uplink`` logs them).
"""

from __future__ import annotations

import math
import os
import struct
from dataclasses import dataclass, field
from typing import Any, BinaryIO, Optional

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from roboray.shared import modes  # noqa: E402

#: tlog time of virtual time 0: the virtual clock's epoch (2021-01-01 UTC).
EPOCH_US = 1609459200 * 1000000
GCS_SYSID = 255
GCS_COMPID = 190        # MAV_COMP_ID_MISSIONPLANNER
VEHICLE_SYSID = 1
VEHICLE_COMPID = 1
RETRY_S = 1.0
#: A board whose first HEARTBEAT comes within this (s) is up at once (the
#: host's interpreters: 0.02 s); ``Action.from_boot`` shifts by the rest.
BOOT_S = 0.1
TRIES = 5
#: The signing clock (10 us units since 2015-01-01) the runner's key record
#: gives the vehicle: the twin's epoch (virtual time 0).
SIGNING_EPOCH = (EPOCH_US // 1000000 - 1420070400) * 100000
#: The ground's signing clock at virtual time 0: where the vehicle's starts
#: at boot (firmware/link.py BOOT_MARGIN_S past the record's).
SIGNING_TS0 = SIGNING_EPOCH + 120 * 100000


@dataclass
class Action:
    """One operator step: at ``t`` (s, or as soon as ``after`` succeeded)."""

    t: float
    kind: str                      #: arm, disarm, mode (args: a mode name), target, velocity, param, param_read, reboot
    args: tuple = ()
    after: Optional[str] = None    #: label of an action that must have succeeded first
    label: Optional[str] = None
    max_tries: int = TRIES
    #: ``t`` is later by as much as the vehicle's first HEARTBEAT came
    #: after ``BOOT_S`` (the operator sees it come up late): a board booting
    #: at a Pico 2's speed (0.8 s on the emulated one) has aligned its
    #: estimator that much later
    from_boot: bool = False
    tries: int = 0
    sent_at: Optional[float] = None
    done: bool = False
    result: Optional[str] = None
    done_at: Optional[float] = None


class _Sink:
    """pymavlink's ``file``: collects what it sends."""

    def __init__(self) -> None:
        self.data = bytearray()

    def write(self, buf: bytes) -> None:
        self.data += buf


@dataclass
class Seen:
    """What the ground decoded, for the run's report."""

    texts: list = field(default_factory=list)          # (t, severity, text)
    heartbeats: list = field(default_factory=list)     # (t, custom_mode, armed)
    sys_status: list = field(default_factory=list)     # (t, errors_count1, health, present)
    positions: list = field(default_factory=list)      # (t, x, y, z, vx, vy, vz)
    attitudes: list = field(default_factory=list)      # (t, roll, pitch, yaw)
    params: dict = field(default_factory=dict)         # name -> (t, value)
    acks: list = field(default_factory=list)           # (t, command, result)
    radio_status: list = field(default_factory=list)   # (t, rssi, remrssi, noise, rxerrors): the ground's radio
    frames: int = 0
    bad: int = 0


class Ground:
    """The operator, tracker relay and recorder of a twin run.

    Parameters
    ----------
    script:
        The operator's ``Action`` list.
    tlog:
        Binary file for the tlog, or None.
    heartbeats:
        Send a GCS heartbeat every second.
    key:
        32-byte signing key (sign and check), or None.
    """

    def __init__(self, script: list[Action], tlog: Optional[BinaryIO] = None, heartbeats: bool = True,
                 key: Optional[bytes] = None) -> None:
        self._sink = _Sink()
        self.mav = mavlink.MAVLink(self._sink, srcSystem=GCS_SYSID, srcComponent=GCS_COMPID)
        self.mav.robust_parsing = True
        self._rx = mavlink.MAVLink(None, srcSystem=GCS_SYSID, srcComponent=GCS_COMPID)
        self._rx.robust_parsing = True
        self.script = script
        self.tlog = tlog
        self.heartbeats = heartbeats
        self.seen = Seen()
        #: chunked STATUSTEXTs being put together: id -> texts so far
        self._chunks: dict[int, list[str]] = {}
        self.t = 0.0
        self._next_hb = 0.0
        self.armed = False
        self.mode = -1
        self.armed_at: Optional[float] = None
        self._boot_t: Optional[float] = None   # the vehicle's first HEARTBEAT
        self.fixes_sent = 0
        self.key = key
        if key is not None:
            for m in (self.mav, self._rx):
                m.signing.secret_key = key
                m.signing.link_id = 0
                m.signing.timestamp = SIGNING_TS0
            self.mav.signing.sign_outgoing = True
            # the radio's own RADIO_STATUS is never signed (MAVProxy's and
            # ArduPilot's accept list)
            self._rx.signing.allow_unsigned_callback = lambda mav, msg_id: msg_id == mavlink.MAVLINK_MSG_ID_RADIO_STATUS

    # ------------------------------------------------------------ bytes
    def _log(self, frame: bytes, t: float) -> None:
        if self.tlog is not None:
            self.tlog.write(struct.pack(">Q", EPOCH_US + int(round(t * 1e6))) + bytes(frame))

    def take(self) -> bytes:
        """What the ground sends now (logged as sent)."""
        data = bytes(self._sink.data)
        self._sink.data.clear()
        pos = 0
        while pos < len(data):
            n = _frame_length(data, pos)
            if n <= 0:
                break
            self._log(data[pos:pos + n], self.t)
            pos += n
        return data

    def record_uplink(self, frames: list[bytes]) -> None:
        """Log frames a person's ground station sent."""
        for f in frames:
            self._log(f, self.t)

    def receive(self, data: bytes) -> list[Any]:
        """Decode what the vehicle sent; the messages."""
        if not data:
            return []
        msgs = self._rx.parse_buffer(data) or []
        out = []
        for m in msgs:
            if m.get_type() == "BAD_DATA":
                self.seen.bad += 1
                continue
            self.seen.frames += 1
            self._log(m.get_msgbuf(), self.t)
            self._note(m)
            out.append(m)
        return out

    def _note(self, m: Any) -> None:
        t = self.t
        s = self.seen
        kind = m.get_type()
        if kind == "HEARTBEAT":
            armed = bool(m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            s.heartbeats.append((t, m.custom_mode, armed))
            if self._boot_t is None:
                self._boot_t = t
            if armed and not self.armed:
                self.armed_at = t
            self.armed = armed
            self.mode = m.custom_mode
        elif kind == "STATUSTEXT":
            # a text over 50 bytes comes in chunks with one id (MAVLink 2),
            # the last shorter than 50 (empty after an exact multiple): the
            # operator reads it whole, as MAVProxy and QGroundControl show it
            tid = getattr(m, "id", 0)
            if not tid:
                s.texts.append((t, m.severity, m.text))
            else:
                parts = self._chunks.setdefault(tid, [])
                parts.append(m.text)
                if len(m.text.encode("utf-8", "replace")) < 50:
                    del self._chunks[tid]
                    s.texts.append((t, m.severity, "".join(parts)))
        elif kind == "SYS_STATUS":
            s.sys_status.append((t, m.errors_count1, m.onboard_control_sensors_health,
                                 m.onboard_control_sensors_present))
        elif kind == "LOCAL_POSITION_NED":
            s.positions.append((t, m.x, m.y, m.z, m.vx, m.vy, m.vz))
        elif kind == "ATTITUDE":
            s.attitudes.append((t, m.roll, m.pitch, m.yaw))
        elif kind == "RADIO_STATUS":
            s.radio_status.append((t, m.rssi, m.remrssi, m.noise, m.rxerrors))
        elif kind == "PARAM_VALUE":
            s.params[m.param_id] = (t, m.param_value)
            for a in self.script:
                if a.kind in ("param", "param_read") and not a.done and a.sent_at is not None \
                        and a.args[0] == m.param_id:
                    a.done = True
                    a.done_at = t
                    a.result = "%g" % m.param_value
        elif kind == "COMMAND_ACK":
            s.acks.append((t, m.command, m.result))
            for a in self.script:
                if not a.done and a.sent_at is not None and _command_of(a) == m.command:
                    if m.result == mavlink.MAV_RESULT_ACCEPTED:
                        a.done = True
                        a.done_at = t
                        a.result = "accepted"
                    else:
                        a.result = "refused (%d)" % m.result
                    break

    # ------------------------------------------------------------ time
    def tick(self, t: float, fixes: list[tuple[float, float, float, float]]) -> None:
        """Everything the ground does at virtual time ``t`` (s)."""
        self.t = t
        if self.key is not None:
            sg = self.mav.signing
            sg.timestamp = max(sg.timestamp, SIGNING_TS0 + int(t * 100000), self._rx.signing.timestamp)
        if self.heartbeats and t >= self._next_hb:
            self._next_hb = t + 1.0
            self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        for arrival, tm, north, east in fixes:
            self.mav.att_pos_mocap_send(int(round(tm * 1e6)), [1.0, 0.0, 0.0, 0.0], north, east, math.nan)
            self.fixes_sent += 1
        labels = {a.label for a in self.script if a.done and a.label}
        for a in self.script:
            if a.done or t < a.t or (a.after is not None and a.after not in labels):
                continue
            if a.sent_at is not None and t - a.sent_at < RETRY_S:
                continue
            if a.tries >= a.max_tries:
                continue
            if a.from_boot and (self._boot_t is None or t < a.t + max(0.0, self._boot_t - BOOT_S)):
                continue
            a.tries += 1
            a.sent_at = t
            self._send(a)

    def _send(self, a: Action) -> None:
        m = self.mav
        ts, tc = VEHICLE_SYSID, VEHICLE_COMPID
        k = a.kind
        if k == "arm":
            m.command_long_send(ts, tc, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        elif k == "disarm":
            m.command_long_send(ts, tc, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
        elif k == "mode":
            number = modes.mode_number(a.args[0])
            if number < 0:
                raise ValueError("operator action mode: unknown mode %r" % (a.args[0],))
            m.command_long_send(ts, tc, mavlink.MAV_CMD_DO_SET_MODE, 0,
                                mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, modes.CUSTOM[number], 0, 0, 0, 0, 0)
        elif k == "target":
            north, east, down = a.args
            m.command_long_send(ts, tc, mavlink.MAV_CMD_DO_REPOSITION, 0, -1, 0, 0, 0, north, east, down)
        elif k == "velocity":
            vn, ve, vd = a.args
            m.set_position_target_local_ned_send(0, ts, tc, mavlink.MAV_FRAME_LOCAL_NED, 0x0DC7,
                                                 0, 0, 0, vn, ve, vd, 0, 0, 0, 0, 0)
            a.done = True   # no acknowledgement exists for a setpoint
            a.done_at = self.t
            a.result = "sent"
        elif k == "param":
            name, value = a.args
            m.param_set_send(ts, tc, name.encode(), float(value), mavlink.MAV_PARAM_TYPE_REAL32)
        elif k == "param_read":
            m.param_request_read_send(ts, tc, a.args[0].encode(), -1)
        elif k == "reboot":
            m.command_long_send(ts, tc, mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0, 0, 0, 0, 0, 0)
        else:
            raise ValueError("unknown operator action %r" % k)


def _command_of(a: Action) -> int:
    return {"arm": mavlink.MAV_CMD_COMPONENT_ARM_DISARM, "disarm": mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
            "mode": mavlink.MAV_CMD_DO_SET_MODE, "target": mavlink.MAV_CMD_DO_REPOSITION,
            "reboot": mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN}.get(a.kind, -1)


def _frame_length(data: bytes, pos: int) -> int:
    """Length of the MAVLink frame at ``data[pos]`` from its header; 0 if none."""
    if pos + 3 > len(data):
        return 0
    stx = data[pos]
    if stx == 0xFD:
        return 12 + data[pos + 1] + (13 if data[pos + 2] & 1 else 0)
    if stx == 0xFE:
        return 8 + data[pos + 1]
    return 0


class Framer:
    """Cuts a byte stream from a person's ground station into whole frames,
    so the twin's own frames (the relay's fixes) go between them, never
    inside one. Bytes between frames (noise) pass as they are."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[bytes]:
        self._buf += data
        out = []
        buf = self._buf
        while buf:
            if buf[0] not in (0xFD, 0xFE):
                i = 1
                while i < len(buf) and buf[i] not in (0xFD, 0xFE):
                    i += 1
                out.append(bytes(buf[:i]))
                del buf[:i]
                continue
            n = _frame_length(buf, 0)
            if n == 0 or n > len(buf):
                break
            out.append(bytes(buf[:n]))
            del buf[:n]
        return out
