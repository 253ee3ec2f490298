"""What every emulated I2C device shares: the bus protocol and the faults.

MicroPython code, run by the twin next to the firmware. A device answers
the emulated ``machine.I2C`` through ``read``, ``write``, ``read_mem`` and
``write_mem``, which raise ``OSError(EIO)`` when it does not acknowledge,
and ``answers`` (False: it would NACK) for a scan (see ``machine.py``); the
read paths write into the caller's buffer and allocate nothing, so a
driver's allocation measured against an emulated device is the driver's
own. The firmware reads its sensors a few hundred times a second, so the
read path is written out flat: a Python call costs more on MicroPython than
the work it would hide.

Faults the twin injects with ``set_fault``:

- ``FAULT_NACK``: the device stops answering (every transfer is a NACK,
  ``OSError(EIO)`` on the board);
- ``FAULT_GARBAGE``: it answers with noise (a 16-bit LFSR, deterministic);
- ``FAULT_STICK``: its outputs freeze at their present values while it goes
  on answering and flagging new data, like a sensor whose front end died;
- ``FAULT_NONE``: healthy again.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

FAULT_NONE = const(0)
FAULT_NACK = const(1)
FAULT_GARBAGE = const(2)
FAULT_STICK = const(3)

FAULT_NAMES = ("none", "nack", "garbage", "stick")

_EIO = const(5)


class Device:
    """Base of the emulated devices: address, fault state, noise source."""

    def __init__(self, address, clock=None):
        if clock is None:
            import time as clock
        self.address = address
        self.clock = clock
        self.fault = FAULT_NONE
        self._lfsr = 0xACE1
        #: Transfers seen, for tests and the twin's statistics.
        self.transfers = 0
        #: The part's own output noise, +- counts on each latched output
        #: (``set_noise``).
        self.noise_counts = 0

    def set_noise(self, counts):
        """Add +-``counts`` (uniform, from the device's LFSR: deterministic)
        to every output value each sample, as a live part's front end does.
        For rigs that feed a part constants (a vehicle at rest in a test or
        a bench): the firmware judges a part whose counts never move as
        frozen. The twin's world feeds noisy values and leaves this at 0."""
        if not 0 <= counts <= 127:
            raise ValueError("noise of %r counts: 0..127" % (counts,))
        self.noise_counts = counts

    def _dither(self, regs, at, n, big_endian):
        # n 16-bit outputs from regs[at]; bytes in and out, so the part's
        # reads still allocate nothing (a driver's heap figure is its own)
        k = self.noise_counts
        span = 2 * k + 1
        lo = 1 if big_endian else 0
        hi = 1 - lo
        for j in range(at, at + 2 * n, 2):
            v = regs[j + lo] | (regs[j + hi] << 8)
            v = (v ^ 0x8000) - 0x8000 + self._noise() % span - k
            v = -32768 if v < -32768 else (32767 if v > 32767 else v)
            regs[j + lo] = v & 0xFF
            regs[j + hi] = (v >> 8) & 0xFF

    def set_fault(self, kind):
        if kind not in (FAULT_NONE, FAULT_NACK, FAULT_GARBAGE, FAULT_STICK):
            raise ValueError("unknown fault %r" % (kind,))
        self.fault = kind

    def answers(self):
        return self.fault != FAULT_NACK

    def _noise(self):
        # 16-bit Galois LFSR (taps 0xB400): small integers only.
        x = self._lfsr
        x = (x >> 1) ^ (0xB400 if x & 1 else 0)
        self._lfsr = x
        return x & 0xFF

    def _fill_noise(self, buf):
        for i in range(len(buf)):
            buf[i] = self._noise()

    def power_on(self):
        """Supply cut and restored: back to the power-on state."""


class RegisterDevice(Device):
    """A chip with 8-bit registers behind an address pointer.

    Subclasses give ``_reset_registers()``, ``_sync()`` (bring outputs up to
    the present time), ``_write_reg(reg, value)`` and ``_read_clears(first,
    count)``: the bits of ``regs[self._status]`` that reading registers
    ``first .. first+count-1`` clears, a function of the two alone (it is
    asked once per burst and remembered). The pointer auto-increments while
    ``self._inc_all`` is true, else when the sub-address has a bit of
    ``INC_BIT`` set.
    """

    #: Sub-address bit that asks for auto-increment (0: none does).
    INC_BIT = 0
    #: The pointer auto-increments whatever the sub-address (a subclass may
    #: keep this per instance, following a control register).
    _inc_all = True
    #: The status register reads clear bits of.
    _status = 0

    def __init__(self, address, size=128, clock=None):
        Device.__init__(self, address, clock)
        self.regs = bytearray(size)
        self._mask = size - 1
        # (view of the registers, status bits kept, pointer after) by burst
        # (first << 8 | count)
        self._bursts = {}
        self._ptr = 0
        self._inc = True
        self._reset_registers()

    def power_on(self):
        self._reset_registers()

    # bus side
    def read_mem(self, memaddr, buf):
        """Set the pointer to ``memaddr`` and read ``buf`` full."""
        if self.fault and self.fault != FAULT_STICK:
            if self.fault == FAULT_NACK:
                raise OSError(_EIO)  # rp2's error for a NACK
            self._set_pointer(memaddr)
            self.read(buf)
            return
        self._inc = self._inc_all or memaddr & self.INC_BIT
        self._ptr = memaddr & self._mask
        self.transfers += 1
        self._sync()
        # A burst read before is one slice copy through a view of its
        # registers, with the status bits it keeps and where it leaves the
        # pointer: no per-byte Python loop, no allocation.
        burst = self._bursts.get((self._ptr << 8) | len(buf)) if self._inc else None
        if burst is None:
            self._read_slow(buf)
            return
        buf[:] = burst[0]
        self._ptr = burst[2]
        self.regs[self._status] &= burst[1]

    def read(self, buf):
        """Read ``buf`` full on from the pointer."""
        if self.fault == FAULT_NACK:
            raise OSError(_EIO)
        self.transfers += 1
        if self.fault == FAULT_GARBAGE:
            self._fill_noise(buf)
            return
        self._sync()
        self._read_slow(buf)

    def _read_slow(self, buf):
        # the first read of a burst (kept for the next ones), or one that
        # wraps around or repeats a register
        regs = self.regs
        p = self._ptr
        n = len(buf)
        if not self._inc:
            v = regs[p]
            for i in range(n):
                buf[i] = v
            regs[self._status] &= 0xFF & ~self._read_clears(p, 1)
            return
        for i in range(n):
            buf[i] = regs[(p + i) & self._mask]
        self._ptr = (p + n) & self._mask
        keep = 0xFF & ~self._read_clears(p, n)
        regs[self._status] &= keep
        if p + n <= len(regs):
            self._bursts[(p << 8) | n] = (memoryview(regs)[p:p + n], keep, self._ptr)

    def write_mem(self, memaddr, buf):
        if self.fault == FAULT_NACK:
            raise OSError(_EIO)  # rp2's error for a NACK
        self.transfers += 1
        self._set_pointer(memaddr)
        for i in range(len(buf)):
            self._write_reg(self._ptr, buf[i])
            self._advance()

    def write(self, buf):
        if self.fault == FAULT_NACK:
            raise OSError(_EIO)  # rp2's error for a NACK
        self.transfers += 1
        if len(buf) == 0:
            return
        self._set_pointer(buf[0])
        for i in range(1, len(buf)):
            self._write_reg(self._ptr, buf[i])
            self._advance()

    def _set_pointer(self, subaddr):
        self._inc = self._inc_all or subaddr & self.INC_BIT
        self._ptr = subaddr & self._mask

    def _advance(self):
        if self._inc:
            self._ptr = (self._ptr + 1) & self._mask

    # to override
    def _reset_registers(self):
        pass

    def _sync(self):
        pass

    def _read_clears(self, first, count):
        return 0

    def _write_reg(self, reg, value):
        pass

