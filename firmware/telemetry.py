"""What the vehicle reports: the estimator and the drivers into ``Telemetry``.

The MAVLink endpoint sends the telemetry streams from a
``shared/mavlink/telemetry.Telemetry`` at their ``SR_*`` rates; ``Reporter``
keeps that object current. ``fast()`` copies the attitude, which the
ATTITUDE stream may want at up to 50 Hz, with slice copies between
``array('f')`` buffers (no float boxed); ``fill()`` does the rest at 10 Hz:
position and velocity (NED, from the estimator's ``nav``), depth, pressure
and temperature, the IMU in body axes, wing angles and pulses, battery, loop
load. Failsafe flags and the SYS_STATUS sensor bits are written by
``firmware/failsafe.py`` as it evaluates them.

The battery's remaining charge is reported unknown (-1): the vehicle has no
current sensor, and a Li-ion pack's voltage under a servo load says little
about its charge.
"""

_RAD_TO_DEG = 57.29577951308232


class Reporter:
    """Fills ``telemetry`` from ``nav`` (Navigation), ``wings``, ``battery``, ``sched``."""

    def __init__(self, telemetry, nav, wings, battery, sched):
        self.t = telemetry
        self.nav = nav
        self.wings = wings
        self.battery = battery
        self.sched = sched
        telemetry.battery[2] = -1.0

    def fast(self):
        """Attitude and rates (every link cycle)."""
        t = self.t
        est = self.nav.est
        t.q[0:4] = est.q
        t.rates[0:3] = est.rates

    def fill(self):
        """Everything else (10 Hz)."""
        t = self.t
        nav = self.nav
        n = nav.est.nav
        p = t.pos_ned
        p[0] = n[2]
        p[1] = n[3]
        p[2] = n[0]
        v = t.vel_ned
        v[0] = n[4]
        v[1] = n[5]
        v[2] = n[1]
        env = t.env
        env[0] = n[0]
        d = nav.depth
        env[1] = d.pressure_pa
        env[2] = d.temp_cc * 0.01
        t.imu[0:9] = nav.body
        w = self.wings
        c = w.command
        s = t.servo_deg
        for k in range(4):
            s[k] = c[k] * _RAD_TO_DEG
        t.servo_us[0:4] = w.pulse_us
        t.battery[0] = self.battery.volts[0]
        sched = self.sched
        if sched is not None:
            lp = sched.load_permille
            t.load_permille = 0 if lp < 0 else (1000 if lp > 1000 else lp)
