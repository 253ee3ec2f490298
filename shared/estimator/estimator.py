"""The composite estimator the firmware calls: attitude, depth, position,
health, with one time-stamped call per sensor sample.

See the package docstring (``roboray.shared.estimator``) for the step API.

Load levelling: ``mag()``, ``depth()``, ``fix()`` and ``wings()`` only store
their sample; every ``imu()`` then does its prediction plus at most one
extra job, chosen in this order: a pending fix, a pending depth sample, the
10 Hz housekeeping (covariances to now, attitude variance model,
quaternion normalisation, descent-model gain), a pending magnetometer
sample. A cycle in which every sensor arrives costs one IMU step plus the
dearest job, and the rest follow in the next steps, each corrected for its
age through its time stamp. A magnetometer sample still waiting when the
next one arrives is replaced (the newer wins); one is fused at most every
``mag_period_s`` (25 Hz; the firmware reads the chip at that rate).
"""

import math
from array import array

from roboray.shared.estimator import health as _h
from roboray.shared.estimator.attitude import HEADING_REJECTED_INNOVATION, HEADING_USED, Attitude
from roboray.shared.estimator.descent_model import DescentModel
from roboray.shared.estimator.horizontal import FIX_REJECTED, FIX_TOO_OLD, Horizontal
from roboray.shared.estimator.ticks import ticks_diff
from roboray.shared.estimator.vertical import Vertical

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_G = 9.80665
# health bits and status/output slots used in the step code: the values of
# ``health`` again, as constants the compiler inlines (a test checks they agree)
_IMU_OK = const(0x001)
_MAG_OK = const(0x002)
_DEPTH_OK = const(0x004)
_FIX_OK = const(0x008)
_ATTITUDE_VALID = const(0x010)
_DEPTH_VALID = const(0x020)
_POSITION_VALID = const(0x040)
_ACCEL_USED = const(0x080)
_SERVOS_MOVING = const(0x100)
_FAST_ALIGN = const(0x200)
_HALF = const(0x20000000)   # half the tick period
_TMAX = const(0x3FFFFFFF)

#: ``Estimator.job``: the extra job the last ``imu()`` did.
JOB_NONE = const(0)
JOB_FIX = const(1)
JOB_DEPTH = const(2)
JOB_HOUSEKEEPING = const(3)
JOB_MAG = const(4)
_PEND_MAG = const(1)
_PEND_DEPTH = const(2)
_PEND_FIX = const(4)
_HOUSEKEEPING_STEPS = const(10)
_STALE_US = const(50000)
_SETTLED_STEPS = const(100)    # 1 s of tilt error < 1 deg ...
_SETTLED_MAG = const(100)      # ... and 100 heading samples averaging < 1 deg end the alignment
_MAX_GAP_US = const(250000)
#: The fraction of an integrated vertical speed change taken as its error
#: (one sigma): the wing fold of a failsafe, integrated from the IMU, came
#: out 15-25 % off the speed the pressure showed (the twin, passive drop).
_DYNAMIC_ERROR = 0.5
#: A step longer than this since the last IMU sample is a stall's backlog
#: (the nav loop's period is 10 ms).
_GAP_US = const(25000)
#: An IMU outage longer than this ends with the attitude levelled again
#: from gravity (``Attitude.relevel``); a shorter one keeps it.
_RELEVEL_US = const(1000000)
#: The attitude stays valid while the IMU has been silent less than this: a
#: planned stall (a flash save, up to 150 ms, announced) overflows the IMU's
#: FIFO, and the read after it empties it, so the IMU is silent ~160 ms with
#: nothing wrong; the attitude held over it is the vehicle's (the gyro's
#: integration picks up after it). Dropping it there refused the operator's
#: mode changes on the bottom at every log flush and parked the wings for a
#: few control steps after a save in flight. A silent IMU still drops
#: ``IMU_OK`` at its time-out; the failsafe confirms it over 200 ms.
_ATT_HOLD_US = const(250000)
#: A pressure older than this when its turn comes is not fused: the MS5837
#: dates a sample at the middle of its conversion, ~8 ms before it is read
#: in a steady loop; ~40 ms after a collection's stall.
_DEPTH_LAG_MAX_US = const(25000)
#: Interval between magnetometer fusions, s (see ``Estimator``'s ``mag_period_s``).
MAG_PERIOD_S = 0.04
#: Degrees per radian over four wings: mean fold in degrees from the sum of angles.
_QUARTER_DEG_PER_RAD = 14.32394487827058


