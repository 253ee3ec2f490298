"""The LSM6DSOX accelerometer and gyroscope, emulated at register level.

MicroPython code for the twin. The register map the firmware's driver uses
(ST LSM6DSOX datasheet DS12814):

- ``WHO_AM_I`` (0x0F) = 0x6C; ``CTRL1_XL`` (0x10): ODR_XL[7:4], FS_XL[3:2]
  (00 +-2 g, 01 +-16 g, 10 +-4 g, 11 +-8 g); ``CTRL2_G`` (0x11): ODR_G[7:4],
  FS_G[3:2] (250, 500, 1000, 2000 dps), FS_125[1]; ``CTRL3_C`` (0x12):
  BOOT[7], BDU[6], IF_INC[2] (register auto-increment, on after reset),
  SW_RESET[0] (restores the defaults, then reads back 0);
- ``STATUS_REG`` (0x1E): TDA[2], GDA[1], XLDA[0], set when a new sample is
  latched at the output data rate (against the clock) and cleared when the
  matching output registers are read; bits 7..3 read 0;
- outputs, little-endian two's complement: ``OUT_TEMP`` (0x20, 256 LSB/C,
  0 at 25 C), ``OUTX_L_G`` .. (0x22-0x27), ``OUTX_L_A`` .. (0x28-0x2D),
  scaled by the configured full scale (0.061/0.122/0.244/0.488 mg/LSB;
  4.375/8.75/17.50/35/70 mdps/LSB) and clipped to 16 bits.

Power-on state: both sensors off (ODR 0), so nothing is ever "ready" until
a driver configures the chip. Inputs from the twin, in the sensor's axes:
``set_accel`` (specific force, m/s^2), ``set_gyro`` (rad/s),
``set_temperature`` (C). Faults as in ``i2c_device``.
"""

import math
from math import copysign
from struct import pack_into

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.sim.twin.board.i2c_device import FAULT_STICK, RegisterDevice

ADDRESS = const(0x6A)
WHO_AM_I_VALUE = const(0x6C)
G = 9.80665

_WHO_AM_I = const(0x0F)
_CTRL1_XL = const(0x10)
_CTRL2_G = const(0x11)
_CTRL3_C = const(0x12)
_CTRL9_XL = const(0x18)
_STATUS = const(0x1E)
_OUT_TEMP_L = const(0x20)
_OUTX_L_G = const(0x22)
_OUTX_L_A = const(0x28)

_TICKS_MAX = const(0x3FFFFFFF)

_XLDA = const(0x01)
_GDA = const(0x02)
_TDA = const(0x04)

#: Sample period by ODR code (12.5 Hz .. 6667 Hz; 11 = 1.6 Hz low-power), us.
_ODR_US = (0, 80000, 38462, 19231, 9615, 4808, 2404, 1200, 600, 300, 150, 625000)
#: Accelerometer sensitivity by FS_XL code, mg/LSB.
_XL_MG = (0.061, 0.488, 0.122, 0.244)
#: Gyroscope sensitivity by FS_G code, mdps/LSB.
_G_MDPS = (8.75, 17.50, 35.0, 70.0)

_WRITABLE = (0x01, 0x02, 0x04, 0x07, 0x08, 0x09, 0x0A, 0x0B, 0x0C, 0x0D, 0x0E,
             0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16, 0x17, 0x18, 0x19)


