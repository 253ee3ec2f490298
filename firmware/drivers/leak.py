"""Leak sensor on a digital input, debounced.

A leak probe (Blue Robotics SOS style) drives its output high when water
bridges its contacts. One wet reading can be a splash or noise; ``samples``
equal readings in a row change the debounced state ``wet``. ``detected``
latches the first debounced leak until ``clear()``: water in the dome does
not go away, and the failsafe must not flicker. The pin is injected
(``machine.Pin(n, Pin.IN, Pin.PULL_DOWN)``, so an unplugged probe reads
dry). ``health`` counts updates as good samples: a digital probe has no
failure the board can see.
"""

from roboray.firmware.drivers.health import Health


class Leak:
    """Debounced leak input on ``pin``; ``active_high`` as the probe drives it."""

    def __init__(self, pin, active_high=True, samples=3, clock=None, timeout_ms=1000):
        if clock is None:
            import time as clock
        if samples < 1:
            raise ValueError("leak samples must be >= 1, got %r" % (samples,))
        self._pin = pin
        self._active = 1 if active_high else 0
        self.samples = samples
        self.wet = False
        self.detected = False
        self._run = 0
        self.health = Health(clock, timeout_ms)

    def update(self):
        """Scheduler task: sample the pin; the debounced state."""
        raw_wet = self._pin.value() == self._active
        if raw_wet == self.wet:
            self._run = 0
        else:
            self._run += 1
            if self._run >= self.samples:
                self.wet = raw_wet
                self._run = 0
                if raw_wet:
                    self.detected = True
        self.health.good()
        return self.wet

    def clear(self):
        """Forget a latched leak (after the dome was dried)."""
        self.detected = self.wet
