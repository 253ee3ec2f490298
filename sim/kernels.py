"""Compiled right-hand side of the equations of motion (numba).

One implementation serves one vehicle and a batch of thousands: the loop
over vehicles is the outer loop and each vehicle's arithmetic is scalar, so
a vehicle's result does not depend on the batch it runs in. ``dynamics.py``
documents the equations (K1)-(K3) and the forces; this module computes them.
numpy alone costs ~0.4 ms an evaluation for one vehicle (a hundred small
array operations); compiled, an evaluation takes about a microsecond.

Tables (built by ``dynamics.Model``), first axis the vehicle (size 1 when
the batch shares one vehicle), passed as one tuple ``T``:

- ``c0`` (V, 36): centre-body inertia at O (rigid + added), row-major 6x6;
- ``vv_at`` (K, 4) / ``vv_val`` (V, K): the non-zero Fourier terms of the
  wings' inertia, (wing, basis function, row, column in the upper
  triangle), unsigned;
- ``vs_at`` (L, 3) / ``vs_val`` (V, L): the same for the coupling M_vs,
  (wing, basis function, row), unsigned;
- ``p`` (V, NP): scalars at the ``P_*`` columns;
- ``opt`` (NOPT,): switches and options at the ``O_*`` entries.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import numba
from numba import njit, prange
from numba.core import event as _numba_event

log = logging.getLogger(__name__)

#: What the first compile of the kernels takes on a 2-core machine: about
#: 70 s in the suite's fresh-clone run (README); 84 s wall for the first
#: ``roboray-sim drop --wings 0,0,90,90 --duration 1`` after ``pip install .``
#: on a loaded one (2026-12-04). Later runs load them from numba's cache
#: (sim/__init__.py says where) in about a second.
COMPILE_S = 70


class _SayCompiling(_numba_event.Listener):
    """Says once a process that the kernels are being compiled: a user
    otherwise sees a minute of nothing and then a slow "x real time"."""

    said = False

    def on_start(self, event):
        if self.said:
            return
        dispatcher = (event.data or {}).get("dispatcher")
        module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
        if module.startswith("roboray.sim"):
            self.said = True
            log.info("compiling the dynamics kernels, once after an install or a change "
                     "(about %d s; cached in %s)", COMPILE_S, numba.config.CACHE_DIR or "the package")

    def on_end(self, event):
        pass


_numba_event.register("numba:compile", _SayCompiling())

# Columns of p
P_MASS, P_RHO, P_G, P_CD, P_CF, P_VOLUME, P_TAU, P_RATE, P_SMIN, P_SMAX = range(10)
P_HW, P_MWING, P_VWING, P_AREA_C, P_AREA_W, P_KROT_C, P_KROT_W, P_HALF_SIDE = range(10, 18)
P_MFIRST, P_VFIRST, P_IMU, P_PORT = 18, 21, 24, 27   # 3 each
P_MUNK = 30   # scale of the added-mass (Munk) moment of translation, 1 = the full Kirchhoff term
NP = 31
# Entries of opt
O_GRAVITY, O_DRAG, O_CURRENT, O_CUR_V, O_CUR_SHEAR = 0, 1, 2, 3, 6   # 3 each for the last two
O_BOTTOM, O_DEPTH, O_STIFF, O_DAMP, O_MU, O_SLIP = 9, 10, 11, 12, 13, 14
NOPT = 15

NB = 9  # Fourier basis per wing: 1, cos ks, sin ks for k = 1..4

#: Wing i's outward direction r_i and hinge axis t_i = z x r_i, exact.
RADIAL = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
HINGE = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])

# Rows of the 3-vector scratch
_F, _M, _U, _FP, _OM, _WB, _WATER, _TMP, _RG, _RB, _PT, _VB, _VW = range(13)

# numpy's error model: a division by zero gives inf rather than raising,
# which spares a test on every division (none divides by zero here).
_JIT = dict(cache=True, nogil=True, error_model="numpy")
# What allocates nothing compiles without the runtime's reference counts:
# each array view took an atomic add, a sixth of a batch's time. Adding an
# allocation to one of these fails at compile time ("NRT required").
_HOT = dict(_JIT, _nrt=False)
# Small functions inlined where called: a call passes the tables and the
# scratch flattened, some 200 words (0.75-0.84 of the time without).
_LEAF = dict(_HOT, inline="always")


def scratch():
    """Work arrays for one vehicle evaluation (make one per thread)."""
    return (np.empty((4, NB)), np.empty((6, 6)), np.empty((6, 4)), np.empty(6), np.zeros((6, 6)),
            np.empty(6), np.empty(6), np.empty((3, 3)), np.empty((5, 3)), np.empty((5, 3)),
            np.empty((13, 3)), np.empty((4, 2)))


_scratch = njit(**_JIT)(scratch)


@njit(**_LEAF)
def _basis(c1, s1, out):
    """out[0..8] = 1, cos s, sin s, cos 2s, sin 2s, ..., sin 4s from c1 = cos s, s1 = sin s."""
    c2 = c1 * c1 - s1 * s1
    s2 = 2.0 * s1 * c1
    out[0] = 1.0
    out[1] = c1
    out[2] = s1
    out[3] = c2
    out[4] = s2
    out[5] = c2 * c1 - s2 * s1
    out[6] = s2 * c1 + c2 * s1
    out[7] = c2 * c2 - s2 * s2
    out[8] = 2.0 * s2 * c2


@njit(**_LEAF)
def trig(s, cs):
    """cs[i] = (cos s_i, sin s_i): every use of the wing angles needs both."""
    for i in range(4):
        cs[i, 0] = math.cos(s[i])
        cs[i, 1] = math.sin(s[i])


@njit(**_LEAF)
def inertia_into(v, cs, T, basis, mvv, mvs):
    """M_vv (6x6) and M_vs (6x4) of vehicle table v at wing angles whose
    cosines and sines are cs (4, 2). The index tables are unsigned: numba
    then indexes without testing for negative indices, a third of this
    loop's time."""
    c0, vv_at, vv_val, vs_at, vs_val = T[0], T[1], T[2], T[3], T[4]
    for a in range(6):
        for b in range(6):
            mvv[a, b] = c0[v, 6 * a + b]
    for i in range(4):
        _basis(cs[i, 0], cs[i, 1], basis[i])
    for t in range(vv_at.shape[0]):
        mvv[vv_at[t, 2], vv_at[t, 3]] += basis[vv_at[t, 0], vv_at[t, 1]] * vv_val[v, t]
    for a in range(6):
        for b in range(a + 1, 6):
            mvv[b, a] = mvv[a, b]
    mvs[:, :] = 0.0
    for t in range(vs_at.shape[0]):
        mvs[vs_at[t, 2], vs_at[t, 0]] += basis[vs_at[t, 0], vs_at[t, 1]] * vs_val[v, t]


