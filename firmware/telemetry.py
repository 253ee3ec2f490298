"""What the vehicle reports: the estimator and the drivers into ``Telemetry``.

The MAVLink endpoint sends the telemetry streams from a
``shared/mavlink/telemetry.Telemetry`` at their ``SR_*`` rates; ``Reporter``
keeps that object current, one stream's part at a time, just before the
endpoint sends it (``firmware/link.py`` passes ``refresh`` as the
endpoint's ``on_refresh``): ``fast()`` copies the attitude and rates
element by element between ``array('f')`` buffers (a slice assignment
builds a slice object, a heap block; on RoboRay's MicroPython a float
copied costs nothing, on stock one boxed float each);
``position()`` position and velocity (NED, from the estimator's ``nav``),
their variances (the estimator's ``cov``: north and east grow while the
position is dead-reckoned without fixes) and depth; ``sensors()`` pressure, temperature and the IMU in body axes;
``servo()`` wing angles and pulses; ``power()`` battery and loop load.
``fill()`` does all but ``fast()``. Failsafe flags and the SYS_STATUS sensor bits
are written by ``firmware/failsafe.py`` as it evaluates them.

The battery's remaining charge is reported unknown (-1): the vehicle has no
current sensor, and a Li-ion pack's voltage under a servo load says little
about its charge.
"""

from roboray.shared.estimator import health as _h

_RAD_TO_DEG = 57.29577951308232

# Stream numbers (shared/mavlink/endpoint.py): what ``refresh`` is called with
_ATTITUDE = 0
_POSITION = 1
_SENSORS = 2
_SERVO = 3


class Reporter:
    """Fills ``telemetry`` from ``nav`` (Navigation), ``wings``, ``battery``, ``sched``."""

    def __init__(self, telemetry, nav, wings, battery, sched):
        self.t = telemetry
        self.nav = nav
        self.wings = wings
        self.battery = battery
        self.sched = sched
        telemetry.battery[2] = -1.0
        # the estimator's north, east, v north, v east variances, in
        # Telemetry.var_ned's order (health.COV_NORTH..COV_VE are adjacent)
        # (a view made once: its items are the estimator's, read in place)
        self._cov_h = memoryview(nav.est.cov)[_h.COV_NORTH:_h.COV_VE + 1]
        self._var_ned = telemetry.var_ned

    def refresh(self, stream):
        """The part of the telemetry stream number ``stream`` sends (the endpoint's ``on_refresh``)."""
        if stream == _ATTITUDE:
            self.fast()
        elif stream == _POSITION:
            self.position()
        elif stream == _SENSORS:
            self.sensors()
        elif stream == _SERVO:
            self.servo()
        else:   # battery, status
            self.power()

    def fast(self):
        """Attitude and rates."""
        t = self.t
        est = self.nav.est
        # element by element: a slice assignment builds a slice object (a
        # heap block a call); on RoboRay's build a float copied costs none
        q = t.q
        e = est.q
        q[0] = e[0]
        q[1] = e[1]
        q[2] = e[2]
        q[3] = e[3]
        r = t.rates
        e = est.rates
        r[0] = e[0]
        r[1] = e[1]
        r[2] = e[2]

    def position(self):
        """Position and velocity (NED), their variances, depth."""
        t = self.t
        est = self.nav.est
        # element by element (no slice object; the estimator's order, see
        # __init__)
        vn = self._var_ned
        ch = self._cov_h
        vn[0] = ch[0]
        vn[1] = ch[1]
        vn[2] = ch[2]
        vn[3] = ch[3]
        c = est.cov
        z = t.var_dz
        z[0] = c[_h.COV_DEPTH]
        z[1] = c[_h.COV_VZ]
        n = est.nav
        p = t.pos_ned
        p[0] = n[2]
        p[1] = n[3]
        p[2] = n[0]
        v = t.vel_ned
        v[0] = n[4]
        v[1] = n[5]
        v[2] = n[1]
        t.env[0] = n[0]

    def sensors(self):
        """Pressure and temperature; the IMU in body axes."""
        t = self.t
        nav = self.nav
        env = t.env
        d = nav.depth
        env[1] = d.pressure_pa
        env[2] = d.temp_cc * 0.01
        imu = t.imu
        b = nav.body
        for i in range(9):    # no slice object; range() in a for loop allocates nothing
            imu[i] = b[i]

    def servo(self):
        """Wing angles (degrees) and pulses."""
        t = self.t
        w = self.wings
        c = w.command
        s = t.servo_deg
        s[0] = c[0] * _RAD_TO_DEG
        s[1] = c[1] * _RAD_TO_DEG
        s[2] = c[2] * _RAD_TO_DEG
        s[3] = c[3] * _RAD_TO_DEG
        su = t.servo_us
        pu = w.pulse_us
        su[0] = pu[0]
        su[1] = pu[1]
        su[2] = pu[2]
        su[3] = pu[3]

    def power(self):
        """Battery voltage and loop load."""
        t = self.t
        t.battery[0] = self.battery.volts[0]
        sched = self.sched
        if sched is not None:
            lp = sched.load_permille
            t.load_permille = 0 if lp < 0 else (1000 if lp > 1000 else lp)

    def fill(self):
        """Everything but the attitude (``fast``)."""
        self.position()
        self.sensors()
        self.servo()
        self.power()