def _variance_step(T, k, q, r):
    """(a, b) of var <- a var + b: exact discretisation over ``T`` s of
    d var/dt = q + k^2 r - 2 k var (a first-order loop of gain ``k`` 1/s,
    driven by rate noise ``q`` and reference noise ``r``)."""
    if k <= 0.0:
        return (1.0, q * T)
    a = math.exp(-2.0 * k * T)
    return (a, (q + k * k * r) / (2.0 * k) * (1.0 - a))


class Estimator:
    """Attitude, depth and position estimator (board code).

    Parameters
    ----------
    attitude, vertical, horizontal:
        The three filters; ``None`` builds each with its defaults.
    descent:
        The descent model (``descent_model.DescentModel``, the firmware's
        from its ``DR_*`` parameters); ``None``: today's table.
    imu_position, port_position:
        IMU and pressure port in the body frame (m, from the centre of
        buoyancy).
    fluid_density:
        kg/m^3 (1000 fresh water, 1025 sea water).
    surface_pressure_pa:
        Pressure at depth 0 (atmosphere), Pa; see ``zero_depth``.
    startup_s:
        Duration of the fast-gain alignment after the first sample or a
        reset.
    servo_hold_s:
        The magnetometer is ignored this long after a wing command changes
        (servo current disturbs it).
    mag_period_s:
        Magnetometer fusion interval (default 25 Hz): newer samples wait in
        the pending slot until it has passed. The heading loop's gains
        (0.3 rad/s flying, 2 rad/s aligning) make it a 0.05-0.3 Hz filter,
        so 25 Hz still averages 80 or more samples per time constant, and
        a fusion (a fifth of a step's floats) is done a third as often as
        when every 100 Hz step fused one.
    timeouts_us:
        (imu, mag, depth, fix) time-outs of the health flags.
    tilt_var_max, depth_var_max, position_var_max:
        Variances above which an estimate stops being valid.
    """

    def __init__(self, attitude=None, vertical=None, horizontal=None, descent=None,
                 imu_position=(0.0, 0.0, -0.045), port_position=(0.0, 0.0, -0.05), fluid_density=1000.0,
                 surface_pressure_pa=101325.0, startup_s=8.0, servo_hold_s=0.3,
                 timeouts_us=(_h.TIMEOUT_IMU_US, _h.TIMEOUT_MAG_US, _h.TIMEOUT_DEPTH_US, _h.TIMEOUT_FIX_US),
                 tilt_var_max=0.0012, depth_var_max=0.0025, position_var_max=0.0625,
                 tilt_psd=1e-6, tilt_ref_psd=5e-4, heading_psd=1e-6, heading_ref_psd=2e-4,
                 heading_var_floor=7.6e-5, mag_period_s=MAG_PERIOD_S):
        if fluid_density <= 0.0:
            raise ValueError("fluid_density %r must be > 0 kg/m^3" % fluid_density)
        if len(port_position) != 3 or len(imu_position) != 3:
            raise ValueError("imu_position and port_position need 3 numbers each")
        if len(timeouts_us) != 4 or min(timeouts_us) <= 0:
            raise ValueError("timeouts_us needs 4 positive tick counts, got %r" % (timeouts_us,))
        self.att = attitude if attitude is not None else Attitude()
        self.vert = vertical if vertical is not None else Vertical()
        #: The descent model (``descent_model.DescentModel``: the ``DR_*`` parameters' table).
        self.descent = descent if descent is not None else DescentModel()
        self.hor = horizontal if horizontal is not None else Horizontal(tau=self.descent.tau_s)
        self._glide = array("f", [0.0, 0.0])

        # ----- outputs, written every IMU step
        #: Body -> NED quaternion [w, x, y, z].
        self.q = array("f", [1.0, 0.0, 0.0, 0.0])
        #: Bias-corrected body rates, rad/s.
        self.rates = array("f", [0.0, 0.0, 0.0])
        #: [roll, pitch, yaw], rad (Z-Y-X).
        self.euler = array("f", [0.0, 0.0, 0.0])
        #: Depth, vertical speed, north, east, v_north, v_east (``health.NAV_*``).
        self.nav = array("f", [0.0] * _h.NAV_SIZE)
        #: Variances (``health.COV_*``), refreshed at 10 Hz and on updates.
        self.cov = array("f", [0.0] * _h.COV_SIZE)
        #: Health bits, valid flag, rejection counts (``health.STATUS_*``).
        self.status = array("i", [0] * _h.STATUS_SIZE)
        #: Last innovation test ratios (``health.INNOV_*``).
        self.innovation = array("f", [0.0] * _h.INNOV_SIZE)
        #: Depth samples the gate refused while the vertical prediction was
        #: the IMU's since the last sample it took: evidence against the
        #: depth sensor. A refusal after the filter coasted without the IMU
        #: (``_coast``) is not: the prediction, not the pressure, is in doubt.
        self.depth_blamed = 0
        #: Pressures fused (a stale one, older than ``_DEPTH_LAG_MAX_US``
        #: when its turn came, is neither fused nor refused).
        self.depth_used = 0

        # ----- configuration
        self._ix = float(imu_position[0])
        self._iy = float(imu_position[1])
        self._iz = float(imu_position[2])
        # the port seen from the IMU
        self._rx = float(port_position[0]) - self._ix
        self._ry = float(port_position[1]) - self._iy
        self._rz = float(port_position[2]) - self._iz
        self._rho_g = fluid_density * _G
        self._inv_rho_g = 1.0 / self._rho_g
        self._p0 = float(surface_pressure_pa)
        self._startup_us = int(startup_s * 1e6)
        self._settled_mag = _SETTLED_MAG
        self._to_imu = timeouts_us[0]
        self._to_mag = timeouts_us[1]
        self._to_depth = timeouts_us[2]
        self._to_fix = timeouts_us[3]
        # alive while ((now - last + _HALF) & _TMAX) < timeout + _HALF: the
        # signed tick difference without a call (a late-stamped sample counts)
        self._lim_imu = timeouts_us[0] + _HALF
        self._lim_mag = timeouts_us[1] + _HALF
        self._lim_depth = timeouts_us[2] + _HALF
        self._lim_fix = timeouts_us[3] + _HALF
        self._lim_servo = int(servo_hold_s * 1e6) + _HALF
        self._lim_att = max(timeouts_us[0], _ATT_HOLD_US) + _HALF
        # a magnetometer sample is fused when it was measured at least 7/8 of
        # ``mag_period_s`` after the last one fused (the firmware reads the
        # chip once a period: its time stamps jitter by a fraction of a step)
        self._lim_mag_period = int(mag_period_s * 875000.0) + _HALF
        self._tilt_var_max = tilt_var_max
        self._depth_var_max = depth_var_max
        self._pos_var_max = position_var_max
        att = self.att
        period = _HOUSEKEEPING_STEPS * 0.01
        self._tilt_ab = _variance_step(period, att.kp, tilt_psd, tilt_ref_psd)
        self._tilt_ab_fast = _variance_step(period, att.kp_fast, tilt_psd, tilt_ref_psd)
        self._tilt_ab_open = _variance_step(period, 0.0, tilt_psd, tilt_ref_psd)
        self._head_ab = _variance_step(period, att.k_heading, heading_psd, heading_ref_psd)
        self._head_ab_fast = _variance_step(period, att.k_heading_fast, heading_psd, heading_ref_psd)
        self._head_ab_open = _variance_step(period, 0.0, heading_psd, heading_ref_psd)
        self._head_floor = heading_var_floor
        #: Magnetometer calibration: offset (3, gauss) then matrix (9, row-major).
        self._mcal = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]

        # ----- pending samples
        self._pending = 0
        self._m = [0.0, 0.0, 0.0]
        self._t_m = 0
        self._p = 0.0
        self._t_p = 0
        self._fix = [0.0, 0.0]
        self._t_fix = 0

        # ----- time keeping
        self._wings = [0.0, 0.0, 0.0, 0.0]
        self._wings_changed = False
        self.hor.set_gain(self.descent.glide_gain(0.0))
        self._reset_times()

    def _reset_times(self):
        self._started = False
        self._t_imu = 0
        self._t_imu_seen = 0
        self._imu_lost = False
        self._t_lost = 0
        self._t_start = 0
        self._t_servo = 0
        self._servo_seen = False
        self._t_mag_used = 0
        self._t_mag_ok = 0
        self._t_depth_ok = 0
        self._t_fix_ok = 0
        self._mag_seen = False
        self._t_mag_job = 0
        self._mag_wait = False
        self._depth_seen = False
        self._fix_seen = False
        self._aligned = False
        self._steps = 0
        self.job = JOB_NONE
        self._tilt_var = 0.01
        self._head_var = 1.0
        self._wings_changed = True
        self._pending = 0

    # ------------------------------------------------------------ settings
    def zero_depth(self, pressure_pa, depth_m=0.0):
        """Take ``pressure_pa`` as the pressure of the port at ``depth_m``
        (m): sets the surface pressure (call at the surface before a dive)."""
        self._p0 = pressure_pa - depth_m * self._rho_g

    def set_mag_calibration(self, offset, matrix):
        """Hard-iron ``offset`` (3, gauss) and soft-iron ``matrix`` (9,
        row-major): calibrated = matrix (raw - offset)."""
        if len(offset) != 3 or len(matrix) != 9:
            raise ValueError("magnetometer calibration needs 3 offsets and 9 matrix terms")
        c = self._mcal
        for i in range(3):
            c[i] = float(offset[i])
        for i in range(9):
            c[3 + i] = float(matrix[i])

    def set_attitude(self, w, x, y, z):
        """Force the attitude (e.g. a test's wrong start); restarts alignment."""
        self.att.set_attitude(w, x, y, z)
        self.att.fast = True
        self._t_start = self._t_imu
        self._aligned = True
        self._outputs()

    def reset(self):
        """Forget everything but the configuration; the next samples restart it."""
        self.att.set_attitude(1.0, 0.0, 0.0, 0.0)
        self.att.set_bias(0.0, 0.0, 0.0)
        self.vert.initialised = False
        self.hor.initialised = False
        self._reset_times()

    def resume(self, bx, by, bz, startup_s, heading_samples=25):
        """A start under water after a reset (``firmware/resume.py``): the
        gyro bias (rad/s) learned at the surface before the dive (the fast
        gains learn it only while the vehicle is held still), and a fast
        alignment of ``startup_s`` that ends once the tilt has settled and
        ``heading_samples`` compass samples in a row agreed within a degree
        (not 100: the first one set the heading, ``align_heading``), so the
        estimate is valid again within about 2 s instead of 8."""
        self.att.set_bias(bx, by, bz)
        self._startup_us = int(startup_s * 1e6)
        self._settled_mag = heading_samples

    # ------------------------------------------------------- sensor inputs
    def wings(self, s1, s2, s3, s4):
        """Commanded wing angles, rad. A changed command flags the servos as
        moving (their current disturbs the magnetometer) and sets the
        descent model's gain at the next housekeeping."""
        w = self._wings
        if s1 == w[0] and s2 == w[1] and s3 == w[2] and s4 == w[3]:
            return
        w[0] = s1
        w[1] = s2
        w[2] = s3
        w[3] = s4
        self._wings_changed = True
        if self._started:  # before the first IMU sample there is no time yet
            self._t_servo = self._t_imu
            self._servo_seen = True

    def mag(self, t_us, mx, my, mz):
        """A raw magnetometer sample (gauss, body axes) measured at ``t_us``."""
        m = self._m
        m[0] = mx
        m[1] = my
        m[2] = mz
        self._t_m = t_us
        self._pending |= _PEND_MAG

    def depth(self, t_us, pressure_pa):
        """An absolute pressure (Pa) measured at ``t_us`` (mid-conversion)."""
        self._p = pressure_pa
        self._t_p = t_us
        self._pending |= _PEND_DEPTH

    def fix(self, t_us, north, east):
        """A position fix (m, NED) measured at ``t_us`` (not when it arrived)."""
        f = self._fix
        f[0] = north
        f[1] = east
        self._t_fix = t_us
        self._pending |= _PEND_FIX

    def imu(self, t_us, gx, gy, gz, ax, ay, az):
        """One IMU sample at ``t_us``: gyro (rad/s), specific force (m/s^2),
        body axes. Fuses one pending sample, predicts, writes the outputs."""
        if not self._started:
            self._start(t_us, ax, ay, az)
            return
        n = ((t_us - self._t_imu + _HALF) & _TMAX) - _HALF   # ticks_diff, without the call
        if n <= 0:
            return
        # one job at the state of the previous step, whose tick is _t_imu
        self._job(True)
        self._t_imu = t_us
        self._t_imu_seen = t_us
        att = self.att
        back = self._imu_lost
        if back and ((t_us - self._t_lost + _HALF) & _TMAX) - _HALF < _RELEVEL_US:
            # back within a second (a flash save's stall emptied the FIFO):
            # the attitude held meanwhile is still good, the gyro's
            # integration picks up where it stopped
            self._imu_lost = False
        if self._imu_lost:
            # the first sample after coasting without the IMU: the attitude
            # held meanwhile is stale (the vehicle turned, its failsafe
            # moved the wings), and the vertical prediction would integrate
            # gravity leaking through the stale tilt (issue 16: 10 deg off
            # after a 3 s outage made 0.9 m/s^2 of false acceleration, and the
            # depth gate refused good pressures). Level again from gravity.
            self._imu_lost = False
            att.relevel(ax, ay, az)
        if att.fast and ((t_us - self._t_start + _HALF) & _TMAX) - _HALF >= self._startup_us \
                and att.tilt_settled >= _SETTLED_STEPS \
                and (att.heading_settled >= self._settled_mag or not self._mag_seen):
            att.fast = False
        if n <= _MAX_GAP_US:
            dt = n * 1e-6
            att.predict(dt, gx, gy, gz, ax, ay, az)
            R = att.R
            # Vertical.predict, written out (a call costs as much as three
            # or four float operations on the board)
            vert = self.vert
            x = vert.x
            dw = (R[6] * ax + R[7] * ay + R[8] * az + _G - x[2]) * dt
            w = x[1] + dw
            # the mean speed over the step: after a stall the step is 50 ms,
            # and the old speed's distance would be off by dw dt / 2
            x[0] = x[0] + (w + x[1]) * 0.5 * dt
            x[1] = w
            # The speed change integrated here is trusted to a fraction of
            # itself (``DYNAMIC_ERROR``): folding wings, an impact, a fast
            # turn integrate with errors of their own size (the attitude
            # used to rotate the specific force, the sensor's scale, its
            # lever arm), where ``accel_psd`` only knows the sensor's
            # noise. In a steady descent dw is ~1e-3 m/s and this adds
            # nothing; through a wing fold the filter lets the pressures
            # steer it instead of refusing them.
            e = dw * _DYNAMIC_ERROR
            P = vert.P
            P[3] = P[3] + e * e
            if n > _GAP_US:
                # a long step (a stall's backlog): where in it the change
                # happened is unknown, and the distance with it
                e = e * dt
                P[0] = P[0] + e * e
            self.hor.predict(t_us, dt, R, w)
        self._outputs()
        if back:
            # IMU_OK back now, not at the next housekeeping (up to 100 ms);
            # the attitude was held valid over the silence
            self.status[0] |= _IMU_OK

    def check(self, t_us):
        """No IMU sample this step: re-evaluate the health flags against the
        caller's clock ``t_us`` (notices a silent IMU); returns the health
        bits. Once the IMU has been silent for its time-out, the estimator
        coasts to ``t_us`` (``_coast``): depth and fixes are still fused."""
        if self._started and ((t_us - self._t_imu_seen + _HALF) & _TMAX) - _HALF > self._to_imu:
            self._coast(t_us)
        self._health(t_us)
        return self.status[_h.STATUS_HEALTH]

    # ------------------------------------------------------------ internals
    def _start(self, t_us, ax, ay, az):
        self.att.level_from_accel(ax, ay, az)
        self.att.fast = True
        self._t_imu = t_us
        self._t_imu_seen = t_us
        self._t_start = t_us
        self._started = True
        self._health(t_us)
        self._outputs()

    def _job(self, mag):
        """At most one pending job a step (``Estimator.job`` says which):
        a fix, a pressure, housekeeping, then (``mag``: not while coasting,
        it needs the attitude the IMU keeps) the magnetometer."""
        self._steps += 1
        p = self._pending
        if p & _PEND_FIX:
            self._pending = p & ~_PEND_FIX
            self.job = JOB_FIX
            self._fuse_fix()
        elif p & _PEND_DEPTH:
            self._pending = p & ~_PEND_DEPTH
            self.job = JOB_DEPTH
            self._fuse_depth()
        elif self._steps >= _HOUSEKEEPING_STEPS:
            self._steps = 0
            self.job = JOB_HOUSEKEEPING
            self._housekeeping()
        elif p and mag:
            if self._mag_wait and ((self._t_m - self._t_mag_job + _HALF) & _TMAX) < self._lim_mag_period:
                self.job = JOB_NONE    # one was fused less than a period ago: the newest waits
            else:
                self._pending = 0
                self.job = JOB_MAG
                self._fuse_mag()
        else:
            self.job = JOB_NONE

    def _coast(self, t_us):
        """The IMU is silent (or its samples were refused): move the state to
        ``t_us`` without it. The attitude holds; the vertical filter goes on
        at its speed, its covariance growing with the accelerations the
        vehicle could have had meanwhile (``Vertical.coast``), so the
        pressures that arrive pass its gate and steer it; the horizontal
        filter follows the descent model. One pending job first, as a step
        does (the magnetometer waits for the IMU: it needs the attitude)."""
        n = ((t_us - self._t_imu + _HALF) & _TMAX) - _HALF
        if n <= 0:
            return
        self._job(False)
        vert = self.vert
        vert.propagate(self._t_imu)
        vert.coast(t_us)
        self.att.accel_used = False
        if not self._imu_lost:
            self._t_lost = self._t_imu_seen
        self._imu_lost = True
        self._t_imu = t_us
        if n <= _MAX_GAP_US:
            self.hor.predict(t_us, n * 1e-6, self.att.R, vert.x[1])
        self._outputs()

    def _fuse_mag(self):
        t = self._t_m
        self._t_mag_job = t
        self._mag_wait = True
        # ticks_diff(t, _t_servo) < the servo hold, inline, as _health() compares
        if self._servo_seen and ((t - self._t_servo + _HALF) & _TMAX) < self._lim_servo:
            self._t_mag_ok = t
            self._mag_seen = True
            return
        m = self._m
        c = self._mcal
        x = m[0] - c[0]
        y = m[1] - c[1]
        z = m[2] - c[2]
        mx = c[3] * x + c[4] * y + c[5] * z
        my = c[6] * x + c[7] * y + c[8] * z
        mz = c[9] * x + c[10] * y + c[11] * z
        att = self.att
        if not self._aligned:
            att.align_heading(mx, my, mz)
            self._aligned = True
            self._t_mag_used = t
            self._t_mag_ok = t
            self._mag_seen = True
            return
        n = ((t - self._t_mag_used + _HALF) & _TMAX) - _HALF   # ticks_diff
        if n <= 0:
            return
        if n > 100000:
            n = 100000
        result = att.heading(mx, my, mz, n * 1e-6)
        self._t_mag_used = t
        if result == HEADING_USED:
            self._t_mag_ok = t
            self._mag_seen = True
        else:
            self.status[_h.STATUS_MAG_REJECTS] += 1
            if result == HEADING_REJECTED_INNOVATION:
                self.innovation[_h.INNOV_MAG] = att.heading_ratio

    def _fuse_depth(self):
        vert = self.vert
        R = self.att.R
        z = (self._p - self._p0) * self._inv_rho_g
        lever = R[6] * self._rx + R[7] * self._ry + R[8] * self._rz
        t = self._t_p
        if not vert.initialised:
            vert.reset(z - lever, self._t_imu)
            self._t_depth_ok = t
            self._depth_seen = True
            return
        n = ticks_diff(self._t_imu, t)
        if n > _DEPTH_LAG_MAX_US:
            # taken before a stall ended: its back-projection by the
            # present speed would cross whatever the stall hid (a bottom
            # met, a bounce); the next pressure is 20 ms away
            return
        vert.propagate(self._t_imu)
        used = vert.update(z, lever, n * 1e-6)
        self.innovation[_h.INNOV_DEPTH] = vert.ratio
        if used:
            self.depth_used += 1
            self._t_depth_ok = t
            self._depth_seen = True
        else:
            self.status[_h.STATUS_DEPTH_REJECTS] += 1
            if not vert.coasted:
                # refused against a prediction the IMU drove: the sensor's
                # word against the accelerometer's (see ``depth_blamed``)
                self.depth_blamed += 1

    def _fuse_fix(self):
        hor = self.hor
        f = self._fix
        t = self._t_fix
        result = hor.update(self._t_imu, t, f[0], f[1])
        self.innovation[_h.INNOV_FIX] = hor.ratio
        if result == FIX_REJECTED or result == FIX_TOO_OLD:
            self.status[_h.STATUS_FIX_REJECTS] += 1
        else:
            self._t_fix_ok = t
            self._fix_seen = True

    def _housekeeping(self):
        """10 Hz: covariances to now, attitude variance model, quaternion
        normalisation, descent gain, covariance outputs, health flags."""
        t = self._t_imu
        vert = self.vert
        hor = self.hor
        att = self.att
        att.normalize()
        if ticks_diff(t, vert.t_cov) > _STALE_US:  # else a depth update just did it
            vert.propagate(t)
        hor.propagate(t)
        if self._wings_changed:
            self._wings_changed = False
            w = self._wings
            d = self.descent
            g = self._glide
            d.glide_vector(w[0], w[1], w[2], w[3], g)
            hor.set_gain(d.glide_gain((w[0] + w[1] + w[2] + w[3]) * _QUARTER_DEG_PER_RAD), g[0], g[1])
        # first-order model of the Mahony loops' errors over one period:
        # var <- a var + b, from d var/dt = q + k^2 r - 2 k var
        if att.accel_used:
            ab = self._tilt_ab_fast if att.fast else self._tilt_ab
        else:
            ab = self._tilt_ab_open
        tv = self._tilt_var * ab[0] + ab[1]
        self._tilt_var = tv
        if self._mag_seen and ticks_diff(t, self._t_mag_used) < self._to_mag:
            ab = self._head_ab_fast if att.fast else self._head_ab
        else:
            ab = self._head_ab_open
        hv = self._head_var * ab[0] + ab[1]
        if hv < self._head_floor:
            hv = self._head_floor
        self._head_var = hv
        c = self.cov
        c[_h.COV_TILT] = tv
        c[_h.COV_HEADING] = hv
        P = vert.P
        c[_h.COV_DEPTH] = P[0]
        c[_h.COV_VZ] = P[3]
        c[_h.COV_ACCEL_BIAS] = P[5]
        P = hor.P
        c[_h.COV_NORTH] = P[0]
        c[_h.COV_EAST] = P[0]
        # the velocity's: the bias (current) and the descent model's gain
        # error on the speed it predicts now (``horizontal.MODEL_ERROR``)
        x = hor.x
        v2 = (x[4] * x[4] + x[5] * x[5]) * hor.model_var
        c[_h.COV_VN] = P[2] + v2
        c[_h.COV_VE] = P[2] + v2
        self._health(t)

    def _health(self, t_us):
        h = 0
        t = t_us + _HALF
        if self._started and ((t - self._t_imu_seen) & _TMAX) < self._lim_imu:
            h = _IMU_OK
        if self._mag_seen and ((t - self._t_mag_ok) & _TMAX) < self._lim_mag:
            h |= _MAG_OK
        if self._depth_seen and ((t - self._t_depth_ok) & _TMAX) < self._lim_depth:
            h |= _DEPTH_OK
        if self._fix_seen and ((t - self._t_fix_ok) & _TMAX) < self._lim_fix:
            h |= _FIX_OK
        att = self.att
        if att.accel_used:
            h |= _ACCEL_USED
        if att.fast:
            h |= _FAST_ALIGN
        if self._servo_seen and ((t - self._t_servo) & _TMAX) < self._lim_servo:
            h |= _SERVOS_MOVING
        valid = 0
        if self._started and ((t - self._t_imu_seen) & _TMAX) < self._lim_att and not att.fast \
                and self._tilt_var < self._tilt_var_max:
            h |= _ATTITUDE_VALID
            valid = 1
        vert = self.vert
        if vert.initialised and vert.P[0] < self._depth_var_max:
            h |= _DEPTH_VALID
        else:
            valid = 0
        hor = self.hor
        if hor.initialised and hor.P[0] < self._pos_var_max:
            h |= _POSITION_VALID
        else:
            valid = 0
        s = self.status
        s[0] = h
        s[1] = valid

    def _outputs(self):
        att = self.att
        q = att.q
        o = self.q
        o[0] = q[0]
        o[1] = q[1]
        o[2] = q[2]
        o[3] = q[3]
        r = att.rate
        o = self.rates
        o[0] = r[0]
        o[1] = r[1]
        o[2] = r[2]
        R = att.R
        e = self.euler
        e[0] = math.atan2(R[7], R[8])
        s = R[6]
        if s > 1.0:
            s = 1.0
        elif s < -1.0:
            s = -1.0
        e[1] = -math.asin(s)
        e[2] = math.atan2(R[3], R[0])
        # centre of buoyancy = IMU - R r_imu; its rate, - R (omega x r_imu)
        x = self.vert.x
        o = self.nav
        ix = self._ix
        iy = self._iy
        iz = self._iz
        o[0] = x[0] - (R[6] * ix + R[7] * iy + R[8] * iz)
        cx = r[1] * iz - r[2] * iy
        cy = r[2] * ix - r[0] * iz
        cz = r[0] * iy - r[1] * ix
        o[1] = x[1] - (R[6] * cx + R[7] * cy + R[8] * cz)
        x = self.hor.x
        o[2] = x[0]
        o[3] = x[1]
        v = self.hor.v
        o[4] = v[0]
        o[5] = v[1]
