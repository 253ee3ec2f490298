"""The X.25 checksum of MAVLink frames (CRC-16/MCRF4XX: poly 0x1021 reflected,
initial value 0xFFFF, no final xor), as in the MAVLink C library's checksum.h.

A 256-entry table makes one byte four integer operations; everything stays a
small integer, so the loop allocates nothing on the board.

On CPython, where ``binascii.crc_hqx`` (the same polynomial, not reflected)
is written in C, the checksum is computed with it on bit-reversed bytes:
for a reflected CRC, ``crc(data, init) = rev16(crc_hqx(rev8(data),
rev16(init)))``. The board has no ``crc_hqx``: where the interpreter has a
native code emitter (the rp2 port has), the loop is compiled to machine code
at import (``@micropython.viper``, from a string, so that the module stays
bytecode that every port loads): ~90 instructions a byte on the emulated
RP2350 where the table loop takes ~630. Elsewhere (the WebAssembly port,
which has no emitter) the table loop; tests check that all give the same
checksums.
"""

import binascii
from array import array

CRC_INIT = 0xFFFF


def _table():
    # The table is linear in its index (t[a ^ b] = t[a] ^ t[b]): the eight
    # single-bit entries, shifted out bit by bit, give every other entry
    # with one xor. 64 + 248 steps at import instead of 2,048 (on the
    # MicroPython interpreter importing this module took 14.6 ms, now 4.7).
    t = array("H", bytearray(512))
    for k in range(8):
        crc = 1 << k
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
        t[1 << k] = crc
    for i in range(3, 256):
        low = i & -i
        if low != i:
            t[i] = t[i ^ low] ^ t[low]
    return t


TABLE = _table()

_hqx = getattr(binascii, "crc_hqx", None)
_REV = bytes([int("{:08b}".format(i)[::-1], 2) for i in range(256)]) if _hqx is not None else b""


# MCRF4XX a byte without the table (the MAVLink C library's crc_accumulate),
# in viper: machine integers, the buffer read through a pointer. ``trim``:
# a MAVLink 2 payload's length without its trailing zero bytes (one stays).
_VIPER = """
@micropython.viper
def v2_finish(buf, n: int, msgid: int, packed: int) -> int:
    b = ptr8(buf)
    while n > 1 and b[9 + n] == 0:
        n -= 1
    b[0] = 0xFD
    b[1] = n
    b[3] = 0
    b[4] = packed & 0xFF
    b[5] = (packed >> 16) & 0xFF
    b[7] = msgid & 0xFF
    b[8] = (msgid >> 8) & 0xFF
    b[9] = (msgid >> 16) & 0xFF
    end = 10 + n
    b[end] = (packed >> 8) & 0xFF
    c = 0xFFFF
    i = 1
    while i <= end:
        x = (b[i] ^ c) & 0xFF
        x ^= (x << 4) & 0xFF
        c = ((c >> 8) ^ (x << 8) ^ (x << 3) ^ (x >> 4)) & 0xFFFF
        i += 1
    b[end] = c & 0xFF
    b[end + 1] = (c >> 8) & 0xFF
    return end + 2
@micropython.viper
def trim(buf, start: int, n: int) -> int:
    b = ptr8(buf)
    while n > 1 and b[start + n - 1] == 0:
        n -= 1
    return n
@micropython.viper
def viper_accumulate(crc: int, buf, start: int, end: int) -> int:
    b = ptr8(buf)
    c = crc
    i = start
    while i < end:
        x = (b[i] ^ c) & 0xFF
        x ^= (x << 4) & 0xFF
        c = ((c >> 8) ^ (x << 8) ^ (x << 3) ^ (x >> 4)) & 0xFFFF
        i += 1
    return c
"""


def _native():
    # MicroPython with a native emitter only: CPython has crc_hqx, and a port
    # without an emitter (WebAssembly) refuses the decorator.
    if _hqx is not None:
        return None
    try:
        import micropython  # noqa: F401  (the decorator's namespace)
        ns = {"micropython": micropython}
        exec(_VIPER, ns)
        f = ns["viper_accumulate"]
        t = ns["trim"]
        if f(CRC_INIT, b"123456789", 0, 9) != 0x6F91 or t(b"\x00ab\x00\x00", 1, 4) != 2:
            return None
        b = bytearray(16)
        b[10] = 7
        if ns["v2_finish"](b, 4, 0x10203, 5 | (50 << 8) | (1 << 16)) != 13 or b[1] != 1 or \
                (b[11] | (b[12] << 8)) != f(f(CRC_INIT, b, 1, 11), bytes((50,)), 0, 1):
            return None
        return ns
    except Exception:
        return None


def python_trim(buf, start, n):
    """``n`` less the trailing zero bytes of ``buf[start:start + n]``, at least 1."""
    while n > 1 and buf[start + n - 1] == 0:
        n -= 1
    return n


_NS = _native()
#: The compiled loops, or None where the port cannot compile them.
viper_accumulate = _NS["viper_accumulate"] if _NS is not None else None
trim = _NS["trim"] if _NS is not None else python_trim
#: A MAVLink 2 frame's header and checksum in one native call, or None:
#: ``v2_finish(buf, max_len, msgid, seq | crc_extra << 8 | sysid << 16)``
#: -> frame length (the payload packed at 10, trailing zeros dropped;
#: ``buf[2]`` and ``buf[6]``, flags and compid, are the caller's).
v2_finish = _NS["v2_finish"] if _NS is not None else None


def accumulate(crc, buf, start, end):
    """CRC of ``buf[start:end]`` continuing from ``crc``."""
    if _hqx is not None:
        r = _REV
        c = _hqx(bytes(buf[start:end]).translate(r), (r[crc & 0xFF] << 8) | r[crc >> 8])
        return (r[c & 0xFF] << 8) | r[c >> 8]
    v = viper_accumulate
    if v is not None:
        return v(crc, buf, start, end)
    return table_accumulate(crc, buf, start, end)


#: The fastest CRC here, ``fast(crc, buf, start, end)``: the compiled loop
#: itself where there is one (one call less), else ``accumulate``.
fast = viper_accumulate if viper_accumulate is not None else accumulate


def table_accumulate(crc, buf, start, end):
    """The table loop: the board's path, and CPython's for comparison."""
    t = TABLE
    # four bytes a pass: the loop's own step costs as much as a byte's
    # arithmetic on MicroPython; the remaining 0..3 bytes one at a time
    mid = end - ((end - start) & 3)
    for i in range(start, mid, 4):
        crc = (crc >> 8) ^ t[(crc ^ buf[i]) & 0xFF]
        crc = (crc >> 8) ^ t[(crc ^ buf[i + 1]) & 0xFF]
        crc = (crc >> 8) ^ t[(crc ^ buf[i + 2]) & 0xFF]
        crc = (crc >> 8) ^ t[(crc ^ buf[i + 3]) & 0xFF]
    for i in range(mid, end):
        crc = (crc >> 8) ^ t[(crc ^ buf[i]) & 0xFF]
    return crc


def accumulate_byte(crc, b):
    return (crc >> 8) ^ TABLE[(crc ^ b) & 0xFF]
