"""Parsing MAVLink 1 and 2 frames from a byte stream, one frame buffer.

``Parser.feed(data, start, end)`` consumes bytes until a frame is complete
and valid, and returns the index of the first byte it did not consume; then
``ready`` is True and the frame's fields are attributes (``msgid``,
``sysid``, ``payload`` zero-filled to the message's full length, ...). The
caller handles the frame and calls ``feed`` again from that index::

    i = 0
    while i < n:
        i = parser.feed(rx, i, n)
        if parser.ready:
            handle(parser)

Robustness: a candidate frame (a start byte and what follows it) is
checked as early as possible: unknown incompat flags, unknown message ids
and impossible lengths are rejected on the header, a bad checksum on the
whole frame. A rejected candidate is never skipped by its claimed length:
the search restarts at its second byte, within the bytes already buffered,
so a false start byte in garbage cannot swallow the valid frames behind it.
Unknown message ids count in ``unknown`` (they cannot be checked without
their CRC_EXTRA, so they are resynchronised over, not trusted).

Signatures: the checksum covers header and payload, not a signed frame's 13
signature bytes. A frame whose signature was cut short takes the next
frame's start byte and header as signature bytes, and its checksum still
passes. Its ``sig_status`` says what the parser made of a signed frame:

- ``SIG_OK``: verified with the key (``sig_ok`` True);
- ``SIG_BAD``: refused by the key's check (``Signing.verify``: wrong,
  replayed, out of its time window);
- ``SIG_UNCHECKED``: no key, and no frame starts inside its signature;
- ``SIG_CUT``: no key, and a frame starts inside its signature bytes (its
  start byte, its header checks and its checksum passes): the signature was
  cut short, and the frame that begins there is the next delivered. Bytes
  still to come may decide this (a start byte near the signature's end):
  the signed frame waits for them, a few bytes usually, up to that frame;
  at the end of the input ``flush()`` decides on what is there.

After a ``SIG_BAD`` or ``SIG_CUT`` frame the search resumes at the byte
after its checksum, so a frame that begins inside its signature bytes is
found, with a key and without. Only what the checksum vouched for is
skipped: a frame is lost only when a damaged frame whose checksum passed
by chance covers its start. A signature changed in place (a bit flipped in
its 13 bytes) cannot be told from a good one without the key:
``SIG_UNCHECKED`` never claims more.

Counters: ``frames`` (valid), ``crc_errors``, ``unknown``, ``bad_header``,
``lost`` (gaps in sequence numbers per sender), ``garbage`` (bytes outside
any candidate), ``bad_signature`` (signed frames that failed verification),
``cut_signature`` (signed frames, no key, with a frame inside their signature).

Feeding a ``memoryview`` costs one small view object per copy on the board
(16 bytes); ``bytes`` cost a copy of the slice.
"""

import sys
from array import array

from roboray.shared.mavlink import crc
from roboray.shared.mavlink.messages import WIRE, wire_high

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_crc = crc.fast
_CRC_INIT = const(0xFFFF)
_HOST = sys.implementation.name != "micropython"

_STX_V2 = const(0xFD)
_STX_V1 = const(0xFE)
_HEADER_V2 = const(10)
_HEADER_V1 = const(6)
_SIGNATURE_LEN = const(13)
# a frame (280 bytes at most) and one that starts in its signature's last byte
_BUF_LEN = const(560)
_SOURCES = const(8)
# a message id's three bytes in messages.WIRE
_W_CRC_EXTRA = const(0)
_W_MIN_LEN = const(1)
_W_MAX_LEN = const(2)
_W_DENSE = const(256)    # messages.WIRE_DENSE: ids indexed directly; above, wire_high()

#: ``Parser.sig_status`` of the last frame
SIG_NONE = const(0)       # not signed
SIG_OK = const(1)         # verified with the key
SIG_UNCHECKED = const(2)  # signed, no key to check it, nothing wrong seen
SIG_BAD = const(3)        # the key says no
SIG_CUT = const(4)        # no key; a frame starts inside its signature bytes


