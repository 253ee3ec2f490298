"""MAVLink 2 message signing (mavlink.io, "Message Signing").

A signed frame carries 13 more bytes after its CRC: the link id (1 byte), a
48-bit timestamp in 10 us units since 2015-01-01 00:00 UTC (6 bytes,
little-endian) and the first 6 bytes of
``SHA-256(secret_key + header + payload + crc + link_id + timestamp)``.
The 32-byte secret key is the SHA-256 of a passphrase, as MAVProxy's
``signing setup`` derives it (``key_from_passphrase``).

A frame is accepted when its signature matches and its timestamp is newer
than the last one accepted from the same (link id, system, component)
stream; an older or equal one is a replay. A stream never seen before is
refused when it is more than a minute older than our own clock (pymavlink's
rule), so an old recording cannot open a new stream.

Our clock: ``tick(now_ms)`` advances it with the board's monotonic clock;
an accepted frame moves it up to the frame's timestamp; the owner sets it at
boot from flash (``advance``) and persists it (``firmware/link.py``). One
frame may move it by a bounded step only: a frame more than ``AHEAD_S``
(10 minutes) ahead of our clock is refused and counted in ``future``, not
adopted, so a frame stamped far in the future (a ground whose clock was
wrong, recorded and replayed) cannot push the clock where the legitimate
ground's frames look like old recordings. Until the first frame is accepted
after a boot (``synced`` False) the bound is ``BOOT_AHEAD_S`` (30 days): a
vehicle that was off for days starts behind the ground's wall clock and
must catch up once. A clock never set (under 2**24 units, 168 s past 2015:
no record, no SETUP_SIGNING) takes the first authentic frame's time.

Timestamps exceed the boards' 31-bit small integers, so they are kept as two
24-bit halves (``hi``, ``lo``): comparing and incrementing them never makes
a big integer on the heap.
"""

import hashlib
import struct
from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

SIGNATURE_LEN = const(13)
_HALF = const(0x1000000)       # 2**24
_MASK = const(0xFFFFFF)
_NEW_STREAM_SLACK = const(6000000)  # 60 s in 10 us units, pymavlink's window
_UNIX_2015 = 1420070400        # 2015-01-01 00:00 UTC in unix seconds
# the bounds on one frame's step ahead of our clock, as 24-bit halves
_AHEAD_HI = const(3)           # 10 min = 60 000 000 units = 3 * 2**24 + 9 668 352
_AHEAD_LO = const(9668352)
_BOOT_AHEAD_HI = const(15449)  # 30 days = 259 200 000 000 units
_BOOT_AHEAD_LO = const(8790016)
_TICK_CAP_MS = const(10000000)  # a tick's step at most (keeps d * 100 a small int)

#: How far one accepted frame may be ahead of our clock (s), and before the
#: first accepted frame after a boot.
AHEAD_S = 600
BOOT_AHEAD_S = 30 * 86400

#: Why the last frame was refused (``reason``).
REFUSED_NONE = 0
REFUSED_BAD = 1        # signature mismatch: wrong key or damaged
REFUSED_REPLAY = 2     # not newer than its stream's last, or a new stream too old
REFUSED_FUTURE = 3     # further ahead of our clock than the bound


def key_from_passphrase(passphrase):
    """The 32-byte key MAVProxy's ``signing setup PASSPHRASE`` uses."""
    if isinstance(passphrase, str):
        passphrase = passphrase.encode()
    return hashlib.sha256(passphrase).digest()


