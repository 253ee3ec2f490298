"""The MS5837-30BA pressure sensor, emulated at its I2C command interface.

MicroPython code for the twin. What the firmware's driver meets on the bus
(TE Connectivity MS5837-30BA datasheet, rev. of 2019):

- commands: reset ``0x1E``; convert D1 (pressure) ``0x40 + 2*k`` and D2
  (temperature) ``0x50 + 2*k`` for OSR 256 * 2**k (k = 0..5, OSR 8192 for
  k = 5); ADC read ``0x00`` (3 bytes, MSB first); PROM read
  ``0xA0 + 2*i`` (2 bytes, MSB first, i = 0..6);
- conversion time by OSR (datasheet maximum: 0.60, 1.17, 2.28, 4.54, 9.04,
  18.08 ms), against the clock. An ADC read before the conversion ends, a
  second ADC read, or one with no conversion, returns 0 (datasheet); a read
  during a conversion also spoils that conversion's result, as the
  datasheet warns. A convert command during a conversion is ignored;
- after reset the PROM reloads for 2.8 ms, during which the chip does not
  acknowledge (our model: the datasheet gives the time, not the behaviour);
- the PROM: word 0 holds the CRC-4 (bits 15..12) and the product version
  (bits 11..5, 0x1A for the 30BA, as Blue Robotics' library reads it),
  words 1..6 the coefficients C1..C6 (the datasheet example by default),
  and the CRC covers them as the datasheet's routine computes it.

The twin feeds physical values with ``set(pressure_pa, temp_c)``; the D2
and D1 the chip will convert are found by inverting the datasheet's first-
and second-order compensation, so a correct driver reads back the pressure
to the nearest 0.1 mbar (10 Pa) and the temperature to 0.01 C. ``set``
computes with floats and big integers (twin side, once a step); the bus
path allocates nothing.

Faults (``i2c_device``): NACK, garbage, stick (conversions return the
values frozen at the moment it stuck); and ``corrupt_prom()`` flips a bit
of C1 so the CRC no longer matches.
"""

from array import array
from math import sqrt

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.sim.twin.board.i2c_device import FAULT_GARBAGE, FAULT_NACK, FAULT_STICK, Device

ADDRESS = const(0x76)
VERSION_30BA = const(0x1A)

#: Datasheet example coefficients C1..C6.
DATASHEET_PROM = (34982, 36352, 20328, 22354, 26646, 26146)

_CMD_RESET = const(0x1E)
_CMD_ADC_READ = const(0x00)
_CMD_D1 = const(0x40)
_CMD_D2 = const(0x50)
_CMD_PROM = const(0xA0)
_RELOAD_US = const(2800)

#: Maximum conversion time by OSR index (256, 512, ..., 8192), us.
CONVERSION_US = (600, 1170, 2280, 4540, 9040, 18080)

_EIO = const(5)
_IDLE = const(0)
_OUT_NONE = const(0)
_OUT_PROM = const(1)
_OUT_ADC = const(2)


def crc4(words):
    """CRC-4 of the PROM as the datasheet's routine computes it.

    ``words`` holds 8 16-bit words; the CRC nibble of word 0 and word 7 are
    taken as 0, as the routine sets them.
    """
    rem = 0
    for cnt in range(16):
        w = words[cnt >> 1]
        if cnt == 0 or cnt == 1:
            w &= 0x0FFF
        if cnt >= 14:
            w = 0
        rem ^= (w & 0xFF) if cnt & 1 else (w >> 8)
        for _ in range(8):
            if rem & 0x8000:
                rem = ((rem << 1) ^ 0x3000) & 0xFFFF
            else:
                rem = (rem << 1) & 0xFFFF
    return (rem >> 12) & 0xF


def prom_words(c, version=VERSION_30BA):
    """The 8 PROM words for coefficients ``c`` = (C1..C6), CRC included."""
    words = [(version & 0x7F) << 5] + list(c) + [0]
    words[0] |= crc4(words) << 12
    return words


