"""LSM6DSOX accelerometer and gyroscope on I2C (ST, DS12814).

Configured as the estimator expects: accelerometer +-4 g (0.122 mg/LSB),
gyroscope +-500 dps (17.50 mdps/LSB), both at 208 Hz, block data update on,
register auto-increment on. ``read()`` is one 16-byte burst from
``STATUS_REG`` (0x1E) through ``OUTZ_H_A`` (0x2D) into a buffer made once,
decoded with shifts, in the sensor's axes:

- ``raw``: the counts [temp, gx, gy, gz, ax, ay, az], for code that folds
  the scale into its own arithmetic (``ACCEL_SCALE``, ``GYRO_SCALE``), as
  the firmware's navigation does;
- ``accel`` (m/s^2, specific force: +9.81 on z lying flat) and ``gyro``
  (rad/s): the last sample scaled to SI when asked for (each a buffer made
  once, filled on reading the attribute);
- ``temp_c`` (C, the last one the chip flagged new, scaled when asked for).

A read boxes no float; asking for ``accel`` or ``gyro`` boxes three,
``temp_c`` one.
``health`` gets a bus error, a status byte with its reserved bits set or a
temperature outside the part's range (impossible values), no new sample
(stale), or new samples whose six output counts all repeat the last ones
``FROZEN_SAMPLES`` times in a row (frozen: ``health.py`` says why a live
part never does that). After 10 failed reads in a row the driver writes its configuration
again, which brings back a part that reset itself on a supply dip.
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.firmware.drivers.registers import Registers
from roboray.firmware.drivers.health import ERR_BUS, ERR_RANGE, ERR_STALE, Health

ADDRESS = const(0x6A)

_WHO_AM_I = const(0x0F)
_CTRL1_XL = const(0x10)
_CTRL2_G = const(0x11)
_CTRL3_C = const(0x12)
_STATUS_REG = const(0x1E)
_ID = const(0x6C)

_SW_RESET = const(0x01)
_XL_208HZ_4G = const(0x58)     # ODR_XL 0101 (208 Hz), FS_XL 10 (+-4 g)
_G_208HZ_500DPS = const(0x54)  # ODR_G 0101 (208 Hz), FS_G 01 (+-500 dps)
_BDU_IF_INC = const(0x44)      # BDU, IF_INC
_XLDA_GDA = const(0x03)
_TDA = const(0x04)
_RESERVED = const(0xF8)

_TEMP_MIN = const(-16640)      # (-40 C - 25 C) * 256 LSB/C: the part's range
_TEMP_MAX = const(15360)       # (85 C - 25 C) * 256

#: m/s^2 per LSB at +-4 g: 0.122 mg (datasheet) * 9.80665.
ACCEL_SCALE = 0.122e-3 * 9.80665
#: rad/s per LSB at +-500 dps: 17.50 mdps (datasheet).
GYRO_SCALE = 17.50e-3 * 3.141592653589793 / 180.0
#: C per LSB of the temperature output (0 LSB = 25 C).
TEMP_SCALE = 1.0 / 256.0


class LSM6DSOX(Registers):
    """LSM6DSOX on ``i2c`` at ``address`` (0x6A, or 0x6B with SDO high).

    Raises OSError naming the address when nothing answers, another part
    answers (WHO_AM_I), the reset does not finish or the configuration does
    not read back.
    """

    PART = "LSM6DSOX"

    def __init__(self, i2c, address=ADDRESS, clock=None, timeout_ms=50):
        if clock is None:
            import time as clock
        Registers.__init__(self, i2c, address)
        self._clock = clock
        self._buf = bytearray(16)
        self._accel = array("f", [0.0, 0.0, 0.0])
        self._gyro = array("f", [0.0, 0.0, 0.0])
        self._temp_c = array("f", [25.0])
        self._temp = 0     # counts of the last temperature flagged new (0 = 25 C)
        self.raw = array("h", [0] * 7)
        self.health = Health(clock, timeout_ms)
        self._check_identity(_WHO_AM_I, _ID)
        self._configure()

    def _configure(self):
        self._write_reg(_CTRL3_C, _SW_RESET | 0x04)
        for _ in range(10):
            if not self._read_reg(_CTRL3_C) & _SW_RESET:
                break
            self._clock.sleep_ms(1)
        else:
            raise self._fail("software reset did not finish")
        for reg, value in ((_CTRL3_C, _BDU_IF_INC), (_CTRL1_XL, _XL_208HZ_4G), (_CTRL2_G, _G_208HZ_500DPS)):
            self._write_reg(reg, value)
            got = self._read_reg(reg)
            if got != value:
                raise self._fail("register 0x%02X reads 0x%02X after writing 0x%02X" % (reg, got, value))

    def read(self):
        """Scheduler task: read the latest sample. True when it was new and sound."""
        health = self.health
        try:
            self._i2c.readfrom_mem_into(self.address, _STATUS_REG, self._buf)
        except OSError:
            health.bad(ERR_BUS)
            self._recover()
            return False
        b = self._buf
        status = b[0]
        # little-endian 16-bit two's complement: (u ^ 0x8000) - 0x8000 extends the sign
        t = ((b[2] | (b[3] << 8)) ^ 0x8000) - 0x8000
        if status & _RESERVED or t < _TEMP_MIN or t > _TEMP_MAX:
            health.bad(ERR_RANGE)
            self._recover()
            return False
        if status & _XLDA_GDA != _XLDA_GDA:
            health.bad(ERR_STALE)
            self._recover()
            return False
        # Straight-line decoding: a loop or a helper call per value costs
        # more than the arithmetic on MicroPython.
        raw = self.raw
        g0 = ((b[4] | (b[5] << 8)) ^ 0x8000) - 0x8000
        g1 = ((b[6] | (b[7] << 8)) ^ 0x8000) - 0x8000
        g2 = ((b[8] | (b[9] << 8)) ^ 0x8000) - 0x8000
        a0 = ((b[10] | (b[11] << 8)) ^ 0x8000) - 0x8000
        a1 = ((b[12] | (b[13] << 8)) ^ 0x8000) - 0x8000
        a2 = ((b[14] | (b[15] << 8)) ^ 0x8000) - 0x8000
        # a live part's noise changes some count every sample (health.py)
        same = (a0 == raw[4] and g0 == raw[1] and a1 == raw[5]
                and a2 == raw[6] and g1 == raw[2] and g2 == raw[3])
        raw[0] = t
        raw[1] = g0
        raw[2] = g1
        raw[3] = g2
        raw[4] = a0
        raw[5] = a1
        raw[6] = a2
        if not health.fresh(same):  # frozen (counted there)
            self._recover()
            return False
        if status & _TDA:
            self._temp = t
        return True

    @property
    def temp_c(self):
        """The last temperature, C (scaled when asked for: one boxed float)."""
        c = self._temp_c
        c[0] = 25.0 + self._temp * TEMP_SCALE
        return c

    @property
    def accel(self):
        """The last sample's specific force, m/s^2 (chip axes)."""
        return self._scaled(self._accel, 4, ACCEL_SCALE)

    @property
    def gyro(self):
        """The last sample's rate, rad/s (chip axes)."""
        return self._scaled(self._gyro, 1, GYRO_SCALE)
