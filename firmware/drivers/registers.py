"""Byte registers of a part on an I2C bus: reads, writes and identity.

The IMU parts (LSM6DSOX, LIS3MDL) are register maps behind one address;
this is what their drivers share. One preallocated byte, so a register
access allocates nothing; every failure names the part and its address.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

# A part that keeps failing is reconfigured every this many failures: it may
# have reset itself on a supply dip and lost its configuration.
_RECOVER_AFTER = const(10)


class Registers:
    """Base of a register-map driver: ``i2c`` injected, ``address`` 7-bit."""

    PART = "I2C part"

    def __init__(self, i2c, address):
        self._i2c = i2c
        self.address = address
        self._reg = bytearray(1)
        self.reconfigurations = 0

    def _fail(self, what):
        return OSError("%s at I2C address 0x%02X: %s" % (self.PART, self.address, what))

    def _read_reg(self, reg):
        self._i2c.readfrom_mem_into(self.address, reg, self._reg)
        return self._reg[0]

    def _write_reg(self, reg, value):
        self._reg[0] = value
        self._i2c.writeto_mem(self.address, reg, self._reg)

    def _check_identity(self, reg, expected):
        """Raise OSError unless register ``reg`` reads ``expected``."""
        try:
            who = self._read_reg(reg)
        except OSError as e:
            raise self._fail("no answer (%s)" % e)
        if who != expected:
            raise self._fail("WHO_AM_I is 0x%02X, expected 0x%02X: another part at this address"
                             % (who, expected))

    def _scaled(self, out, first, scale):
        """``out`` (3 floats) = ``raw[first:first+3]`` counts times ``scale``:
        the SI view of a sample, made when asked for, not at every read."""
        raw = self.raw
        out[0] = raw[first] * scale
        out[1] = raw[first + 1] * scale
        out[2] = raw[first + 2] * scale
        return out

    def _recover(self):
        """After repeated failures, try the configuration again (the driver's
        ``_configure``; its failures are counted by ``health``)."""
        if self.health.consecutive % _RECOVER_AFTER:
            return
        try:
            self._configure()
            self.reconfigurations += 1
        except OSError:
            pass
