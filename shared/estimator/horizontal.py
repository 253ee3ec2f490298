"""Horizontal position and velocity: dead reckoning with the descent model,
corrected by delayed position fixes.

Between fixes the position integrates ``v = v_model + c``: ``v_model`` from
the descent model (``descent_model``), ``c`` a slowly varying velocity bias
(water current plus model error), per axis. The filter per axis has state
``[p, c]``::

    p_dot = v_model + c + n_p,     c_dot = n_c

The two axes see the same noise and the same fixes, so they share one 2x2
covariance ``[Ppp, Ppc, Pcc]``.

The descent model's own error is mostly a gain error: a vehicle whose added
mass, drag or ``ell`` differ from the model's glides proportionally faster
or slower, and a little off in direction, for the whole dive. Its position
error is then that fraction of the distance dead-reckoned since the last
fix, ``D``, so ``Ppp`` also grows by ``MODEL_ERROR^2 * |D|^2`` (per axis,
added as ``|D|`` reaches new highs, never taken back): with fixes every
second this is nothing (0.1 m between fixes: 4e-5 m^2, a tenth of a fix's
variance), without them it is the uncertainty that matters (a dive in the
sea, where the radio reaches ~0.1 m and no fix arrives after release). A
fix restarts ``D``.

A fix is measured at ``t_m`` and arrives later (the tracker's latency,
0.2 s by default). A ring of the last ``history`` predicted positions (one
per IMU step) gives the estimate at ``t_m``; the innovation there corrects
``[p, c]`` at ``t_m``, and the correction is carried to now through the
model (``dp_now = dp_m + dc * (now - t_m)``). The ring stores positions
minus the sum of corrections applied so far, so older entries need no
rewriting when a correction lands.
"""

from array import array

from roboray.shared.estimator.ticks import ticks_diff

#: Relative error (1 sigma, per axis) of the descent model's horizontal
#: velocity over a dive. From the Monte Carlo's model errors (added mass,
#: C_D, ell, servo lag each +-10 %) with no fix after the release:
#: ``roboray-sim montecarlo --runs 30 --water sea --distance 1|2|4
#: --results F.csv`` (10 m bottom) gave an estimate error at landing of
#: 0.144, 0.162 and 0.288 m RMS (2-D) over 1.04, 2.00 and 3.12 m reckoned.
#: Fitted as err^2 = a^2 + (e D)^2, the part that grows with the distance
#: is per axis 0.031 D from the 1 and 2 m targets, 0.061 D by least squares
#: over all three (the 4 m target is near the glide's reach): 0.046 D
#: between. The part that does not grow with the distance (0.08-0.14 m)
#: grows with time, which the bias's random walk (``bias_psd``) already
#: covers, more than fully (its 23 s of dive alone give 0.14 m per axis).
MODEL_ERROR = 0.046

#: ``update()`` results.
FIX_USED = 0
FIX_REJECTED = 1       # innovation beyond the gate
FIX_TOO_OLD = 2        # measured before the oldest history entry
FIX_RESET = 3          # first fix, or gate failed ``reacquire`` times: restarted on it


