"""Sensor health: what a driver saw go wrong, for the failsafes to judge.

Every driver owns a ``Health`` and reports each sample attempt to it:
``good()`` for a sample it trusts, ``bad(code)`` with the reason otherwise.
A sensor is failed by what it does (bus errors, a CRC, impossible values,
no fresh data, outputs frozen), never by a quantity that stays the same: a
vehicle resting on the bottom reads the same depth for minutes, and that
is not a fault. Frozen outputs are something else: a MEMS part whose raw
counts repeat bit for bit on every axis while it flags new samples. Its
own noise (LSM6DSOX accelerometer ~9 counts RMS at 208 Hz, gyroscope ~3,
LIS3MDL ~20) moves a live part's counts every sample, at rest or not, so
twenty repeats in a row mean a front end that died (``Health.frozen``,
``FROZEN_SAMPLES``).

``healthy()`` is True while the last good sample is younger than the
driver's time-out and fewer than ``max_consecutive`` attempts in a row went
wrong. Counters are small integers; nothing here allocates.
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

OK = const(0)
ERR_BUS = const(1)        # NACK, bus time-out: the part did not answer
ERR_CRC = const(2)        # calibration or data failed its check
ERR_RANGE = const(3)      # a value the part cannot produce (reserved bits, out of range)
ERR_STALE = const(4)      # no new sample where one was due
ERR_NOT_READY = const(5)  # a conversion read before it finished (the part returned 0)
ERR_FROZEN = const(6)     # new samples flagged, every output count the same as the last ones
ERR_OVERFLOW = const(7)   # samples lost: the part's FIFO overflowed, or held more than a read takes

#: Text for each code, for logs and STATUSTEXT.
ERRORS = ("ok", "bus error", "CRC mismatch", "impossible value", "no fresh data", "conversion not ready",
          "outputs frozen", "samples lost")

#: Samples in a row with every output count unchanged that make a part
#: frozen (the module docstring says why this is no reading at rest).
FROZEN_SAMPLES = const(20)


class Health:
    """Counters of one sensor.

    Attributes
    ----------
    samples, errors : int
        Good samples and failed attempts since start-up.
    consecutive : int
        Failed attempts since the last good sample.
    last_error : int
        Code of the last failure (``OK`` if none yet).
    counts : array('l')
        Failures by code, indexed like ``ERRORS``.
    """

    def __init__(self, clock, timeout_ms, max_consecutive=5, frozen_samples=FROZEN_SAMPLES):
        self._clock = clock
        #: Repeats in a row that freeze the part (and moving samples that
        #: bring it back): ``FROZEN_SAMPLES``, fewer for a part read less
        #: often (the navigation reads the magnetometer at 25 Hz).
        self.frozen_samples = frozen_samples
        self.timeout_ms = timeout_ms
        self.max_consecutive = max_consecutive
        self.samples = 0
        self.errors = 0
        self.consecutive = 0
        self.last_error = OK
        self.counts = array("l", [0] * len(ERRORS))
        self.last_good_ms = clock.ticks_ms()
        #: New samples in a row whose output counts all repeat the last ones,
        #: and (while frozen) in a row that moved; see ``frozen()``.
        self.frozen_run = 0
        self.live_run = 0
        self.is_frozen = False

    def good(self):
        self.samples += 1
        self.consecutive = 0
        self.last_good_ms = self._clock.ticks_ms()

    def bad(self, code):
        self.errors += 1
        self.consecutive += 1
        self.counts[code] += 1
        self.last_error = code

    def frozen(self, same):
        """Judge a new sample by its counts: ``same`` when every output count
        repeats the last sample's. True while the part is frozen:
        FROZEN_SAMPLES repeats in a row freeze it, as many moving samples in
        a row bring it back (one change, such as the reset a
        reconfiguration makes, does not)."""
        if same:
            self.frozen_run += 1
            self.live_run = 0
            if self.frozen_run >= self.frozen_samples:
                self.is_frozen = True
        elif self.is_frozen:
            self.frozen_run = 0
            self.live_run += 1
            if self.live_run >= self.frozen_samples:
                self.is_frozen = False
        else:
            self.frozen_run = 0
        return self.is_frozen

    def fresh(self, same):
        """A new sample in one call (a driver's read, at its sample rate):
        ``frozen(same)``, then ``good()``, or ``bad(ERR_FROZEN)`` while
        frozen. True when the sample is good."""
        if same or self.is_frozen:
            if self.frozen(same):
                self.bad(ERR_FROZEN)
                return False
        else:
            self.frozen_run = 0
        self.samples += 1
        self.consecutive = 0
        self.last_good_ms = self._clock.ticks_ms()
        return True

    def age_ms(self):
        """Milliseconds since the last good sample (or since start-up)."""
        return self._clock.ticks_diff(self._clock.ticks_ms(), self.last_good_ms)

    def healthy(self):
        clock = self._clock
        return (self.samples > 0 and self.consecutive < self.max_consecutive
                and clock.ticks_diff(clock.ticks_ms(), self.last_good_ms) <= self.timeout_ms)
