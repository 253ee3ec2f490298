"""MS5837-30BA pressure and temperature sensor on I2C (TE Connectivity).

The sensor Blue Robotics' Bar30 carries. Start-up resets it, reads the
calibration PROM and checks its CRC-4 and product version; after that
``update()``, called every 20 ms by the scheduler, never blocks: it collects
the conversion started on the previous call (once its conversion time has
passed, checked against the clock) and starts the next one, D1 (pressure)
and D2 (temperature) in turn. At OSR 8192 (18.08 ms a conversion) that
gives a new pressure every 40 ms, 25 Hz.

Compensation is the datasheet's first- and second-order integer formula,
done so that no intermediate leaves MicroPython's small integers (31 bits on
the boards, where ``D1 * SENS`` alone needs 48): ``compensate()`` splits the
products into 12- and 13-bit limbs and carries by hand, and gives exactly
what the datasheet's 64-bit arithmetic (with floor division) gives. It
allocates nothing.

Results are integers, so a sample boxes no float: ``pressure_pa`` (Pa,
10 Pa steps), ``temp_cc`` (0.01 C), ``sample_us`` (``ticks_us`` at the
middle of the pressure conversion). Failures go to ``health``: a bus error,
an ADC read that returned 0 (conversion not ready), a temperature or
pressure outside what the part can measure.
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.firmware.drivers.health import ERR_BUS, ERR_NOT_READY, ERR_RANGE, OK, Health

ADDRESS = const(0x76)

_CMD_RESET = const(0x1E)
_CMD_ADC_READ = const(0x00)
_CMD_D1 = const(0x40)
_CMD_D2 = const(0x50)
_CMD_PROM = const(0xA0)
_RESET_MS = const(3)           # PROM reload: 2.8 ms max

_VERSION_30BA = const(0x1A)    # PROM word 0 bits 11..5 (Blue Robotics' reading)
_VERSION_02BA01 = const(0x00)
_VERSION_02BA21 = const(0x15)

_TEMP_MIN = const(-4000)       # 0.01 C: below the part's -20 C rating with margin
_TEMP_MAX = const(8500)        # 85 C, its upper rating
_P_MAX = const(400000)         # 0.1 mbar: 40 bar, above its 30 bar range

_IDLE = const(0)
_D1 = const(1)
_D2 = const(2)
_WAIT = const(3)               # after a failed read: let any conversion finish

#: OSR -> (command offset, maximum conversion time in us), datasheet.
_OSR = {256: (0, 600), 512: (2, 1170), 1024: (4, 2280), 2048: (6, 4540),
        4096: (8, 9040), 8192: (10, 18080)}


def crc4(prom):
    """CRC-4 of the 8 PROM words as the datasheet's routine computes it.

    The CRC nibble (word 0, bits 15..12) and word 7 count as 0.
    """
    rem = 0
    for cnt in range(16):
        w = prom[cnt >> 1]
        if cnt < 2:
            w &= 0x0FFF
        elif cnt >= 14:
            w = 0
        rem ^= (w & 0xFF) if cnt & 1 else (w >> 8)
        for _ in range(8):
            if rem & 0x8000:
                rem = ((rem << 1) ^ 0x3000) & 0xFFFF
            else:
                rem = (rem << 1) & 0xFFFF
    return rem >> 12


def _sq_shift(dh, dl, f, e):
    # floor(f * dT^2 / 2^e) for dT = dh * 2^12 + dl, e >= 24, f <= 3.
    # dT^2 = dh^2 2^24 + 2 dh dl 2^12 + dl^2; each product stays below 2^28.
    z2 = f * dh * dh               # <= 3 * 2^24
    z1 = 2 * f * dh * dl           # |.| < 6 * 2^24
    z0 = f * dl * dl               # < 3 * 2^24
    return (z2 + ((z1 + (z0 >> 12)) >> 12)) >> (e - 24)


def compensate(c, d1, d2, out):
    """Datasheet compensation of the MS5837-30BA, first and second order.

    ``c[1]..c[6]`` are the PROM coefficients C1..C6, ``d1``/``d2`` the raw
    24-bit conversions. Writes ``out[0]`` = P (0.1 mbar) and ``out[1]`` =
    TEMP (0.01 C) and returns ``OK``, or returns ``ERR_RANGE`` (``out``
    untouched) when the temperature or pressure is outside what the part
    measures.

    Exact: equal to the datasheet's int64 arithmetic with floor division
    (the datasheet example, D1 = 4958179, D2 = 6815414, gives P = 39998,
    TEMP = 1981). Every intermediate stays below 2^30 in magnitude for any
    16-bit coefficients and 24-bit conversions (bounds in the comments;
    ``tests/test_drivers_ms5837.py`` checks every operation).
    """
    # dT = D2 - C5 * 2^8, |dT| < 2^24; split dT = dh * 2^12 + dl.
    dt = d2 - (c[5] << 8)
    dh = dt >> 12                  # -2^12 <= dh < 2^12 (floor)
    dl = dt & 0xFFF                # 0 <= dl < 2^12
    # TEMP = 2000 + dT * C6 / 2^23; dh*C6, dl*C6 < 2^28.
    c6 = c[6]
    temp = 2000 + ((dh * c6 + ((dl * c6) >> 12)) >> 11)
    if temp < _TEMP_MIN or temp > _TEMP_MAX:
        return ERR_RANGE
    # Second order (30BA): Ti, OFFi, SENSi; |TEMP - 2000| <= 6500.
    t = temp - 2000
    if temp < 2000:
        ti = _sq_shift(dh, dl, 3, 33)          # 3 dT^2 / 2^33
        offi = (3 * t * t) >> 1                # 3 (TEMP-2000)^2 / 2  < 2^27
        sensi = (5 * t * t) >> 3               # 5 (TEMP-2000)^2 / 2^3 < 2^25
        if temp < -1500:
            u = temp + 1500                    # >= -2500
            offi += 7 * u * u                  # 7 (TEMP+1500)^2 < 2^26
            sensi += 4 * u * u                 # 4 (TEMP+1500)^2 < 2^25
    else:
        ti = _sq_shift(dh, dl, 2, 37)          # 2 dT^2 / 2^37
        offi = (t * t) >> 4                    # (TEMP-2000)^2 / 2^4
        sensi = 0
    # OFF2 = C2 2^16 + C4 dT / 2^7 - OFFi, kept as hi * 2^13 + lo.
    # C4 dT / 2^7 = 32 u + floor(C4 dl / 2^7) with u = C4 dh (|u| < 2^28).
    c4 = c[4]
    u = c4 * dh
    m = ((c4 * dl) >> 7) - offi                # |m| < 2^27
    o_hi = (c[2] << 3) + ((u + (m >> 5)) >> 8)     # floor(OFF2 / 2^13), |.| < 2^21
    o_lo = (((u & 0xFF) << 5) + m) & 0x1FFF        # OFF2 mod 2^13
    # SENS2 = C1 2^15 + C3 dT / 2^8 - SENSi in base-2^12 limbs s2 s1 s0.
    # C3 dT / 2^8 = 16 u3 + floor(C3 dl / 2^8) with u3 = C3 dh.
    c3 = c[3]
    u3 = c3 * dh                               # |u3| < 2^28
    x = ((c3 * dl) >> 8) + ((u3 & 0xFF) << 4) - sensi
    s0 = x & 0xFFF
    x = (c[1] << 3) + (u3 >> 8) + (x >> 12)    # |x| < 2^21
    s1 = x & 0xFFF
    s2 = x >> 12                               # |s2| < 2^9
    # D1 SENS2 / 2^21 with D1 = a 2^12 + b; products of limbs < 2^25.
    a = d1 >> 12
    b = d1 & 0xFFF
    w0 = b * s0
    w1 = a * s0 + b * s1
    w2 = a * s1 + b * s2
    w3 = a * s2
    # floor(D1 SENS2 / 2^21) = w3 2^15 + y, y = 8 w2 + floor((w1 2^12 + w0) / 2^21)
    y = (w2 << 3) + ((w1 + (w0 >> 12)) >> 9)   # |y| < 2^28
    x_hi = (w3 << 2) + (y >> 13)               # floor(. / 2^13)
    x_lo = y & 0x1FFF
    # P = floor((D1 SENS2 / 2^21 - OFF2) / 2^13)
    p = x_hi - o_hi + ((x_lo - o_lo) >> 13)
    if p < 0 or p > _P_MAX:
        return ERR_RANGE
    out[0] = p
    out[1] = temp - ti
    return OK


class MS5837:
    """MS5837-30BA on ``i2c`` at ``address``.

    Parameters
    ----------
    i2c:
        The bus (``machine.I2C`` or anything with its methods).
    osr:
        Oversampling, 256 .. 8192 (conversion 0.6 .. 18.08 ms).
    clock:
        The ``time`` module (or the twin's virtual clock).
    timeout_ms:
        ``health.healthy()`` drops when no good pressure came for this long.

    Raises OSError naming the address when the part does not answer, its
    PROM fails its CRC or looks blank, or it is a 02BA (other formula).
    """

    def __init__(self, i2c, address=ADDRESS, osr=8192, clock=None, timeout_ms=200):
        if clock is None:
            import time as clock
        if osr not in _OSR:
            raise ValueError("MS5837 osr must be one of 256, 512, 1024, 2048, 4096, 8192, not %r" % (osr,))
        self._i2c = i2c
        self.address = address
        self._clock = clock
        self._cmd_offset, self.conversion_us = _OSR[osr]
        self._cmd = bytearray(1)
        self._adc = bytearray(3)
        self._word = bytearray(2)
        self.prom = array("H", [0] * 8)
        self._c = array("l", [0] * 7)
        self._out = array("l", [0, 0])
        self._state = _IDLE
        self._t_start = 0
        self._d1 = 0
        self._d2 = 0
        #: Latest results: pressure (Pa), temperature (0.01 C), when (ticks_us).
        self.pressure_pa = 0
        self.temp_cc = 0
        self.sample_us = 0
        self.health = Health(clock, timeout_ms)
        self.version = self._start()

    def _fail(self, what):
        return OSError("MS5837 at I2C address 0x%02X: %s" % (self.address, what))

    def _start(self):
        try:
            self._send(_CMD_RESET)
        except OSError as e:
            raise self._fail("no answer (%s)" % e)
        self._clock.sleep_ms(_RESET_MS)
        try:
            for i in range(7):
                self._i2c.readfrom_mem_into(self.address, _CMD_PROM + 2 * i, self._word)
                self.prom[i] = (self._word[0] << 8) | self._word[1]
        except OSError as e:
            raise self._fail("PROM read failed (%s)" % e)
        stored = self.prom[0] >> 12
        computed = crc4(self.prom)
        if stored != computed:
            raise self._fail("PROM CRC mismatch (stored 0x%X, computed 0x%X): a damaged "
                             "part or a noisy bus" % (stored, computed))
        for i in range(1, 7):
            w = self.prom[i]
            if w == 0 or w == 0xFFFF:
                raise self._fail("PROM coefficient C%d is 0x%04X: no calibration" % (i, w))
            self._c[i] = w
        version = (self.prom[0] >> 5) & 0x7F
        if version == _VERSION_02BA01 or version == _VERSION_02BA21:
            raise self._fail("this is an MS5837-02BA (version 0x%02X); the driver is for the 30BA" % version)
        return version

    def _send(self, cmd):
        self._cmd[0] = cmd
        self._i2c.writeto(self.address, self._cmd)

    def update(self):
        """Scheduler task: collect the finished conversion, start the next.

        Returns True when a new pressure is in ``pressure_pa``.
        """
        clock = self._clock
        now = clock.ticks_us()
        state = self._state
        fresh = False
        if state != _IDLE:
            if clock.ticks_diff(now, self._t_start) < self.conversion_us:
                return False  # called early: the conversion is still running
            if state != _WAIT:
                try:
                    self._i2c.readfrom_mem_into(self.address, _CMD_ADC_READ, self._adc)
                except OSError:
                    self.health.bad(ERR_BUS)
                    self._state = _IDLE
                    return False
                adc = self._adc
                v = (adc[0] << 16) | (adc[1] << 8) | adc[2]
                if v == 0:
                    # The part says no conversion was ready: wait a whole
                    # conversion time before the next command, so a late
                    # result cannot be taken for the other kind.
                    self.health.bad(ERR_NOT_READY)
                    self._state = _WAIT
                    self._t_start = now
                    return False
                if state == _D1:
                    self._d1 = v
                    if self._d2:
                        fresh = self._sample(self._t_start)
                else:
                    self._d2 = v
        # Next conversion: temperature first, then pressure and temperature in turn.
        nxt = _D2 if state == _D1 or self._d2 == 0 else _D1
        cmd = self._cmd
        cmd[0] = (_CMD_D1 if nxt == _D1 else _CMD_D2) + self._cmd_offset
        try:
            self._i2c.writeto(self.address, cmd)   # as _send() does, without the call
        except OSError:
            self.health.bad(ERR_BUS)
            self._state = _IDLE
            return fresh
        self._state = nxt
        # the conversion started when the command went out, after this
        # call's work and the read's bus time: timed from `now` it would be
        # collected that much too early, and the part answers 0 (not ready)
        self._t_start = clock.ticks_us()
        return fresh

    def _sample(self, d1_start):
        if compensate(self._c, self._d1, self._d2, self._out) != OK:
            self.health.bad(ERR_RANGE)
            return False
        self.pressure_pa = self._out[0] * 10
        self.temp_cc = self._out[1]
        self.sample_us = self._clock.ticks_add(d1_start, self.conversion_us >> 1)
        self.health.good()
        return True
