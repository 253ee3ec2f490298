"""LIS3MDL magnetometer on I2C (ST, DocID024204).

Configured for the estimator's heading: +-4 gauss (6842 LSB/gauss),
ultra-high-performance mode on all three axes, continuous conversion,
block data update, temperature sensor on. Rate: 155 Hz, the fastest the
datasheet allows in ultra-high-performance (FAST_ODR); 80 Hz would be the
fastest "normal" rate, but then one 100 Hz loop cycle in five would find no
new sample, and ultra-high-performance has the lowest noise at any rate.

``read()`` is one 9-byte burst from ``STATUS_REG`` (0x27) through
``TEMP_OUT_H`` (0x2F); on I2C the chip advances the register address only
when bit 7 of the sub-address is set, so the burst starts at ``0x27 | 0x80``.
Results in the sensor's axes: ``raw`` counts [temp, x, y, z] with
``MAG_SCALE`` (what the firmware's navigation uses), ``mag_gauss`` (gauss,
as MAVLink's SCALED_IMU and the telemetry carry it: the last sample scaled
when asked for, three boxed floats) and ``temp_c`` (the last temperature,
scaled when asked for, one). A read boxes no float. ``overruns`` counts
reads that found a sample the chip had overwritten unread (every read when
the firmware reads at 25 Hz: ``firmware/navigation.py``).
``health`` as in the LSM6DSOX driver: bus errors, no new sample, a
temperature outside the part's range, frozen outputs (x, y, z); its
time-out is 250 ms (the firmware reads the part at 25 Hz, and a 70 ms
collection can fall between two reads); after 10
failed reads in a row the
configuration is written again.
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.firmware.drivers.registers import Registers
from roboray.firmware.drivers.health import ERR_BUS, ERR_RANGE, ERR_STALE, Health

ADDRESS = const(0x1C)

_WHO_AM_I = const(0x0F)
_CTRL_REG1 = const(0x20)
_CTRL_REG2 = const(0x21)
_CTRL_REG3 = const(0x22)
_CTRL_REG4 = const(0x23)
_CTRL_REG5 = const(0x24)
_STATUS_REG = const(0x27)
_AUTO_INC = const(0x80)
_ID = const(0x3D)

_SOFT_RST = const(0x04)
_REG1_UHP_155HZ = const(0xE2)  # TEMP_EN, OM 11 (UHP), FAST_ODR: 155 Hz
_REG2_4GAUSS = const(0x00)     # FS 00: +-4 gauss
_REG3_CONTINUOUS = const(0x00)
_REG4_UHP_Z = const(0x0C)      # OMZ 11 (UHP), little-endian
_REG5_BDU = const(0x40)
_ZYXDA = const(0x08)
_ZYXOR = const(0x80)

_TEMP_MIN = const(-520)        # (-40 C - 25 C) * 8 LSB/C
_TEMP_MAX = const(480)         # (85 C - 25 C) * 8

#: gauss per LSB at +-4 gauss (6842 LSB/gauss, datasheet).
MAG_SCALE = 1.0 / 6842.0
#: C per LSB of the temperature output (0 LSB = 25 C).
TEMP_SCALE = 1.0 / 8.0


class LIS3MDL(Registers):
    """LIS3MDL on ``i2c`` at ``address`` (0x1C, or 0x1E with SDO high).

    Raises OSError naming the address when nothing answers, another part
    answers, the reset does not finish or the configuration does not read
    back.
    """

    PART = "LIS3MDL"

    def __init__(self, i2c, address=ADDRESS, clock=None, timeout_ms=250):
        if clock is None:
            import time as clock
        Registers.__init__(self, i2c, address)
        self._clock = clock
        self._buf = bytearray(9)
        self._gauss = array("f", [0.0, 0.0, 0.0])
        self._temp_c = array("f", [25.0])
        self.raw = array("h", [0] * 4)
        self.health = Health(clock, timeout_ms)
        self.overruns = 0
        self._check_identity(_WHO_AM_I, _ID)
        self._configure()

    def _configure(self):
        self._write_reg(_CTRL_REG2, _SOFT_RST)
        for _ in range(10):
            if not self._read_reg(_CTRL_REG2) & _SOFT_RST:
                break
            self._clock.sleep_ms(1)
        else:
            raise self._fail("soft reset did not finish")
        for reg, value in ((_CTRL_REG2, _REG2_4GAUSS), (_CTRL_REG4, _REG4_UHP_Z), (_CTRL_REG5, _REG5_BDU),
                           (_CTRL_REG1, _REG1_UHP_155HZ), (_CTRL_REG3, _REG3_CONTINUOUS)):
            self._write_reg(reg, value)
            got = self._read_reg(reg)
            if got != value:
                raise self._fail("register 0x%02X reads 0x%02X after writing 0x%02X" % (reg, got, value))

    def read(self):
        """Scheduler task: read the latest sample. True when it was new and sound."""
        health = self.health
        try:
            self._i2c.readfrom_mem_into(self.address, _STATUS_REG | _AUTO_INC, self._buf)
        except OSError:
            health.bad(ERR_BUS)
            self._recover()
            return False
        b = self._buf
        status = b[0]
        # little-endian 16-bit two's complement: (u ^ 0x8000) - 0x8000 extends the sign
        t = ((b[7] | (b[8] << 8)) ^ 0x8000) - 0x8000
        if t < _TEMP_MIN or t > _TEMP_MAX:
            health.bad(ERR_RANGE)
            self._recover()
            return False
        if not status & _ZYXDA:
            health.bad(ERR_STALE)
            self._recover()
            return False
        if status & _ZYXOR:
            self.overruns += 1
        raw = self.raw
        m0 = ((b[1] | (b[2] << 8)) ^ 0x8000) - 0x8000
        m1 = ((b[3] | (b[4] << 8)) ^ 0x8000) - 0x8000
        m2 = ((b[5] | (b[6] << 8)) ^ 0x8000) - 0x8000
        # a live part's noise changes some count every sample (health.py)
        same = m0 == raw[1] and m1 == raw[2] and m2 == raw[3]
        raw[1] = m0
        raw[2] = m1
        raw[3] = m2
        if not health.fresh(same):  # frozen (counted there)
            self._recover()
            return False
        raw[0] = t
        return True

    @property
    def temp_c(self):
        """The last temperature, C (scaled when asked for: one boxed float)."""
        c = self._temp_c
        c[0] = 25.0 + self.raw[0] * TEMP_SCALE
        return c

    @property
    def mag_gauss(self):
        """The last sample's field, gauss (chip axes)."""
        return self._scaled(self._gauss, 1, MAG_SCALE)
