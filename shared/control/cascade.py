"""The cascade controller: position, velocity and descent speed through a
glide allocated from the model's steady descents.

How it was designed from the model (numbers from ``roboray-sim trim``,
``modes``, ``envelope``, ``controllability`` and ``tools/gen_allocation.py``):

- **Actuation.** The wings steer through the *steady* glide a
  configuration settles into, not through the reaction of moving them (the
  thesis's controller, ``backstepping``: the plate's centre moves 1.6 mm per radian of stroke). A
  harmonic fold ``s_i = c + A cos(psi - a_i)`` at mean fold c = 45 deg
  glides towards its folded side at 0.073 glide ratio per 8 deg of
  asymmetry, up to 0.34 towards a wing and 0.49 between two, spinning under
  0.04 rad/s, while its descent speed hardly changes (0.445 to 0.416 m/s).
  So the horizontal command is a glide *vector* in the body frame, which
  ``allocation`` turns into four angles from a table of trims.
- **Heading.** Nothing the wings do turns the vehicle at a symmetric fall
  (rank 14 of 16: heading and spin are out of reach), so the controller
  never steers the heading: every step it turns the requested NED glide
  into the body frame with the estimated heading and folds the side that
  faces it.
- **Dynamics of the glide.** A new configuration's glide settles through
  the feathering modes (1.35 Hz, damping ratio 0.24, time constant 0.49 s)
  and the heave (0.26 s): about a second. The outer loops cross over
  near 0.5 rad/s, well below. The wing commands slew at most
  ``CTL_SLEW_DPS`` (60 deg/s): the reaction of a moving wing first tilts
  the body the other way (0.57 rad per rad of differential stroke), so a
  full-speed move (300 deg/s) tilts it 18 deg where 60 deg/s tilts it 8 and
  settles as fast (1.7 s to the set velocity).
- **No inner rate loop.** Tilt-rate feedback through the glide request
  (tried as a damping gain of 0.3 per rad/s) fights that reaction and
  destabilises the loop (velocity error 0.09 m/s RMS against 0.008); the
  water damps the feathering modes enough.
- **Velocity from position.** The estimator's horizontal velocity is dead
  reckoning from the *commanded* wings (its descent model, no lag),
  corrected by 1 Hz fixes: it answers a wing command at once, about a
  second before the water does, so feedback of it returns the command to
  itself (``CTL_VEL_P`` 0.5: 3000 deg of servo travel and 0.020 m/s RMS of
  velocity error in a 23 s descent, against 250 deg and 0.008 m/s
  without). The position, which the fixes hold to 2-3 cm, is the honest
  measurement: VELOCITY follows a reference point moving at the set
  velocity, the glide request being the set velocity plus ``CTL_POS_P``
  (0.5/s) times the distance to that point, which is held within
  ``CTL_POS_LEASH`` of the vehicle (this loop's anti-windup). A steady
  model error leaves a constant distance and no velocity error.
  ``CTL_VEL_P`` (0 by default) remains for an estimator that measures
  velocity.
- **Gain schedule.** The plant's gain from glide ratio to horizontal
  velocity is the descent speed, so the velocity demand is divided by the
  descent speed of the commanded fold (``allocation.descent``): the loop
  gain is the same at every fold.
- **Descent speed.** Symmetric folding: 0.358 m/s at c = 30 deg to 0.445
  m/s at 45 deg (the table's rows). Below 30 deg the glide turns to the
  other side and its authority vanishes near 22 deg; above 45 deg the
  straight glides are unstable and asymmetric folds spin at 1-3 rad/s.
  Feed-forward from the table plus an integrator (``CTL_DESC_I``) on the
  depth filter's vertical speed, stopped at the table's limits; without a
  descent command the fold is ``CTL_FOLD_DEG`` (45 deg: the most glide).
  Below 45 deg the reach shrinks off the axes (0.1-0.26 at 30-40 deg,
  spin-limited): a combined command may saturate (``saturated``).
- **TARGET.** Guidance to a point on the bottom at depth D: with ``h`` the
  height still to fall and ``e`` the horizontal error, the vehicle must
  glide at least ``|e| / h``; the guidance asks for ``K e / h``
  (``CTL_TGT_K`` 2: it closes the error while half the remaining depth is
  left, so a model error or a current still has depth to be corrected), as
  the velocity ``K e w / h``. ``h`` is held above ``CTL_TGT_HMIN`` so the
  last metre keeps a finite gain. A target beyond the reach (``|e| / h``
  above the table's ratio) saturates: the vehicle glides straight at it at
  its best ratio.
- **Saturation.** The velocity set point is limited to ``CTL_VEL_MAX``,
  the glide to the table's reach in its direction (keeping the direction),
  the fold to the table's rows, the wings to their travel.
- **ATTITUDE.** Roll and pitch through the glide request (a glide tilts the
  body towards its folded side, about 0.13 rad of tilt per unit of glide
  ratio, up to 4-6 deg): a PI on the tilt error (gravity in the body
  frame). Yaw is not controllable (above) and is ignored.
"""

