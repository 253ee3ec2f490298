"""Battery voltage through a resistor divider on an ADC pin.

``volts = read_u16 / 65535 * vref * divider``, low-pass filtered (first
order, time constant ``tau_s`` at the task's period) so servo current
spikes do not trip the low-battery failsafe. The divider ratio is the
``BATT_VOLT_MULT`` parameter (ArduPilot's name), 3.0 by default for a 2S
Li-ion pack (8.4 V full reads 2.8 V at the pin).

An ADC pinned at either rail (a divider open or shorted) is an impossible
reading for a connected pack and goes to ``health`` as such; a pack that is
merely low is the failsafe's business, not a sensor fault. ``volts`` and
``raw_volts`` live in ``array('f')``; an update boxes three floats.
"""

from array import array

from roboray.firmware.drivers.health import ERR_RANGE, Health
from roboray.shared.params import TYPE_REAL32

#: Divider parameter (shared/params.py declaration).
PARAMS = (
    ("BATT_VOLT_MULT", TYPE_REAL32, 3.0, 1.0, 20.0),  # pack volts per ADC-pin volt
)

_RAIL_LOW = 64        # counts of 65535: within ~3 mV of a rail
_RAIL_HIGH = 65535 - 64


class Battery:
    """Pack voltage from ``adc`` (``machine.ADC``).

    Parameters
    ----------
    divider:
        Pack volts per volt at the pin.
    vref:
        ADC full-scale voltage (the RP2350's 3.3 V supply).
    period_s, tau_s:
        Task period and filter time constant.
    """

    def __init__(self, adc, divider=3.0, vref=3.3, period_s=0.1, tau_s=1.0, clock=None, timeout_ms=1000):
        if clock is None:
            import time as clock
        if not divider > 0.0:
            raise ValueError("battery divider must be > 0, got %r" % (divider,))
        if not (period_s > 0.0 and tau_s >= 0.0):
            raise ValueError("battery period_s must be > 0 and tau_s >= 0")
        self._adc = adc
        self.vref = vref
        self._alpha = period_s / (tau_s + period_s)
        self.volts = array("f", [0.0])
        self.raw_volts = array("f", [0.0])
        self.health = Health(clock, timeout_ms)
        self.set_divider(divider)

    def set_divider(self, divider):
        if not divider > 0.0:
            raise ValueError("battery divider must be > 0, got %r" % (divider,))
        self.divider = divider
        self._k = self.vref * divider / 65535.0

    def update(self):
        """Scheduler task: one reading into the filter. False when implausible."""
        raw = self._adc.read_u16()
        if raw <= _RAIL_LOW or raw >= _RAIL_HIGH:
            self.health.bad(ERR_RANGE)
            return False
        v = raw * self._k
        self.raw_volts[0] = v
        if self.health.samples == 0:
            self.volts[0] = v
        else:
            f = self.volts[0]
            self.volts[0] = f + self._alpha * (v - f)
        self.health.good()
        return True
