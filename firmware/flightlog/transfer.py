"""The MAVLink log protocol on the vehicle: list, download and erase the logs.

What MAVProxy's ``log list`` / ``log download``, QGroundControl's log
download and ``roboray-ground log`` speak (mavlink.io, "Log transfer";
ArduPilot's ``AP_Logger_MAVLinkLogTransfer``):

- LOG_REQUEST_LIST -> one LOG_ENTRY a log in the asked id range (the log
  prepared for the next dive, its header alone, left out; ``id`` is
  the file's number, ``00000007.BIN`` is log 7; ``num_logs`` how many
  there are, ``last_log_num`` the newest number, ``size`` in bytes,
  ``time_utc`` 0: the board keeps no calendar), or one entry with
  ``num_logs`` 0 when there are none;
- LOG_REQUEST_DATA (id, ofs, count; count 0xFFFFFFFF: to the end) -> LOG_DATA,
  90 bytes each with their offset; past the end one LOG_DATA with count 0;
  a new request replaces the one running (a ground station asking again
  for a missing range);
- LOG_ERASE removes every log (refused while armed: the log being written
  is the dive's);
- LOG_REQUEST_END stops what is being sent.

Served only while disarmed (ArduPilot serves logs disarmed): a download
shares the radio with telemetry, and in a dive telemetry comes first; a
request while armed gets a STATUSTEXT saying so. Entries and data go out
as the endpoint's other bulk traffic (the parameter list), as fast as the
line's credit allows (``bytes_per_s``), one frame an update: ~4.7 kB of
log a second at 57,600 baud.

Reading flash does not stall the chip, erasing does: LOG_ERASE is a planned
stall (``expect_delay``). The file a request opens and the numbers a list
request finds are the only allocations, one a request; a LOG_DATA reads
into a buffer made here once.
"""

import struct
from array import array

from roboray.shared.mavlink import messages as msg

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

DATA_BYTES = const(90)
_MAX_LOGS = const(500)
_TO_END = const(0xFFFFFFFF)
#: What erasing every log may stall the chip for (ms): a remove commits
#: metadata, a few of them compact it (a sector erase each).
ERASE_STALL_MS = const(400)

_ARMED = "logs: not while armed (disarm first)"