class Horizontal:
    """Dead-reckoning position filter with a delayed-fix history ring.

    Parameters
    ----------
    fix_var:
        Variance of one fix per axis, m^2.
    pos_psd:
        White velocity noise driving the position, (m/s)^2/Hz: the part of
        the model error that averages out (feathering oscillations).
    bias_psd:
        Random walk of the velocity bias ``c``, (m/s)^2/s.
    gate:
        Innovation gate (2-D, standard deviations).
    history:
        Ring length in IMU steps; must cover the fix latency.
    tau:
        Lag of the descent model, s (``descent_model.TAU_S``).
    model_error:
        Relative error of the descent model's velocity (``MODEL_ERROR``).
    """

    def __init__(self, fix_var=4e-4, pos_psd=5e-5, bias_psd=5e-6, gate=4.0,
                 history=64, tau=0.4, reacquire=4, pos_var0=100.0,
                 bias_var0=0.0025, model_error=MODEL_ERROR):
        if fix_var <= 0.0 or pos_psd <= 0.0 or bias_psd < 0.0 or gate <= 0.0:
            raise ValueError("horizontal filter noise and gate must be positive")
        if model_error < 0.0:
            raise ValueError("model_error %r must be >= 0" % model_error)
        if history < 4:
            raise ValueError("history %r must be at least 4 steps" % history)
        #: [north m, east m, current north m/s, current east m/s,
        #:  model velocity north m/s, model velocity east m/s]
        self.x = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        #: Velocity estimate [north, east], m/s.
        self.v = [0.0, 0.0]
        # What the position's running sum lost in its last step (north,
        # east; Kahan's compensation, see predict)
        self._lost = [0.0, 0.0]
        #: Shared covariance [Ppp, Ppc, Pcc].
        self.P = [pos_var0, 0.0, bias_var0]
        self.initialised = False
        self.rejects = 0
        self.ratio = 0.0
        self.t_cov = 0
        self._r = fix_var
        self._qp = pos_psd
        self._qc = bias_psd
        self._g2 = gate * gate
        self._reacquire = reacquire
        self._inv_tau = 1.0 / tau if tau > 0.0 else 0.0
        self._lag = tau > 0.0
        self._mk = 0.0
        self._gx = 0.0
        self._gy = 0.0
        self._glide = False
        self._var0 = (pos_var0, bias_var0)
        self._n = history
        self._t = array("i", [0] * history)
        # the predicted track, as float32 arrays: a list of 64 boxed floats
        # is 64 heap objects the collector must push at once, which
        # overflowed its 64-entry mark stack on the board and cost every
        # collection a second walk of the whole heap
        self._pn = array("f", [0.0] * history)
        self._pe = array("f", [0.0] * history)
        self._head = 0
        self._count = 0
        #: Sum of the corrections applied so far (north, east), m.
        self._s = [0.0, 0.0]
        #: model_error^2: per axis, the model's gain error makes a velocity's
        #: variance model_var * |v_model|^2 and a distance's model_var * |D|^2.
        self.model_var = model_error * model_error
        #: The position at the last fix (north, east), m, and the largest
        #: squared distance dead-reckoned from it so far, m^2.
        self.reckoned = array("f", [0.0, 0.0, 0.0])

    def set_gain(self, glide_gain, glide_x=0.0, glide_y=0.0):
        """Descent model for the current wings: tilt gain K and the body-frame
        glide (x, y) per unit descent speed from differential folding."""
        self._mk = -glide_gain
        self._gx = glide_x
        self._gy = glide_y
        self._glide = glide_x != 0.0 or glide_y != 0.0

    def predict(self, t_us, dt, R, w):
        """Advance by ``dt`` s with the body -> NED rotation ``R`` (9, row
        major) and the descent speed ``w`` (m/s), and log the position at
        ``t_us``."""
        x = self.x
        r22 = R[8]
        if r22 < 0.17:  # past 80 deg of tilt the glide model means nothing
            r22 = 0.17
        g = w * self._mk / r22
        # The floats a step boxes are its cost on the board: the terms of a
        # differential fold and of the lag only when there are any.
        if self._glide:
            gx = w * self._gx
            gy = w * self._gy
            mn = g * R[2] + gx * R[0] + gy * R[1]
            me = g * R[5] + gx * R[3] + gy * R[4]
        else:
            mn = g * R[2]
            me = g * R[5]
        if self._lag:
            a = dt * self._inv_tau
            if 0.0 < a < 1.0:
                n0 = x[4]
                e0 = x[5]
                mn = n0 + (mn - n0) * a
                me = e0 + (me - e0) * a
        x[4] = mn
        x[5] = me
        v = self.v
        vn = mn + x[2]
        ve = me + x[3]
        v[0] = vn
        v[1] = ve
        # The position is a running sum of 100 steps a second, each a few
        # mm, and RoboRay's MicroPython keeps 21 mantissa bits and truncates:
        # 35 s at 0.3 m/s from 100 m lost 32 mm, from 10 m 3 mm (counted on
        # roboray-unix). Compensated (Kahan, "Further remarks on reducing
        # truncation errors", CACM 8(1), 1965: what a step lost is carried
        # into the next) the sum is off by 1e-6 m. A fix that moves x
        # leaves at most a last bit of the old step in ``_lost``.
        lost = self._lost
        y = vn * dt - lost[0]
        n = x[0] + y
        lost[0] = (n - x[0]) - y
        y = ve * dt - lost[1]
        e = x[1] + y
        lost[1] = (e - x[1]) - y
        x[0] = n
        x[1] = e
        k = self._head + 1
        if k >= self._n:
            k = 0
        self._head = k
        self._t[k] = t_us
        s = self._s
        self._pn[k] = n - s[0]
        self._pe[k] = e - s[1]
        if self._count < self._n:
            self._count += 1

    def propagate(self, t_us):
        """Bring the covariance to tick ``t_us``."""
        n = ticks_diff(t_us, self.t_cov)
        if n <= 0:
            return
        self.t_cov = t_us
        T = n * 1e-6
        P = self.P
        ppc = P[1]
        tpcc = T * P[2]
        P[0] = P[0] + T * (ppc + ppc + tpcc) + self._qp * T
        P[1] = ppc + tpcc
        P[2] = P[2] + self._qc * T
        # the model's gain error over the distance reckoned since the last fix
        x = self.x
        pf = self.reckoned
        dn = x[0] - pf[0]
        de = x[1] - pf[1]
        d2 = dn * dn + de * de
        if d2 > pf[2]:
            P[0] = P[0] + self.model_var * (d2 - pf[2])
            pf[2] = d2

    def _find(self, t_meas):
        """Ring index of the newest entry at or before ``t_meas``, or -1."""
        k = self._head
        n = self._n
        t = self._t
        for _ in range(self._count):
            if ticks_diff(t[k], t_meas) <= 0:
                return k
            k -= 1
            if k < 0:
                k = n - 1
        return -1

    def update(self, t_now, t_meas, zn, ze):
        """Fuse a fix (north, east in m) measured at tick ``t_meas``; ``t_now``
        is the tick of the last predict. Returns ``FIX_*``."""
        if zn - zn != 0.0 or ze - ze != 0.0:   # NaN or infinite (x - x is NaN then): never a fix
            return FIX_REJECTED
        k = self._find(t_meas)
        if k < 0:
            return FIX_TOO_OLD
        x = self.x
        s = self._s
        if not self.initialised:
            self._restart(k, zn, ze)
            return FIX_RESET
        self.propagate(t_now)
        P = self.P
        ppp = P[0]
        ppc = P[1]
        yn = zn - (self._pn[k] + s[0])
        ye = ze - (self._pe[k] + s[1])
        sv = ppp + self._r
        d2 = yn * yn + ye * ye
        g2s = self._g2 * sv
        self.ratio = d2 / g2s
        if not d2 <= g2s:    # (a NaN compares false: written so it is rejected)
            self.rejects += 1
            if self.rejects >= self._reacquire:
                self._restart(k, zn, ze)
                return FIX_RESET
            return FIX_REJECTED
        self.rejects = 0
        age = ticks_diff(t_now, self._t[k]) * 1e-6
        inv = 1.0 / sv
        kp = ppp * inv
        kc = ppc * inv
        dcn = kc * yn
        dce = kc * ye
        dpn = kp * yn + dcn * age
        dpe = kp * ye + dce * age
        x[0] = x[0] + dpn
        x[1] = x[1] + dpe
        x[2] = x[2] + dcn
        x[3] = x[3] + dce
        s[0] = s[0] + dpn
        s[1] = s[1] + dpe
        P[0] = ppp - kp * ppp
        P[1] = ppc - kp * ppc
        P[2] = P[2] - kc * ppc
        self._fixed_here()
        return FIX_USED

    def _fixed_here(self):
        """A fix has just placed the position: dead reckoning starts again."""
        x = self.x
        pf = self.reckoned
        pf[0] = x[0]
        pf[1] = x[1]
        pf[2] = 0.0

    def _restart(self, k, zn, ze):
        """Put the position on the fix, carried to now by the dead-reckoned
        displacement since ring entry ``k``; reset the covariance."""
        x = self.x
        s = self._s
        dn = zn - (self._pn[k] + s[0])
        de = ze - (self._pe[k] + s[1])
        x[0] = x[0] + dn
        x[1] = x[1] + de
        s[0] = s[0] + dn
        s[1] = s[1] + de
        P = self.P
        P[0] = self._r
        P[1] = 0.0
        if P[2] < self._var0[1]:
            P[2] = self._var0[1]
        self.t_cov = self._t[self._head]
        self.initialised = True
        self.rejects = 0
        self._fixed_here()
