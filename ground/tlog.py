"""Telemetry logs in MAVProxy's tlog format, read with the board's own codec.

A tlog is a sequence of records: an 8-byte big-endian timestamp in
microseconds since the Unix epoch, then one raw MAVLink frame, so
``mavlogdump.py`` and MAVExplorer read ours and we read theirs.

``records`` walks a file and resynchronises over damage (a cut write, a
corrupt byte); ``decode`` turns each frame into a dict with pymavlink's
field names and a ``mavpackettype`` key, using ``shared/mavlink`` (not
pymavlink): the codec the vehicle runs is the one that reads its logs.
``trim`` cuts a record a stopped writer left unfinished off a file's end,
so a log interrupted at any byte is one every reader takes whole.
"""

from __future__ import annotations

import struct
import time
from typing import Any, BinaryIO, Iterator, Optional

from roboray.shared.mavlink import crc
from roboray.shared.mavlink.messages import ARRAYS, CRC_EXTRA, FIELDS, FMT, MAX_LEN, NAME, TABLE
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import Signing

_TS = struct.Struct(">Q")
# Plausible timestamps: 2000-01-01 .. 2100-01-01, in microseconds.
_TS_MIN = 946684800 * 10**6
_TS_MAX = 4102444800 * 10**6


class TlogWriter:
    """Append frames with their receive time."""

    def __init__(self, f: BinaryIO) -> None:
        self.f = f
        self.frames = 0

    def write(self, frame: bytes, t_us: Optional[int] = None) -> None:
        if t_us is None:
            t_us = int(time.time() * 1e6)
        self.f.write(_TS.pack(t_us) + bytes(frame))
        self.frames += 1


def frame_length(data: bytes, pos: int) -> int:
    """Length of the frame starting at ``data[pos]`` from its header, 0 if not a frame start."""
    if pos + 2 > len(data):
        return 0
    stx = data[pos]
    if stx == 0xFD:
        if pos + 3 > len(data):
            return 0
        return 10 + data[pos + 1] + 2 + (13 if data[pos + 2] & 1 else 0)
    if stx == 0xFE:
        return 6 + data[pos + 1] + 2
    return 0


def complete_length(data: bytes) -> int:
    """The length of ``data``'s whole records from its start: where a
    writer that stopped mid-record (an interrupted run) left off. A tlog
    written record by record has no damage before that point."""
    pos = 0
    n = len(data)
    while pos + 8 < n:
        flen = frame_length(data, pos + 8)
        if not flen or pos + 8 + flen > n:
            break
        pos += 8 + flen
    return pos


#: The longest record: a timestamp and a signed MAVLink 2 frame of 255 bytes.
MAX_RECORD = 8 + 10 + 255 + 2 + 13


def trim(path: str) -> int:
    """Cut the unfinished record off the end of ``path``; the bytes cut off
    (0 for a file that ends on a record). Only a tail shorter than one
    record is a writer's unfinished one: damage further in is left for
    ``records`` to skip and report."""
    import os

    size = os.path.getsize(path)
    with open(path, "rb") as f:
        keep = complete_length(f.read())
    if keep < size and size - keep < MAX_RECORD:
        os.truncate(path, keep)
        return size - keep
    return 0


def _plausible(data: bytes, pos: int) -> int:
    """Frame length of a record starting at ``pos`` whose timestamp and header look right, else 0."""
    if pos + 8 >= len(data):
        return 0
    (t_us,) = _TS.unpack_from(data, pos)
    flen = frame_length(data, pos + 8)
    if not flen or not _TS_MIN <= t_us <= _TS_MAX or pos + 8 + flen > len(data):
        return 0
    return flen


def _crc_ok(frame: bytes) -> bool:
    v2 = frame[0] == 0xFD
    hdr = 10 if v2 else 6
    entry = TABLE.get((frame[7] | frame[8] << 8 | frame[9] << 16) if v2 else frame[5])
    if entry is None:
        return False
    end = hdr + frame[1]
    c = crc.accumulate_byte(crc.accumulate(crc.CRC_INIT, frame, 1, end), entry[CRC_EXTRA])
    return frame[end] | frame[end + 1] << 8 == c


class Damage:
    """What ``records`` had to skip: damaged stretches and a cut end."""

    def __init__(self) -> None:
        self.skipped_bytes = 0   # bytes in damaged stretches, the cut end included
        self.stretches = 0       # places where the walk lost and found the record boundary
        self.cut_at = -1         # offset of a last record cut short (a write interrupted), -1 if none

    def describe(self, name: str, records: int) -> str:
        """One line for the user, "" when nothing was damaged."""
        parts = []
        inner = self.stretches - (1 if self.cut_at >= 0 else 0)
        if inner > 0:
            parts.append("skipped %d damaged stretch(es)" % inner)
        if self.cut_at >= 0:
            parts.append("the file ends in a record cut short at byte %d (a write interrupted?)" % self.cut_at)
        if not parts:
            return ""
        return "%s: %s; %d good record(s) read, %d byte(s) skipped" % (
            name, " and ".join(parts), records, self.skipped_bytes)