class Signing:
    """Signs outgoing frames and checks incoming ones.

    Parameters
    ----------
    key:
        32-byte secret key, or None (signing off).
    link_id:
        Our link id, written into every frame we sign.
    streams:
        How many (link, system, component) streams the replay table holds;
        the least recently seen is replaced when a new one arrives.
    """

    def __init__(self, key=None, link_id=0, streams=8):
        if streams < 1:
            raise ValueError("streams must be >= 1, got %r" % (streams,))
        self.key = None
        self.link_id = link_id & 0xFF
        self.hi = 0  # our timestamp, upper 24 bits
        self.lo = 0  # lower 24 bits
        self._keys = array("l", [-1] * streams)  # link<<16 | sys<<8 | comp
        self._hi = array("l", [0] * streams)
        self._lo = array("l", [0] * streams)
        self._age = array("l", [0] * streams)
        self._tick = 0
        self.good = 0
        self.bad = 0      # signature mismatch
        self.replays = 0  # timestamp not newer than the stream's last
        self.future = 0   # too far ahead of our clock (AHEAD_S)
        self.reason = REFUSED_NONE
        #: a frame was accepted (or the clock set by SETUP_SIGNING) since boot
        self.synced = False
        self._ms = -1     # tick()'s last board time
        self._sig = bytearray(6)
        self.set_key(key)

    @property
    def enabled(self):
        return self.key is not None

    def set_key(self, key):
        """Set or clear (None) the secret key; clears the replay table."""
        if key is not None and len(key) != 32:
            raise ValueError("signing key must be 32 bytes, got %d" % len(key))
        self.key = None if key is None else bytes(key)
        for i in range(len(self._keys)):
            self._keys[i] = -1

    def advance(self, hi, lo):
        """Move our timestamp up to ``hi * 2**24 + lo`` (never back)."""
        self._advance_to(hi, lo)

    def set_timestamp(self, ts):
        """Move our timestamp up to ``ts`` (10 us units since 2015; host side)."""
        self._advance_to(ts >> 24, ts & _MASK)

    def tick(self, now_ms):
        """Advance our clock by the board time since the last call (ms, ticks_ms)."""
        last = self._ms
        self._ms = now_ms
        if last < 0:
            return
        d = (now_ms - last) & 0x3FFFFFFF
        if d <= 0 or d >= 0x20000000:
            return
        if d > _TICK_CAP_MS:
            d = _TICK_CAP_MS
        lo = self.lo + d * 100
        hi = self.hi
        while lo > _MASK:
            lo -= _HALF
            hi += 1
        self.hi = hi
        self.lo = lo

    def set_unix_time(self, seconds):
        """Move our timestamp up to a wall-clock time (never back)."""
        ts = int((seconds - _UNIX_2015) * 100000)
        if ts <= 0:
            return
        self._advance_to(ts // _HALF, ts & _MASK)

    def timestamp(self):
        """Our 48-bit timestamp as one integer (host side, tests)."""
        return self.hi * _HALF + self.lo

    def _advance_to(self, hi, lo):
        if hi > self.hi or (hi == self.hi and lo > self.lo):
            self.hi = hi
            self.lo = lo

    def _digest(self, buf, n):
        h = hashlib.sha256(self.key)
        h.update(memoryview(buf)[0:n])
        d = h.digest()
        s = self._sig
        for i in range(6):
            s[i] = d[i]
        return s

    def sign(self, buf, n):
        """Append link id, timestamp and signature to the frame ``buf[:n]``
        (whose incompat flags already say signed); returns the new length."""
        lo = self.lo + 1  # a fresh timestamp for every frame
        hi = self.hi
        if lo > _MASK:
            lo = 0
            hi += 1
        self.hi = hi
        self.lo = lo
        buf[n] = self.link_id
        buf[n + 1] = lo & 0xFF
        buf[n + 2] = (lo >> 8) & 0xFF
        buf[n + 3] = lo >> 16
        buf[n + 4] = hi & 0xFF
        buf[n + 5] = (hi >> 8) & 0xFF
        buf[n + 6] = hi >> 16
        s = self._digest(buf, n + 7)
        for i in range(6):
            buf[n + 7 + i] = s[i]
        return n + SIGNATURE_LEN

    def verify(self, buf, flen, sysid, compid):
        """True when the signed frame ``buf[:flen]`` is authentic and new.

        Counts ``good``, ``bad`` and ``replays``; only an authentic frame moves
        the stream's last timestamp and our own clock.
        """
        if self.key is None:
            return False
        base = flen - SIGNATURE_LEN
        s = self._digest(buf, flen - 6)
        for i in range(6):
            if s[i] != buf[flen - 6 + i]:
                self.bad += 1
                self.reason = REFUSED_BAD
                return False
        link = buf[base]
        lo = buf[base + 1] | (buf[base + 2] << 8) | (buf[base + 3] << 16)
        hi = buf[base + 4] | (buf[base + 5] << 8) | (buf[base + 6] << 16)
        # a bounded step ahead: further is refused, never adopted
        if self.synced:
            ahi = self.hi + _AHEAD_HI
            alo = self.lo + _AHEAD_LO
        else:
            ahi = self.hi + _BOOT_AHEAD_HI
            alo = self.lo + _BOOT_AHEAD_LO
        if alo > _MASK:
            alo -= _HALF
            ahi += 1
        # (a clock under 2**24 units, 168 s past 2015, was never set: no bound)
        if (hi > ahi or (hi == ahi and lo > alo)) and self.hi:
            self.future += 1
            self.reason = REFUSED_FUTURE
            return False
        key = (link << 16) | (sysid << 8) | compid
        keys = self._keys
        slot = -1
        for i in range(len(keys)):
            if keys[i] == key:
                slot = i
                break
        if slot >= 0:
            if hi < self._hi[slot] or (hi == self._hi[slot] and lo <= self._lo[slot]):
                self.replays += 1
                self.reason = REFUSED_REPLAY
                return False
        else:
            # A new stream must not be much older than our clock.
            ohi = self.hi
            olo = self.lo - _NEW_STREAM_SLACK
            while olo < 0:
                olo += _HALF
                ohi -= 1
            if hi < ohi or (hi == ohi and lo < olo):
                self.replays += 1
                self.reason = REFUSED_REPLAY
                return False
            slot = 0
            for i in range(1, len(keys)):
                if self._age[i] < self._age[slot]:
                    slot = i
            keys[slot] = key
        self._hi[slot] = hi
        self._lo[slot] = lo
        self._tick += 1
        self._age[slot] = self._tick
        self._advance_to(hi, lo)
        self.synced = True
        self.good += 1
        return True


_REASON_SIGNING_ARMED = "signing setup refused: disarm first"


def handle_setup_signing(ep, p):
    """SETUP_SIGNING (MAVProxy's ``signing setup``) for the endpoint ``ep``: the
    key (all zeros: off) and the clock moved up to ``initial_timestamp``;
    refused while armed. Its fields are bytes and integers: nothing to check
    for range. With a key set the endpoint takes it only signed with that key."""
    pl = p.payload
    if not ep._for_us(pl[8], pl[9]):
        return
    s = ep.signing
    if s is None:
        return
    if ep.modes.armed:
        ep.send_text(4, _REASON_SIGNING_ARMED)      # MAV_SEVERITY_WARNING
        return
    key = bytes(pl[10:42])
    off = True
    for b in key:
        if b:
            off = False
            break
    s.set_key(None if off else key)
    # initial_timestamp as 16-bit words: its 24-bit halves stay small ints
    w0, w1, w2 = struct.unpack_from("<3H", pl, 0)
    s.advance((w1 >> 8) | (w2 << 8), w0 | ((w1 & 0xFF) << 16))
    s.synced = True
    if ep.on_setup_signing is not None:
        ep.on_setup_signing()
    ep.send_text(6, "signing off" if off else "signing key set")   # MAV_SEVERITY_INFO
