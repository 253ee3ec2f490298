"""Downloading the vehicle's on-board logs over MAVLink (the log protocol).

The protocol (mavlink.io, "Log transfer", and ArduPilot's
``AP_Logger_MAVLinkLogTransfer``): LOG_REQUEST_LIST brings one LOG_ENTRY a
log (id, size, UTC time); LOG_REQUEST_DATA asks for a byte range of one log
and the vehicle streams LOG_DATA, 90 bytes each with their offset, as fast
as its radio carries; LOG_ERASE removes every log; LOG_REQUEST_END tells the
vehicle the transfer is over, so it goes back to its normal streams.

A radio in the water loses frames, so ``download`` asks for the whole log,
keeps each frame where its offset says, and asks again for the ranges still
missing whenever the stream pauses (MAVProxy's ``log download`` does the
same). What has arrived is kept in ``FILE.part`` and which 90-byte blocks
it holds in ``FILE.part.json`` (with the log's id, size and time), written
as it goes: an interrupted download (Ctrl-C, a lost link) resumes from
there and asks only for what it lacks, provided the vehicle still has the
same log (same id, size and time; otherwise it starts over). When every
byte is there the part file is renamed to ``FILE``.
"""

from __future__ import annotations

import json
import os
import time
from typing import Any, Callable, Optional

from roboray.ground.link import LinkError

#: Bytes a LOG_DATA carries.
BLOCK = 90
#: A stream this long silent (s) is a pause: ask again for what is missing.
PAUSE_S = 0.5
#: Ranges asked for at once after a pause, at most (each its own LOG_REQUEST_DATA).
GAPS_PER_ASK = 8


class LogEntry:
    """One LOG_ENTRY: ``id``, ``size`` (bytes), ``time_utc`` (s, 0: unknown)."""

    def __init__(self, log_id: int, size: int, time_utc: int) -> None:
        self.id = log_id
        self.size = size
        self.time_utc = time_utc

    def as_dict(self) -> dict:
        return {"id": self.id, "size": self.size, "time_utc": self.time_utc}


def list_logs(link: Any, timeout: float = 5.0) -> list[LogEntry]:
    """Every log on the vehicle, by id. LinkError when it does not answer."""
    link.ready()
    link.mav.log_request_list_send(link.target_system, link.target_component, 0, 0xFFFF)
    entries: dict[int, LogEntry] = {}
    count = -1
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = link.recv(0.2)
        if m is not None and m.get_type() == "STATUSTEXT" and m.text.startswith("logs:"):
            raise LinkError("the vehicle refused the log list: %s" % m.text[5:].strip())
        if m is None or m.get_type() != "LOG_ENTRY":
            continue
        count = m.num_logs
        if count == 0:
            break
        entries[m.id] = LogEntry(m.id, m.size, m.time_utc)
        end = time.monotonic() + 1.0   # the rest follow at the radio's pace
        if len(entries) >= count:
            break
    link.mav.log_request_end_send(link.target_system, link.target_component)
    if count < 0:
        raise LinkError("no LOG_ENTRY from %s within %g s: is the firmware recording logs?"
                        % (link.describe(), timeout))
    if len(entries) < count:
        raise LinkError("got %d of %d log entries from %s" % (len(entries), count, link.describe()))
    return [entries[k] for k in sorted(entries)]


def erase_logs(link: Any, timeout: float = 5.0) -> None:
    """LOG_ERASE, then check the list is empty (the vehicle sends no ack)."""
    link.ready()
    link.mav.log_erase_send(link.target_system, link.target_component)
    end = time.monotonic() + timeout
    while True:
        left = list_logs(link, timeout=max(1.0, end - time.monotonic()))
        if not left:
            return
        if time.monotonic() > end:
            raise LinkError("%d log(s) still on the vehicle after LOG_ERASE (is it armed?)" % len(left))
        time.sleep(0.3)