class LSM6DSOXDevice(RegisterDevice):
    """An LSM6DSOX on the bus; feed it with ``set_accel``/``set_gyro``."""

    _status = _STATUS

    def __init__(self, address=ADDRESS, clock=None):
        self._temp_c = 25.0
        self._motion = (0.0, 0.0, G, 0.0, 0.0, 0.0)  # set_motion()'s arguments
        # output registers 0x20..0x2D as the next sample will show them
        self._temp = bytearray(2)
        self._gyro = bytearray(6)
        self._accel = bytearray(6)
        # LSB sizes at the configured full scales (``gyro_lsb``, ``accel_lsb``)
        # and sample periods at the configured rates (0: off), us
        self._g_lsb = 1.0
        self._a_lsb = 1.0
        self._xl_period = 0
        self._g_period = 0
        RegisterDevice.__init__(self, address, 128, clock)

    # ------------------------------------------------------------ twin side
    def set_accel(self, ax, ay, az):
        """Specific force along the sensor's axes, m/s^2 (+g on z lying flat)."""
        m = self._motion
        self.set_motion(ax, ay, az, m[3], m[4], m[5])

    def set_gyro(self, gx, gy, gz):
        """Angular rate about the sensor's axes, rad/s."""
        m = self._motion
        self.set_motion(m[0], m[1], m[2], gx, gy, gz)

    def set_temperature(self, temp_c):
        self._temp_c = temp_c
        self._quantise()

    def set_motion(self, ax, ay, az, gx, gy, gz):
        """``set_accel`` and ``set_gyro`` at once (the twin's step); the
        temperature stays as it is."""
        self._motion = (ax, ay, az, gx, gy, gz)
        # Each value to the nearest code, halves away from zero, clipped to
        # 16 bits (int(x + copysign(0.5, x)) rounds as x + 0.5 above zero
        # and x - 0.5 below, bit for bit), straight into the output bytes:
        # a helper call a value would cost more than the arithmetic.
        g = self._g_lsb
        pack_into("<hhh", self._gyro, 0,
                  max(-32768, min(32767, int(gx / g + copysign(0.5, gx)))),
                  max(-32768, min(32767, int(gy / g + copysign(0.5, gy)))),
                  max(-32768, min(32767, int(gz / g + copysign(0.5, gz)))))
        a = self._a_lsb
        pack_into("<hhh", self._accel, 0,
                  max(-32768, min(32767, int(ax / a + copysign(0.5, ax)))),
                  max(-32768, min(32767, int(ay / a + copysign(0.5, ay)))),
                  max(-32768, min(32767, int(az / a + copysign(0.5, az)))))

    def accel_lsb(self):
        """m/s^2 per LSB at the configured full scale."""
        return _XL_MG[(self.regs[_CTRL1_XL] >> 2) & 3] * 1e-3 * G

    def gyro_lsb(self):
        """rad/s per LSB at the configured full scale."""
        c = self.regs[_CTRL2_G]
        mdps = 4.375 if c & 0x02 else _G_MDPS[(c >> 2) & 3]
        return mdps * 1e-3 * math.pi / 180.0

    def _quantise(self):
        # all outputs again, after a new full scale or temperature
        x = (self._temp_c - 25.0) * 256.0
        pack_into("<h", self._temp, 0, max(-32768, min(32767, int(x + copysign(0.5, x)))))
        self._g_lsb = self.gyro_lsb()
        self._a_lsb = self.accel_lsb()
        self.set_motion(*self._motion)

    # ---------------------------------------------------------- chip model
    def _reset_registers(self):
        regs = self.regs
        for i in range(len(regs)):
            regs[i] = 0
        regs[_WHO_AM_I] = WHO_AM_I_VALUE
        regs[_CTRL3_C] = 0x04
        regs[_CTRL9_XL] = 0xE0
        self._inc_all = True  # IF_INC
        self._next_xl = 0
        self._next_g = 0
        self._xl_period = 0
        self._g_period = 0
        self._quantise()

    def _write_reg(self, reg, value):
        if reg not in _WRITABLE:
            return
        if reg == _CTRL3_C and value & 0x81:
            self._reset_registers()  # SW_RESET / BOOT: defaults, bits read back 0
            return
        old = self.regs[reg]
        self.regs[reg] = value
        now = self.clock.ticks_us()
        if reg == _CTRL1_XL:
            if (old >> 4) == 0 and (value >> 4):
                self._next_xl = self.clock.ticks_add(now, _ODR_US[value >> 4])
            self._xl_period = _ODR_US[value >> 4]
            self._quantise()
        elif reg == _CTRL2_G:
            if (old >> 4) == 0 and (value >> 4):
                self._next_g = self.clock.ticks_add(now, _ODR_US[value >> 4] if value >> 4 < 11 else 0)
            self._g_period = _ODR_US[value >> 4] if value >> 4 < 11 else 0  # 1.6 Hz: accelerometer only
            self._quantise()
        elif reg == _CTRL3_C:
            self._inc_all = value & 0x04

    def _sync(self):
        clock = self.clock
        now = clock.now_us if not clock.tick_cost_us else clock.ticks_us()
        regs = self.regs
        # Samples are latched on a grid of ODR periods; a late read skips the
        # missed ones (the sum is masked here, since after a long gap it can
        # exceed the interval ticks_add accepts).
        period = self._xl_period
        if period:
            late = clock.ticks_diff(now, self._next_xl)
            if late >= 0:
                self._next_xl = (self._next_xl + (late // period + 1) * period) & _TICKS_MAX
                if self.fault != FAULT_STICK:
                    regs[_OUTX_L_A:_OUTX_L_A + 6] = self._accel
                    regs[_OUT_TEMP_L:_OUT_TEMP_L + 2] = self._temp
                    if self.noise_counts:
                        self._dither(regs, _OUTX_L_A, 3, False)
                regs[_STATUS] |= _XLDA | _TDA
        period = self._g_period
        if period:
            late = clock.ticks_diff(now, self._next_g)
            if late >= 0:
                self._next_g = (self._next_g + (late // period + 1) * period) & _TICKS_MAX
                if self.fault != FAULT_STICK:
                    regs[_OUTX_L_G:_OUTX_L_G + 6] = self._gyro
                    regs[_OUT_TEMP_L:_OUT_TEMP_L + 2] = self._temp
                    if self.noise_counts:
                        self._dither(regs, _OUTX_L_G, 3, False)
                regs[_STATUS] |= _GDA | _TDA

    def _read_clears(self, first, count):
        # Reading any byte of an output clears its data-ready bit.
        end = first + count
        bits = 0
        if first < _OUTX_L_A + 6 and end > _OUTX_L_A:
            bits |= _XLDA
        if first < _OUTX_L_G + 6 and end > _OUTX_L_G:
            bits |= _GDA
        if first < _OUT_TEMP_L + 2 and end > _OUT_TEMP_L:
            bits |= _TDA
        return bits