import math
from array import array

from roboray.shared import modes as _m
from roboray.shared.control import gains as _g
from roboray.shared.control.allocation import Allocation
from roboray.shared.estimator import health as _h
from roboray.shared.estimator.ticks import ticks_diff

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

#: Layout of ``Controller.command`` (set points of the inner loops).
CMD_VN = const(0)       # m/s, velocity set point north
CMD_VE = const(1)       # m/s, velocity set point east
CMD_VD = const(2)       # m/s, descent speed set point (0: none)
CMD_GX = const(3)       # glide ratio requested, body x (after saturation)
CMD_GY = const(4)       # glide ratio requested, body y
CMD_FOLD = const(5)     # rad, mean wing fold
CMD_REACH = const(6)    # largest glide ratio in the requested direction
CMD_HEIGHT = const(7)   # m, TARGET: height left to the bottom
CMD_SIZE = const(8)

_DT = 0.02              # s, nominal step (50 Hz)
_DT_MAX = 0.1           # s, longest step integrated (a stall is not integrated)
_W_MIN = 0.2            # m/s, smallest descent speed used to turn velocity into glide


class Controller:
    """Cascade controller (board code); the API is ``roboray.shared.control``'s.

    Parameters
    ----------
    params:
        A ``shared.params.ParamTable`` with the ``CTL_*`` group and the
        modes' wing angles (``SERVO_SAFE_DEG``, ``PASSIVE_WING_DEG``,
        ``FS_WING_DEG``), or None for the declared defaults.
    """

    def __init__(self, params=None):
        self.gains = _g.Gains(params)
        self.alloc = Allocation()
        #: Inner-loop set points, ``CMD_*`` layout (read-only telemetry).
        self.command = array("f", [0.0] * CMD_SIZE)
        #: Last wing commands written, rad.
        self.wings = array("f", [0.0] * 4)
        #: The glide request exceeded the reach (or the velocity its limit).
        self.saturated = False
        #: The estimate this mode needs was not valid: PASSIVE wings written.
        self.degraded = False
        #: Mode of the last step (-1 before the first).
        self.mode = -1
        # set points: target (north, east, bottom depth), velocity, attitude
        self._target = array("f", [0.0, 0.0, 0.0])
        self._vel = array("f", [0.0, 0.0, 0.0])
        self._att = array("f", [0.0, 0.0, 0.0])
        self.target_set = False
        # integrators: descent fold (rad), tilt x, y
        self._i = array("f", [0.0] * 3)
        # descent set point whose feed-forward fold is cached, and that fold
        self._vd_ff = -1.0
        self._fold_ff = 0.0
        # VELOCITY's reference point (north, east), set at the mode's start
        self._ref = array("f", [0.0, 0.0])
        self._ref_new = True
        self._t_prev = 0
        self._fresh = True
        # glide request of the loops (body frame): an array, not a tuple
        self._g = array("f", [0.0, 0.0])

    # ------------------------------------------------------------ set points
    def set_target(self, north, east, down=0.0):
        """TARGET: land at (north, east) m from the release point, on a
        bottom at ``down`` m (0 or less: ``CTL_DEPTH_M``)."""
        t = self._target
        t[0] = north
        t[1] = east
        t[2] = down
        self.target_set = True

    def set_velocity(self, v_north, v_east, v_down=0.0):
        """VELOCITY: horizontal velocity (m/s, NED) and descent speed
        (m/s; 0 or less: no descent-speed command, fold ``CTL_FOLD_DEG``)."""
        v = self._vel
        v[0] = v_north
        v[1] = v_east
        v[2] = v_down

    def set_attitude(self, roll, pitch, yaw=0.0):
        """ATTITUDE: roll and pitch (rad); yaw is not controllable and is
        kept only for telemetry."""
        a = self._att
        a[0] = roll
        a[1] = pitch
        a[2] = yaw

    def reset(self):
        """Clear the integrators (mode changes, arming); the wing commands
        keep slewing from where they are."""
        i = self._i
        for k in range(3):
            i[k] = 0.0
        self._fresh = True
        self._ref_new = True

    # ------------------------------------------------------------------ step
    def step(self, t_us, mode, est, out):
        """One 50 Hz step: reads ``est`` (an ``Estimator``), writes the four
        wing commands (rad) into ``out``."""
        k = self.gains.k
        self.gains.refresh()
        if mode != self.mode:
            self.reset()
            self.mode = mode
        if self._fresh:
            dt = _DT
            self._fresh = False
        else:
            dt = ticks_diff(t_us, self._t_prev) * 1e-6
            if dt < 0.0:
                dt = 0.0
            elif dt > _DT_MAX:
                dt = _DT_MAX
        self._t_prev = t_us
        self.saturated = False
        self.degraded = False
        if mode == _m.DISARMED:
            self._fixed(out, k[_g.SAFE])
            return
        if mode == _m.FAILSAFE or mode < 0 or mode > _m.FAILSAFE:
            self._fixed(out, k[_g.FAILSAFE])
            return
        if mode == _m.PASSIVE:
            self._fixed(out, k[_g.PASSIVE])
            return
        health = est.status[_h.STATUS_HEALTH]
        if mode == _m.ATTITUDE:
            if not health & _h.ATTITUDE_VALID:
                self._degraded(out, k)
                return
            self._attitude(est, k, dt)
            fold = k[_g.FOLD]
        else:
            if est.status[_h.STATUS_VALID] != 1:
                self._degraded(out, k)
                return
            fold = self._descent(est, k, dt)
            # descent speed of the fold: the gain schedule (once a step)
            w = self.alloc.descent(fold)
            if w < _W_MIN:
                w = _W_MIN
            if mode == _m.TARGET:
                self._guidance(est, k, w)
            else:
                c = self.command
                v = self._vel
                c[CMD_VN] = v[0]
                c[CMD_VE] = v[1]
                c[CMD_HEIGHT] = 0.0
            self._velocity(est, k, dt, w)
        g = self._g
        self._allocate(out, k, fold, g[0], g[1], dt)

    # ------------------------------------------------------------ the loops
    def _descent(self, est, k, dt):
        """Mean fold (rad): the table's fold for the descent set point plus
        an integrator on the descent-speed error; CTL_FOLD_DEG without one."""
        c = self.command
        vd = self._vel[2] if self.mode == _m.VELOCITY else 0.0
        c[CMD_VD] = vd
        if vd <= 0.0:
            return k[_g.FOLD]
        alloc = self.alloc
        i = self._i
        if vd != self._vd_ff:
            # the table's fold for this descent speed, once per set point
            self._vd_ff = vd
            self._fold_ff = alloc.fold_for(vd)
        fold = self._fold_ff + i[0]
        lo = alloc.fold_min
        hi = alloc.fold_max
        e = vd - est.nav[_h.NAV_VZ]
        # anti-windup: no integration pushing further into a limit
        if (fold < hi or e < 0.0) and (fold > lo or e > 0.0):
            i[0] += k[_g.DESC_I] * e * dt
        if fold < lo:
            fold = lo
        elif fold > hi:
            fold = hi
        return fold

    def _guidance(self, est, k, w):
        """TARGET: velocity set point K e w / h towards the target."""
        t = self._target
        nav = est.nav
        depth = t[2] if t[2] > 0.0 else k[_g.DEPTH]
        h = depth - nav[_h.NAV_DEPTH]
        c = self.command
        c[CMD_HEIGHT] = h
        hmin = k[_g.TGT_HMIN]
        if h < hmin:
            h = hmin
        gain = k[_g.TGT_K] * w / h
        c[CMD_VN] = (t[0] - nav[_h.NAV_NORTH]) * gain
        c[CMD_VE] = (t[1] - nav[_h.NAV_EAST]) * gain

    def _velocity(self, est, k, dt, w):
        """Velocity set point to a glide request in the body frame (divided
        by the fold's descent speed: the gain schedule). VELOCITY adds the
        pull of a reference point moving at the set velocity."""
        c = self.command
        nav = est.nav
        vn = c[CMD_VN]
        ve = c[CMD_VE]
        vmax = k[_g.VEL_MAX]
        n2 = vn * vn + ve * ve
        if n2 > vmax * vmax:
            s = vmax / math.sqrt(n2)
            vn *= s
            ve *= s
            self.saturated = True
            c[CMD_VN] = vn
            c[CMD_VE] = ve
        dn = vn
        de = ve
        if self.mode == _m.VELOCITY:
            ref = self._ref
            pn = nav[_h.NAV_NORTH]
            pe = nav[_h.NAV_EAST]
            if self._ref_new:
                ref[0] = pn
                ref[1] = pe
                self._ref_new = False
            en = ref[0] + vn * dt - pn
            ee = ref[1] + ve * dt - pe
            # the leash: a vehicle that cannot follow does not wind it up
            leash = k[_g.POS_LEASH]
            e2 = en * en + ee * ee
            if e2 > leash * leash:
                s = leash / math.sqrt(e2)
                en *= s
                ee *= s
            ref[0] = pn + en
            ref[1] = pe + ee
            kp = k[_g.POS_P]
            dn += kp * en
            de += kp * ee
        kv = k[_g.VEL_P]
        if kv > 0.0:
            dn += kv * (vn - nav[_h.NAV_VN])
            de += kv * (ve - nav[_h.NAV_VE])
        inv = 1.0 / w
        yaw = est.euler[2]
        cy = math.cos(yaw) * inv
        sy = math.sin(yaw) * inv
        gx = cy * dn + sy * de
        gy = cy * de - sy * dn
        g = self._g
        g[0] = gx
        g[1] = gy

    def _attitude(self, est, k, dt):
        """ATTITUDE: PI from the tilt error (gravity in the body frame) to
        the glide request."""
        a = self._att
        sr = math.sin(a[0])
        cp = math.cos(a[1])
        q = est.q
        w = q[0]
        x = q[1]
        y = q[2]
        z = q[3]
        # Gamma = R^T (0, 0, 1): set point minus measurement
        ex = -math.sin(a[1]) - 2.0 * (x * z - w * y)
        ey = sr * cp - 2.0 * (y * z + w * x)
        i = self._i
        if not self.alloc.saturated:
            ki = k[_g.ATT_I] * dt
            i[1] += ki * ex
            i[2] += ki * ey
        kp = k[_g.ATT_P]
        c = self.command
        c[CMD_VN] = 0.0
        c[CMD_VE] = 0.0
        c[CMD_VD] = 0.0
        c[CMD_HEIGHT] = 0.0
        g = self._g
        g[0] = kp * ex + i[1]
        g[1] = kp * ey + i[2]

    # ------------------------------------------------------------- outputs
    def _allocate(self, out, k, fold, gx, gy, dt):
        alloc = self.alloc
        reach = alloc.wings(fold, gx, gy)
        if alloc.saturated:
            self.saturated = True
        c = self.command
        c[CMD_FOLD] = fold
        c[CMD_REACH] = reach
        c[CMD_GX] = gx
        c[CMD_GY] = gy
        s = alloc.s
        last = self.wings
        step = k[_g.SLEW] * dt
        for j in range(4):
            d = s[j] - last[j]
            if d > step:
                d = step
            elif d < -step:
                d = -step
            v = last[j] + d
            last[j] = v
            out[j] = v

    def _fixed(self, out, angle):
        """A mode's fixed configuration, every wing at ``angle`` (rad),
        within the servos' travel."""
        if angle < 0.0:
            angle = 0.0
        elif angle > 1.5707963267948966:
            angle = 1.5707963267948966
        last = self.wings
        for j in range(4):
            last[j] = angle
            out[j] = angle
        c = self.command
        for j in range(CMD_SIZE):
            c[j] = 0.0

    def _degraded(self, out, k):
        self._fixed(out, k[_g.PASSIVE])
        self.degraded = True
