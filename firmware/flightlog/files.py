"""The numbered log files on the board's flash, as ArduPilot keeps them.

Logs live under ``/logs`` as ``00000001.BIN``, ``00000002.BIN``, ...
(ArduPilot's ``AP_Logger_File``: eight digits, ``.BIN``), and
``LASTLOG.TXT`` holds the number of the newest one, so numbers keep rising
across erasures and resets (after 500 they start again at 1, as
ArduPilot's ``MAX_LOG_FILES``).

Room: before a new log is created the oldest logs are removed until the
file system has ``min_free`` bytes free (ArduPilot frees the oldest logs
below 10% free space; a Pico 2 has ~3 MB of file system, so we keep a
quarter of it, ``MIN_FREE_FRACTION``, or the log buffer twice over,
whichever is more): a new dive always has room, at the cost of the oldest
dives. The log being written is never removed; when its own writes find
the flash full, the rest of that dive is lost, and counted.

Writes are appends of whole chunks (``append``); each opens, writes and
closes the file, so what a reset or a power cut interrupts is at most the
chunk in progress: littlefs commits a file's new size at close, so an
interrupted append leaves the file as it was before it.

The file system is injected (``param_store.Files``: the board's by default,
the twin's flash-charging wrapper there).
"""

import io

from roboray.firmware.param_store import Files

#: MicroPython's streams write a part of a buffer, ``write(buf, off, n)``,
#: so an append needs no slice of the log's ring (a memoryview slice is an
#: allocation); CPython's do not.
try:
    io.BytesIO().write(b"", 0, 0)
    _STREAM_PARTS = True
except TypeError:
    _STREAM_PARTS = False

ROOT = "/logs"
LASTLOG = "LASTLOG.TXT"
MAX_NUMBER = 500
MIN_FREE_FRACTION = 0.25
MIN_FREE_MAX = 1048576      # bytes: a quarter of a Pico 2's ~3 MB is 768 kB


def name_of(number):
    return "%08d.BIN" % number


def number_of(name):
    """The log number of file name ``name``, or -1 when it is not a log."""
    if len(name) != 12 or not name.endswith(".BIN"):
        return -1
    digits = name[:8]
    for c in digits:
        if c < "0" or c > "9":
            return -1
    return int(digits)


class LogFiles:
    """The logs under ``root`` on ``fs``."""

    def __init__(self, fs=None, root=ROOT):
        self.fs = fs if fs is not None else Files()
        self.root = root
        self.current = 0          # the number of the log being written, 0: none
        self._path = ""           # its path, made once (an append then formats nothing)
        self._path_of = 0
        self.write_errors = 0     # appends the flash refused (full, or failing)
        self.removed = 0          # old logs removed for room

    def path(self, number):
        return self.root + "/" + name_of(number)

    def _ensure_root(self):
        if not self.fs.exists(self.root):
            self.fs.mkdir(self.root)

    def numbers(self):
        """The log numbers present, oldest first (by number, then wrap order)."""
        if not self.fs.exists(self.root):
            return []
        found = []
        for name in self.fs.listdir(self.root):
            n = number_of(name)
            if n > 0:
                found.append(n)
        found.sort()
        last = self.last_number()
        # after a wrap the numbers above the newest are the oldest
        return [n for n in found if n > last] + [n for n in found if n <= last]

    def last_number(self):
        """The newest log's number from LASTLOG.TXT (0: none yet or unreadable)."""
        p = self.root + "/" + LASTLOG
        if not self.fs.exists(p):
            return 0
        try:
            f = self.fs.open(p, "r")
            try:
                text = f.read()
            finally:
                f.close()
            n = int(text.strip())
        except (OSError, ValueError):
            return 0
        return n if 0 < n <= MAX_NUMBER else 0

    def size(self, number):
        try:
            return self.fs.stat(self.path(number))[6]
        except OSError:
            return -1

    def free_bytes(self):
        s = self.fs.statvfs(self.root if self.fs.exists(self.root) else "/")
        return s[0] * s[4]

    def total_bytes(self):
        s = self.fs.statvfs(self.root if self.fs.exists(self.root) else "/")
        return s[0] * s[2]

    def make_room(self, need):
        """Remove the oldest logs (never the current one) until ``need`` bytes are free."""
        for n in self.numbers():
            if self.free_bytes() >= need:
                return
            if n != self.current:
                self.fs.remove(self.path(n))
                self.removed += 1

    def create(self, first, buf_bytes, reuse_at_most=0):
        """Start the next log with ``first`` (its header: bytes-like), after
        making room; returns its number. ``reuse_at_most``: when the newest
        log holds no more than that many bytes (a log prepared on deck for
        a dive that never came: its header alone), its number is used
        again, so a board switched on and off does not fill the flash
        with empty logs."""
        self._ensure_root()
        want = self.total_bytes() * MIN_FREE_FRACTION
        if want > MIN_FREE_MAX:
            want = MIN_FREE_MAX     # (a file system far larger than a Pico's: the twin on a host)
        if want < 2 * buf_bytes:
            want = 2 * buf_bytes
        self.make_room(want)
        last = self.last_number()
        if last and 0 <= self.size(last) <= reuse_at_most:
            n = last
        else:
            n = last % MAX_NUMBER + 1
        # a leftover of the same number (a wrap) is the oldest log: replaced
        f = self.fs.open(self.path(n), "wb")
        try:
            f.write(first)
        finally:
            f.close()
        f = self.fs.open(self.root + "/" + LASTLOG, "w")
        try:
            f.write("%d\r\n" % n)
        finally:
            f.close()
        self.current = n
        return n

    def append(self, data, off=0, n=-1):
        """Add ``data`` (bytes-like; ``n`` bytes from ``off`` of it, -1: to
        its end) to the current log; False when the flash refused it."""
        if not self.current:
            return False
        if self._path_of != self.current:
            self._path = self.path(self.current)
            self._path_of = self.current
        if n < 0:
            n = len(data) - off
        try:
            f = self.fs.open(self._path, "ab")
            try:
                if _STREAM_PARTS:
                    f.write(data, off, n)
                else:
                    f.write(memoryview(data)[off:off + n])
            finally:
                f.close()
        except OSError:
            self.write_errors += 1
            return False
        return True

    def erase(self):
        """Remove every log and LASTLOG.TXT (MAVLink LOG_ERASE; refused while armed by the caller)."""
        for n in self.numbers():
            self.fs.remove(self.path(n))
        p = self.root + "/" + LASTLOG
        if self.fs.exists(p):
            self.fs.remove(p)
        self.current = 0
