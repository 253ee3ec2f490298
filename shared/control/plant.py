"""The vehicle's equations of motion on the board, for model-based control.

A pure Python port of the right-hand side of ``sim/kernels.py`` (the
derivation is ``sim/dynamics.py``'s), on the constants ``plant_tables``
copies from the model: the thesis's backstepping controller needs the
drift ``F_b`` and the input matrix ``G_b`` of its eq. 4.2 at the current
state. In velocities ``nu = (V, Omega)`` with the wing rates ``s_dot``:

    h = (p, pi) = M_vv(s) nu + M_vs(s) s_dot                      (K3)
    p_dot = p x Omega + F,  pi_dot = pi x Omega + p x V + tau      (K1), (K2)
    nu_dot = M_vv^-1 (h_dot - dM_vv/dt nu - dM_vs/dt s_dot - M_vs s_ddot)

so ``drift`` is nu_dot at s_ddot = 0 and ``reaction`` is -M_vv^-1 M_vs,
the acceleration per unit wing acceleration (the added-mass reaction, the
only way the thesis's inputs act). Forces: weight at the CG and buoyancy at
the CB, plate-normal drag at every plate's centroid velocity (translation,
rotation, hinge rate), rotational drag about each plate's in-plane axes; no
current, no bottom, no skin friction. Body frame, SI units, still water.

Board code, buffers made once; a call boxes a few thousand floats on a
board (it is the comparison controller's model, not the flight path).
"""

import math
from array import array

from roboray.shared.control import plant_tables as T

# outward direction r_i and hinge axis t_i = z x r_i of wing i (x, y only)
_RX = (1.0, 0.0, -1.0, 0.0)
_RY = (0.0, 1.0, 0.0, -1.0)
_TX = (0.0, -1.0, 0.0, 1.0)
_TY = (1.0, 0.0, -1.0, 0.0)


