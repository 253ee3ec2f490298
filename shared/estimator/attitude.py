"""Attitude: a Mahony complementary filter with gyro-bias estimation and a
tilt-compensated magnetometer heading.

Equations (Mahony, Hamel, Pflimlin, "Nonlinear complementary filters on the
special orthogonal group", IEEE TAC 2008, eqs. 32-33, the "passive" filter)::

    omega = omega_gyro - b + kp e            corrected body rate
    b_dot = -ki e                            gyro bias (integral action)
    q_dot = 1/2 q (x) (0, omega)             body -> NED quaternion

with ``e = (v x f) / g``: ``v`` the estimated direction of gravity in the body
frame (third row of ``R``) and ``f`` the measured specific force, which reads
``-g v`` when the vehicle does not accelerate. Feathering (and the IMU's
lever arm) turns the apparent gravity by a few tenths of a degree at
0.2-1 Hz: the flight gain kp = 0.5 rad/s (a 0.08 Hz corner) passes kp/omega
of it, which keeps the tilt error near 0.4 deg on the standard scenario,
while a lower gain lets the gyro's rate-dependent errors (its 1 % cross-axis
coupling of the spin) build up: the gains were swept on that scenario. The
accelerometer is ignored when ``|f|`` leaves ``accel_band`` around ``g``
(a knock, a wing slap): feathering only changes ``|f|`` by ~0.1 %.

The magnetometer corrects heading only: the measured field is rotated into
NED with the current estimate, its azimuth compared with the local
declination, and the estimate turned about NED down by a fraction of the
error, so a magnetic disturbance can never tilt the attitude.

Two gain sets: ``fast`` (after start-up or a reset: converges from 90 deg and
learns a 1 deg/s bias within seconds while the vehicle is held still) and
flight (rejects feathering). The estimator switches between them. While
fast, the bias integrals only run once the tilt error is under 2 deg and
the heading error under 3 deg (no wind-up during a large alignment), and
``tilt_settled`` / ``heading_settled`` count the consecutive samples with
the tilt error under 1 deg and the averaged heading error under 1 deg,
which the estimator waits for before it trusts the attitude.

Why Mahony and not a multiplicative EKF: ``roboray-sim bench estimator
--compare-attitude`` flies both in the same estimator on the standard
scenario (10 seeds). Attitude error 0.795 deg RMS here, 0.797 deg with the
6-state MEKF (``mekf.py``, tuned on the same runs); but the MEKF's worst
step boxes 941 floats on MicroPython (6.8 ms on an RP2350 at 7.2 us a
float) against 215 with this filter (1.5 ms): its 6x6 covariance costs more
than the whole step budget. The price paid here is that the attitude
variances the estimator reports come from a first-order model of this
filter's loops, not from a propagated covariance.

Allocation: state lives in lists made once; reading a list element does not
box a float (reading an ``array('f')`` element does), so a step boxes only
its arithmetic results.
"""

import math

from roboray.shared import quat

_G = 9.80665
_PI = 3.141592653589793
_TWO_PI = 6.283185307179586

#: ``heading()`` results.
HEADING_USED = 0
HEADING_REJECTED_FIELD = 1      # horizontal field strength implausible
HEADING_REJECTED_INNOVATION = 2  # heading error beyond the gate


