"""The LIS3MDL magnetometer, emulated at register level.

MicroPython code for the twin. The register map the firmware's driver uses
(ST LIS3MDL datasheet DocID024204):

- ``WHO_AM_I`` (0x0F) = 0x3D. On I2C the register address auto-increments
  only when bit 7 of the sub-address is set (``0x28 | 0x80``); without it a
  multi-byte read repeats one register, as on the chip;
- ``CTRL_REG1`` (0x20): TEMP_EN[7], OM[6:5] (X/Y performance), DO[4:2]
  (0.625 .. 80 Hz), FAST_ODR[1] (then the ODR follows OM: 1000, 560, 300,
  155 Hz for low-power .. ultra-high-performance); ``CTRL_REG2`` (0x21):
  FS[6:5] (+-4, 8, 12, 16 gauss: 6842, 3421, 2281, 1711 LSB/gauss),
  SOFT_RST[2]; ``CTRL_REG3`` (0x22): MD[1:0] (00 continuous, 01 single,
  1x power-down, the reset state); ``CTRL_REG4`` (0x23): OMZ[3:2], BLE[1]
  (big-endian outputs); ``CTRL_REG5`` (0x24): BDU[6];
- ``STATUS_REG`` (0x27): ZYXDA[3] (and ZDA, YDA, XDA) on a new sample,
  ZYXOR[7] (and ZOR, YOR, XOR) when a sample overwrote an unread one; both
  cleared by reading the outputs;
- ``OUT_X_L`` .. ``OUT_Z_H`` (0x28-0x2D) two's complement; ``TEMP_OUT``
  (0x2E-0x2F), 8 LSB/C, 0 at 25 C (as ST's driver converts it), updated
  only with TEMP_EN.

Inputs: ``set_field`` (gauss, sensor axes) and ``set_temperature`` (C).
Faults as in ``i2c_device``.
"""

from math import copysign
from struct import pack_into

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.sim.twin.board.i2c_device import FAULT_STICK, RegisterDevice

ADDRESS = const(0x1C)
WHO_AM_I_VALUE = const(0x3D)

_WHO_AM_I = const(0x0F)
_CTRL_REG1 = const(0x20)
_CTRL_REG2 = const(0x21)
_CTRL_REG3 = const(0x22)
_CTRL_REG4 = const(0x23)
_CTRL_REG5 = const(0x24)
_STATUS = const(0x27)
_OUT_X_L = const(0x28)
_TEMP_OUT_L = const(0x2E)
_INT_CFG = const(0x30)

_TICKS_MAX = const(0x3FFFFFFF)

#: LSB per gauss by FS code.
_LSB_PER_GAUSS = (6842, 3421, 2281, 1711)
#: Sample period by DO code (0.625 .. 80 Hz), us.
_DO_US = (1600000, 800000, 400000, 200000, 100000, 50000, 25000, 12500)
#: Sample period with FAST_ODR by OM code (LP 1000, MP 560, HP 300, UHP 155 Hz), us.
_FAST_US = (1000, 1786, 3333, 6452)

_WRITABLE = (0x05, 0x06, 0x07, 0x08, 0x09, 0x0A, 0x20, 0x21, 0x22, 0x23, 0x24, 0x30, 0x32, 0x33)


