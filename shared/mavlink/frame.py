"""Framing outgoing MAVLink messages in one preallocated buffer.

The caller packs the payload in place, then ``finish`` adds the header, the
checksum and, when a key is set, the signature::

    struct.pack_into(messages.ATTITUDE_FMT, w.buf, w.payload, t_ms, roll, ...)
    n = w.finish(messages.MSG_ATTITUDE)
    transport.write(w.view(n))

Nothing but the returned view is allocated (and signing's hash). MAVLink 2
frames drop the payload's trailing zero bytes (at least one byte stays), as
the specification and pymavlink do; MAVLink 1 frames carry the base fields
only and are never signed.
"""

from roboray.shared.mavlink import crc
from roboray.shared.mavlink.messages import WIRE, wire_high

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_crc = crc.fast
_trim = crc.trim
_v2_finish = crc.v2_finish
_CRC_INIT = const(0xFFFF)

STX_V2 = const(0xFD)
STX_V1 = const(0xFE)
HEADER_V2 = const(10)
HEADER_V1 = const(6)
IFLAG_SIGNED = const(0x01)
# a message id's three bytes in messages.WIRE
_W_CRC_EXTRA = const(0)
_W_MIN_LEN = const(1)
_W_MAX_LEN = const(2)
_W_DENSE = const(256)    # messages.WIRE_DENSE: ids indexed directly; above, wire_high()
#: Longest frame: MAVLink 2 header, 255-byte payload, CRC, signature.
FRAME_MAX = const(280)


class Writer:
    """Frames payloads for one (system, component) on one link.

    Parameters
    ----------
    sysid, compid:
        Our MAVLink system and component ids.
    signing:
        A ``Signing`` object; frames are signed whenever it has a key.
    mavlink1:
        Emit MAVLink 1 frames (payload at offset 6) instead of MAVLink 2.
    """

    def __init__(self, sysid, compid, signing=None, mavlink1=False):
        for name, v in (("sysid", sysid), ("compid", compid)):
            if not 0 <= v <= 255:
                raise ValueError("%s must be 0..255, got %r" % (name, v))
        self.buf = bytearray(FRAME_MAX)
        self._mv = memoryview(self.buf)
        # a view of each frame length, made the first time that length is
        # sent: slicing a view for every frame allocated 16 bytes a frame
        self._views = [None] * (FRAME_MAX + 1)
        self.sysid = sysid
        self.compid = compid
        self.signing = signing
        self.mavlink1 = mavlink1
        #: Where ``struct.pack_into`` puts the payload.
        self.payload = HEADER_V1 if mavlink1 else HEADER_V2
        self.seq = 0
        self.sent = 0

    def clear(self, length):
        """Zero ``length`` payload bytes (before packing a message partly)."""
        b = self.buf
        p = self.payload
        for i in range(p, p + length):
            b[i] = 0

    def finish(self, msgid, seq=-1):
        """Frame the payload packed at ``self.payload``; returns the frame length.

        ``seq`` overrides the sequence number (tests); by default it counts up.
        """
        w = 3 * msgid if 0 <= msgid < _W_DENSE else wire_high(msgid)
        if not WIRE[w + _W_MAX_LEN] or (self.mavlink1 and msgid > 255):
            raise KeyError(msgid)   # (MAVLink 1 carries ids 0-255 only)
        b = self.buf
        signed = False
        if seq < 0:
            seq = self.seq
            self.seq = (seq + 1) & 0xFF
        if _v2_finish is not None and not self.mavlink1:
            # the board: header, truncation and checksum in one native call
            signing = self.signing
            if signing is not None:
                signed = signing.key is not None
            b[2] = IFLAG_SIGNED if signed else 0
            b[6] = self.compid
            n = _v2_finish(b, WIRE[w + _W_MAX_LEN], msgid, seq | (WIRE[w + _W_CRC_EXTRA] << 8) | (self.sysid << 16))
            if signed:
                n = self.signing.sign(b, n)  # type: ignore[union-attr]
            self.sent += 1
            return n
        if self.mavlink1:
            plen = WIRE[w + _W_MIN_LEN]
            b[0] = STX_V1
            b[1] = plen
            b[2] = seq
            b[3] = self.sysid
            b[4] = self.compid
            b[5] = msgid
            end = HEADER_V1 + plen
        else:
            plen = _trim(b, HEADER_V2, WIRE[w + _W_MAX_LEN])
            signing = self.signing
            if signing is not None:
                signed = signing.key is not None
            b[0] = STX_V2
            b[1] = plen
            b[2] = IFLAG_SIGNED if signed else 0
            b[3] = 0
            b[4] = seq
            b[5] = self.sysid
            b[6] = self.compid
            b[7] = msgid & 0xFF
            b[8] = (msgid >> 8) & 0xFF
            b[9] = msgid >> 16
            end = HEADER_V2 + plen
        # CRC_EXTRA goes where the checksum will be, so that one pass covers it
        b[end] = WIRE[w + _W_CRC_EXTRA]
        c = _crc(_CRC_INIT, b, 1, end + 1)
        b[end] = c & 0xFF
        b[end + 1] = c >> 8
        n = end + 2
        if signed:
            n = self.signing.sign(b, n)  # type: ignore[union-attr]
        self.sent += 1
        return n

    def view(self, n):
        """The first ``n`` bytes of the buffer, without copying them (a view
        kept for each length: the same length again allocates nothing)."""
        v = self._views[n]
        if v is None:
            v = self._mv[0:n]
            self._views[n] = v
        return v