class Parser:
    """MAVLink frame parser.

    Parameters
    ----------
    signing:
        A ``Signing`` object; signed frames are verified when it has a key
        (``sig_ok``). The policy, what to do with unsigned frames, is the
        caller's.
    """

    def __init__(self, signing=None):
        self.buf = bytearray(_BUF_LEN)
        self._mv = memoryview(self.buf)
        self.payload = bytearray(256)
        self._dirty = 0    # payload bytes from here on are all zero
        self.signing = signing
        self._n = 0        # bytes held in buf, from a start byte
        self._need = 1     # bytes needed before the next decision
        self._flen = 0     # length of the candidate frame, 0 until its header is read
        self._drop = 0     # bytes of the delivered frame removed on the next call
        self._probe = 0    # a possible frame's start in a signature being looked into, 0: none
        self.ready = False
        # the last valid frame
        self.msgid = -1
        self.sysid = 0
        self.compid = 0
        self.seq = 0
        self.length = 0     # payload bytes on the wire
        self.frame_len = 0  # whole frame, as in buf[:frame_len]
        self.mavlink1 = False
        self.signed = False
        self.sig_ok = False
        self.sig_status = SIG_NONE
        # counters
        self.frames = 0
        self.crc_errors = 0
        self.unknown = 0
        self.bad_header = 0
        self.lost = 0
        self.garbage = 0
        self.bad_signature = 0
        self.cut_signature = 0
        self._src = array("l", [-1] * _SOURCES)   # sysid << 8 | compid
        self._last = array("B", bytearray(_SOURCES))
        self._next_src = 0
        self._last_src = 0

    def reset(self):
        """Forget any partial frame (counters stay)."""
        self._n = 0
        self._need = 1
        self._flen = 0
        self._drop = 0
        self._probe = 0
        self.ready = False

    # ------------------------------------------------------------- feeding
    def feed(self, data, start=0, end=-1):
        """Consume ``data[start:end]`` until a frame is ready; the index reached."""
        if end < 0:
            end = len(data)
        if self._drop:
            self._remove(self._drop)
        self.ready = False
        if self._n and self._n >= self._need and self._run():
            return start
        buf = self.buf
        i = start
        while i < end:
            n = self._n
            if n == 0:
                b = data[i]
                if b == _STX_V2 and i + _HEADER_V2 <= end:
                    # A MAVLink 2 header all here: when the whole frame is
                    # too, it is taken in one copy and, valid, delivered
                    # straight away; anything else is left to _run (which
                    # checks the same and counts).
                    msgid = data[i + 7] | (data[i + 8] << 8) | (data[i + 9] << 16)
                    w = 3 * msgid if msgid < _W_DENSE else wire_high(msgid)
                    if WIRE[w + _W_MAX_LEN]:
                        plen = data[i + 1]
                        flags = data[i + 2]
                        k = _HEADER_V2 + 2 + plen + (_SIGNATURE_LEN if flags & 1 else 0)
                        if i + k <= end:
                            buf[0:k] = data[i:i + k]
                            i += k
                            self._n = k
                            if not flags & 0xFE and plen <= WIRE[w + _W_MAX_LEN]:
                                e = _HEADER_V2 + plen
                                lo = buf[e]
                                buf[e] = WIRE[w + _W_CRC_EXTRA]
                                c = _crc(_CRC_INIT, buf, 1, e + 1)
                                buf[e] = lo
                                if lo == (c & 0xFF) and buf[e + 1] == (c >> 8):
                                    self._flen = k
                                    cut = 0
                                    if flags:   # signed: without a key, look inside the signature
                                        s = self.signing
                                        if s is None or s.key is None:
                                            cut = self._look_inside(e + 2, False)
                                            if cut < 0:
                                                continue   # bytes to come decide
                                    self._deliver(True, _HEADER_V2, msgid, plen, cut)
                                    return i
                            self._need = _HEADER_V2
                            if self._run():
                                return i
                            continue
                i += 1
                if b == _STX_V2:
                    self._need = _HEADER_V2
                elif b == _STX_V1:
                    self._need = _HEADER_V1
                else:
                    self.garbage += 1
                    continue
                buf[0] = b
                self._n = 1
                continue
            k = self._need - n
            if k > end - i:
                k = end - i
            buf[n:n + k] = data[i:i + k]
            i += k
            self._n = n + k
            if self._n >= self._need and self._run():
                return i
        return i

    def flush(self):
        """No more bytes are coming (the end of a file, of a record): a signed
        frame held while bytes still to come decide whether a frame starts
        inside its signature is decided on what is here and delivered. True
        when a frame is ready (then call ``feed`` or ``flush`` again)."""
        if self._drop:
            self._remove(self._drop)
        self.ready = False
        if self._n and self._n >= self._need and self._run():
            return True
        if not self._probe:
            return False
        cut = self._look_inside(self._flen - _SIGNATURE_LEN, True)
        buf = self.buf
        self._deliver(True, _HEADER_V2, buf[7] | (buf[8] << 8) | (buf[9] << 16), buf[1], cut)
        return True

    def parse_byte(self, b):
        """Feed one byte; True when a frame is ready."""
        if self._drop:
            self._remove(self._drop)
        self.ready = False
        n = self._n
        if n == 0:
            if b == _STX_V2:
                self._need = _HEADER_V2
            elif b == _STX_V1:
                self._need = _HEADER_V1
            else:
                self.garbage += 1
                return False
        self.buf[n] = b
        self._n = n + 1
        if self._n >= self._need:
            return self._run()
        return False

    # ------------------------------------------------------------ deciding
    def _remove(self, k):
        """Drop the first ``k`` held bytes, keep the rest from its next start byte."""
        self._drop = 0
        self._flen = 0
        n = self._n
        if k >= n:   # the usual case: a whole frame was held, and only it
            self._n = 0
            self._need = 1
            return
        buf = self.buf
        j = k
        while j < n and buf[j] != _STX_V2 and buf[j] != _STX_V1:
            j += 1
        self.garbage += j - k
        if j >= n:
            self._n = 0
            self._need = 1
            return
        m = n - j
        for i in range(m):  # rare (after a rejected candidate): a plain loop allocates nothing
            buf[i] = buf[j + i]
        self._n = m
        self._need = _HEADER_V2 if buf[0] == _STX_V2 else _HEADER_V1

    def _reject(self):
        # restart the search at the candidate's second byte
        self.garbage += 1
        self._remove(1)

    def _run(self):
        """Decide on the held bytes while there are enough; True on a frame."""
        buf = self.buf
        while self._n and self._n >= self._need:
            if self._probe:
                # a signed frame, checksum good, no key: whether a frame
                # starts inside its signature, with the bytes now here
                cut = self._look_inside(self._flen - _SIGNATURE_LEN, False)
                if cut < 0:
                    continue
                self._deliver(True, _HEADER_V2, buf[7] | (buf[8] << 8) | (buf[9] << 16), buf[1], cut)
                return True
            if self._flen == 0:
                if buf[0] == _STX_V2:
                    hdr = _HEADER_V2
                    flags = buf[2]
                    if flags & 0xFE:
                        self.bad_header += 1
                        self._reject()
                        continue
                    msgid = buf[7] | (buf[8] << 8) | (buf[9] << 16)
                else:
                    hdr = _HEADER_V1
                    flags = 0
                    msgid = buf[5]
                w = 3 * msgid if msgid < _W_DENSE else wire_high(msgid)
                if not WIRE[w + _W_MAX_LEN]:
                    self.unknown += 1
                    self._reject()
                    continue
                plen = buf[1]
                # MAVLink 2 may truncate; MAVLink 1 carries the base fields, and
                # pymavlink adds the extensions to its MAVLink 1 frames: accept both.
                if plen > WIRE[w + _W_MAX_LEN] or (hdr == _HEADER_V1 and plen < WIRE[w + _W_MIN_LEN]):
                    self.bad_header += 1
                    self._reject()
                    continue
                self._flen = hdr + plen + 2 + (_SIGNATURE_LEN if flags & 1 else 0)
                self._need = self._flen
                continue
            # the whole candidate is here
            v2 = buf[0] == _STX_V2
            hdr = _HEADER_V2 if v2 else _HEADER_V1
            msgid = (buf[7] | (buf[8] << 8) | (buf[9] << 16)) if v2 else buf[5]
            plen = buf[1]
            end = hdr + plen
            # CRC_EXTRA in the checksum's place for one pass, then the byte back
            lo = buf[end]
            buf[end] = WIRE[(3 * msgid if msgid < _W_DENSE else wire_high(msgid)) + _W_CRC_EXTRA]
            c = _crc(_CRC_INIT, buf, 1, end + 1)
            buf[end] = lo
            if lo != (c & 0xFF) or buf[end + 1] != (c >> 8):
                self.crc_errors += 1
                self._reject()
                continue
            cut = 0
            if v2 and buf[2] & 1:   # signed: without a key, look inside the signature
                s = self.signing
                if s is None or s.key is None:
                    cut = self._look_inside(end + 2, False)
                    if cut < 0:
                        continue   # bytes to come decide
            self._deliver(v2, hdr, msgid, plen, cut)
            return True
        return False

    def _look_inside(self, c, final):
        """Whether a frame starts in the signature ``buf[c:c + 13]`` of the
        held signed frame: 1 yes, 0 no, -1 not known until ``_need`` bytes
        are held (``_probe``: the start byte waiting for them); ``final``:
        no more bytes are coming, what they would decide is a no."""
        buf = self.buf
        a = self._probe or c
        e = c + _SIGNATURE_LEN
        while True:
            j = buf.find(b"\xfd", a, e)
            k = buf.find(b"\xfe", a, e)
            if j < 0 or 0 <= k < j:
                j = k
            if j < 0:
                self._probe = 0
                return 0
            r = self._frame_at(j)
            if r > 0:
                self._probe = 0
                return 1
            if r == 0 and not final:
                self._probe = j
                return -1
            a = j + 1

    def _frame_at(self, s):
        """Whether a frame starts at ``buf[s]``, judged on the held bytes:
        1 yes (header and checksum check out), -1 no, 0 not known until
        ``_need`` bytes are held. Each header byte is checked as soon as it
        is here, so most false starts are refused without waiting."""
        buf = self.buf
        n = self._n
        if buf[s] == _STX_V2:
            hdr = _HEADER_V2
            if n > s + 2 and buf[s + 2] & 0xFE:
                return -1
            if n > s + 9 and buf[s + 9]:
                return -1
            if n > s + 8:
                m = buf[s + 7] | (buf[s + 8] << 8)
                if not WIRE[(3 * m if m < _W_DENSE else wire_high(m)) + _W_MAX_LEN]:
                    return -1
        else:
            hdr = _HEADER_V1
            if n > s + 5 and not WIRE[3 * buf[s + 5] + _W_MAX_LEN]:
                return -1
        if n < s + hdr:
            self._need = s + hdr
            return 0
        if hdr == _HEADER_V2:
            m = buf[s + 7] | (buf[s + 8] << 8)
            w = 3 * m if m < _W_DENSE else wire_high(m)
        else:
            w = 3 * buf[s + 5]
        plen = buf[s + 1]
        if plen > WIRE[w + _W_MAX_LEN] or (hdr == _HEADER_V1 and plen < WIRE[w + _W_MIN_LEN]):
            return -1
        end = s + hdr + plen
        if n < end + 2:
            self._need = end + 2
            return 0
        lo = buf[end]
        buf[end] = WIRE[w + _W_CRC_EXTRA]
        c = _crc(_CRC_INIT, buf, s + 1, end + 1)
        buf[end] = lo
        if lo == (c & 0xFF) and buf[end + 1] == (c >> 8):
            return 1
        return -1

    if _HOST:
        # Host side only: the board keeps no table of names and formats, and
        # on MicroPython a property makes every attribute store on the
        # instance look through the class first (~900 instructions a store
        # on the emulated RP2350 where it takes ~120; ~20 a frame).
        @property
        def entry(self):
            """The last frame's ``messages.TABLE`` entry (CPython)."""
            from roboray.shared.mavlink.table import TABLE
            return TABLE.get(self.msgid)

    def _deliver(self, v2, hdr, msgid, plen, cut):
        buf = self.buf
        flen = self._flen
        self.msgid = msgid
        self.mavlink1 = not v2
        if v2:
            seq = buf[4]
            sysid = buf[5]
            compid = buf[6]
            signed = (buf[2] & 1) == 1
        else:
            seq = buf[2]
            sysid = buf[3]
            compid = buf[4]
            signed = False
        self.seq = seq
        self.sysid = sysid
        self.compid = compid
        self.signed = signed
        self.length = plen
        self.frame_len = flen
        p = self.payload
        p[0:plen] = self._mv[hdr:hdr + plen]
        # MAVLink 2 truncation: the rest is zeros; only what an earlier, longer
        # frame left there needs clearing
        for i in range(plen, self._dirty):
            p[i] = 0
        self._dirty = plen
        st = SIG_NONE
        drop = flen
        if signed:
            s = self.signing
            if s is not None and s.key is not None:
                if s.verify(buf, flen, sysid, compid):
                    st = SIG_OK
                else:
                    st = SIG_BAD
                    self.bad_signature += 1
                    drop = flen - _SIGNATURE_LEN
            elif cut:
                st = SIG_CUT
                self.cut_signature += 1
                drop = flen - _SIGNATURE_LEN
            else:
                st = SIG_UNCHECKED
        # (after a signature found wrong the search resumes at the byte after
        # the checksum: a frame may begin inside the signature bytes)
        self.sig_status = st
        self.sig_ok = st == SIG_OK
        # sequence gaps: most frames come from the sender of the one before
        i = self._last_src
        last = self._last
        if self._src[i] == (sysid << 8) | compid:
            self.lost += (seq - last[i] - 1) & 0xFF
            last[i] = seq
        else:
            self._count_sequence()
        self.frames += 1
        self.ready = True
        self._drop = drop

    def _count_sequence(self):
        key = (self.sysid << 8) | self.compid
        src = self._src
        i = self._last_src   # most frames come from the sender of the one before
        if src[i] == key:
            self.lost += (self.seq - self._last[i] - 1) & 0xFF
            self._last[i] = self.seq
            return
        for i in range(_SOURCES):
            if src[i] == key:
                self.lost += (self.seq - self._last[i] - 1) & 0xFF
                self._last[i] = self.seq
                self._last_src = i
                return
        i = self._next_src
        self._last_src = i
        self._next_src = (i + 1) % _SOURCES
        src[i] = key
        self._last[i] = self.seq

    def frame(self):
        """The last valid frame's bytes, as a view (host side: ``bytes(...)``)."""
        return self._mv[0:self.frame_len]
