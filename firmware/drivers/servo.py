"""Wing servos on PWM: wing angle (rad) to pulse width, per-servo calibration.

A hobby servo takes a pulse every 20 ms (50 Hz) whose width sets its
position. Each wing's calibration: the pulse at 0 deg (wing flat) and at
90 deg (folded), the direction (reversed for a servo mounted the other way
round: then 0 deg is at the 90 deg end) and a trim added to both (spline
offset). The angle is clamped to 0..90 deg and the pulse to the servo's
500..2500 us, so no command and no calibration can drive a servo into its
end stops; a NaN command keeps the last pulse and is counted in
``invalid``. A command equal to the last one sent (within 0..90 deg) leaves
the PWM alone: its pulse is already the one it would compute.

``Servo`` drives one PWM channel (injected: ``machine.PWM(Pin(n),
freq=50)``); ``Wings`` holds the four with the command buffer the
controller writes (``command``, rad) and is the scheduler task
(``update()``). ``PARAMS`` declares the calibration parameters, named as
ArduPilot's (``SERVOn_MIN``: pulse at 0 deg, ``SERVOn_MAX``: at 90 deg,
``SERVOn_TRIM``, ``SERVOn_REVERSED``). Setting a pulse boxes one float.
"""

from array import array

from roboray.shared.params import TYPE_INT16, TYPE_UINT8, TYPE_UINT16

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

PULSE_MIN_US = const(500)      # what hobby servos accept at all
PULSE_MAX_US = const(2500)
FREQ_HZ = const(50)
ANGLE_MAX = 1.5707963267948966  # 90 deg, rad
_ANGLE_TO_NS = 1000.0 / ANGLE_MAX  # us per rad at 1 us span, x1000 for ns
_NONE = float("nan")  # "no angle": equal to no command

#: Calibration parameters of wings 1..4 (shared/params.py declarations).
PARAMS = ()
for _k in range(1, 5):
    PARAMS += (
        ("SERVO%d_MIN" % _k, TYPE_UINT16, 1000, PULSE_MIN_US, PULSE_MAX_US),  # us at 0 deg (flat)
        ("SERVO%d_MAX" % _k, TYPE_UINT16, 2000, PULSE_MIN_US, PULSE_MAX_US),  # us at 90 deg (folded)
        ("SERVO%d_TRIM" % _k, TYPE_INT16, 0, -200, 200),                      # us added to both
        ("SERVO%d_REVERSED" % _k, TYPE_UINT8, 0, 0, 1),                        # 1: 0 deg at the MAX end
    )


class Servo:
    """One servo on ``pwm`` with its calibration (pulses in us)."""

    def __init__(self, pwm, min_us=1000, max_us=2000, trim_us=0, reversed=False):
        self._pwm = pwm
        self.invalid = 0
        self.clamped = 0
        self.pulse_us = 0
        self._angle = _NONE   # the last in-range angle sent
        self.calibrate(min_us, max_us, trim_us, reversed)

    def calibrate(self, min_us, max_us, trim_us=0, reversed=False):
        for name, v in (("min_us", min_us), ("max_us", max_us)):
            if not PULSE_MIN_US <= v <= PULSE_MAX_US:
                raise ValueError("servo %s %r outside %d..%d us" % (name, v, PULSE_MIN_US, PULSE_MAX_US))
        if min_us == max_us:
            raise ValueError("servo min_us and max_us are both %r: no travel" % (min_us,))
        if not -500 <= trim_us <= 500:
            raise ValueError("servo trim_us %r outside -500..500 us" % (trim_us,))
        lo, hi = (max_us, min_us) if reversed else (min_us, max_us)
        self._zero_ns = (lo + trim_us) * 1000
        self._ns_per_rad = (hi - lo) * _ANGLE_TO_NS
        self._angle = _NONE

    def set_angle(self, angle):
        """Command the wing to ``angle`` rad (0 flat .. pi/2 folded); the pulse in us."""
        if angle == self._angle:
            return self.pulse_us
        if angle != angle:
            self.invalid += 1
            return self.pulse_us
        if angle < 0.0:
            angle = 0.0
            self.clamped += 1
            self._angle = _NONE   # counted every time it is asked for
        elif angle > ANGLE_MAX:
            angle = ANGLE_MAX
            self.clamped += 1
            self._angle = _NONE
        else:
            self._angle = angle
        ns = self._zero_ns + int(angle * self._ns_per_rad)
        if ns < PULSE_MIN_US * 1000:
            ns = PULSE_MIN_US * 1000
        elif ns > PULSE_MAX_US * 1000:
            ns = PULSE_MAX_US * 1000
        self._pwm.duty_ns(ns)
        self.pulse_us = ns // 1000
        return self.pulse_us

    def off(self):
        """No more pulses: the servo stops holding its position."""
        self._pwm.duty_ns(0)
        self.pulse_us = 0
        self._angle = _NONE


class Wings:
    """The four wing servos and their command buffer.

    ``command[i]`` (rad) is what the controller wants for wing i+1;
    ``update()`` sends all four. ``safe`` is the angle ``hold_safe()``
    commands (the ``SERVO_SAFE_DEG`` parameter, converted by the caller).
    """

    def __init__(self, servos, safe=0.0):
        if len(servos) != 4:
            raise ValueError("Wings needs 4 servos, got %d" % len(servos))
        self.servos = servos
        self.safe = safe
        self.command = array("f", [safe] * 4)
        self.pulse_us = array("H", [0] * 4)

    def configure(self, params):
        """Calibrate from the ``SERVOn_*`` parameters of a parameter table."""
        for k in range(4):
            prefix = "SERVO%d_" % (k + 1)
            values = []
            for suffix in ("MIN", "MAX", "TRIM", "REVERSED"):
                i = params.index(prefix + suffix)
                if i < 0:
                    raise ValueError("parameter %s%s is not declared" % (prefix, suffix))
                values.append(int(params.get(i)))
            self.servos[k].calibrate(values[0], values[1], values[2], values[3] != 0)

    def hold_safe(self):
        c = self.command
        for k in range(4):
            c[k] = self.safe
        self.update()

    def update(self):
        """Scheduler task: send the four commands."""
        c = self.command
        p = self.pulse_us
        s = self.servos
        p[0] = s[0].set_angle(c[0])
        p[1] = s[1].set_angle(c[1])
        p[2] = s[2].set_angle(c[2])
        p[3] = s[3].set_angle(c[3])

    def off(self):
        """No pulses to any servo (the telemetry's outputs read 0)."""
        for k in range(4):
            self.servos[k].off()
            self.pulse_us[k] = 0