def compensate(c, d1, d2):
    """The datasheet's first- and second-order compensation (30BA), exact.

    ``c`` indexes C1..C6 as ``c[1]..c[6]``. Returns (P in 0.1 mbar, TEMP in
    0.01 C). Floor division throughout (the datasheet's int64 arithmetic
    with arithmetic shifts). Big integers: twin side only.
    """
    dt = d2 - c[5] * 256
    temp = 2000 + (dt * c[6] >> 23)
    off = c[2] * 65536 + (c[4] * dt >> 7)
    sens = c[1] * 32768 + (c[3] * dt >> 8)
    if temp < 2000:
        ti = 3 * dt * dt >> 33
        offi = 3 * (temp - 2000) ** 2 >> 1
        sensi = 5 * (temp - 2000) ** 2 >> 3
        if temp < -1500:
            offi += 7 * (temp + 1500) ** 2
            sensi += 4 * (temp + 1500) ** 2
    else:
        ti = 2 * dt * dt >> 37
        offi = (temp - 2000) ** 2 >> 4
        sensi = 0
    off2 = off - offi
    sens2 = sens - sensi
    p = ((d1 * sens2 >> 21) - off2) >> 13
    return p, temp - ti


class MS5837Device(Device):
    """An MS5837-30BA on the bus; ``set()`` what it senses."""

    def __init__(self, address=ADDRESS, prom=DATASHEET_PROM, version=VERSION_30BA, clock=None):
        Device.__init__(self, address, clock)
        if len(prom) != 6:
            raise ValueError("prom needs the six coefficients C1..C6")
        self.prom = array("H", prom_words(prom, version))
        self._c = [0] + list(prom)
        self.pressure_pa = 101325.0
        self.temp_c = 20.0
        self.d1 = 0
        self.d2 = 0
        self._stuck_d1 = 0
        self._stuck_d2 = 0
        self._conv = _IDLE
        self._conv_start = 0
        self._conv_us = 0
        self._result = 0
        self._spoiled = False
        self._out = _OUT_NONE
        self._out_value = 0
        self._busy_until = 0
        self._busy = False
        #: Conversions started, ADC reads that returned 0, for tests.
        self.conversions = 0
        self.zero_reads = 0
        self.set(self.pressure_pa, self.temp_c)

    # ------------------------------------------------------------ twin side
    def set(self, pressure_pa, temp_c):
        """What the sensor senses now: absolute pressure (Pa), temperature (C)."""
        self.pressure_pa = pressure_pa
        self.temp_c = temp_c
        c = self._c
        # Temperature: solve TEMP2(dT) = target (0.01 C) for the continuous dT
        # (datasheet: TEMP = 2000 + dT C6 / 2^23; TEMP2 = TEMP - Ti, Ti =
        # 3 dT^2 / 2^33 below 20 C, 2 dT^2 / 2^37 above). On each side of
        # 20 C that is a quadratic a dT^2 - k dT + (target - 2000) = 0, and
        # dT < 0 exactly when target < 2000; its root nearest the first-order
        # one, in the form that does not cancel, with one sqrt (a Newton
        # solve cost four passes of lines on the interpreter).
        e = temp_c * 100.0 - 2000.0
        k = c[6] / 8388608.0
        a = 3.0 / 8589934592.0 if e < 0 else 2.0 / 137438953472.0
        x = 2.0 * e / (k + sqrt(k * k - 4.0 * a * e))
        d2 = int(c[5] * 256 + x + 0.5)
        d2 = 0 if d2 < 0 else (0xFFFFFF if d2 > 0xFFFFFF else d2)
        # Pressure: with that D2, OFF2 and SENS2 are fixed integers; pick D1
        # so that floor((floor(D1 SENS2 / 2^21) - OFF2) / 2^13) rounds the
        # target P (0.1 mbar) to the nearest code: aim half a code up.
        dt = d2 - c[5] * 256
        temp = 2000 + (dt * c[6] >> 23)
        off = c[2] * 65536 + (c[4] * dt >> 7)
        sens = c[1] * 32768 + (c[3] * dt >> 8)
        if temp < 2000:
            offi = 3 * (temp - 2000) ** 2 >> 1
            sensi = 5 * (temp - 2000) ** 2 >> 3
            if temp < -1500:
                offi += 7 * (temp + 1500) ** 2
                sensi += 4 * (temp + 1500) ** 2
        else:
            offi = (temp - 2000) ** 2 >> 4
            sensi = 0
        off2 = off - offi
        sens2 = sens - sensi
        p = pressure_pa / 10.0
        if sens2 > 0:
            d1 = int(((p + 0.5) * 8192.0 + off2) * 2097152.0 / sens2 + 0.5)
        else:
            d1 = 0
        d1 = 0 if d1 < 0 else (0xFFFFFF if d1 > 0xFFFFFF else d1)
        self.d1 = d1
        self.d2 = d2

    def set_fault(self, kind):
        if kind == FAULT_STICK and self.fault != FAULT_STICK:
            self._stuck_d1 = self.d1
            self._stuck_d2 = self.d2
        Device.set_fault(self, kind)

    def corrupt_prom(self):
        """Flip the lowest bit of C1: the stored CRC no longer matches."""
        self.prom[1] ^= 1

    def power_on(self):
        self._conv = _IDLE
        self._result = 0
        self._out = _OUT_NONE
        self._busy = False

    # ------------------------------------------------------------- bus side
    def answers(self):
        if self._busy:
            if self.clock.ticks_diff(self.clock.ticks_us(), self._busy_until) < 0:
                return False
            self._busy = False
        return Device.answers(self)

    def _command(self, cmd):
        if self._busy or self.fault == FAULT_NACK:
            if not self.answers():
                raise OSError(_EIO)  # rp2's error for a NACK
        self.transfers += 1
        clock = self.clock
        if self._conv != _IDLE:
            # A finished conversion leaves its result in the ADC register.
            now = clock.now_us if not clock.tick_cost_us else clock.ticks_us()
            if clock.ticks_diff(now, self._conv_start) >= self._conv_us:
                stuck = self.fault == FAULT_STICK
                if self._conv == _CMD_D1:
                    v = self._stuck_d1 if stuck else self.d1
                else:
                    v = self._stuck_d2 if stuck else self.d2
                if self._spoiled:
                    v ^= 0x5A5A5  # "the final result will be wrong"
                self._result = v
                self._conv = _IDLE
                self._spoiled = False
        if cmd == _CMD_ADC_READ:
            self._out = _OUT_ADC
            if self._conv != _IDLE:
                self._spoiled = True
                self._out_value = 0
            else:
                self._out_value = self._result
            if self._out_value == 0:
                self.zero_reads += 1
            self._result = 0
        elif (cmd & 0xF0) in (_CMD_D1, _CMD_D2) and (cmd & 0x0F) <= 0x0A and not cmd & 1:
            if self._conv == _IDLE:
                self._conv = cmd & 0xF0
                self._conv_us = CONVERSION_US[(cmd & 0x0F) >> 1]
                self._conv_start = clock.now_us if not clock.tick_cost_us else clock.ticks_us()
                self._result = 0
                self.conversions += 1
        elif cmd == _CMD_RESET:
            self._conv = _IDLE
            self._result = 0
            self._out = _OUT_NONE
            self._busy = True
            self._busy_until = clock.ticks_add(clock.ticks_us(), _RELOAD_US)
        elif cmd & 0xF1 == _CMD_PROM:
            self._out = _OUT_PROM
            self._out_value = self.prom[(cmd >> 1) & 7]

    def write(self, buf):
        if len(buf):
            self._command(buf[0])
        elif self._busy or self.fault == FAULT_NACK:
            if not self.answers():
                raise OSError(_EIO)

    def write_mem(self, memaddr, buf):
        self._command(memaddr)

    def read_mem(self, memaddr, buf):
        self._command(memaddr)
        if self._out == _OUT_ADC and len(buf) == 3 and self.fault != FAULT_GARBAGE:
            # the driver's ADC read, written out: MSB first, then 0 on a repeat
            v = self._out_value
            buf[0] = (v >> 16) & 0xFF
            buf[1] = (v >> 8) & 0xFF
            buf[2] = v & 0xFF
            self._out_value = 0
            return
        self._read_out(buf)

    def read(self, buf):
        if self._busy or self.fault == FAULT_NACK:
            if not self.answers():
                raise OSError(_EIO)
        self._read_out(buf)

    def _read_out(self, buf):
        if self.fault == FAULT_GARBAGE:
            self._fill_noise(buf)
            return
        n = len(buf)
        v = self._out_value
        width = 3 if self._out == _OUT_ADC else 2
        for i in range(n):
            # MSB first; bytes past the word read as 0
            buf[i] = (v >> (8 * (width - 1 - i))) & 0xFF if i < width else 0
        if self._out == _OUT_ADC:
            self._out_value = 0  # a repeated read gives 0