class Attitude:
    """Mahony filter state and its two steps, ``predict`` and ``heading``.

    Parameters
    ----------
    kp, ki:
        Flight gains: accelerometer proportional gain (rad/s per rad of
        tilt error) and bias integral gain (1/s^2).
    kp_fast, ki_fast:
        Start-up gains.
    k_heading, k_heading_fast:
        Heading correction rate (rad/s per rad of heading error), flight and
        start-up; applied with the magnetometer's sample interval.
    ki_heading, ki_heading_fast:
        Bias integral gain of the heading loop (1/s^2): the only way the
        bias about the vertical is learned.
    accel_band:
        Relative band around ``g`` in which ``|f|`` must lie for the
        accelerometer to be used (0.06: 9.22-10.40 m/s^2).
    declination:
        Angle from the NED north axis to magnetic north, rad (east positive).
    field_h:
        Expected horizontal strength of the Earth's field, gauss; a sample
        outside 0.6-1.5 times it is rejected.
    heading_gate:
        Largest heading error (rad) accepted in flight; after
        ``reacquire`` consecutive rejections the next sample is used anyway.
    max_bias:
        Clamp of each bias component, rad/s.
    pairs:
        Correct from the accelerometer once per two samples (their mean,
        50 Hz at the firmware's 100 Hz), the gyro still integrated at every
        sample. The correction loops are 0.08 Hz (flight) and 0.3 Hz
        (alignment) filters and feathering is 0.2-1 Hz, so 50 Hz loses
        nothing they pass, and the pair's mean filters what lies above
        25 Hz instead of folding it down; it saves ~28 boxed floats every
        other step. ``False``: every sample, as before.
    """

    def __init__(self, kp=0.5, ki=0.03, kp_fast=2.0, ki_fast=1.0,
                 k_heading=0.3, k_heading_fast=2.0, ki_heading=0.005,
                 ki_heading_fast=0.5, accel_band=0.06,
                 declination=0.0, field_h=0.2, heading_gate=0.35,
                 reacquire=40, max_bias=0.1, pairs=True):
        if kp <= 0.0 or kp_fast <= 0.0 or ki < 0.0 or ki_fast < 0.0:
            raise ValueError("attitude gains must be positive")
        if not 0.0 < accel_band < 1.0:
            raise ValueError("accel_band %r must be in (0, 1)" % accel_band)
        if field_h <= 0.0:
            raise ValueError("field_h %r must be > 0 gauss" % field_h)
        self.q = [1.0, 0.0, 0.0, 0.0]
        #: Body -> NED rotation matrix of ``q``, row-major, refreshed each predict.
        self.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        #: Gyro bias estimate, rad/s.
        self.bias = [0.0, 0.0, 0.0]
        #: Bias-corrected body rate of the last step, rad/s.
        self.rate = [0.0, 0.0, 0.0]
        #: Correction rate from the last accelerometer sample, rad/s.
        self.e = [0.0, 0.0, 0.0]
        self.fast = True
        #: True when the last predict used the accelerometer.
        self.accel_used = False
        #: Last heading error seen by the magnetometer (rad) and its test ratio.
        self.heading_error = 0.0
        self.heading_ratio = 0.0
        self.rejects = 0
        self.tilt_settled = 0
        self.heading_settled = 0
        self._hf = 0.0
        #: Accelerometer samples per correction (1 or 2, ``pairs``).
        self._pairs = pairs
        self._per = 2 if pairs else 1
        self._odd = False
        self._a = [0.0, 0.0, 0.0]
        self._dt0 = 0.0
        self._ka = kp / _G / self._per
        self._ka_fast = kp_fast / _G / self._per
        self._kb = ki / kp
        self._kb_fast = ki_fast / kp_fast
        self.k_heading = k_heading
        self.k_heading_fast = k_heading_fast
        self._kih = ki_heading
        self._kih_fast = ki_heading_fast
        self.kp = kp
        self.kp_fast = kp_fast
        lo = _G * (1.0 - accel_band)
        hi = _G * (1.0 + accel_band)
        self._f2_lo = lo * lo * (self._per * self._per)
        self._f2_hi = hi * hi * (self._per * self._per)
        # |e| = kp sin(tilt error) while fast: wind-up and settling thresholds
        self._e2_windup = (kp_fast * 0.0348995) * (kp_fast * 0.0348995)    # 2 deg
        self._e2_settle = (kp_fast * 0.0174524) * (kp_fast * 0.0174524)    # 1 deg
        self._decl = declination
        self._h2_lo = (0.6 * field_h) * (0.6 * field_h)
        self._h2_hi = (1.5 * field_h) * (1.5 * field_h)
        self._gate = heading_gate
        self._inv_gate = 1.0 / heading_gate
        self._reacquire = reacquire
        self._max_bias = max_bias
        self._min_bias = -max_bias

    # ---------------------------------------------------------------- set-up
    def set_attitude(self, w, x, y, z):
        """Set the quaternion (normalised here) and refresh ``R``."""
        self.tilt_settled = 0
        self.heading_settled = 0
        self._hf = 0.0
        q = self.q
        q[0] = w
        q[1] = x
        q[2] = y
        q[3] = z
        quat.normalize(q)
        self._rotation()

    def level_from_accel(self, ax, ay, az):
        """Roll and pitch from one specific-force sample, yaw zero."""
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if n < 1e-3:
            raise ValueError("accelerometer reads zero: cannot level")
        s = ax / n
        if s > 1.0:
            s = 1.0
        elif s < -1.0:
            s = -1.0
        quat.from_euler(self.q, math.atan2(-ay, -az), math.asin(s), 0.0)
        self._rotation()

    def relevel(self, ax, ay, az):
        """Roll and pitch from one specific-force sample, the heading kept:
        after the IMU was lost, the attitude held meanwhile is whatever the
        vehicle did since, the direction of gravity is not."""
        R = self.R
        yaw = math.atan2(R[3], R[0])
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if n < 1e-3:
            return
        s = ax / n
        if s > 1.0:
            s = 1.0
        elif s < -1.0:
            s = -1.0
        quat.from_euler(self.q, math.atan2(-ay, -az), math.asin(s), yaw)
        self._rotation()
        e = self.e
        e[0] = 0.0
        e[1] = 0.0
        e[2] = 0.0

    def set_bias(self, bx, by, bz):
        b = self.bias
        b[0] = bx
        b[1] = by
        b[2] = bz

    # ----------------------------------------------------------------- steps
    def predict(self, dt, gx, gy, gz, ax, ay, az):
        """Integrate one gyro sample (rad/s) over ``dt`` s with the correction
        of the previous accelerometer sample, then form the correction of
        this one (m/s^2, body frame)."""
        b = self.bias
        e = self.e
        cx = gx - b[0]
        cy = gy - b[1]
        cz = gz - b[2]
        r = self.rate
        r[0] = cx
        r[1] = cy
        r[2] = cz
        h = 0.5 * dt
        hx = (cx + e[0]) * h
        hy = (cy + e[1]) * h
        hz = (cz + e[2]) * h
        # q + 1/2 dt q (x) (0, omega): first order; |q|^2 grows by
        # (|omega| dt / 2)^2 a step (6e-5 at 1.5 rad/s and 100 Hz), and
        # normalize() runs at 10 Hz. Until then R from the unnormalised q is
        # (1 + eps) R - eps I: a direction error of eps sin(tilt), < 0.01 deg.
        q = self.q
        quat.turn(q, hx, hy, hz)
        R = self.R
        quat.to_matrix(R, q)
        if self._pairs:
            # the accelerometer by pairs of samples (see ``pairs``): the
            # first is kept, the correction e of the last pair holds
            a = self._a
            if not self._odd:
                a[0] = ax
                a[1] = ay
                a[2] = az
                self._dt0 = dt
                self._odd = True
                return
            self._odd = False
            ax = ax + a[0]      # twice the pair's mean: band and gain are scaled
            ay = ay + a[1]
            az = az + a[2]
            dt = dt + self._dt0
        f2 = ax * ax + ay * ay + az * az
        if self._f2_lo < f2 < self._f2_hi:
            if self.fast:
                ka = self._ka_fast
                kb = self._kb_fast * dt
            else:
                ka = self._ka
                kb = self._kb * dt
            vx = R[6]   # gravity's direction in the body frame, R's last row
            vy = R[7]
            vz = R[8]
            ex = (vy * az - vz * ay) * ka
            ey = (vz * ax - vx * az) * ka
            ez = (vx * ay - vy * ax) * ka
            e[0] = ex
            e[1] = ey
            e[2] = ez
            self.accel_used = True
            if self.fast:
                e2 = ex * ex + ey * ey + ez * ez
                if e2 < self._e2_settle:
                    if self.tilt_settled < 10000:
                        self.tilt_settled += self._per
                else:
                    self.tilt_settled = 0
                if e2 > self._e2_windup:
                    return
            # b_dot = -ki e: e above is kp e, hence ki / kp
            mb = self._max_bias
            nb = self._min_bias
            bx = b[0] - ex * kb
            by = b[1] - ey * kb
            bz = b[2] - ez * kb
            if nb < bx < mb:
                b[0] = bx
            if nb < by < mb:
                b[1] = by
            if nb < bz < mb:
                b[2] = bz
        else:
            e[0] = 0.0
            e[1] = 0.0
            e[2] = 0.0
            self.accel_used = False

    def heading(self, mx, my, mz, dt):
        """Turn the estimate about NED down towards a calibrated field sample
        (gauss, body frame) taken ``dt`` s after the previous one.
        Returns ``HEADING_USED`` or why it was rejected."""
        R = self.R
        mn = R[0] * mx + R[1] * my + R[2] * mz
        me = R[3] * mx + R[4] * my + R[5] * mz
        h2 = mn * mn + me * me
        if not self._h2_lo < h2 < self._h2_hi:
            self.rejects += 1
            return HEADING_REJECTED_FIELD
        err = math.atan2(me, mn) - self._decl
        if err > _PI:
            err -= _TWO_PI
        elif err < -_PI:
            err += _TWO_PI
        self.heading_error = err
        if self.fast:
            k = self.k_heading_fast
            ki = self._kih_fast
            # settled on the error's average (one sample is noisy: ~1 deg)
            hf = self._hf + 0.05 * (err - self._hf)
            self._hf = hf
            if -0.0174533 < hf < 0.0174533:    # 1 deg
                if self.heading_settled < 10000:
                    self.heading_settled += 1
            else:
                self.heading_settled = 0
            if err > 0.0523599 or err < -0.0523599 or self.tilt_settled == 0:
                ki = 0.0    # beyond 3 deg, or tilted wrong: no bias wind-up
        else:
            k = self.k_heading
            ki = self._kih
            gate = self._gate
            if (err > gate or err < -gate) and self.rejects < self._reacquire:
                self.heading_ratio = err * self._inv_gate
                self.rejects += 1
                return HEADING_REJECTED_INNOVATION
        self.rejects = 0
        # bias: the correction turns about NED down, whose body direction is
        # R's third row; b_dot = -ki e with e = -err (R^T e_z)
        c = ki * dt * err
        b = self.bias
        mb = self._max_bias
        nb = self._min_bias
        bx = b[0] + c * R[6]
        by = b[1] + c * R[7]
        bz = b[2] + c * R[8]
        if nb < bx < mb:
            b[0] = bx
        if nb < by < mb:
            b[1] = by
        if nb < bz < mb:
            b[2] = bz
        # q <- (1, 0, 0, -k dt err / 2) (x) q: a turn of -k dt err about NED down
        a = -0.5 * k * dt
        if a < -0.5:
            a = -0.5
        h = a * err
        q = self.q
        w = q[0]
        x = q[1]
        y = q[2]
        z = q[3]
        q[0] = w - h * z
        q[1] = x - h * y
        q[2] = y + h * x
        q[3] = z + h * w
        return HEADING_USED

    def align_heading(self, mx, my, mz):
        """Set the heading from one calibrated field sample at once (exact
        turn; start-up only)."""
        R = self.R
        mn = R[0] * mx + R[1] * my + R[2] * mz
        me = R[3] * mx + R[4] * my + R[5] * mz
        if mn * mn + me * me < 1e-12:
            return
        err = math.atan2(me, mn) - self._decl
        c = math.cos(0.5 * err)
        s = -math.sin(0.5 * err)
        q = self.q
        w = q[0]
        x = q[1]
        y = q[2]
        z = q[3]
        q[0] = c * w - s * z
        q[1] = c * x - s * y
        q[2] = c * y + s * x
        q[3] = c * z + s * w
        self._rotation()

    def normalize(self):
        """Scale q back to unit norm (one Newton step; |q| is within 1e-3 of 1)."""
        q = self.q
        w = q[0]
        x = q[1]
        y = q[2]
        z = q[3]
        k = 1.5 - 0.5 * (w * w + x * x + y * y + z * z)
        q[0] = w * k
        q[1] = x * k
        q[2] = y * k
        q[3] = z * k

    # --------------------------------------------------------------- helpers
    def _rotation(self):
        """R from q (assumed unit), row-major: 24 boxed floats."""
        quat.to_matrix(self.R, self.q)
