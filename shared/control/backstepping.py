"""The thesis's geometric backstepping controller (ch. 4), for comparison.

Chapter 4 writes the vehicle in the backstepping form of eq. 4.2 with
(sec. 4.4)

    eta = (b, R, S),   xi = (V, Omega, S_dot),   u = S_ddot  (eq. 2.10)
    eta_dot = G_a xi,  xi_dot = F_b + G_b u,     G_b = [g_i(S); h_i(S); e_i]

and tracks a reference with (sec. 4.3)

    delta_eta = eta - eta_r,  phi = eta_dot_r - delta_eta,  delta_xi = xi - phi
    u = -G_b^+ (K delta_xi + delta_eta - xi_dot_r + F_b).

Here G_b's velocity rows are the added-mass reaction -M_vv^-1 M_vs of the
model (``plant.Plant.reaction``; only the hinge deflection about y_i exists
in our model, which is what sec. 4.4 keeps after dropping the x_i, z_i
deflections) and F_b is the model's drift (``Plant.drift``) on the board.

Corrections, so the printed law can be computed at all:

1. Dimensions. eta (16 numbers: b, the nine entries of R, S) and xi (10)
   cannot be subtracted as sec. 4.3 does ("approximate eta_dot as xi").
   The configuration errors are taken in xi's coordinates instead: the
   position error in the body frame R^T (b - b_r), the geometric attitude
   error e_R = 1/2 vee(R_r^T R - R^T R_r) (Lee, Leok, McClamroch), and
   S - S_r; then phi = xi_r - delta_eta is a velocity.
2. The reference. Sec. 5.2 gives only "track a trajectory in the positive
   y_c direction at 0.3 m/s": b_r(t) moves from the start along the initial
   y_c at 0.3 m/s and down at the initial 0.3 m/s, R_r is the initial
   (level) attitude with Omega_r = 0, S_r = 45 deg. xi_dot_r is the
   derivative of the body-frame reference velocity, -Omega x V_r.
3. Inputs. The law returns wing accelerations; the servos take angles, so
   the controller integrates u twice into the commanded angle (rate limited
   to the servos' 6 rad/s, angle to the travel), and uses that integrated
   (S, S_dot) as the wings' state, as the thesis's S_ddot = u model does.

``K`` is ``CTL_BS_K`` times the identity, its y_c velocity entry
``CTL_BS_KV2`` (the re-weighting of sec. 5.2.2). The flight modes give the
reference: VELOCITY the set velocity (descent: the set one, or the 45 deg
fold's), TARGET the straight line from the start to the target on the
bottom at that descent speed, ATTITUDE the set roll and pitch with no
position error. Same API as ``Controller``.

Why it cannot steer (``roboray-sim bench control`` and the README give the
numbers): u acts only through the reaction, which integrates to a bounded
*displacement* per wing stroke (momentum is conserved while a wing moves),
never to a steady velocity; the steady horizontal force of a deflected wing
(drag and CG) that does steer the vehicle is in F_b as a drift the law
cancels, not an input it uses.
"""

import math
from array import array

from roboray.shared import modes as _m
from roboray.shared.control import gains as _g
from roboray.shared.control.cascade import CMD_FOLD, CMD_HEIGHT, CMD_SIZE, CMD_VD, CMD_VE, CMD_VN
from roboray.shared.control.plant import Plant
from roboray.shared.estimator import health as _h
from roboray.shared.estimator.ticks import ticks_diff

_DT = 0.02
_DT_MAX = 0.1
_HALF_PI = 1.5707963267948966
#: Wing rate limit of the integrated command, rad/s (the servos' 6 rad/s).
_RATE_MAX = 6.0
#: Descent speed of the 45 deg symmetric fall, m/s (allocation_table.DESCENT).
_W45 = 0.44548