class _Part:
    """The part file and its map of received blocks."""

    def __init__(self, path: str, entry: LogEntry) -> None:
        self.path = path + ".part"
        self.map_path = path + ".part.json"
        self.entry = entry
        self.blocks = (entry.size + BLOCK - 1) // BLOCK
        self.have = bytearray(self.blocks)
        self.resumed = 0
        meta = None
        if os.path.exists(self.map_path) and os.path.exists(self.path):
            try:
                with open(self.map_path) as f:
                    meta = json.load(f)
            except (OSError, ValueError):
                meta = None
        same = (meta is not None and meta.get("id") == entry.id and meta.get("size") == entry.size
                and meta.get("time_utc") == entry.time_utc)
        if same:
            for k in meta.get("have", []):
                if 0 <= k < self.blocks:
                    self.have[k] = 1
            self.resumed = sum(self.have)
            self.f = open(self.path, "r+b")
        else:
            self.f = open(self.path, "w+b")
            self.f.truncate(entry.size)
        self._saved = time.monotonic()

    def put(self, ofs: int, data: bytes) -> bool:
        if ofs % BLOCK or ofs >= self.entry.size:
            return False
        k = ofs // BLOCK
        if self.have[k]:
            return False
        if len(data) < min(BLOCK, self.entry.size - ofs):
            # a block short of what the list promised: the end of the file
            # as the vehicle had it then (its last records were still
            # reaching flash); asked again, not kept with zeros after it
            return False
        self.f.seek(ofs)
        self.f.write(data[: self.entry.size - ofs])
        self.have[k] = 1
        if time.monotonic() - self._saved > 1.0:
            self.save()
        return True

    def missing(self) -> list[tuple[int, int]]:
        """Missing byte ranges, (offset, count), in order."""
        gaps = []
        k = 0
        n = self.blocks
        while k < n:
            if self.have[k]:
                k += 1
                continue
            j = k
            while j < n and not self.have[j]:
                j += 1
            ofs = k * BLOCK
            gaps.append((ofs, min(j * BLOCK, self.entry.size) - ofs))
            k = j
        return gaps

    def save(self) -> None:
        self.f.flush()
        tmp = self.map_path + ".tmp"
        with open(tmp, "w") as f:
            json.dump({**self.entry.as_dict(), "have": [k for k in range(self.blocks) if self.have[k]]}, f)
        os.replace(tmp, self.map_path)
        self._saved = time.monotonic()

    def received(self) -> int:
        return min(sum(self.have) * BLOCK, self.entry.size)

    def finish(self, path: str) -> None:
        self.f.close()
        os.replace(self.path, path)
        os.remove(self.map_path)


def download(link: Any, entry: LogEntry, path: str, timeout: float = 10.0,
             progress: Optional[Callable[[int, int], None]] = None) -> dict:
    """Fetch log ``entry`` into ``path``, resuming a part file; returns figures.

    ``timeout``: seconds without a single new byte before giving up (the part
    file stays for the next attempt). ``progress(received, size)`` is called
    as bytes arrive."""
    part = _Part(path, entry)
    t0 = time.monotonic()
    asks = 0
    frames = 0
    try:
        link.ready()
        if entry.size == 0:
            part.finish(path)
            return {"id": entry.id, "size": 0, "path": path, "seconds": 0.0, "asks": 0, "resumed_bytes": 0}
        last_new = time.monotonic()
        asked_at = 0.0
        while True:
            gaps = part.missing()
            if not gaps:
                break
            now = time.monotonic()
            if now - last_new > timeout:
                part.save()
                raise LinkError("log %d: no data from %s for %g s, %d of %d bytes kept in %s: run the same "
                                "command again to resume" % (entry.id, link.describe(), timeout,
                                                             part.received(), entry.size, part.path))
            if now - asked_at > PAUSE_S:
                # the first ask takes the whole rest of the log: the vehicle
                # streams to the end; later ones fill the gaps a few at a time
                first = asks == 0
                for ofs, count in gaps[:1] if first else gaps[:GAPS_PER_ASK]:
                    n = 0xFFFFFFFF if first else count
                    link.mav.log_request_data_send(link.target_system, link.target_component, entry.id, ofs, n)
                    asks += 1
                asked_at = now
            m = link.recv(0.1)
            if m is None or m.get_type() != "LOG_DATA" or m.id != entry.id:
                continue
            frames += 1
            asked_at = time.monotonic()   # the stream is running: no new ask until it pauses
            data = bytes(m.data[: m.count])
            if m.count and part.put(m.ofs, data):
                last_new = time.monotonic()
                if progress is not None:
                    progress(part.received(), entry.size)
        link.mav.log_request_end_send(link.target_system, link.target_component)
        resumed = part.resumed * BLOCK
        part.finish(path)
    except BaseException:
        if not part.f.closed:
            part.save()
            part.f.close()
        raise
    seconds = time.monotonic() - t0
    return {"id": entry.id, "size": entry.size, "path": path, "seconds": round(seconds, 2), "asks": asks,
            "frames": frames, "resumed_bytes": min(resumed, entry.size),
            "bytes_per_s": round((entry.size - min(resumed, entry.size)) / seconds) if seconds > 0 else None}
