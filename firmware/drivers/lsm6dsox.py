"""LSM6DSOX accelerometer and gyroscope on I2C (ST, DS12814).

Configured as the estimator expects: accelerometer +-4 g (0.122 mg/LSB),
gyroscope +-500 dps (17.50 mdps/LSB), both at 208 Hz, block data update on,
register auto-increment on. ``read()`` is one 16-byte burst from
``STATUS_REG`` (0x1E) through ``OUTZ_H_A`` (0x2D) into a buffer made once,
decoded with shifts and scaled to SI in the sensor's axes:

- ``accel`` (m/s^2, specific force: +9.81 on z lying flat), ``gyro``
  (rad/s), ``temp_c`` (C, refreshed when the chip flags a new one);
- ``raw``: the counts [temp, gx, gy, gz, ax, ay, az], for code that folds
  the scale into its own arithmetic (``ACCEL_SCALE``, ``GYRO_SCALE``).

A read boxes six floats (seven with a new temperature) and nothing else.
``health`` gets a bus error, a status byte with its reserved bits set or a
temperature outside the part's range (impossible values), or no new sample
(stale). After 10 failed reads in a row the driver writes its configuration
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
        self.accel = array("f", [0.0, 0.0, 0.0])
        self.gyro = array("f", [0.0, 0.0, 0.0])
        self.temp_c = array("f", [25.0])
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
        t = b[2] | (b[3] << 8)
        t -= (t & 0x8000) << 1
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
        raw[0] = t
        v = b[4] | (b[5] << 8)
        raw[1] = v - ((v & 0x8000) << 1)
        v = b[6] | (b[7] << 8)
        raw[2] = v - ((v & 0x8000) << 1)
        v = b[8] | (b[9] << 8)
        raw[3] = v - ((v & 0x8000) << 1)
        v = b[10] | (b[11] << 8)
        raw[4] = v - ((v & 0x8000) << 1)
        v = b[12] | (b[13] << 8)
        raw[5] = v - ((v & 0x8000) << 1)
        v = b[14] | (b[15] << 8)
        raw[6] = v - ((v & 0x8000) << 1)
        g = self.gyro
        a = self.accel
        g[0] = raw[1] * GYRO_SCALE
        g[1] = raw[2] * GYRO_SCALE
        g[2] = raw[3] * GYRO_SCALE
        a[0] = raw[4] * ACCEL_SCALE
        a[1] = raw[5] * ACCEL_SCALE
        a[2] = raw[6] * ACCEL_SCALE
        if status & _TDA:
            self.temp_c[0] = 25.0 + t * TEMP_SCALE
        health.good()
        return True