class Plant:
    """Inertia, forces and accelerations of the vehicle (board code)."""

    def __init__(self):
        self.mvv = array("f", [0.0] * 36)     #: M_vv, row-major
        self.mvs = array("f", [0.0] * 24)     #: M_vs (6x4), row-major
        self.dmvv = array("f", [0.0] * 36)    #: dM_vv/dt
        self.dmvs = array("f", [0.0] * 24)    #: dM_vs/dt
        self.force = array("f", [0.0] * 6)    #: (F, tau) about O, body frame
        self.h = array("f", [0.0] * 6)        #: momenta (p, pi)
        self._basis = array("f", [0.0] * 36)  # 4 wings x 9
        self._dbasis = array("f", [0.0] * 36)
        self._cs = array("f", [0.0] * 8)      # cos s_i, sin s_i
        self._l = array("f", [0.0] * 36)      # Cholesky factor of M_vv
        self._y = array("f", [0.0] * 6)
        self._b = array("f", [0.0] * 6)
        self._cen = array("f", [0.0] * 15)    # plate centroids (5 x 3)
        self._nor = array("f", [0.0] * 15)    # plate normals
        # the Fourier values as floats once (tuples of the generated module)
        self._c0 = array("f", T.C0)
        self._vv = array("f", T.VV_VALUE)
        self._vs = array("f", T.VS_VALUE)

    # ------------------------------------------------------------ inertia
    def inertia(self, s, sd):
        """M_vv, M_vs and their rates of change for wing angles ``s`` and
        rates ``sd`` (4 each, rad and rad/s)."""
        cs = self._cs
        for i in range(4):
            cs[2 * i] = math.cos(s[i])
            cs[2 * i + 1] = math.sin(s[i])
            _basis(cs[2 * i], cs[2 * i + 1], sd[i], self._basis, self._dbasis, 9 * i)
        mvv = self.mvv
        dmvv = self.dmvv
        c0 = self._c0
        for k in range(36):
            mvv[k] = c0[k]
            dmvv[k] = 0.0
        b = self._basis
        db = self._dbasis
        vv = self._vv
        wing = T.VV_WING
        basis = T.VV_BASIS
        flat = T.VV_FLAT
        for t in range(len(wing)):
            j = 9 * wing[t] + basis[t]
            k = flat[t]
            mvv[k] += b[j] * vv[t]
            dmvv[k] += db[j] * vv[t]
        for a in range(6):
            for c in range(a + 1, 6):
                mvv[6 * c + a] = mvv[6 * a + c]
                dmvv[6 * c + a] = dmvv[6 * a + c]
        mvs = self.mvs
        dmvs = self.dmvs
        for k in range(24):
            mvs[k] = 0.0
            dmvs[k] = 0.0
        vs = self._vs
        wing = T.VS_WING
        basis = T.VS_BASIS
        row = T.VS_ROW
        for t in range(len(wing)):
            w = wing[t]
            j = 9 * w + basis[t]
            k = 4 * row[t] + w
            mvs[k] += b[j] * vs[t]
            dmvs[k] += db[j] * vs[t]
        _cholesky6(mvv, self._l)

    # ------------------------------------------------------------- forces
    def forces(self, s, sd, V, W, gamma):
        """(F, tau) about O into ``force``: weight and buoyancy for the
        gravity direction ``gamma`` (body frame, unit), drag. Call
        ``inertia`` first (it fills the wings' trig)."""
        cs = self._cs
        cen = self._cen
        nor = self._nor
        hw3 = T.HW / 3.0
        half = T.HALF_SIDE
        # plates: centre (normal z) and the wings
        for k in range(3):
            cen[k] = 0.0
        nor[0] = 0.0
        nor[1] = 0.0
        nor[2] = 1.0
        for i in range(4):
            c = cs[2 * i]
            si = cs[2 * i + 1]
            o = 3 + 3 * i
            cen[o] = (half + hw3 * c) * _RX[i]
            cen[o + 1] = (half + hw3 * c) * _RY[i]
            cen[o + 2] = -hw3 * si
            nor[o] = si * _RX[i]
            nor[o + 1] = si * _RY[i]
            nor[o + 2] = c
        f = self.force
        # weight at the CG, buoyancy at the CB (the wings move both)
        ox = 0.0
        oy = 0.0
        oz = 0.0
        for i in range(4):
            o = 3 + 3 * i
            ox += cen[o] - half * _RX[i]
            oy += cen[o + 1] - half * _RY[i]
            oz += cen[o + 2]
        gx = (T.M_FIRST[0] + T.M_WING * ox) / T.MASS
        gy = (T.M_FIRST[1] + T.M_WING * oy) / T.MASS
        gz = (T.M_FIRST[2] + T.M_WING * oz) / T.MASS
        bx = (T.V_FIRST[0] + T.V_WING * ox) / T.VOLUME
        by = (T.V_FIRST[1] + T.V_WING * oy) / T.VOLUME
        bz = (T.V_FIRST[2] + T.V_WING * oz) / T.VOLUME
        wgt = T.MASS * T.G
        buo = T.RHO * T.VOLUME * T.G
        fx = wgt * gamma[0]
        fy = wgt * gamma[1]
        fz = wgt * gamma[2]
        f[0] = fx - buo * gamma[0]
        f[1] = fy - buo * gamma[1]
        f[2] = fz - buo * gamma[2]
        # r_G x weight + r_B x buoyancy (buoyancy = -buo gamma)
        f[3] = gy * fz - gz * fy - buo * (by * gamma[2] - bz * gamma[1])
        f[4] = gz * fx - gx * fz - buo * (bz * gamma[0] - bx * gamma[2])
        f[5] = gx * fy - gy * fx - buo * (bx * gamma[1] - by * gamma[0])
        half_rho_cd = 0.5 * T.RHO * T.CD
        for pl in range(5):
            o = 3 * pl
            cx = cen[o]
            cy = cen[o + 1]
            cz = cen[o + 2]
            nx = nor[o]
            ny = nor[o + 1]
            nz = nor[o + 2]
            # centroid velocity through the water, less the hinge motion
            ux = V[0] + W[1] * cz - W[2] * cy
            uy = V[1] + W[2] * cx - W[0] * cz
            uz = V[2] + W[0] * cy - W[1] * cx
            if pl > 0:
                hs = hw3 * sd[pl - 1]
                ux -= hs * nx
                uy -= hs * ny
                uz -= hs * nz
            un = ux * nx + uy * ny + uz * nz
            area = T.AREA_C if pl == 0 else T.AREA_W
            fn = -half_rho_cd * area * un * abs(un)
            px = fn * nx
            py = fn * ny
            pz = fn * nz
            f[0] += px
            f[1] += py
            f[2] += pz
            f[3] += cy * pz - cz * py
            f[4] += cz * px - cx * pz
            f[5] += cx * py - cy * px
            # rotational drag about the in-plane axes (eq. 2.1, corrected)
            ox = W[0]
            oy = W[1]
            oz = W[2]
            if pl > 0:
                ox += sd[pl - 1] * _TX[pl - 1]
                oy += sd[pl - 1] * _TY[pl - 1]
            on = ox * nx + oy * ny + oz * nz
            ox -= on * nx
            oy -= on * ny
            oz -= on * nz
            k = (T.KROT_C if pl == 0 else T.KROT_W) * math.sqrt(ox * ox + oy * oy + oz * oz)
            f[3] -= k * ox
            f[4] -= k * oy
            f[5] -= k * oz

    # ------------------------------------------------------- accelerations
    def drift(self, s, sd, V, W, gamma, out):
        """nu_dot (6) at zero wing acceleration into ``out``: the drift of
        the thesis's eq. 2.8-2.9 (its F_b)."""
        self.inertia(s, sd)
        self.forces(s, sd, V, W, gamma)
        mvv = self.mvv
        mvs = self.mvs
        dmvv = self.dmvv
        dmvs = self.dmvs
        h = self.h
        for r in range(6):
            acc = 0.0
            for c in range(3):
                acc += mvv[6 * r + c] * V[c] + mvv[6 * r + 3 + c] * W[c]
            for i in range(4):
                acc += mvs[4 * r + i] * sd[i]
            h[r] = acc
        f = self.force
        b = self._b
        # (K1), (K2)
        b[0] = f[0] + h[1] * W[2] - h[2] * W[1]
        b[1] = f[1] + h[2] * W[0] - h[0] * W[2]
        b[2] = f[2] + h[0] * W[1] - h[1] * W[0]
        b[3] = f[3] + h[4] * W[2] - h[5] * W[1] + h[1] * V[2] - h[2] * V[1]
        b[4] = f[4] + h[5] * W[0] - h[3] * W[2] + h[2] * V[0] - h[0] * V[2]
        b[5] = f[5] + h[3] * W[1] - h[4] * W[0] + h[0] * V[1] - h[1] * V[0]
        for r in range(6):
            acc = b[r]
            for c in range(3):
                acc -= dmvv[6 * r + c] * V[c] + dmvv[6 * r + 3 + c] * W[c]
            for i in range(4):
                acc -= dmvs[4 * r + i] * sd[i]
            b[r] = acc
        _solve6(self._l, b, self._y, out)

    def reaction(self, out):
        """-M_vv^-1 M_vs (6x4, row-major) into ``out``: the body's
        acceleration per unit wing acceleration, at the angles of the last
        ``inertia`` call."""
        b = self._b
        y = self._y
        col = self.h
        for i in range(4):
            for r in range(6):
                b[r] = -self.mvs[4 * r + i]
            _solve6(self._l, b, y, col)
            for r in range(6):
                out[4 * r + i] = col[r]


