"""Depth and vertical speed: a three-state Kalman filter fusing pressure
depth with the vertical specific force.

State ``x = [d, w, b]``: depth of the IMU (m, down positive), its rate
(m/s) and the bias of the measured vertical acceleration (m/s^2). The IMU's
point is the one whose acceleration is measured: tracking the centre of
buoyancy instead would feed it the IMU's lever-arm accelerations (1 cm off
the axis at 0.5 Hz feathering: 6 mm/s of vertical-speed error); the
estimator converts to the centre of buoyancy on output. Process model,
driven by the measured downward acceleration ``a = (R f)_z + g`` (the IMU's
vertical specific force plus gravity)::

    d_dot = w,   w_dot = a - b + n_a,   b_dot = n_b

``n_a``: white acceleration noise of density ``accel_psd`` ((m/s^2)^2/Hz,
sensor noise plus what the IMU's lever arm and tilt errors leak in);
``n_b``: bias random walk of density ``bias_psd`` ((m/s^2)^2/s).
Measurement: the pressure port's depth ``z = d + lever - w lag``, where
``lever`` is the port's depth below the IMU in the current attitude and
``lag`` how old the sample is (the MS5837 integrates over its conversion
window).

The state is predicted every IMU step; the covariance only when something
reads it (an update, or the estimator's 10 Hz housekeeping), over the whole
interval ``T`` at once: this model's transition matrix composes exactly
(``F(T1) F(T2) = F(T1 + T2)``), so nothing is lost but rounding.
"""

from roboray.shared.estimator.ticks import ticks_diff


class Vertical:
    """Depth / vertical-speed / accelerometer-bias filter.

    Parameters
    ----------
    meas_var:
        Variance of one depth measurement, m^2.
    accel_psd, bias_psd:
        Process noise densities, see the module docstring.
    gate:
        Innovation gate in standard deviations.
    reacquire:
        After this many consecutive rejections the filter restarts on the
        next measurement (the estimate, not the sensor, is then wrong).
    """

    def __init__(self, meas_var=5e-6, accel_psd=1e-4, bias_psd=1e-6,
                 gate=5.0, reacquire=12, depth_var0=1.0, speed_var0=0.04,
                 bias_var0=0.04, coast_psd=0.5):
        if meas_var <= 0.0 or accel_psd <= 0.0 or bias_psd < 0.0 or gate <= 0.0:
            raise ValueError("vertical filter noise and gate must be positive")
        #: [depth m, vertical speed m/s, accel bias m/s^2]
        self.x = [0.0, 0.0, 0.0]
        #: Upper triangle of P: p00 p01 p02 p11 p12 p22.
        self.P = [depth_var0, 0.0, 0.0, speed_var0, 0.0, bias_var0]
        self.initialised = False
        self.rejects = 0
        #: Last innovation's test ratio: y^2 / (gate^2 S); above 1 is rejected.
        self.ratio = 0.0
        self._r = meas_var
        self._qa = accel_psd
        self._qb = bias_psd
        self._g2 = gate * gate
        self._reacquire = reacquire
        self._var0 = (depth_var0, speed_var0, bias_var0)
        self._qc = coast_psd
        self.t_cov = 0
        #: The state coasted without the IMU since the last depth it took.
        self.coasted = False

    def reset(self, depth, t_us):
        """Restart at ``depth`` (m), at rest, bias kept, covariance reset."""
        x = self.x
        x[0] = depth
        x[1] = 0.0
        P = self.P
        P[0] = self._r
        P[1] = 0.0
        P[2] = 0.0
        P[3] = self._var0[1]
        P[4] = 0.0
        if P[5] < self._var0[2]:
            P[5] = self._var0[2]
        self.t_cov = t_us
        self.initialised = True
        self.rejects = 0
        self.coasted = False

    def coast(self, t_us):
        """No IMU from the covariance's tick to ``t_us``: the state goes on
        at its speed, and the covariance grows as under an acceleration
        noise of ``coast_psd`` ((m/s^2)^2/Hz; 0.5: about 1 m/s^2 the
        vehicle could have had, changing over ~0.5 s: the bottom's impact
        stops a 0.3 m/s descent in ~0.2 s), where ``accel_psd`` is the
        measured acceleration's error. The gate then takes the pressures
        that tell where the vehicle went."""
        n = ticks_diff(t_us, self.t_cov)
        if n <= 0:
            return
        x = self.x
        x[0] = x[0] + x[1] * (n * 1e-6)
        qa = self._qa
        self._qa = self._qc
        self.propagate(t_us)
        self._qa = qa
        self.coasted = True

    def predict(self, dt, a_down):
        """Advance the state by ``dt`` s with the downward acceleration (m/s^2)."""
        x = self.x
        w = x[1]
        x[0] = x[0] + w * dt
        x[1] = w + (a_down - x[2]) * dt

    def propagate(self, t_us):
        """Bring the covariance to tick ``t_us``: P = F P F' + Q over the interval."""
        n = ticks_diff(t_us, self.t_cov)
        if n <= 0:
            return
        self.t_cov = t_us
        T = n * 1e-6
        P = self.P
        p00 = P[0]
        p01 = P[1]
        p02 = P[2]
        p11 = P[3]
        p12 = P[4]
        p22 = P[5]
        h = 0.5 * T * T
        # F = [[1, T, -T^2/2], [0, 1, -T], [0, 0, 1]]
        n12 = p12 - T * p22
        n02 = p02 + T * p12 - h * p22
        u = p01 + T * p11 - h * p12
        qa = self._qa * T
        P[0] = p00 + T * p01 - h * p02 + T * u - h * n02 + qa * h * 0.6666667
        P[1] = u - T * n02 + qa * T * 0.5
        P[2] = n02
        P[3] = p11 - T * (p12 + n12) + qa
        P[4] = n12
        P[5] = p22 + self._qb * T

    def update(self, z, lever, lag):
        """Fuse a port depth ``z`` (m) taken ``lag`` s before the last
        predict; ``lever``: port depth minus IMU depth (m). Returns 1 if
        used, 0 if rejected by the gate."""
        x = self.x
        P = self.P
        p00 = P[0]
        p01 = P[1]
        p02 = P[2]
        y = z - (x[0] + lever - x[1] * lag)
        s = p00 + self._r
        y2 = y * y
        g2s = self._g2 * s
        self.ratio = y2 / g2s
        if y2 > g2s:
            self.rejects += 1
            if self.rejects >= self._reacquire:
                x[0] = z - lever
                x[1] = 0.0
                P[0] = self._r
                P[1] = 0.0
                P[2] = 0.0
                P[3] = self._var0[1]
                self.rejects = 0
            return 0
        self.rejects = 0
        self.coasted = False
        inv = 1.0 / s
        k0 = p00 * inv
        k1 = p01 * inv
        k2 = p02 * inv
        x[0] = x[0] + k0 * y
        x[1] = x[1] + k1 * y
        x[2] = x[2] + k2 * y
        # P - K H P with H = [1, 0, 0]
        P[0] = p00 - k0 * p00
        P[1] = p01 - k0 * p01
        P[2] = p02 - k0 * p02
        P[3] = P[3] - k1 * p01
        P[4] = P[4] - k1 * p02
        P[5] = P[5] - k2 * p02
        return 1
