"""What every emulated I2C device shares: the bus protocol and the faults.

MicroPython code, run by the twin next to the firmware. A device answers
the emulated ``machine.I2C`` through ``answers``, ``read``, ``write``,
``read_mem`` and ``write_mem`` (see ``machine.py``); the read paths write
into the caller's buffer and allocate nothing, so a driver's allocation
measured against an emulated device is the driver's own.

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

    Subclasses give ``_reset_registers()``, ``_auto_increment(subaddr)``,
    ``_sync()`` (bring outputs up to the present time), ``_after_read(first,
    count)`` (registers ``first .. first+count-1`` were read) and
    ``_write_reg(reg, value)``.
    """

    def __init__(self, address, size=128, clock=None):
        Device.__init__(self, address, clock)
        self.regs = bytearray(size)
        self._views = {}
        self._ptr = 0
        self._inc = True
        self._reset_registers()

    def power_on(self):
        self._reset_registers()

    # bus side
    def read_mem(self, memaddr, buf):
        self._set_pointer(memaddr)
        self.read(buf)

    def write_mem(self, memaddr, buf):
        self.transfers += 1
        self._set_pointer(memaddr)
        for i in range(len(buf)):
            self._write_reg(self._ptr, buf[i])
            self._advance()

    def write(self, buf):
        self.transfers += 1
        if len(buf) == 0:
            return
        self._set_pointer(buf[0])
        for i in range(1, len(buf)):
            self._write_reg(self._ptr, buf[i])
            self._advance()

    def read(self, buf):
        self.transfers += 1
        if self.fault == FAULT_GARBAGE:
            self._fill_noise(buf)
            return
        self._sync()
        regs = self.regs
        p = self._ptr
        n = len(buf)
        if not self._inc:
            v = regs[p]
            for i in range(n):
                buf[i] = v
            self._after_read(p, 1)
            return
        if p + n <= len(regs):
            # One slice copy through a view made on first use of this burst:
            # no allocation after that, and no per-byte Python loop.
            key = (p << 8) | n
            view = self._views.get(key)
            if view is None:
                view = memoryview(regs)[p:p + n]
                self._views[key] = view
            buf[0:n] = view
        else:
            mask = len(regs) - 1
            for i in range(n):
                buf[i] = regs[(p + i) & mask]
        self._ptr = (p + n) & (len(regs) - 1)
        self._after_read(p, n)

    def _set_pointer(self, subaddr):
        self._inc = self._auto_increment(subaddr)
        self._ptr = subaddr & (len(self.regs) - 1)

    def _advance(self):
        if self._inc:
            self._ptr = (self._ptr + 1) & (len(self.regs) - 1)

    # to override
    def _reset_registers(self):
        pass

    def _auto_increment(self, subaddr):
        return True

    def _sync(self):
        pass

    def _after_read(self, first, count):
        pass

    def _write_reg(self, reg, value):
        pass


def put_s16_le(regs, at, value):
    """Store a signed 16-bit value little-endian (as the ST parts do)."""
    regs[at] = value & 0xFF
    regs[at + 1] = (value >> 8) & 0xFF


def clamp_s16(x):
    """Round a physical value in LSB to the nearest code the ADC can output."""
    v = int(x + 0.5) if x >= 0 else -int(-x + 0.5)
    if v > 32767:
        return 32767
    if v < -32768:
        return -32768
    return v
