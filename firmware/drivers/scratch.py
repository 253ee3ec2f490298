"""Words that survive a watchdog reset: the RP2350 watchdog's scratch registers.

The RP2350's WATCHDOG block (datasheet section 12.9, base 0x400d8000) has
eight 32-bit scratch registers, SCRATCH0-7 at offsets 0x0c-0x28, that keep
their contents through a watchdog reset (the rp2 port's ``machine.WDT`` and
``machine.reset()`` reset the system through the power-on state machine,
not the whole chip) and read 0 after a power-on or a RUN pin reset
(section 12.9.5). The bootrom reads SCRATCH4-7 for its watchdog boot
vector (section 5.2.4), so the firmware keeps to SCRATCH0-3: 16 bytes.

Access is through ``machine.mem32`` (injected: the board's, or the twin's
emulated one). A read returns the word as the rp2 port does, as a signed
32-bit int (``mp_obj_new_int`` of the uint32), so ``read_into`` masks it.
A word above 2**30 is a big integer on MicroPython: reading and writing
allocate, which is why the firmware does both only at boot and at the
events it records, never in a step.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

#: Bytes the firmware's four words hold.
SIZE = const(16)


class Scratch:
    """SCRATCH0-3 of the watchdog at ``base`` (the address of SCRATCH0) through
    ``mem32``."""

    def __init__(self, mem32, base):
        self._mem = mem32
        self._base = base

    def read_into(self, buf):
        """The 16 bytes (little-endian words) into ``buf`` (a bytearray of 16)."""
        mem = self._mem
        for k in range(4):
            w = mem[self._base + 4 * k] & 0xFFFFFFFF
            j = 4 * k
            buf[j] = w & 0xFF
            buf[j + 1] = (w >> 8) & 0xFF
            buf[j + 2] = (w >> 16) & 0xFF
            buf[j + 3] = (w >> 24) & 0xFF
        return buf

    def write(self, buf):
        """Store 16 bytes (little-endian words)."""
        mem = self._mem
        for k in range(4):
            j = 4 * k
            mem[self._base + j] = buf[j] | (buf[j + 1] << 8) | (buf[j + 2] << 16) | (buf[j + 3] << 24)

    def clear(self):
        mem = self._mem
        for k in range(4):
            mem[self._base + 4 * k] = 0