class LIS3MDLDevice(RegisterDevice):
    """An LIS3MDL on the bus; feed it with ``set_field``."""

    INC_BIT = 0x80
    _inc_all = False
    _status = _STATUS

    def __init__(self, address=ADDRESS, clock=None):
        self._temp_c = 25.0
        self._b = (0.2, 0.0, 0.4)  # set_field()'s arguments, gauss
        # OUT_X..OUT_Z and TEMP_OUT as the next sample will show them
        self._field = (bytearray(6), bytearray(6))  # little-, big-endian
        self._temp = (bytearray(2), bytearray(2))
        self._k = 1      # lsb_per_gauss() at the configured full scale
        self._period = 0  # _period_us() in the configured mode
        RegisterDevice.__init__(self, address, 128, clock)

    # ------------------------------------------------------------ twin side
    def set_field(self, bx, by, bz):
        """Magnetic flux density along the sensor's axes, gauss."""
        self._b = (bx, by, bz)
        # Each value to the nearest code, halves away from zero, clipped to
        # 16 bits (int(x + copysign(0.5, x)) rounds as x + 0.5 above zero
        # and x - 0.5 below, bit for bit), in both byte orders: a helper
        # call a value would cost more than the arithmetic.
        k = self._k
        x = max(-32768, min(32767, int(bx * k + copysign(0.5, bx))))
        y = max(-32768, min(32767, int(by * k + copysign(0.5, by))))
        z = max(-32768, min(32767, int(bz * k + copysign(0.5, bz))))
        le, be = self._field
        pack_into("<hhh", le, 0, x, y, z)
        pack_into(">hhh", be, 0, x, y, z)

    def set_temperature(self, temp_c):
        self._temp_c = temp_c
        self._quantise()

    def lsb_per_gauss(self):
        return _LSB_PER_GAUSS[(self.regs[_CTRL_REG2] >> 5) & 3]

    def _quantise(self):
        # all outputs again, after a new full scale or temperature
        x = (self._temp_c - 25.0) * 8.0
        v = max(-32768, min(32767, int(x + copysign(0.5, x))))
        le, be = self._temp
        pack_into("<h", le, 0, v)
        pack_into(">h", be, 0, v)
        self._k = self.lsb_per_gauss()
        self.set_field(*self._b)

    def _period_us(self):
        md = self.regs[_CTRL_REG3] & 3
        if md >= 2:
            return 0
        c1 = self.regs[_CTRL_REG1]
        if c1 & 0x02:
            return _FAST_US[(c1 >> 5) & 3]
        return _DO_US[(c1 >> 2) & 7]

    # ---------------------------------------------------------- chip model
    def _reset_registers(self):
        regs = self.regs
        for i in range(len(regs)):
            regs[i] = 0
        regs[_WHO_AM_I] = WHO_AM_I_VALUE
        regs[_CTRL_REG1] = 0x10
        regs[_CTRL_REG3] = 0x03
        regs[_INT_CFG] = 0xE8
        self._next = 0
        self._period = 0  # power-down
        self._quantise()

    def _write_reg(self, reg, value):
        if reg not in _WRITABLE:
            return
        if reg == _CTRL_REG2 and value & 0x0C:
            self._reset_registers()  # SOFT_RST / REBOOT
            return
        was = self._period
        self.regs[reg] = value
        if reg == _CTRL_REG2:
            self._quantise()
        period = self._period = self._period_us()
        if period and (not was or reg == _CTRL_REG3):
            self._next = self.clock.ticks_add(self.clock.ticks_us(), period)

    def _sync(self):
        period = self._period
        if not period:
            return
        clock = self.clock
        late = clock.ticks_diff(clock.now_us if not clock.tick_cost_us else clock.ticks_us(), self._next)
        if late < 0:
            return
        # the next sample on the grid (masked: after a long gap the sum can
        # exceed the interval ticks_add accepts)
        self._next = (self._next + (late // period + 1) * period) & _TICKS_MAX
        regs = self.regs
        if not self.fault == FAULT_STICK:
            be = 1 if regs[_CTRL_REG4] & 0x02 else 0
            regs[_OUT_X_L:_OUT_X_L + 6] = self._field[be]
            if self.noise_counts:
                self._dither(regs, _OUT_X_L, 3, be)
            if regs[_CTRL_REG1] & 0x80:
                regs[_TEMP_OUT_L:_TEMP_OUT_L + 2] = self._temp[be]
        # new data; overrun when a sample was overwritten unread
        regs[_STATUS] |= 0xFF if regs[_STATUS] & 0x08 or late >= period else 0x0F
        if regs[_CTRL_REG3] & 3 == 1:
            regs[_CTRL_REG3] |= 3  # single conversion done: power down
            self._period = 0

    def _read_clears(self, first, count):
        # reading the outputs clears the whole status register
        return 0xFF if first < _OUT_X_L + 6 and first + count > _OUT_X_L else 0
