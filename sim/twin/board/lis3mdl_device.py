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

from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.sim.twin.board.i2c_device import FAULT_STICK, RegisterDevice, clamp_s16

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

#: LSB per gauss by FS code.
_LSB_PER_GAUSS = (6842, 3421, 2281, 1711)
#: Sample period by DO code (0.625 .. 80 Hz), us.
_DO_US = (1600000, 800000, 400000, 200000, 100000, 50000, 25000, 12500)
#: Sample period with FAST_ODR by OM code (LP 1000, MP 560, HP 300, UHP 155 Hz), us.
_FAST_US = (1000, 1786, 3333, 6452)

_WRITABLE = (0x05, 0x06, 0x07, 0x08, 0x09, 0x0A, 0x20, 0x21, 0x22, 0x23, 0x24, 0x30, 0x32, 0x33)


class LIS3MDLDevice(RegisterDevice):
    """An LIS3MDL on the bus; feed it with ``set_field``."""

    def __init__(self, address=ADDRESS, clock=None):
        self._phys = array("d", [25.0, 0.2, 0.0, 0.4])  # temp C, field gauss
        self._raw = array("h", [0] * 4)
        # OUT_X..OUT_Z and TEMP_OUT as the next sample will show them
        self._field = (bytearray(6), bytearray(6))  # little-, big-endian
        self._temp = (bytearray(2), bytearray(2))
        RegisterDevice.__init__(self, address, 128, clock)

    # ------------------------------------------------------------ twin side
    def set_field(self, bx, by, bz):
        """Magnetic flux density along the sensor's axes, gauss."""
        p = self._phys
        p[1] = bx
        p[2] = by
        p[3] = bz
        self._quantise()

    def set_temperature(self, temp_c):
        self._phys[0] = temp_c
        self._quantise()

    def lsb_per_gauss(self):
        return _LSB_PER_GAUSS[(self.regs[_CTRL_REG2] >> 5) & 3]

    def _quantise(self):
        # both byte orders, written out (the twin calls this every step)
        p = self._phys
        r = self._raw
        r[0] = clamp_s16((p[0] - 25.0) * 8.0)
        k = self.lsb_per_gauss()
        r[1] = clamp_s16(p[1] * k)
        r[2] = clamp_s16(p[2] * k)
        r[3] = clamp_s16(p[3] * k)
        le, be = self._field
        for i in range(3):
            v = r[1 + i]
            lo = v & 0xFF
            hi = (v >> 8) & 0xFF
            le[2 * i] = lo
            le[2 * i + 1] = hi
            be[2 * i] = hi
            be[2 * i + 1] = lo
        v = r[0]
        le, be = self._temp
        le[0] = be[1] = v & 0xFF
        le[1] = be[0] = (v >> 8) & 0xFF

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
        self._quantise()

    def _auto_increment(self, subaddr):
        return bool(subaddr & 0x80)

    def _write_reg(self, reg, value):
        if reg not in _WRITABLE:
            return
        if reg == _CTRL_REG2 and value & 0x0C:
            self._reset_registers()  # SOFT_RST / REBOOT
            return
        was = self._period_us()
        self.regs[reg] = value
        if reg == _CTRL_REG2:
            self._quantise()
        period = self._period_us()
        if period and (not was or reg == _CTRL_REG3):
            self._next = self.clock.ticks_add(self.clock.ticks_us(), period)

    def _sync(self):
        period = self._period_us()
        if not period:
            return
        clock = self.clock
        late = clock.ticks_diff(clock.ticks_us(), self._next)
        if late < 0:
            return
        self._next = clock.ticks_add(self._next, (late // period + 1) * period)
        regs = self.regs
        if not self.fault == FAULT_STICK:
            be = 1 if regs[_CTRL_REG4] & 0x02 else 0
            regs[_OUT_X_L:_OUT_X_L + 6] = self._field[be]
            if regs[_CTRL_REG1] & 0x80:
                regs[_TEMP_OUT_L:_TEMP_OUT_L + 2] = self._temp[be]
        if regs[_STATUS] & 0x08 or late >= period:
            regs[_STATUS] |= 0xF0  # overrun: a sample was overwritten unread
        regs[_STATUS] |= 0x0F
        if regs[_CTRL_REG3] & 3 == 1:
            regs[_CTRL_REG3] |= 3  # single conversion done: power down

    def _after_read(self, first, count):
        if first < _OUT_X_L + 6 and first + count > _OUT_X_L:
            self.regs[_STATUS] = 0
