"""LSM6DSOX accelerometer and gyroscope on I2C (ST, DS12814), read through its FIFO.

Configured as the estimator expects: accelerometer +-4 g (0.122 mg/LSB),
gyroscope +-500 dps (17.50 mdps/LSB), both at 104 Hz, block data update
on, register auto-increment on, and both batched into the chip's FIFO at
104 Hz in continuous mode (DS12814 section 6.5), with the temperature at
1.6 Hz. The FIFO keeps every sample while the board does something else:
a garbage collection stalls the loop ~42 ms (4 to 5 samples), a parameter
save up to 150 ms; read from the output registers, those samples were
lost, and the estimator never saw what happened meanwhile (the bottom's
impact). Why 104 Hz: navigation runs at 100 Hz, so a read finds one
sample of each sensor (two in 4 % of the steps, as 104 Hz runs ahead of
the loop), the same bytes on the bus as reading the output registers at
208 Hz; batching at 208 Hz would double the words read and decoded every
step for a band the vehicle does not use (its motion is below 5 Hz), and
the chip's filters at ODR 104 Hz band-limit the samples to 52 Hz.

``read()`` (a scheduler task at 100 Hz): ``FIFO_STATUS1``/``2`` (0x3A, 2
bytes: words unread, overrun flags), then every unread word in one burst
from ``FIFO_DATA_OUT_TAG`` (0x78: with IF_INC the address wraps from 0x7E
back to 0x78, 7 bytes a word) into a buffer made once (a view of each
length made once too). Each word's tag (TAG_SENSOR, bits 7..3: 0x01
gyroscope, 0x02 accelerometer, 0x03 temperature) says what it holds. The
counts of the samples read are summed per axis, as small integers:

- ``sums``: [n_gyro, gx, gy, gz, n_accel, ax, ay, az], the number of
  samples and the sum of their counts, in the sensor's axes. Their mean
  over the read's interval is what the estimator integrates (the
  delta-angle and delta-velocity of PX4's and ArduPilot's FIFO drivers):
  one estimator step after a stall, at a normal step's cost, and no float
  boxed per sample;
- ``raw``: [temp, gx, gy, gz, ax, ay, az], the counts of the last read's
  mean sample (its only sample in a normal step);
- ``accel`` (m/s^2, specific force: +9.81 on z lying flat) and ``gyro``
  (rad/s): ``raw`` scaled to SI when asked for (each a buffer made once,
  filled on reading the attribute);
- ``temp_c`` (C, the last batched temperature, scaled when asked for).

A read boxes no float; asking for ``accel`` or ``gyro`` boxes three,
``temp_c`` one.
``health`` gets a bus error; an impossible value (FIFO_STATUS2's bit 2,
which reads 0, set, more words than the FIFO holds, a word whose tag is no
sensor batched, a temperature outside the part's range); samples lost
(``ERR_OVERFLOW``: the FIFO overran, or holds more than ``MAX_WORDS``
after a stall longer than the longest planned one: the driver empties it
and starts again); no new sample for longer than ``STALE_MS`` (stale); or
new samples whose six output counts all repeat the last ones
``FROZEN_SAMPLES`` reads in a row (frozen: ``health.py`` says why a live
part never does that). After 10 failed reads in a row the driver writes its
configuration again, which brings back a part that reset itself on a
supply dip.
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.firmware.drivers.registers import Registers
from roboray.firmware.drivers.health import ERR_BUS, ERR_OVERFLOW, ERR_RANGE, ERR_STALE, Health

ADDRESS = const(0x6A)

_FIFO_CTRL3 = const(0x09)
_FIFO_CTRL4 = const(0x0A)
_WHO_AM_I = const(0x0F)
_CTRL1_XL = const(0x10)
_CTRL2_G = const(0x11)
_CTRL3_C = const(0x12)
_FIFO_STATUS1 = const(0x3A)
_FIFO_DATA_OUT_TAG = const(0x78)
_ID = const(0x6C)

_SW_RESET = const(0x01)
_XL_104HZ_4G = const(0x48)     # ODR_XL 0100 (104 Hz), FS_XL 10 (+-4 g)
_G_104HZ_500DPS = const(0x44)  # ODR_G 0100 (104 Hz), FS_G 01 (+-500 dps)
_BDU_IF_INC = const(0x44)      # BDU, IF_INC
_BDR_104HZ = const(0x44)       # FIFO_CTRL3: BDR_GY 0100, BDR_XL 0100 (104 Hz)
_FIFO_CONTINUOUS = const(0x16)  # FIFO_CTRL4: ODR_T_BATCH 01 (1.6 Hz), FIFO_MODE 110 (continuous)
_FIFO_BYPASS = const(0x00)     # FIFO_MODE 000: the FIFO empties
# FIFO_STATUS2: FIFO_OVR_IA (6), FIFO_OVR_LATCHED (3): words were lost;
# bit 2 reads 0; DIFF_FIFO_9:8 in bits 1:0
_LOST = const(0x48)
_ZERO2 = const(0x04)
_FIFO_DEPTH = const(512)
_TAG_GYRO = const(0x01)
_TAG_ACCEL = const(0x02)
_TAG_TEMP = const(0x03)

#: Words one read takes at most (7 bytes each): 77 ms of both sensors at
#: 104 Hz, a collection's stall (33-40 ms) and the slot around it with
#: room. Reading costs the I2C bus 22.5 us a byte at 400 kHz: the 30 words
#: a 150 ms flash save leaves took 10 ms, a slot on their own (an overrun
#: on the emulated Pico 2). A longer backlog is emptied (``ERR_OVERFLOW``)
#: and the estimator coasts over the gap, as over a silent IMU.
MAX_WORDS = const(16)
#: A read that finds nothing new this long after the last sample is stale
#: (2.4 batch periods: one read finding nothing is the loop's 100 Hz
#: running behind the chip's 104 Hz, not a fault).
STALE_MS = const(23)

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
        self._st = bytearray(2)
        self._fifo = bytearray(7 * MAX_WORDS)
        mv = memoryview(self._fifo)
        self._views = [mv[:7 * k] for k in range(MAX_WORDS + 1)]
        self._carry = False
        #: [n_gyro, gx, gy, gz, n_accel, ax, ay, az]: the last read's sample
        #: counts and count sums (see the module docstring).
        self.sums = array("l", [0] * 8)
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
        self._carry = False
        # the first sample after a reset is compared with nothing: the chip's
        # filters restart, and a repeat of the last count says nothing of
        # its front end (see ``read``)
        self._restarted = True
        for reg, value in ((_CTRL3_C, _BDU_IF_INC), (_CTRL1_XL, _XL_104HZ_4G), (_CTRL2_G, _G_104HZ_500DPS),
                           (_FIFO_CTRL3, _BDR_104HZ), (_FIFO_CTRL4, _FIFO_CONTINUOUS)):
            self._write_reg(reg, value)
            got = self._read_reg(reg)
            if got != value:
                raise self._fail("register 0x%02X reads 0x%02X after writing 0x%02X" % (reg, got, value))

    def discard(self):
        """Empty the FIFO (bypass, then continuous again): before the loop
        starts, whatever was batched while the rest of the board was set up
        is old, and one read of it would cost the first slot its time."""
        self._write_reg(_FIFO_CTRL4, _FIFO_BYPASS)
        self._write_reg(_FIFO_CTRL4, _FIFO_CONTINUOUS)
        self._carry = False

    def read(self):
        """Scheduler task: the samples batched since the last read. True when
        both sensors gave at least one and they were sound (``sums``)."""
        health = self.health
        i2c = self._i2c
        try:
            i2c.readfrom_mem_into(self.address, _FIFO_STATUS1, self._st)
            st = self._st
            s2 = st[1]
            n = st[0] | ((s2 & 3) << 8)
            if s2 & _ZERO2 or n > _FIFO_DEPTH:
                health.bad(ERR_RANGE)
                self._recover()
                return False
            if s2 & _LOST or n > MAX_WORDS:
                # samples are gone: empty the FIFO and start afresh; the
                # estimator coasts over the gap
                self.discard()
                health.bad(ERR_OVERFLOW)
                self._recover()
                return False
            if n == 0:
                clock = self._clock
                if clock.ticks_diff(clock.ticks_ms(), health.last_good_ms) > STALE_MS:
                    health.bad(ERR_STALE)
                    self._recover()
                return False
            i2c.readfrom_mem_into(self.address, _FIFO_DATA_OUT_TAG, self._views[n])
        except OSError:
            health.bad(ERR_BUS)
            self._recover()
            return False
        sums = self.sums
        if self._carry:
            # a sensor's sample without the other's last time: kept for now
            ng = sums[0]
            g0 = sums[1]
            g1 = sums[2]
            g2 = sums[3]
            na = sums[4]
            a0 = sums[5]
            a1 = sums[6]
            a2 = sums[7]
        else:
            ng = g0 = g1 = g2 = na = a0 = a1 = a2 = 0
        b = self._fifo
        j = 0
        end = 7 * n
        # Straight-line decoding: a helper call per word costs more than
        # the arithmetic on MicroPython; little-endian 16-bit two's
        # complement, (u ^ 0x8000) - 0x8000 extends the sign.
        while j < end:
            tag = b[j] >> 3
            x = ((b[j + 1] | (b[j + 2] << 8)) ^ 0x8000) - 0x8000
            y = ((b[j + 3] | (b[j + 4] << 8)) ^ 0x8000) - 0x8000
            z = ((b[j + 5] | (b[j + 6] << 8)) ^ 0x8000) - 0x8000
            if tag == _TAG_GYRO:
                ng += 1
                g0 += x
                g1 += y
                g2 += z
            elif tag == _TAG_ACCEL:
                na += 1
                a0 += x
                a1 += y
                a2 += z
            elif tag == _TAG_TEMP and _TEMP_MIN <= x <= _TEMP_MAX and y == 0 and z == 0:
                self._temp = x
            else:
                self._carry = False
                health.bad(ERR_RANGE)
                self._recover()
                return False
            j += 7
        sums[0] = ng
        sums[1] = g0
        sums[2] = g1
        sums[3] = g2
        sums[4] = na
        sums[5] = a0
        sums[6] = a1
        sums[7] = a2
        if ng == 0 or na == 0:
            self._carry = ng or na
            return False
        self._carry = False
        if ng > 1:
            g0 //= ng
            g1 //= ng
            g2 //= ng
        if na > 1:
            a0 //= na
            a1 //= na
            a2 //= na
        raw = self.raw
        # a live part's noise changes some count every sample (health.py)
        same = (a0 == raw[4] and g0 == raw[1] and a1 == raw[5]
                and a2 == raw[6] and g1 == raw[2] and g2 == raw[3]) and not self._restarted
        self._restarted = False
        raw[0] = self._temp
        raw[1] = g0
        raw[2] = g1
        raw[3] = g2
        raw[4] = a0
        raw[5] = a1
        raw[6] = a2
        if not health.fresh(same):  # frozen (counted there)
            self._recover()
            return False
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
