"""What a dive needs to survive a reset: 16 bytes, versioned and checked.

``DiveState`` holds the state the firmware cannot get back from its
sensors after a reset under water (``firmware/resume.py`` keeps it and
restores it):

- the mode and whether the vehicle is armed;
- the target (north, east and, when the ground gave one, the bottom's depth
  there), which only the ground sent, once;
- the surface pressure the depth is measured from (``BARO1_GND_PRESS``, set
  at arming): without it the depth after a reset is measured from whatever
  the parameter file held;
- the gyro bias the estimator learned while the vehicle was held still at
  the surface: under water nothing holds it still, and the alignment that
  learns it needs seconds of it.

Nothing else: the attitude comes back from the accelerometer and compass
in a step, the depth from the pressure, the horizontal position from the
next fix (the fixes are the ground tracker's, in its frame: there is no
origin on the board to keep).

The same 16 bytes go into the watchdog's four scratch words
(``drivers/scratch.py``, for a watchdog reset) and into a ``FlashRecord``
(``firmware/flash_record.py``, for a power cut). Layout, little-endian:

======  =====  ==========================================================
offset  type   field
======  =====  ==========================================================
0       u8     tag ``0xA2``: this format, version 2 (another tag is refused;
               version 1 had a DISARMED mode where this has the armed bit)
1       u8     mode (bits 0-2, ``shared/modes.py`` number), target set
               (bit 3), target depth set (bit 4), armed (bit 5), a reboot
               the ground asked for (bit 6: in the scratch words only,
               written just before ``machine.reset()``, which the rp2
               port reports as a watchdog reset), parameters changed in
               RAM and not yet on flash (bit 7: their save waits for the
               vehicle to be disarmed or at rest; a reset before then
               loses them, and the next boot says so)
2       i16    target north, cm (+-327 m)
4       i16    target east, cm
6       u16    target depth, cm (0-655 m)
8       u16    surface pressure: (Pa - 50000) / 2 (50000-181070 Pa, 2 Pa steps)
10      u32    gyro bias x, y, z: 10-bit two's complement each (bits 0-9,
               10-19, 20-29), 0.0002 rad/s steps (+-0.1 rad/s, the
               attitude filter's clamp)
14      u16    CRC-16/CCITT (poly 0x1021, init 0xFFFF) of bytes 0-13
======  =====  ==========================================================

Zeros (the scratch words after a power-on) fail the check. Packing
allocates (it runs at the events the firmware records, never in a step).
"""

import struct

from roboray.shared import modes as M

#: Bytes of a packed state.
SIZE = 16
TAG = 0xA2
_FMT = "<BBhhHHIH"
_HAS_TARGET = 0x08
_HAS_DEPTH = 0x10
_ARMED = 0x20
_REBOOT = 0x40
_PARAMS_UNSAVED = 0x80
_P_MIN = 50000.0
_BIAS_STEP = 0.0002
_BIAS_MAX = 511


def crc16(data, n):
    """CRC-16/CCITT-FALSE of the first ``n`` bytes of ``data``."""
    c = 0xFFFF
    for i in range(n):
        c ^= data[i] << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) & 0xFFFF if c & 0x8000 else (c << 1) & 0xFFFF
    return c


def _clamp(x, lo, hi):
    return lo if x < lo else (hi if x > hi else x)


def _bias_bits(b):
    k = int(round(b / _BIAS_STEP))
    return _clamp(k, -_BIAS_MAX, _BIAS_MAX) & 0x3FF


def _bias_value(bits):
    return ((bits ^ 0x200) - 0x200) * _BIAS_STEP


class DiveState:
    """The fields (see the module docstring); ``pack``/``unpack`` the bytes."""

    def __init__(self):
        self.mode = M.BOOT_MODE
        self.armed = False
        self.has_target = False
        self.north = 0.0
        self.east = 0.0
        #: m, the target's depth (the bottom there); 0: none given
        self.down = 0.0
        self.surface_pa = 101325.0
        self.bias = [0.0, 0.0, 0.0]
        #: the reset that follows was asked for (a reboot command), not a lock-up
        self.reboot = False
        #: parameters were changed and their save is waiting (armed, moving)
        self.params_unsaved = False

    def pack(self, buf=None):
        """The 16 bytes (into ``buf`` when given); ValueError on a bad field."""
        if not M.PASSIVE <= self.mode <= M.FAILSAFE:
            raise ValueError("dive state: mode %r" % (self.mode,))
        flags = (self.mode | (_ARMED if self.armed else 0) | (_REBOOT if self.reboot else 0)
                 | (_PARAMS_UNSAVED if self.params_unsaved else 0))
        north = east = down = 0
        if self.has_target:
            flags |= _HAS_TARGET
            north = _clamp(int(round(self.north * 100.0)), -32767, 32767)
            east = _clamp(int(round(self.east * 100.0)), -32767, 32767)
            if self.down > 0.0:
                flags |= _HAS_DEPTH
                down = _clamp(int(round(self.down * 100.0)), 1, 65535)
        p = _clamp(int(round((self.surface_pa - _P_MIN) * 0.5)), 0, 65535)
        b = self.bias
        bias = _bias_bits(b[0]) | (_bias_bits(b[1]) << 10) | (_bias_bits(b[2]) << 20)
        if buf is None:
            buf = bytearray(SIZE)
        struct.pack_into(_FMT, buf, 0, TAG, flags, north, east, down, p, bias, 0)
        struct.pack_into("<H", buf, 14, crc16(buf, 14))
        return buf

    def unpack(self, data):
        """Fill the fields from 16 bytes; False (fields unchanged) when they
        are no state of this format."""
        if data is None or len(data) != SIZE or data[0] != TAG:
            return False
        tag, flags, north, east, down, p, bias, crc = struct.unpack(_FMT, data)
        if crc != crc16(data, 14) or not M.PASSIVE <= (flags & 7) <= M.FAILSAFE:
            return False
        self.mode = flags & 7
        self.armed = bool(flags & _ARMED)
        self.reboot = bool(flags & _REBOOT)
        self.params_unsaved = bool(flags & _PARAMS_UNSAVED)
        self.has_target = bool(flags & _HAS_TARGET)
        self.north = north * 0.01
        self.east = east * 0.01
        self.down = down * 0.01 if flags & _HAS_DEPTH else 0.0
        self.surface_pa = _P_MIN + 2.0 * p
        b = self.bias
        b[0] = _bias_value(bias & 0x3FF)
        b[1] = _bias_value((bias >> 10) & 0x3FF)
        b[2] = _bias_value((bias >> 20) & 0x3FF)
        return True
