"""Attitude by a multiplicative extended Kalman filter: the alternative the
estimator does not fly, kept to measure it against the Mahony filter.

Six error states, ``x = [dtheta, db]`` (body-frame attitude error, gyro bias
error), covariance ``P`` (6x6, full storage). Markley & Crassidis,
"Fundamentals of Spacecraft Attitude Determination and Control" (2014),
sec. 6.2.4 (the MEKF), first-order propagation::

    P_aa <- P_aa + dt (-[w x] P_aa - P_aa [w x]^T - P_ab - P_ab^T) + q_g dt I
    P_ab <- P_ab + dt (-[w x] P_ab - P_bb)
    P_bb <- P_bb + q_b dt I

Accelerometer: three scalar updates of ``f = -g v`` (``v`` gravity's body
direction), ``H = -g [v x]`` on the attitude error; its noise is the
feathering's acceleration, not the sensor's. Magnetometer: one scalar update
of the heading error, ``H = [v, 0]`` (a turn about NED down seen in the body
frame). After each update the error is folded into ``q`` and the bias.

Same interface as ``attitude.Attitude`` (``Estimator(attitude=Mekf())``).
``roboray-sim bench estimator --compare-attitude`` runs both on the standard
scenario: 0.797 deg RMS here against 0.795 deg for the Mahony filter, for
941 boxed floats a step against 215 (6.8 ms on an RP2350, past the 2 ms
step budget on its own). The firmware flies the Mahony filter.
"""

import math

from roboray.shared import quat
from roboray.shared.estimator.attitude import Attitude

_G = 9.80665
_PI = 3.141592653589793
_TWO_PI = 6.283185307179586