def _basis(c1, s1, rate, out, dout, o):
    """Fourier basis of one wing angle (1, cos ks, sin ks, k = 1..4) and its
    time derivative at the wing rate ``rate``, at ``out[o:o+9]``."""
    c2 = c1 * c1 - s1 * s1
    s2 = 2.0 * s1 * c1
    c3 = c2 * c1 - s2 * s1
    s3 = s2 * c1 + c2 * s1
    c4 = c2 * c2 - s2 * s2
    s4 = 2.0 * s2 * c2
    out[o] = 1.0
    out[o + 1] = c1
    out[o + 2] = s1
    out[o + 3] = c2
    out[o + 4] = s2
    out[o + 5] = c3
    out[o + 6] = s3
    out[o + 7] = c4
    out[o + 8] = s4
    dout[o] = 0.0
    dout[o + 1] = -rate * s1
    dout[o + 2] = rate * c1
    dout[o + 3] = -2.0 * rate * s2
    dout[o + 4] = 2.0 * rate * c2
    dout[o + 5] = -3.0 * rate * s3
    dout[o + 6] = 3.0 * rate * c3
    dout[o + 7] = -4.0 * rate * s4
    dout[o + 8] = 4.0 * rate * c4


def _cholesky6(a, l):
    """l l^T = a (6x6, row-major, symmetric positive definite)."""
    for i in range(6):
        for j in range(i + 1):
            acc = a[6 * i + j]
            for k in range(j):
                acc -= l[6 * i + k] * l[6 * j + k]
            if i == j:
                l[6 * i + i] = math.sqrt(acc)
            else:
                l[6 * i + j] = acc / l[6 * j + j]


def _solve6(l, b, y, out):
    """Solve l l^T x = b into ``out``; ``y`` is scratch."""
    for i in range(6):
        acc = b[i]
        for k in range(i):
            acc -= l[6 * i + k] * y[k]
        y[i] = acc / l[6 * i + i]
    for i in range(5, -1, -1):
        acc = y[i]
        for k in range(i + 1, 6):
            acc -= l[6 * k + i] * out[k]
        out[i] = acc / l[6 * i + i]