@njit(**_LEAF)
def cholesky6(a, l):
    """l l^T = a for symmetric positive definite a (6x6)."""
    for i in range(6):
        for j in range(i + 1):
            acc = a[i, j]
            for k in range(j):
                acc -= l[i, k] * l[j, k]
            if i == j:
                l[i, i] = math.sqrt(acc)
            else:
                l[i, j] = acc / l[j, j]


@njit(**_LEAF)
def solve6(l, b, y, out):
    """Solve l l^T x = b; y (6,) is scratch."""
    for i in range(6):
        acc = b[i]
        for k in range(i):
            acc -= l[i, k] * y[k]
        y[i] = acc / l[i, i]
    for i in range(5, -1, -1):
        acc = y[i]
        for k in range(i + 1, 6):
            acc -= l[k, i] * out[k]
        out[i] = acc / l[i, i]


@njit(**_LEAF)
def rotation(q, r):
    """Body -> NED rotation matrix of the quaternion [w, x, y, z]."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    r[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    r[0, 1] = 2.0 * (x * y - w * z)
    r[0, 2] = 2.0 * (x * z + w * y)
    r[1, 0] = 2.0 * (x * y + w * z)
    r[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    r[1, 2] = 2.0 * (y * z - w * x)
    r[2, 0] = 2.0 * (x * z - w * y)
    r[2, 1] = 2.0 * (y * z + w * x)
    r[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit(**_LEAF)
def add_cross(a, b, out):
    """out += a x b"""
    out[0] += a[1] * b[2] - a[2] * b[1]
    out[1] += a[2] * b[0] - a[0] * b[2]
    out[2] += a[0] * b[1] - a[1] * b[0]


@njit(**_LEAF)
def factor(v, x, T, S):
    """Wing trig, M_vv, M_vs and the Cholesky factor of M_vv for state x: all
    that depends on the wing angles alone (RK4's two midpoint stages share it)."""
    cs = S[11]
    trig(x[13:17], cs)
    inertia_into(v, cs, T, S[0], S[1], S[2])
    cholesky6(S[1], S[4])


@njit(**_LEAF)
def velocity_of(v, x, sd, T, S, nu, factored=False):
    """nu = M_vv^-1 (h - M_vs s_dot), eq. (K3), for one vehicle's state x (17,)."""
    if not factored:
        factor(v, x, T, S)
    mvs, rhs = S[2], S[3]
    for m in range(6):
        acc = x[7 + m]
        for i in range(4):
            acc -= mvs[m, i] * sd[i]
        rhs[m] = acc
    solve6(S[4], rhs, S[5], nu)


@njit(**_LEAF)
def plates(v, cs, p, cen, nor):
    """Centroids and normals (5, 3) of the centre plate and the wings."""
    hw3 = p[v, P_HW] / 3.0
    half = p[v, P_HALF_SIDE]
    cen[0, :] = 0.0
    nor[0, 0] = 0.0
    nor[0, 1] = 0.0
    nor[0, 2] = 1.0
    for i in range(4):
        c = cs[i, 0]
        si = cs[i, 1]
        for k in range(3):
            cen[1 + i, k] = (half + hw3 * c) * RADIAL[i, k]
            nor[1 + i, k] = si * RADIAL[i, k]
        cen[1 + i, 2] -= hw3 * si
        nor[1 + i, 2] += c


@njit(**_LEAF)
def centres(v, s, p, cen, rg, rb):
    """r_G and r_B from O: the wings' centroid offsets move both."""
    for k in range(3):
        off = 0.0
        for i in range(4):
            off += cen[1 + i, k] - p[v, P_HALF_SIDE] * RADIAL[i, k]
        rg[k] = (p[v, P_MFIRST + k] + p[v, P_MWING] * off) / p[v, P_MASS]
        rb[k] = (p[v, P_VFIRST + k] + p[v, P_VWING] * off) / p[v, P_VOLUME]


@njit(**_LEAF)
def water_at(opt, depth, out):
    """Current (NED) at a depth; zero when off."""
    if opt[O_CURRENT] > 0.0:
        for k in range(3):
            out[k] = opt[O_CUR_V + k] + opt[O_CUR_SHEAR + k] * depth
    else:
        out[:] = 0.0


@njit(**_HOT)
def derivative(v, x, sd, T, S, dx, factored=False):
    """dx/dt (17,) of one vehicle whose wings move at sd (4,); ``factored``:
    S already holds ``factor`` of these wing angles."""
    p, opt = T[5], T[6]
    nu, r, cen, nor, vec, cs = S[6], S[7], S[8], S[9], S[10], S[11]
    velocity_of(v, x, sd, T, S, nu, factored)
    V = nu[0:3]
    W = nu[3:6]
    q = x[3:7]
    rotation(q, r)
    force = vec[_F]
    moment = vec[_M]
    force[:] = 0.0
    moment[:] = 0.0
    s = x[13:17]
    plates(v, cs, p, cen, nor)
    if opt[O_GRAVITY] > 0.0:
        # Weight at the CG, buoyancy at the CB; Gamma = R^T k.
        rg = vec[_RG]
        rb = vec[_RB]
        centres(v, s, p, cen, rg, rb)
        fw = vec[_TMP]
        fb = vec[_FP]
        wgt = p[v, P_MASS] * p[v, P_G]
        buo = p[v, P_RHO] * p[v, P_VOLUME] * p[v, P_G]
        for k in range(3):
            fw[k] = wgt * r[2, k]
            fb[k] = -buo * r[2, k]
            force[k] += fw[k] + fb[k]
        add_cross(rg, fw, moment)
        add_cross(rb, fb, moment)
    water = vec[_WATER]
    water_at(opt, x[2], water)
    if opt[O_DRAG] > 0.0:
        _drag(v, cs, sd, V, W, r, water, p, cen, nor, vec, force, moment)
    if opt[O_BOTTOM] > 0.0:
        _bottom(v, x, V, W, r, p, opt, vec, force, moment)
    if opt[O_CURRENT] > 0.0:
        # Sheared current: the rigid mass is carried with the water it crosses.
        vz = r[2, 0] * V[0] + r[2, 1] * V[1] + r[2, 2] * V[2] + water[2]
        rg = vec[_RG]
        rb = vec[_RB]
        centres(v, s, p, cen, rg, rb)
        f = vec[_FP]
        for k in range(3):
            f[k] = -p[v, P_MASS] * vz * (r[0, k] * opt[O_CUR_SHEAR] + r[1, k] * opt[O_CUR_SHEAR + 1]
                                          + r[2, k] * opt[O_CUR_SHEAR + 2])
            force[k] += f[k]
        add_cross(rg, f, moment)
    # Kinematics and the Kirchhoff equations (K1), (K2).
    for k in range(3):
        dx[k] = r[k, 0] * V[0] + r[k, 1] * V[1] + r[k, 2] * V[2] + water[k]
    w, a, b, c = q[0], q[1], q[2], q[3]
    dx[3] = 0.5 * (-a * W[0] - b * W[1] - c * W[2])
    dx[4] = 0.5 * (w * W[0] + b * W[2] - c * W[1])
    dx[5] = 0.5 * (w * W[1] - a * W[2] + c * W[0])
    dx[6] = 0.5 * (w * W[2] + a * W[1] - b * W[0])
    for k in range(3):
        dx[7 + k] = force[k]
        dx[10 + k] = moment[k]
    add_cross(x[7:10], W, dx[7:10])       # p x Omega
    add_cross(x[10:13], W, dx[10:13])     # pi x Omega
    add_cross(x[7:10], V, dx[10:13])      # p x V
    k = p[v, P_MUNK]
    if k != 1.0:
        # p x V holds the Munk moment (A V) x V, A the added mass of
        # translation (docs/design/glide-check.md, (G6)); the upper-left
        # block of M_vv is m I + A and m V x V = 0, so (M_tt V) x V is that
        # moment alone, and (k - 1) times it leaves k of it.
        mvv = S[1]
        u = vec[_TMP]
        for a in range(3):
            u[a] = (k - 1.0) * (mvv[a, 0] * V[0] + mvv[a, 1] * V[1] + mvv[a, 2] * V[2])
        add_cross(u, V, dx[10:13])
    for i in range(4):
        dx[13 + i] = sd[i]


@njit(**_HOT)
def _drag(v, cs, sd, V, W, r, water, p, cen, nor, vec, force, moment):
    """Plate-normal pressure drag at each centroid, skin friction, and the
    rotational drag of each plate about its in-plane axes."""
    hw3 = p[v, P_HW] / 3.0
    rho = p[v, P_RHO]
    wb = vec[_WB]
    u = vec[_U]
    f = vec[_FP]
    om = vec[_OM]
    for k in range(3):
        wb[k] = r[0, k] * water[0] + r[1, k] * water[1] + r[2, k] * water[2]
    for pl in range(5):
        # Centroid velocity through the water: translation, rotation, hinge rate.
        u[0] = V[0] - wb[0] + W[1] * cen[pl, 2] - W[2] * cen[pl, 1]
        u[1] = V[1] - wb[1] + W[2] * cen[pl, 0] - W[0] * cen[pl, 2]
        u[2] = V[2] - wb[2] + W[0] * cen[pl, 1] - W[1] * cen[pl, 0]
        if pl > 0:
            i = pl - 1
            for k in range(3):
                u[k] -= hw3 * sd[i] * cs[i, 1] * RADIAL[i, k]
            u[2] -= hw3 * sd[i] * cs[i, 0]
        un = u[0] * nor[pl, 0] + u[1] * nor[pl, 1] + u[2] * nor[pl, 2]
        area = p[v, P_AREA_C] if pl == 0 else p[v, P_AREA_W]
        fn = -0.5 * rho * p[v, P_CD] * area * un * abs(un)
        for k in range(3):
            f[k] = fn * nor[pl, k]
        if p[v, P_CF] > 0.0:
            ut0 = u[0] - un * nor[pl, 0]
            ut1 = u[1] - un * nor[pl, 1]
            ut2 = u[2] - un * nor[pl, 2]
            sp = math.sqrt(ut0 * ut0 + ut1 * ut1 + ut2 * ut2)
            kf = rho * p[v, P_CF] * area * sp   # both faces: 2 x 1/2
            f[0] -= kf * ut0
            f[1] -= kf * ut1
            f[2] -= kf * ut2
        for k in range(3):
            force[k] += f[k]
        add_cross(cen[pl], f, moment)
        # Rotational drag about the plate's in-plane axes (eq. 2.1, corrected).
        for k in range(3):
            om[k] = W[k]
        if pl > 0:
            for k in range(3):
                om[k] += sd[pl - 1] * HINGE[pl - 1, k]
        on = om[0] * nor[pl, 0] + om[1] * nor[pl, 1] + om[2] * nor[pl, 2]
        for k in range(3):
            om[k] -= on * nor[pl, k]
        mag = math.sqrt(om[0] * om[0] + om[1] * om[1] + om[2] * om[2])
        krot = p[v, P_KROT_C] if pl == 0 else p[v, P_KROT_W]
        for k in range(3):
            moment[k] -= krot * mag * om[k]


@njit(**_LEAF)
def contact_point(v, s, idx, p, out):
    """Contact point idx (0-3 plate corners, 4-7 wing tips), body frame."""
    h = p[v, P_HALF_SIDE]
    if idx < 4:
        out[0] = h if idx == 0 or idx == 3 else -h
        out[1] = h if idx < 2 else -h
        out[2] = 0.0
    else:
        i = idx - 4
        c = math.cos(s[i])
        hw = p[v, P_HW]
        for k in range(3):
            out[k] = (h + hw * c) * RADIAL[i, k]
        out[2] -= hw * math.sin(s[i])


@njit(**_HOT)
def _bottom(v, x, V, W, r, p, opt, vec, force, moment):
    """Spring-damper contact with Coulomb friction at every point below the bottom."""
    pt = vec[_PT]
    vb = vec[_VB]
    vw = vec[_VW]
    fb = vec[_FP]
    for idx in range(8):
        contact_point(v, x[13:17], idx, p, pt)
        pen = x[2] + r[2, 0] * pt[0] + r[2, 1] * pt[1] + r[2, 2] * pt[2] - opt[O_DEPTH]
        if pen <= 0.0:
            continue
        vb[0] = V[0] + W[1] * pt[2] - W[2] * pt[1]
        vb[1] = V[1] + W[2] * pt[0] - W[0] * pt[2]
        vb[2] = V[2] + W[0] * pt[1] - W[1] * pt[0]
        for k in range(3):
            vw[k] = r[k, 0] * vb[0] + r[k, 1] * vb[1] + r[k, 2] * vb[2]
        normal = opt[O_STIFF] * pen + opt[O_DAMP] * vw[2]
        if normal < 0.0:
            normal = 0.0
        speed = math.sqrt(vw[0] * vw[0] + vw[1] * vw[1] + opt[O_SLIP] * opt[O_SLIP])
        f0 = -opt[O_MU] * normal * vw[0] / speed
        f1 = -opt[O_MU] * normal * vw[1] / speed
        f2 = -normal
        for k in range(3):
            fb[k] = r[0, k] * f0 + r[1, k] * f1 + r[2, k] * f2
            force[k] += fb[k]
        add_cross(pt, fb, moment)


@njit(**_LEAF)
def servo_state(p, v, s0, cmd, t, s_out, sd_out):
    """Exact servo response a time t after s0 under a constant command:
    ramp at the rate limit while |error| > rate * tau, then first-order lag."""
    tau = p[v, P_TAU]
    rate = p[v, P_RATE]
    for i in range(4):
        target = min(max(cmd[i], p[v, P_SMIN]), p[v, P_SMAX])
        err0 = target - s0[i]
        sign = 1.0 if err0 > 0.0 else (-1.0 if err0 < 0.0 else 0.0)
        t1 = max(0.0, (abs(err0) - rate * tau) / rate)
        if t < t1:
            s_out[i] = s0[i] + sign * rate * t
            sd_out[i] = sign * rate
        else:
            e1 = sign * min(abs(err0), rate * tau)
            decay = math.exp(-(t - t1) / tau)
            s_out[i] = target - e1 * decay
            sd_out[i] = e1 * decay / tau


@njit(**_LEAF)
def servo_rate(p, v, s, cmd, out):
    """The servo model as an ODE: s_dot = clip((clip(cmd) - s) / tau, +-rate)."""
    for i in range(4):
        target = min(max(cmd[i], p[v, P_SMIN]), p[v, P_SMAX])
        rr = (target - s[i]) / p[v, P_TAU]
        lim = p[v, P_RATE]
        out[i] = min(max(rr, -lim), lim)


@njit(**_HOT)
def rk4_one(v, x, cmd, dt, T, S, ks, out, factored=False):
    """One RK4 step of one vehicle, the servo solved exactly over the step.
    ks (4, 17) stage derivatives, ks scratch rows 4..8 hold y and servo data.
    ``factored``: S holds ``factor`` of x's wing angles, as the previous
    step's last stage leaves it (its wing angles are this step's first)."""
    p = T[5]
    k1, k2, k3, k4, y = ks[0], ks[1], ks[2], ks[3], ks[4]
    s_mid, sd_mid, s_end, sd_end, sd0 = ks[5, 0:4], ks[5, 4:8], ks[5, 8:12], ks[5, 12:16], ks[6, 0:4]
    s0 = x[13:17]
    servo_rate(p, v, s0, cmd, sd0)
    servo_state(p, v, s0, cmd, 0.5 * dt, s_mid, sd_mid)
    servo_state(p, v, s0, cmd, dt, s_end, sd_end)
    derivative(v, x, sd0, T, S, k1, factored)
    for j in range(13):
        y[j] = x[j] + 0.5 * dt * k1[j]
    for i in range(4):
        y[13 + i] = s_mid[i]
    derivative(v, y, sd_mid, T, S, k2)
    for j in range(13):
        y[j] = x[j] + 0.5 * dt * k2[j]
    derivative(v, y, sd_mid, T, S, k3, True)   # same wing angles as stage 2
    for j in range(13):
        y[j] = x[j] + dt * k3[j]
    for i in range(4):
        y[13 + i] = s_end[i]
    derivative(v, y, sd_end, T, S, k4)
    for j in range(13):
        out[j] = x[j] + dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    for i in range(4):
        out[13 + i] = s_end[i]
    nq = math.sqrt(out[3] ** 2 + out[4] ** 2 + out[5] ** 2 + out[6] ** 2)
    for j in range(3, 7):
        out[j] /= nq


@njit(**_JIT)
def rk4(x, cmd, dt, T, out):
    """One RK4 step of every vehicle. Serial: it is the step of one vehicle
    in lockstep with a controller or the twin (batches go through
    ``advance``, parallel and with scratch made once per vehicle)."""
    S = _scratch()
    ks = np.empty((7, 17))
    for m in range(x.shape[0]):
        rk4_one(table_of(T, m), x[m], cmd[m], dt, T, S, ks, out[m])


@njit(**_HOT)
def record(v, x, cmd, T, S, sd, nu, out3, factored=False):
    """Wing rates, velocities, IMU NED velocity (out3[0]) and pressure-port
    depth (out3[1, 0]) of one vehicle, for the recorded run (``factored``:
    as in ``rk4_one``)."""
    p = T[5]
    servo_rate(p, v, x[13:17], cmd, sd)
    velocity_of(v, x, sd, T, S, nu, factored)
    r = S[7]
    rotation(x[3:7], r)
    vec = S[10]
    vb = vec[_VB]
    imu = p[v, P_IMU:P_IMU + 3]
    vb[0] = nu[0] + nu[4] * imu[2] - nu[5] * imu[1]
    vb[1] = nu[1] + nu[5] * imu[0] - nu[3] * imu[2]
    vb[2] = nu[2] + nu[3] * imu[1] - nu[4] * imu[0]
    water = vec[_WATER]
    water_at(T[6], x[2], water)
    for k in range(3):
        out3[0, k] = r[k, 0] * vb[0] + r[k, 1] * vb[1] + r[k, 2] * vb[2] + water[k]
    port = p[v, P_PORT:P_PORT + 3]
    out3[1, 0] = x[2] + r[2, 0] * port[0] + r[2, 1] * port[1] + r[2, 2] * port[2]


def advance(x, cmd, dt, rows, every, T, xs, sds, nus, vimu, depth):
    """``rows * every`` RK4 steps of every vehicle with commands held,
    recording every ``every``-th step the state, wing rates, velocities, IMU
    NED velocity and sensor depth into xs[k], sds[k], nus[k], vimu[k],
    depth[k] (k = 1..rows; index 0 must hold the start). x is left at the
    final state. Runs on numba's threads (``numba.set_num_threads``); one
    vehicle on the caller's alone: a launch wakes and joins every thread of
    the pool even when only one has work, 1-4 ms on a busy machine against
    ~40 us of work (the estimator's standard truth, 12,000 calls: 49 s with
    a pool of two, 0.54 s without; the same numbers)."""
    parts = shares(x.shape[0])
    threads = numba.get_num_threads()
    if parts == 1 and threads > 1:
        numba.set_num_threads(1)
        try:
            _advance(x, cmd, dt, rows, every, T, xs, sds, nus, vimu, depth, 1)
        finally:
            numba.set_num_threads(threads)
        return
    _advance(x, cmd, dt, rows, every, T, xs, sds, nus, vimu, depth, parts)


def shares(n: int) -> int:
    """Into how many shares ``advance`` splits n vehicles: one a thread of
    the caller's (``numba.get_num_threads``), never an empty one."""
    return min(n, numba.get_num_threads())


def advance_from_cache() -> bool:
    """Whether this process loaded the batch kernel from numba's disk cache
    (else it compiled it, or has not called it yet)."""
    return bool(_advance.stats.cache_hits)


@njit(parallel=True, **_JIT)
def _advance(x, cmd, dt, rows, every, T, xs, sds, nus, vimu, depth, parts):
    """``advance`` in ``parts`` contiguous shares of the vehicles, one a
    thread, each with scratch of its own. A vehicle's arithmetic is the same
    whichever thread runs it and nothing is summed across vehicles, so the
    result does not depend on the number of threads. (The count comes from
    the caller: a kernel that asks numba for it cannot be cached.)"""
    n = x.shape[0]
    for b in prange(parts):
        S = _scratch()
        ks = np.empty((7, 17))
        out3 = np.empty((2, 3))
        cur = np.empty(17)
        nxt = np.empty(17)
        for m in range(b * n // parts, (b + 1) * n // parts):
            _advance_one(table_of(T, m), m, x, cmd, dt, rows, every, T, xs, sds, nus, vimu, depth,
                         S, ks, out3, cur, nxt)


@njit(**_HOT)
def _advance_one(v, m, x, cmd, dt, rows, every, T, xs, sds, nus, vimu, depth, S, ks, out3, cur, nxt):
    """``advance`` for vehicle m in scratch the caller made. Compiled
    without the runtime's reference counts: every view took an atomic
    add on a count (of the tables, the command, the scratch), a sixth of
    the batch's time."""
    c = cmd[m]
    for j in range(17):
        cur[j] = xs[0, m, j]
    # A step ends with the inertia factored at its final wing angles, the
    # next step's first: two factorisations a step, not three.
    factored = False
    for k in range(1, rows + 1):
        for _ in range(every):
            rk4_one(v, cur, c, dt, T, S, ks, nxt, factored)
            factored = True
            for j in range(17):
                cur[j] = nxt[j]
        for j in range(17):
            xs[k, m, j] = cur[j]
        record(v, cur, c, T, S, sds[k, m], nus[k, m], out3, True)
        for j in range(3):
            vimu[k, m, j] = out3[0, j]
        depth[k, m] = out3[1, 0]
    for j in range(17):
        x[m, j] = cur[j]


@njit(**_HOT)
def table_of(T, m):
    """Row of the tables for vehicle m: 0 when the batch shares one vehicle."""
    return 0 if T[0].shape[0] == 1 else m


@njit(**_JIT)
def record_all(x, cmd, T, sd, nu, vimu, depth):
    """``record`` for every vehicle at one instant."""
    S = _scratch()
    out3 = np.empty((2, 3))
    for m in range(x.shape[0]):
        v = table_of(T, m)
        record(v, x[m], cmd[m], T, S, sd[m], nu[m], out3)
        vimu[m, :] = out3[0]
        depth[m] = out3[1, 0]


@njit(**_JIT)
def rhs(x, cmd, T, out):
    """dx/dt of every vehicle with the servos as part of the ODE."""
    S = _scratch()
    sd = np.empty(4)
    for m in range(x.shape[0]):
        v = table_of(T, m)
        servo_rate(T[5], v, x[m, 13:17], cmd[m], sd)
        derivative(v, x[m], sd, T, S, out[m])


@njit(**_JIT)
def body_rhs(x, sd, T, out):
    """dx/dt of every vehicle with given wing rates sd (N, 4)."""
    S = _scratch()
    for m in range(x.shape[0]):
        v = table_of(T, m)
        derivative(v, x[m], sd[m], T, S, out[m])


@njit(**_JIT)
def velocities(x, sd, T, out):
    """nu (N, 6) of every vehicle with wing rates sd (N, 4)."""
    S = _scratch()
    for m in range(x.shape[0]):
        v = table_of(T, m)
        velocity_of(v, x[m], sd[m], T, S, out[m])


@njit(**_JIT)
def inertia(s, T, mvv, mvs):
    """M_vv (N, 6, 6) and M_vs (N, 6, 4) at wing angles s (N, 4)."""
    basis = np.empty((4, NB))
    cs = np.empty((4, 2))
    for m in range(s.shape[0]):
        v = table_of(T, m)
        trig(s[m], cs)
        inertia_into(v, cs, T, basis, mvv[m], mvs[m])