class Mekf:
    """Multiplicative EKF attitude filter (see the module docstring).

    Parameters
    ----------
    gyro_psd, bias_psd:
        Gyro white noise ((rad/s)^2/Hz) and bias random walk ((rad/s)^2/s).
    accel_var:
        Variance of one specific-force component, (m/s^2)^2.
    heading_var:
        Variance of one heading sample, rad^2.
    """

    def __init__(self, gyro_psd=1e-6, bias_psd=1e-9, accel_var=0.02, heading_var=0.005,
                 accel_band=0.06, declination=0.0, field_h=0.2, heading_gate=0.35,
                 reacquire=40, max_bias=0.1, attitude_var0=0.1, bias_var0=3e-4):
        self.q = [1.0, 0.0, 0.0, 0.0]
        self.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        self.bias = [0.0, 0.0, 0.0]
        self.rate = [0.0, 0.0, 0.0]
        self.P = [0.0] * 36
        self._var0 = (attitude_var0, bias_var0)
        self._reset_covariance()
        self.fast = True
        self.accel_used = False
        self.heading_error = 0.0
        self.heading_ratio = 0.0
        self.rejects = 0
        self.tilt_settled = 0
        self.heading_settled = 0
        # for the estimator's variance model (Mahony-equivalent loop gains)
        self.kp = 0.5
        self.kp_fast = 2.0
        self.k_heading = 0.3
        self.k_heading_fast = 2.0
        self._qg = gyro_psd
        self._qb = bias_psd
        self._ra = accel_var
        self._rh = heading_var
        lo = _G * (1.0 - accel_band)
        hi = _G * (1.0 + accel_band)
        self._f2_lo = lo * lo
        self._f2_hi = hi * hi
        self._decl = declination
        self._h2_lo = (0.6 * field_h) * (0.6 * field_h)
        self._h2_hi = (1.5 * field_h) * (1.5 * field_h)
        self._gate = heading_gate
        self._reacquire = reacquire
        self._max_bias = max_bias
        self._dx = [0.0] * 6
        self._ph = [0.0] * 6
        self._M = [0.0] * 9
        self._N = [0.0] * 9

    def _reset_covariance(self):
        P = self.P
        for i in range(36):
            P[i] = 0.0
        for i in range(3):
            P[7 * i] = self._var0[0]
            P[7 * (i + 3)] = self._var0[1]

    # ---------------------------------------------------------------- set-up
    def set_attitude(self, w, x, y, z):
        q = self.q
        q[0] = w
        q[1] = x
        q[2] = y
        q[3] = z
        quat.normalize(q)
        self._reset_covariance()
        self.tilt_settled = 0
        self.heading_settled = 0
        self._rotation()

    def level_from_accel(self, ax, ay, az):
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if n < 1e-3:
            raise ValueError("accelerometer reads zero: cannot level")
        s = max(-1.0, min(1.0, ax / n))
        quat.from_euler(self.q, math.atan2(-ay, -az), math.asin(s), 0.0)
        self._rotation()

    def normalize(self):
        quat.normalize(self.q)

    # ----------------------------------------------------------------- steps
    def predict(self, dt, gx, gy, gz, ax, ay, az):
        b = self.bias
        wx = gx - b[0]
        wy = gy - b[1]
        wz = gz - b[2]
        r = self.rate
        r[0] = wx
        r[1] = wy
        r[2] = wz
        quat.integrate(self.q, wx, wy, wz, dt)
        self._rotation()
        self._propagate(dt, wx, wy, wz)
        f2 = ax * ax + ay * ay + az * az
        self.accel_used = self._f2_lo < f2 < self._f2_hi
        if not self.accel_used:
            return
        R = self.R
        vx = R[6]
        vy = R[7]
        vz = R[8]
        dx = self._dx
        for i in range(6):
            dx[i] = 0.0
        g = _G
        # rows of H = -g [v x] on dtheta; residual f + g v
        self._scalar(0.0, g * vz, -g * vy, ax + g * vx, self._ra)
        self._scalar(-g * vz, 0.0, g * vx, ay + g * vy, self._ra)
        self._scalar(g * vy, -g * vx, 0.0, az + g * vz, self._ra)
        if self.fast:
            # settled when the filter itself is sure: attitude variance under (1 deg)^2
            P = self.P
            if P[0] + P[7] + P[14] < 3e-4:
                if self.tilt_settled < 10000:
                    self.tilt_settled += 1
            else:
                self.tilt_settled = 0
        self._fold()

    def heading(self, mx, my, mz, dt):
        R = self.R
        mn = R[0] * mx + R[1] * my + R[2] * mz
        me = R[3] * mx + R[4] * my + R[5] * mz
        h2 = mn * mn + me * me
        if not self._h2_lo < h2 < self._h2_hi:
            self.rejects += 1
            return 1
        err = math.atan2(me, mn) - self._decl
        if err > _PI:
            err -= _TWO_PI
        elif err < -_PI:
            err += _TWO_PI
        self.heading_error = err
        if not self.fast and (err > self._gate or err < -self._gate) and self.rejects < self._reacquire:
            self.heading_ratio = err / self._gate
            self.rejects += 1
            return 2
        self.rejects = 0
        if self.fast:
            if self.tilt_settled:
                if self.heading_settled < 10000:
                    self.heading_settled += 1
            else:
                self.heading_settled = 0
        dx = self._dx
        for i in range(6):
            dx[i] = 0.0
        # a heading error err is a turn of err about NED down: dtheta = err v,
        # so the measurement is err = v . dtheta, residual -err
        self._scalar(R[6], R[7], R[8], -err, self._rh)
        self._fold()
        return 0

    # the same exact turn as the Mahony filter's (both keep q, R and _decl)
    align_heading = Attitude.align_heading
    set_bias = Attitude.set_bias

    # --------------------------------------------------------------- helpers
    def _propagate(self, dt, wx, wy, wz):
        """First-order P <- Phi P Phi^T + Q (Markley & Crassidis eq. 6.60)."""
        P = self.P
        M = self._M
        N = self._N
        # M = [w x] P_aa, N = [w x] P_ab; [w x] rows: (0, -wz, wy), (wz, 0, -wx), (-wy, wx, 0)
        for j in range(3):
            a0 = P[j]
            a1 = P[6 + j]
            a2 = P[12 + j]
            M[j] = wy * a2 - wz * a1
            M[3 + j] = wz * a0 - wx * a2
            M[6 + j] = wx * a1 - wy * a0
            c0 = P[3 + j]
            c1 = P[9 + j]
            c2 = P[15 + j]
            N[j] = wy * c2 - wz * c1
            N[3 + j] = wz * c0 - wx * c2
            N[6 + j] = wx * c1 - wy * c0
        qg = self._qg * dt
        for i in range(3):
            for j in range(i, 3):
                v = P[6 * i + j] - dt * (M[3 * i + j] + M[3 * j + i] + P[6 * i + 3 + j] + P[6 * j + 3 + i])
                if i == j:
                    v += qg
                P[6 * i + j] = v
                P[6 * j + i] = v
        for i in range(3):
            for j in range(3):
                v = P[6 * i + 3 + j] - dt * (N[3 * i + j] + P[6 * (3 + i) + 3 + j])
                P[6 * i + 3 + j] = v
                P[6 * (3 + j) + i] = v
        qb = self._qb * dt
        for i in range(3):
            P[7 * (i + 3)] += qb

    def _scalar(self, h0, h1, h2, y, r):
        """Kalman update with H = [h0 h1 h2 0 0 0] (both measurements see the
        attitude error only), residual ``y``, noise variance ``r``."""
        P = self.P
        ph = self._ph
        for i in range(6):
            ph[i] = P[6 * i] * h0 + P[6 * i + 1] * h1 + P[6 * i + 2] * h2
        s = h0 * ph[0] + h1 * ph[1] + h2 * ph[2] + r
        dx = self._dx
        # residual of the state already corrected by the earlier scalars
        y = y - (h0 * dx[0] + h1 * dx[1] + h2 * dx[2])
        inv = 1.0 / s
        for i in range(6):
            dx[i] += ph[i] * inv * y
        for i in range(6):
            ki = ph[i] * inv
            for j in range(i, 6):
                v = P[6 * i + j] - ki * ph[j]
                P[6 * i + j] = v
                P[6 * j + i] = v

    def _fold(self):
        """q <- q (x) (1, dtheta / 2), bias += db."""
        dx = self._dx
        q = self.q
        hx = 0.5 * dx[0]
        hy = 0.5 * dx[1]
        hz = 0.5 * dx[2]
        quat.turn(q, hx, hy, hz)
        quat.normalize(q)
        b = self.bias
        mb = self._max_bias
        for i in range(3):
            v = b[i] + dx[3 + i]
            if -mb < v < mb:
                b[i] = v
        self._rotation()

    def _rotation(self):
        quat.to_matrix(self.R, self.q)