class LogTransfer:
    """Log list, download and erase for endpoint ``ep`` over ``files`` (``files.LogFiles``).

    ``armed()`` says whether the vehicle is armed; ``on_erase()`` (the
    flight log's) is called after the logs were erased; ``hidden()`` gives
    a log number to leave out of lists (the flight log's ``prepared``: the
    next dive's, its header alone), 0 for none; ``unflushed(n)`` the bytes
    of log n still on their way to flash (the flight log's), which its
    listed size includes."""

    def __init__(self, ep, files, armed, on_erase=None, expect_delay=None, hidden=None, unflushed=None):
        self.ep = ep
        self.files = files
        self.armed = armed
        self.on_erase = on_erase
        self.expect_delay = expect_delay
        self.hidden = hidden
        self.unflushed = unflushed
        self._numbers = array("H", [0] * _MAX_LOGS)
        self._n = 0                 # logs in _numbers
        self._entry_next = -1       # index of the next LOG_ENTRY to send, -1: none
        self._entry_last = -1
        self._gcs = bytearray(2)    # who asked: sysid, compid
        self._f = None              # the file being sent
        self._id = 0
        self._ofs = 0
        self._end = 0
        self._size = 0
        self._frame = memoryview(ep.writer.buf)
        self.sending = False        # entries or data wait to go
        self.entries_sent = 0
        self.data_sent = 0
        self.refusals = 0

    # ------------------------------------------------------------ requests
    def handle(self, p):
        mid = p.msgid
        pl = p.payload
        ep = self.ep
        if mid == msg.MSG_LOG_REQUEST_LIST:
            if not ep._for_us(pl[4], pl[5]):
                return
            if self._refuse_armed():
                return
            self._gcs[0] = p.sysid
            self._gcs[1] = p.compid
            start, end = struct.unpack_from("<HH", pl, 0)
            self._list(start, end)
        elif mid == msg.MSG_LOG_REQUEST_DATA:
            if not ep._for_us(pl[10], pl[11]):
                return
            if self._refuse_armed():
                return
            ofs, count, log_id = struct.unpack_from("<IIH", pl, 0)
            self._open(log_id, ofs, count)
        elif mid == msg.MSG_LOG_ERASE:
            if not ep._for_us(pl[0], pl[1]):
                return
            if self._refuse_armed():
                return
            self._stop()
            if self.expect_delay is not None:
                self.expect_delay(ERASE_STALL_MS)
            self.files.erase()
            if self.on_erase is not None:
                self.on_erase()
            ep.send_text(msg.MAV_SEVERITY_INFO, "logs erased")
        elif mid == msg.MSG_LOG_REQUEST_END:
            if ep._for_us(pl[0], pl[1]):
                self._stop()

    def _refuse_armed(self):
        if self.armed():
            self.refusals += 1
            self.ep.send_text(msg.MAV_SEVERITY_WARNING, _ARMED)
            return True
        return False

    def _list(self, start, end):
        self._stop()
        n = 0
        hide = self.hidden() if self.hidden is not None else 0
        for k in self.files.numbers():
            if n < _MAX_LOGS and k != hide:
                self._numbers[n] = k
                n += 1
        self._n = n
        first = -1
        last = -1
        for i in range(n):
            k = self._numbers[i]
            if start <= k <= end:
                if first < 0:
                    first = i
                last = i
        if n == 0:
            self._send_entry(0, 0, 0, 0)     # "no logs", as ArduPilot says it
            return
        self._entry_next = first
        self._entry_last = last
        self.sending = first >= 0

    def _open(self, log_id, ofs, count):
        self._close()
        size = self.files.size(log_id) if log_id > 0 else -1
        if size < 0:
            self.ep.send_text(msg.MAV_SEVERITY_WARNING, "logs: no log %d" % log_id)
            return
        try:
            self._f = self.files.fs.open(self.files.path(log_id), "rb")
        except OSError:
            self._f = None
            self.ep.send_text(msg.MAV_SEVERITY_WARNING, "logs: log %d will not open" % log_id)
            return
        self._id = log_id
        self._size = size
        self._ofs = ofs if ofs < size else size
        end = size if count == _TO_END or ofs + count > size else ofs + count
        self._end = end if end > self._ofs else self._ofs
        if self._ofs:
            self._f.seek(self._ofs)
        self.sending = True

    def _close(self):
        if self._f is not None:
            try:
                self._f.close()
            except OSError:
                pass
            self._f = None

    def _stop(self):
        self._close()
        self._entry_next = -1
        self.sending = False

    # ------------------------------------------------------------ sending
    def send(self, ep):
        """The next frames while the update's budget and the line allow (the endpoint's ``_send_due``)."""
        while self.sending and ep._budget > 0 and (ep._credit > 0 or not ep._bps):
            if self._entry_next >= 0:
                i = self._entry_next
                k = self._numbers[i]
                size = self.files.size(k)
                if size >= 0 and self.unflushed is not None:
                    size += self.unflushed(k)
                self._send_entry(k, self._n, self._numbers[self._n - 1] if self._n else 0, size)
                self._entry_next = i + 1 if i < self._entry_last else -1
                if self._entry_next < 0 and self._f is None:
                    self.sending = False
            elif self._f is not None:
                self._send_data()
            else:
                self.sending = False

    def _send_entry(self, log_id, num_logs, last, size):
        w = self.ep.writer
        struct.pack_into(msg.LOG_ENTRY_FMT, w.buf, w.payload, 0, size if size > 0 else 0,
                         log_id, num_logs, last)
        self.ep._send(msg.MSG_LOG_ENTRY)
        self.entries_sent += 1

    def _send_data(self):
        ofs = self._ofs
        n = self._end - ofs
        if n > DATA_BYTES:
            n = DATA_BYTES
        w = self.ep.writer
        b = w.buf
        o = w.payload
        if n > 0:
            # straight into the frame (one small view a frame, disarmed only)
            got = self._f.readinto(self._frame[o + 7:o + 7 + n])
            n = got if got is not None and got < n else n
        for i in range(o + 7 + n, o + 7 + DATA_BYTES):
            b[i] = 0
        struct.pack_into("<IHB", b, o, ofs, self._id, n)
        self.ep._send(msg.MSG_LOG_DATA)
        self.data_sent += 1
        self._ofs = ofs + n
        if self._ofs < self._end and n == DATA_BYTES:
            return
        # done: a log that ends on a frame's boundary gets an empty frame
        # after its last full one (a ground station stops at a short frame)
        if n == DATA_BYTES and self._end == self._size:
            return
        self._close()
        if self._entry_next < 0:
            self.sending = False
