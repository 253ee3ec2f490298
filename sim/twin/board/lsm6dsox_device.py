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

- the FIFO (DS12814 section 6.5 and section 9, ``FIFO_CTRL1``-``4``
  0x07-0x0A, ``FIFO_STATUS1``/``2`` 0x3A/0x3B, ``FIFO_DATA_OUT_TAG`` 0x78
  and ``FIFO_DATA_OUT_X_L`` .. ``Z_H`` 0x79-0x7E): ``FIFO_CTRL3`` BDR_GY[7:4]
  and BDR_XL[3:0] (the ODR codes; BDR_XL 1011 1.6 Hz, BDR_GY 1011 6.5 Hz),
  ``FIFO_CTRL4`` ODR_T_BATCH[5:4] (1.6, 12.5, 52 Hz) and FIFO_MODE[2:0]
  (000 bypass: empty and reset; 001 FIFO: stops when full; 110
  continuous: the newest word overwrites the oldest; the triggered modes
  are not modelled and act as bypass), WTM[8:0] in ``FIFO_CTRL1``/``2``.
  Words of 7 bytes: a tag, TAG_SENSOR[7:3] (0x01 gyroscope, 0x02
  accelerometer, 0x03 temperature), TAG_CNT[2:1] (the batch slot, modulo
  4), TAG_PARITY[0] (not modelled: 0), then X, Y, Z as the output
  registers (a temperature word: the temperature, then zeros). Each
  sensor is batched on its own grid of BDR periods as virtual time passes,
  in a slot the gyroscope's word first, with the input valid at that
  moment (``set_motion``'s ``t_us``); 512 words deep, as ST's drivers size
  the LSM6DSO family's FIFO (the datasheet's "9 kbytes" counts compressed
  words). ``FIFO_STATUS1``/``2``: DIFF_FIFO[9:0] words unread,
  FIFO_WTM_IA[7], FIFO_OVR_IA[6] (full and a word was lost), FIFO_FULL_IA[5]
  (full at the next batch), FIFO_OVR_LATCHED[3] (a word was lost since this
  register was last read; reading it clears the bit). With IF_INC a read
  from 0x78 runs through 0x7E and wraps back to 0x78, so n words are one
  burst of 7 n bytes (as Linux's st_lsm6dsx reads them); a word leaves the
  FIFO when its last byte (0x7E) is read; an empty FIFO reads 0.

Power-on state: both sensors off (ODR 0), so nothing is ever "ready" until
a driver configures the chip. Inputs from the twin, in the sensor's axes:
``set_accel`` (specific force, m/s^2), ``set_gyro`` (rad/s),
``set_temperature`` (C); ``set_motion(..., t_us)`` dates the new input
(the twin's step boundary: a stall that skips several boundaries still
batches each FIFO word with the input of its own moment). Faults as in
``i2c_device``; a stuck part batches its frozen counts.
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
_FIFO_CTRL1 = const(0x07)
_FIFO_CTRL2 = const(0x08)
_FIFO_CTRL3 = const(0x09)
_FIFO_CTRL4 = const(0x0A)
_FIFO_STATUS1 = const(0x3A)
_FIFO_STATUS2 = const(0x3B)
_FIFO_TAG = const(0x78)
_FIFO_END = const(0x7E)
_STATUS = const(0x1E)
_OUT_TEMP_L = const(0x20)
_OUTX_L_G = const(0x22)
_OUTX_L_A = const(0x28)

_TICKS_MAX = const(0x3FFFFFFF)

_XLDA = const(0x01)
_GDA = const(0x02)
_TDA = const(0x04)

#: FIFO depth in 7-byte words.
FIFO_WORDS = const(512)
TAG_GYRO = const(0x01)
TAG_ACCEL = const(0x02)
TAG_TEMP = const(0x03)
_WTM_IA = const(0x80)
_OVR_IA = const(0x40)
_FULL_IA = const(0x20)
_OVR_LATCHED = const(0x08)
_MODE_BYPASS = const(0)
_MODE_FIFO = const(1)
_MODE_CONTINUOUS = const(6)

#: Sample period by ODR code (12.5 Hz .. 6667 Hz; 11 = 1.6 Hz low-power), us.
_ODR_US = (0, 80000, 38462, 19231, 9615, 4808, 2404, 1200, 600, 300, 150, 625000)
#: Batch period by BDR code, us: the ODR's, but 1011 is 6.5 Hz for the gyroscope.
_BDR_G_US = (0, 80000, 38462, 19231, 9615, 4808, 2404, 1200, 600, 300, 150, 153846)
#: Temperature batch period by ODR_T_BATCH code (off, 1.6, 12.5, 52 Hz), us.
_BDR_T_US = (0, 625000, 80000, 19231)
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
        # the FIFO: a ring of 7-byte words, the index of the oldest and how
        # many are unread
        self._ring = bytearray(7 * FIFO_WORDS)
        self._fg = bytearray(6)   # the last gyroscope and accelerometer words' data
        self._fa = bytearray(6)
        self._wtmp = bytearray(6)
        self._head = 0
        self._count = 0
        self._lost = False        # FIFO_OVR_LATCHED
        self._mode = _MODE_BYPASS
        self._bdr_g = 0           # batch periods (0: not batched), us
        self._bdr_xl = 0
        self._bdr_t = 0
        self._next_bg = 0         # the next batch times
        self._next_bxl = 0
        self._next_bt = 0
        self._slot = 0            # TAG_CNT
        self._inputs = 0          # set_motion calls so far, and at the last words batched
        self._in_g = -1
        self._in_xl = -1
        # Each FIFO word is the mean of the input over its own batch period,
        # as the chip's filter chain averages the motion between its samples:
        # the integral of the input (SI units) since each sensor's last word,
        # and the tick up to which it is summed.
        self._sum_g = [0.0, 0.0, 0.0]
        self._sum_xl = [0.0, 0.0, 0.0]
        self._mark_g = 0
        self._mark_xl = 0
        self._from_g = 0      # the tick of the sensor's last word
        self._from_xl = 0
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

    def set_motion(self, ax, ay, az, gx, gy, gz, t_us=-1):
        """``set_accel`` and ``set_gyro`` at once (the twin's step); the
        temperature stays as it is. ``t_us``: the tick from which the new
        input holds (default now): the FIFO batches what falls before it
        with the input it replaces."""
        if self._mode:
            if t_us < 0:
                clock = self.clock
                t_us = clock.now_us if not clock.tick_cost_us else clock.ticks_us()
            self._batch(t_us, 1)
            self._integrate(t_us)   # the input being replaced held until t_us
        self._inputs += 1
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
        self._fifo_reset()
        self._mode = _MODE_BYPASS
        self._bdr_g = 0
        self._bdr_xl = 0
        self._bdr_t = 0
        self._quantise()

    def _fifo_reset(self):
        # bypass mode (or a reset): the FIFO empties, its flags clear
        self._head = 0
        self._count = 0
        self._lost = False
        self._slot = 0

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
        elif reg == _FIFO_CTRL3 or reg == _FIFO_CTRL4:
            self._batch(now, 0)   # what the old settings batched until now stays
            regs = self.regs
            mode = regs[_FIFO_CTRL4] & 7
            if mode != _MODE_FIFO and mode != _MODE_CONTINUOUS:
                mode = _MODE_BYPASS
            bdr_g = _BDR_G_US[regs[_FIFO_CTRL3] >> 4] if regs[_FIFO_CTRL3] >> 4 < 12 else 0
            bdr_xl = _ODR_US[regs[_FIFO_CTRL3] & 15] if regs[_FIFO_CTRL3] & 15 < 12 else 0
            bdr_t = _BDR_T_US[(regs[_FIFO_CTRL4] >> 4) & 3]
            if mode == _MODE_BYPASS:
                self._fifo_reset()
            # a sensor that starts batching does so one period from now
            if bdr_g and (bdr_g != self._bdr_g or not self._mode):
                self._next_bg = self.clock.ticks_add(now, bdr_g)
                self._start_sum(self._sum_g, now, True)
            if bdr_xl and (bdr_xl != self._bdr_xl or not self._mode):
                self._next_bxl = self.clock.ticks_add(now, bdr_xl)
                self._start_sum(self._sum_xl, now, False)
            if bdr_t and (bdr_t != self._bdr_t or not self._mode):
                self._next_bt = self.clock.ticks_add(now, bdr_t)
            self._mode = mode
            self._bdr_g = bdr_g
            self._bdr_xl = bdr_xl
            self._bdr_t = bdr_t

    # --------------------------------------------------------------- FIFO
    def _start_sum(self, acc, t, gyro):
        acc[0] = acc[1] = acc[2] = 0.0
        if gyro:
            self._mark_g = self._from_g = t
        else:
            self._mark_xl = self._from_xl = t

    def _integrate(self, t):
        # add the present input over (mark, t] to both sensors' sums
        diff = self.clock.ticks_diff
        m = self._motion
        d = diff(t, self._mark_xl)
        if d > 0:
            acc = self._sum_xl
            acc[0] += m[0] * d
            acc[1] += m[1] * d
            acc[2] += m[2] * d
            self._mark_xl = t
        d = diff(t, self._mark_g)
        if d > 0:
            acc = self._sum_g
            acc[0] += m[3] * d
            acc[1] += m[4] * d
            acc[2] += m[5] * d
            self._mark_g = t

    def _mean_word(self, out, acc, t_from, t, lsb):
        # the mean over (t_from, t] as counts: rounded halves away from
        # zero and clipped, as set_motion quantises the output registers
        n = self.clock.ticks_diff(t, t_from)
        if n <= 0:
            return False
        v0 = acc[0] / (n * lsb)
        v1 = acc[1] / (n * lsb)
        v2 = acc[2] / (n * lsb)
        pack_into("<hhh", out, 0,
                  max(-32768, min(32767, int(v0 + copysign(0.5, v0)))),
                  max(-32768, min(32767, int(v1 + copysign(0.5, v1)))),
                  max(-32768, min(32767, int(v2 + copysign(0.5, v2)))))
        acc[0] = acc[1] = acc[2] = 0.0
        return True

    def _batch(self, until, strict):
        """Batch every word due up to ``until`` (before it, when ``strict``)
        with the present input: on each sensor's grid of batch periods, a
        late call catching up on all of them (the FIFO keeps what the output
        registers skip)."""
        if not self._mode:
            return
        diff = self.clock.ticks_diff
        stick = self.fault == FAULT_STICK
        while True:
            # the earliest due batch of the three (gyroscope first in a slot)
            t = -1
            if self._bdr_g:
                t = self._next_bg
            if self._bdr_xl and (t < 0 or diff(self._next_bxl, t) < 0):
                t = self._next_bxl
            if self._bdr_t and (t < 0 or diff(self._next_bt, t) < 0):
                t = self._next_bt
            if t < 0:
                return
            late = diff(until, t)
            if late < 0 or (strict and late == 0):
                return
            # sensors off (ODR 0) batch nothing but keep their grid
            if self._bdr_g and self._next_bg == t:
                self._next_bg = (t + self._bdr_g) & _TICKS_MAX
                if self._g_period:
                    self._integrate(t)
                    fresh = self._mean_word(self._wtmp, self._sum_g, self._from_g, t, self._g_lsb)
                    self._from_g = t
                    if not stick:
                        self._fg[:] = self._wtmp if fresh else self._gyro
                        if self.noise_counts:
                            self._dither(self._fg, 0, 3, False)
                        elif self._in_g == self._inputs:
                            self._own_noise(self._fg)
                        self._in_g = self._inputs
                    self._push(TAG_GYRO, self._fg)
            if self._bdr_xl and self._next_bxl == t:
                self._next_bxl = (t + self._bdr_xl) & _TICKS_MAX
                if self._xl_period:
                    self._integrate(t)
                    fresh = self._mean_word(self._wtmp, self._sum_xl, self._from_xl, t, self._a_lsb)
                    self._from_xl = t
                    if not stick:
                        self._fa[:] = self._wtmp if fresh else self._accel
                        if self.noise_counts:
                            self._dither(self._fa, 0, 3, False)
                        elif self._in_xl == self._inputs:
                            self._own_noise(self._fa)
                        self._in_xl = self._inputs
                    self._push(TAG_ACCEL, self._fa)
            if self._bdr_t and self._next_bt == t:
                self._next_bt = (t + self._bdr_t) & _TICKS_MAX
                if self._xl_period or self._g_period:
                    self._push(TAG_TEMP, self._temp)
            self._slot = (self._slot + 1) & 3

    def _own_noise(self, data):
        # A second word from one input: the twin's world moves its inputs
        # (noise included) once a 10 ms step, the chip samples at its own
        # rate, and its own noise makes no two samples alike (~9 counts RMS
        # on the accelerometer, 3 on the gyroscope): +-1 count on each axis
        # here, so a live part never repeats itself (the driver would take
        # it for frozen).
        for j in range(0, 6, 2):
            v = data[j] | (data[j + 1] << 8)
            v = (v ^ 0x8000) - 0x8000 + (1 if self._noise() & 1 else -1)
            v = -32768 if v < -32768 else (32767 if v > 32767 else v)
            data[j] = v & 0xFF
            data[j + 1] = (v >> 8) & 0xFF

    def _push(self, tag, data):
        # one word at the tail; a full FIFO drops it (FIFO mode) or loses
        # its oldest word to it (continuous mode)
        if self._count >= FIFO_WORDS:
            self._lost = True
            if self._mode == _MODE_FIFO:
                return
            self._head = (self._head + 1) % FIFO_WORDS
            self._count -= 1
        at = 7 * ((self._head + self._count) % FIFO_WORDS)
        ring = self._ring
        ring[at] = (tag << 3) | (self._slot << 1)
        for i in range(len(data)):
            ring[at + 1 + i] = data[i]
        for i in range(len(data), 6):
            ring[at + 1 + i] = 0
        self._count += 1

    def _fifo_status(self):
        regs = self.regs
        n = self._count
        s2 = (n >> 8) & 3
        wtm = regs[_FIFO_CTRL1] | ((regs[_FIFO_CTRL2] & 1) << 8)
        if wtm and n >= wtm:
            s2 |= _WTM_IA
        if n >= FIFO_WORDS:
            s2 |= _FULL_IA
            if self._lost:
                s2 |= _OVR_IA
        elif n == FIFO_WORDS - 1:
            s2 |= _FULL_IA
        if self._lost:
            s2 |= _OVR_LATCHED
        regs[_FIFO_STATUS1] = n & 0xFF
        regs[_FIFO_STATUS2] = s2

    def read_mem(self, memaddr, buf):
        n = len(buf)
        ends = memaddr + (n if self._inc_all else 1)
        if (self.fault and self.fault != FAULT_STICK) or ends <= _FIFO_STATUS1 or memaddr > _FIFO_END:
            RegisterDevice.read_mem(self, memaddr, buf)
            return
        self.transfers += 1
        self._sync()
        if memaddr < _FIFO_TAG:
            self._fifo_status()
            RegisterDevice._set_pointer(self, memaddr)
            self._read_slow(buf)
            if memaddr <= _FIFO_STATUS2 < ends:
                self._lost = False   # FIFO_OVR_LATCHED: cleared by reading it
            return
        # the FIFO's output: 0x78..0x7E, wrapping back to 0x78 with IF_INC
        a = memaddr
        ring = self._ring
        for i in range(n):
            if self._count:
                buf[i] = ring[7 * self._head + a - _FIFO_TAG]
            else:
                buf[i] = 0
            if a == _FIFO_END:
                if self._count:
                    self._head = (self._head + 1) % FIFO_WORDS
                    self._count -= 1
                a = _FIFO_TAG
            elif self._inc_all:
                a += 1

    def _sync(self):
        clock = self.clock
        now = clock.now_us if not clock.tick_cost_us else clock.ticks_us()
        regs = self.regs
        if self._mode:
            self._batch(now, 0)
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