class BacksteppingController:
    """The thesis's controller (board code); API of ``roboray.shared.control``."""

    def __init__(self, params=None):
        self.gains = _g.Gains(params)
        self.plant = Plant()
        self.command = array("f", [0.0] * CMD_SIZE)
        self.wings = array("f", [0.0] * 4)
        self.saturated = False
        self.degraded = False
        self.mode = -1
        self.target_set = False
        self._target = array("f", [0.0, 0.0, 0.0])
        self._vel = array("f", [0.0, 0.0, 0.0])
        self._att = array("f", [0.0, 0.0, 0.0])
        # reference: start position (3), NED velocity (3), attitude R_r (9)
        self._b0 = array("f", [0.0] * 3)
        self._vr = array("f", [0.0] * 3)
        self._rr = array("f", [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
        self._t_ref = 0.0
        self._t_end = -1.0          # TARGET: time the straight line reaches the target
        self._fixed_ref = False     # set_reference() was called: keep it across mode changes
        # integrated wing state (thesis: S_ddot = u)
        self._s = array("f", [0.0] * 4)
        self._sd = array("f", [0.0] * 4)
        self._started = False
        # work arrays
        self._r = array("f", [0.0] * 9)       # R (body -> NED), row-major
        self._V = array("f", [0.0] * 3)
        self._W = array("f", [0.0] * 3)
        self._gam = array("f", [0.0] * 3)
        self._fb = array("f", [0.0] * 6)
        self._B = array("f", [0.0] * 24)
        self._res = array("f", [0.0] * 10)
        self._m4 = array("f", [0.0] * 16)
        self._v4 = array("f", [0.0] * 4)
        #: Last wing accelerations u (rad/s^2) and the velocity part of
        #: G_b^+ r against its wing part (how much the law steers at all).
        self.u = array("f", [0.0] * 4)
        self._t_prev = 0
        self._fresh = True
        self._new_ref = True

    # ------------------------------------------------------------ set points
    def set_target(self, north, east, down=0.0):
        t = self._target
        t[0] = north
        t[1] = east
        t[2] = down
        self.target_set = True
        self._new_ref = True

    def set_velocity(self, v_north, v_east, v_down=0.0):
        v = self._vel
        v[0] = v_north
        v[1] = v_east
        v[2] = v_down
        self._new_ref = True

    def set_attitude(self, roll, pitch, yaw=0.0):
        a = self._att
        a[0] = roll
        a[1] = pitch
        a[2] = yaw
        self._new_ref = True

    def set_reference(self, north, east, down, v_north, v_east, v_down, yaw):
        """Sec. 5.2's reference: from (north, east, down) at constant NED
        velocity, level attitude at ``yaw``; replaces the modes' reference
        (the thesis's runs)."""
        b = self._b0
        b[0] = north
        b[1] = east
        b[2] = down
        v = self._vr
        v[0] = v_north
        v[1] = v_east
        v[2] = v_down
        _level(self._rr, 0.0, 0.0, yaw)
        self._t_ref = 0.0
        self._t_end = -1.0
        self._fixed_ref = True
        self._new_ref = False

    def reset(self):
        self._fresh = True
        self._new_ref = True
        self._started = False

    # ------------------------------------------------------------------ step
    def step(self, t_us, mode, est, out):
        k = self.gains.k
        self.gains.refresh()
        if mode != self.mode:
            self.reset()
            self.mode = mode
        if self._fresh:
            dt = _DT
            self._fresh = False
            self._t_ref = 0.0
        else:
            dt = ticks_diff(t_us, self._t_prev) * 1e-6
            if dt < 0.0:
                dt = 0.0
            elif dt > _DT_MAX:
                dt = _DT_MAX
            self._t_ref += dt
        self._t_prev = t_us
        self.degraded = False
        self.saturated = False
        if mode == _m.DISARMED or mode == _m.PASSIVE or mode == _m.FAILSAFE or mode < 0 or mode > _m.FAILSAFE:
            angle = k[_g.SAFE] if mode == _m.DISARMED else (k[_g.PASSIVE] if mode == _m.PASSIVE else k[_g.FAILSAFE])
            self._fixed(out, angle)
            return
        valid = est.status[_h.STATUS_VALID] == 1
        if mode == _m.ATTITUDE:
            valid = est.status[_h.STATUS_HEALTH] & _h.ATTITUDE_VALID
        if not valid:
            self._fixed(out, k[_g.PASSIVE])
            self.degraded = True
            return
        self._state(est)
        if not self._started:
            s = self._s
            sd = self._sd
            for i in range(4):
                s[i] = self.wings[i]
                sd[i] = 0.0
            self._started = True
        if self._new_ref and not self._fixed_ref:
            self._reference(est, mode, k)
        self._law(est, mode, k, dt)
        s = self._s
        last = self.wings
        for i in range(4):
            last[i] = s[i]
            out[i] = s[i]

    # --------------------------------------------------------------- parts
    def _state(self, est):
        """R, body velocity V, rates Omega and gravity direction Gamma from
        the estimate."""
        q = est.q
        r = self._r
        _rotation(q[0], q[1], q[2], q[3], r)
        nav = est.nav
        vn = nav[_h.NAV_VN]
        ve = nav[_h.NAV_VE]
        vd = nav[_h.NAV_VZ]
        V = self._V
        for i in range(3):
            V[i] = r[i] * vn + r[3 + i] * ve + r[6 + i] * vd
        W = self._W
        rates = est.rates
        for i in range(3):
            W[i] = rates[i]
        g = self._gam
        for i in range(3):
            g[i] = r[6 + i]

    def _reference(self, est, mode, k):
        """The mode's reference trajectory, from where the vehicle is now."""
        self._new_ref = False
        self._t_ref = 0.0
        self._t_end = -1.0
        nav = est.nav
        b = self._b0
        b[0] = nav[_h.NAV_NORTH]
        b[1] = nav[_h.NAV_EAST]
        b[2] = nav[_h.NAV_DEPTH]
        v = self._vr
        w = self._vel[2] if mode == _m.VELOCITY and self._vel[2] > 0.0 else _W45
        v[2] = w
        yaw = est.euler[2]
        if mode == _m.VELOCITY:
            v[0] = self._vel[0]
            v[1] = self._vel[1]
            _level(self._rr, 0.0, 0.0, yaw)
        elif mode == _m.TARGET:
            t = self._target
            depth = t[2] if t[2] > 0.0 else k[_g.DEPTH]
            fall = depth - b[2]
            if fall < 0.1:
                fall = 0.1
            T = fall / w
            v[0] = (t[0] - b[0]) / T
            v[1] = (t[1] - b[1]) / T
            self._t_end = T
            _level(self._rr, 0.0, 0.0, yaw)
        else:
            v[0] = 0.0
            v[1] = 0.0
            a = self._att
            _level(self._rr, a[0], a[1], yaw)

    def _law(self, est, mode, k, dt):
        """u = -G_b^+ (K delta_xi + delta_eta - xi_dot_r + F_b), integrated."""
        s = self._s
        sd = self._sd
        V = self._V
        W = self._W
        r = self._r
        rr = self._rr
        plant = self.plant
        fb = self._fb
        plant.drift(s, sd, V, W, self._gam, fb)
        B = self._B
        plant.reaction(B)
        # reference at this time
        t = self._t_ref
        vr = self._vr
        b0 = self._b0
        vn = vr[0]
        ve = vr[1]
        vdn = vr[2]
        if self._t_end >= 0.0 and t > self._t_end:
            t = self._t_end
            vn = 0.0
            ve = 0.0
        nav = est.nav
        en = nav[_h.NAV_NORTH] - (b0[0] + vr[0] * t)
        ee = nav[_h.NAV_EAST] - (b0[1] + vr[1] * t)
        ed = nav[_h.NAV_DEPTH] - (b0[2] + vdn * self._t_ref)
        if mode == _m.ATTITUDE:
            en = 0.0
            ee = 0.0
            ed = 0.0
        res = self._res
        kk = k[_g.BS_K]
        # delta_eta (body frame) and the reference velocity in the body frame
        for i in range(3):
            # R^T (b - b_r) and R^T v_r
            de = r[i] * en + r[3 + i] * ee + r[6 + i] * ed
            vb = r[i] * vn + r[3 + i] * ve + r[6 + i] * vdn
            res[i] = de
            self._v4[i] = vb
        # geometric attitude error e_R = 1/2 vee(R_r^T R - R^T R_r)
        # (R_r^T R)_{ij} = sum_k rr[k][i] r[k][j]
        a12 = rr[0] * r[1] + rr[3] * r[4] + rr[6] * r[7]
        a21 = rr[1] * r[0] + rr[4] * r[3] + rr[7] * r[6]
        a13 = rr[0] * r[2] + rr[3] * r[5] + rr[6] * r[8]
        a31 = rr[2] * r[0] + rr[5] * r[3] + rr[8] * r[6]
        a23 = rr[1] * r[2] + rr[4] * r[5] + rr[7] * r[8]
        a32 = rr[2] * r[1] + rr[5] * r[4] + rr[8] * r[7]
        res[3] = 0.5 * (a32 - a23)
        res[4] = 0.5 * (a13 - a31)
        res[5] = 0.5 * (a21 - a12)
        fold = k[_g.FOLD]
        for i in range(4):
            res[6 + i] = s[i] - fold
        # r = K delta_xi + delta_eta - xi_dot_r + F_b, delta_xi = xi - xi_r + delta_eta
        vb = self._v4
        # xi_dot_r: the body-frame reference velocity turns with the body
        xr0 = -(W[1] * vb[2] - W[2] * vb[1])
        xr1 = -(W[2] * vb[0] - W[0] * vb[2])
        xr2 = -(W[0] * vb[1] - W[1] * vb[0])
        kv2 = k[_g.BS_KV2]
        for i in range(3):
            d_eta = res[i]
            d_xi = V[i] - vb[i] + d_eta
            gain = kv2 if i == 1 else kk
            xr = xr0 if i == 0 else (xr1 if i == 1 else xr2)
            res[i] = gain * d_xi + d_eta - xr + fb[i]
        for i in range(3):
            d_eta = res[3 + i]
            d_xi = W[i] + d_eta
            res[3 + i] = kk * d_xi + d_eta + fb[3 + i]
        for i in range(4):
            d_eta = res[6 + i]
            d_xi = sd[i] + d_eta
            res[6 + i] = kk * d_xi + d_eta
        # u = -(G^T G)^-1 G^T r, G = [B; I4]
        m4 = self._m4
        g = self._v4
        for i in range(4):
            acc = res[6 + i]
            for row in range(6):
                acc += B[4 * row + i] * res[row]
            g[i] = acc
            for j in range(4):
                acc = 1.0 if i == j else 0.0
                for row in range(6):
                    acc += B[4 * row + i] * B[4 * row + j]
                m4[4 * i + j] = acc
        _solve4(m4, g)
        u = self.u
        for i in range(4):
            u[i] = -g[i]
        # S_ddot = u, integrated into the commanded angle
        for i in range(4):
            rate = sd[i] + u[i] * dt
            if rate > _RATE_MAX:
                rate = _RATE_MAX
                self.saturated = True
            elif rate < -_RATE_MAX:
                rate = -_RATE_MAX
                self.saturated = True
            angle = s[i] + rate * dt
            if angle < 0.0:
                angle = 0.0
                rate = 0.0
                self.saturated = True
            elif angle > _HALF_PI:
                angle = _HALF_PI
                rate = 0.0
                self.saturated = True
            s[i] = angle
            sd[i] = rate
        c = self.command
        c[CMD_VN] = vn
        c[CMD_VE] = ve
        c[CMD_VD] = vdn
        c[CMD_FOLD] = fold
        c[CMD_HEIGHT] = 0.0

    def _fixed(self, out, angle):
        if angle < 0.0:
            angle = 0.0
        elif angle > _HALF_PI:
            angle = _HALF_PI
        for i in range(4):
            self.wings[i] = angle
            out[i] = angle
        self._started = False


def _rotation(w, x, y, z, r):
    """Body -> NED rotation matrix (row-major) of the quaternion."""
    r[0] = 1.0 - 2.0 * (y * y + z * z)
    r[1] = 2.0 * (x * y - w * z)
    r[2] = 2.0 * (x * z + w * y)
    r[3] = 2.0 * (x * y + w * z)
    r[4] = 1.0 - 2.0 * (x * x + z * z)
    r[5] = 2.0 * (y * z - w * x)
    r[6] = 2.0 * (x * z - w * y)
    r[7] = 2.0 * (y * z + w * x)
    r[8] = 1.0 - 2.0 * (x * x + y * y)


def _level(r, roll, pitch, yaw):
    """R (row-major) of Z-Y-X Euler angles."""
    cr = math.cos(roll)
    sr = math.sin(roll)
    cp = math.cos(pitch)
    sp = math.sin(pitch)
    cy = math.cos(yaw)
    sy = math.sin(yaw)
    r[0] = cy * cp
    r[1] = cy * sp * sr - sy * cr
    r[2] = cy * sp * cr + sy * sr
    r[3] = sy * cp
    r[4] = sy * sp * sr + cy * cr
    r[5] = sy * sp * cr - cy * sr
    r[6] = -sp
    r[7] = cp * sr
    r[8] = cp * cr


def _solve4(a, b):
    """Solve a x = b in place (4x4 symmetric positive definite, Gauss)."""
    for c in range(4):
        p = a[5 * c]
        inv = 1.0 / p
        for j in range(c, 4):
            a[4 * c + j] *= inv
        b[c] *= inv
        for r in range(4):
            if r != c:
                f = a[4 * r + c]
                if f != 0.0:
                    for j in range(c, 4):
                        a[4 * r + j] -= f * a[4 * c + j]
                    b[r] -= f * b[c]