def records(data: bytes, damage: Optional[Damage] = None) -> Iterator[tuple[int, bytes]]:
    """(timestamp_us, frame) for each record; damaged stretches are skipped
    (and counted in ``damage`` when given).

    A record is trusted when its frame's checksum holds, or when another
    record (or the end of the file) follows it; otherwise the search moves
    on a byte, so a record cut short cannot swallow the one after it.
    """
    pos = 0
    n = len(data)
    lost_from = -1
    while pos + 8 < n:
        flen = _plausible(data, pos)
        if flen:
            frame = data[pos + 8:pos + 8 + flen]
            nxt = pos + 8 + flen
            if _crc_ok(frame) or nxt == n or _plausible(data, nxt):
                if lost_from >= 0 and damage is not None:
                    damage.skipped_bytes += pos - lost_from
                    damage.stretches += 1
                lost_from = -1
                yield _TS.unpack_from(data, pos)[0], frame
                pos = nxt
                continue
        if lost_from < 0:
            lost_from = pos
        pos += 1  # resynchronise on the next plausible record
    if damage is not None and (pos < n or lost_from >= 0):   # the walk ended inside a record
        start = lost_from if lost_from >= 0 else pos
        damage.skipped_bytes += n - start
        damage.stretches += 1
        damage.cut_at = start


class Decoder:
    """Decode frames with the board codec; ``signing`` checks signatures when keyed."""

    def __init__(self, key: Optional[bytes] = None) -> None:
        self.signing = Signing(key) if key is not None else None
        self.parser = Parser(self.signing)

    def decode(self, frame: bytes) -> dict[str, Any]:
        """One frame as a dict: fields, ``mavpackettype``, ``crc_ok`` (and ``signature_ok``)."""
        p = self.parser
        p.reset()
        end = p.feed(frame, 0, len(frame))
        if not p.ready and end == len(frame):
            p.flush()   # a signed frame without the key may wait for bytes after it: none come
        out: dict[str, Any]
        if p.ready and end == len(frame):
            entry = p.entry
            assert entry is not None
            out = {"mavpackettype": entry[NAME]}
            out.update(fields(entry, p.payload))
            out["crc_ok"] = True
            if self.signing is not None:
                out["signature_ok"] = bool(p.signed and p.sig_ok)
            return out
        return self._damaged(frame)

    def _damaged(self, frame: bytes) -> dict[str, Any]:
        # Not a valid frame: say what the header claims, with what can be read.
        v2 = frame[:1] == b"\xfd"
        hdr = 10 if v2 else 6
        msgid = -1
        if len(frame) >= hdr:
            msgid = (frame[7] | frame[8] << 8 | frame[9] << 16) if v2 else frame[5]
        entry = TABLE.get(msgid)
        out: dict[str, Any] = {"mavpackettype": entry[NAME] if entry else "UNKNOWN_%d" % msgid}
        if entry is not None and len(frame) >= hdr + 2:
            plen = frame[1]
            payload = bytearray(frame[hdr:hdr + plen]) + bytes(max(0, entry[MAX_LEN] - plen))
            if len(payload) >= entry[MAX_LEN]:
                out.update(fields(entry, payload))
            c = crc.accumulate(crc.CRC_INIT, frame, 1, hdr + plen)
            c = crc.accumulate_byte(c, entry[CRC_EXTRA])
            ok = len(frame) >= hdr + plen + 2 and frame[hdr + plen] | frame[hdr + plen + 1] << 8 == c
            out["crc_ok"] = bool(ok)
        else:
            out["crc_ok"] = False
        if self.signing is not None:
            out["signature_ok"] = False
        return out


def fields(entry: tuple, payload: Any) -> dict[str, Any]:
    """Field name -> value as pymavlink gives them (arrays as lists, text as str)."""
    values = struct.unpack_from(entry[FMT], payload, 0)
    out: dict[str, Any] = {}
    k = 0
    for name, length in zip(entry[FIELDS], entry[ARRAYS]):
        if length:
            out[name] = list(values[k:k + length])
            k += length
        else:
            v = values[k]
            k += 1
            if isinstance(v, bytes):
                v = v.split(b"\x00", 1)[0].decode("utf-8", errors="backslashreplace")
            out[name] = v
    return out
