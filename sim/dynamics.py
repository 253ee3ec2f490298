"""Equations of motion of RoboRay, vectorised over N vehicles.

Derivation (ours, from the kinetic energy; the printed eqs. 2.8-2.9 and
appendix A are not used: A's wing-3 row of A_2 uses r_CG_1, and B is
written both as -M^-1 D^T A and -C D^T J^-1). Quasi-velocities
``nu = (V, Omega)`` of the body origin O in the body frame, wing angles
``s`` and rates ``s_dot``. Every part is rigid, the fluid is ideal for the
added-mass part, so the kinetic energy of body plus fluid is

    T = 1/2 [nu; s_dot]^T  [[M_vv(s), M_vs(s)], [M_vs^T, M_ss(s)]]  [nu; s_dot]   (cf. eq. 2.7)

with ``M_vv`` the locked 6x6 inertia at O (rigid + added, eqs. 2.2-2.4) and
``M_vs`` the coupling of each hinge twist ``S_i = (h_i x t_i, t_i)``. T does
not depend on position or attitude, so the Euler-Poincare (Kirchhoff)
equations hold for the body-frame momenta ``p = dT/dV``, ``pi = dT/dOmega``
(the Kirchhoff impulse and angular impulse about O):

    p_dot  = p x Omega + F                                  (K1)
    pi_dot = pi x Omega + p x V + tau_O                     (K2)
    [V; Omega] = M_vv(s)^-1 ([p; pi] - M_vs(s) s_dot)       (K3)

The wings are position-driven by servos, so s(t) is prescribed by the servo
model and the shape equation only tells the servo torque. Integrating the
momenta instead of the velocities makes the reaction of moving wings exact
(a jump in s_dot is a jump in nu at constant momentum) and conservation
checks direct: with no external force, ``R p`` and ``R pi + b x R p`` are
constant in the inertial frame whatever the wings do.

External forces (body frame, about O): weight at the CG and buoyancy at the
CB, so the restoring moment is ``m_v g ell (z_c x Gamma)`` about the CB
(not the thesis's ``m_v a_w ell``: buoyancy acts at the CB and gives no
moment about it, so the whole weight's arm counts); plate-normal pressure drag on every plate at
its centroid velocity (vehicle translation, rotation and the wing's own hinge
rate), ``-1/2 rho C_D A u_n |u_n| n`` (sec. 2.2.1); rotational pressure drag
of each plate about its in-plane axes (eq. 2.1, corrected: see
``rotational_drag_coefficient``); optional skin friction, water current and
a tank bottom.

State of each vehicle, 17 numbers: ``b`` (NED position of O, 3), ``q``
(body -> NED quaternion [w, x, y, z], 4), ``p`` (3), ``pi`` (3), ``s`` (4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from roboray.sim import kernels
from roboray.sim.vehicle import Vehicle, VehicleParams

STATE_SIZE = 17
POS = slice(0, 3)
QUAT = slice(3, 7)
MOM = slice(7, 13)
LIN = slice(7, 10)
ANG = slice(10, 13)
WINGS = slice(13, 17)

#: Fourier degree of the inertia in each wing angle: products of two
#: rotations (the added mass n n^T) seen from two lever arms give degree 4.
FOURIER_DEGREE = 4
_NB = 2 * FOURIER_DEGREE + 1


def rotational_drag_coefficient(rho: float, cd: float, area: float) -> float:
    """K in M = -K |w| w for a plate turning about an in-plane axis.

    Eq. 2.1 as printed, 1/2 C_D rho int_0^rp (2 pi r)(w r)^2 dr, is a force
    (N), not a moment, and takes the local speed as w r, which holds for a
    disc turning about its normal, where the flow is in-plane and makes no
    pressure drag. For a disc of the same area (r_p = sqrt(A/pi), as eq. 2.1
    does) turning about a diameter, a point at distance y from the axis
    meets the flow at w|y| and its drag has lever arm y:
    M = 1/2 rho C_D w^2 int |y|^3 dA = 4/15 rho C_D r_p^5 w^2.
    """
    rp = math.sqrt(area / math.pi)
    return 4.0 / 15.0 * rho * cd * rp ** 5


@dataclass(frozen=True)
class Current:
    """Horizontal water current, NED, possibly varying with depth.

    ``velocity`` at depth 0 and ``shear`` (1/s) its change per metre of depth:
    w(z) = velocity + shear * z. A uniform current (shear 0) is exact: the
    equations hold in the water's frame. With shear, the fluid forces use the
    velocity relative to the local water and the rigid mass is accelerated
    with the water it crosses (added-mass effects of the shear are neglected).
    """

    velocity: tuple = (0.0, 0.0, 0.0)
    shear: tuple = (0.0, 0.0, 0.0)

    def at(self, depth: np.ndarray) -> np.ndarray:
        return np.asarray(self.velocity) + np.asarray(self.shear) * depth[..., None]


@dataclass(frozen=True)
class Bottom:
    """A flat tank bottom at ``depth`` (m, NED z), felt at the plate corners
    and the wing tips through a spring-damper with Coulomb friction.

    The friction is regularised: ``mu N v / sqrt(v^2 + slip_speed^2)``, so
    below ``slip_speed`` it is a damper of ``mu N / slip_speed`` a point.
    The explicit RK4 step must resolve that damper: on the real axis RK4 is
    stable for ``h lambda > -2.785``, and a resting vehicle whose friction
    mode lies beyond that does not stop; the step map settles instead on a
    spurious cycle that keeps momentum (the sensors read it) and creeps. At
    1 mm/s and the 10 ms step both vehicles resting with wings 0,0,90,90
    yawed 15 deg in 15 s with 52-69 mrad/s of body rate (the twin's gyro
    read it: issue 26 item 6); the yaw mode is the stiffest (tips 0.19-0.25
    m out, little yaw inertia). Resting in the twin's world as
    tests/test_bottom_rest.py sets it, the reference vehicle was still from
    5 mm/s and the buildable one from 20 mm/s (wings 0,0,90,90); 30 mm/s
    keeps a margin. Friction at a landing's
    ~0.1 m/s is still 96 % of Coulomb's; what the regularisation costs is
    a creep under a steady sideways force below ``mu N`` (a current), of
    about ``slip_speed F / (mu N)`` where a real bottom would hold."""

    depth: float
    stiffness: float = 500.0   #: N/m per contact point
    damping: float = 15.0      #: N s/m per contact point
    friction: float = 0.5      #: -, Coulomb coefficient
    slip_speed: float = 0.03   #: m/s, regularisation of the friction law (see above)


def _basis(s: np.ndarray) -> np.ndarray:
    """[1, cos ks, sin ks for k = 1..4] for angles s (...,) -> (..., 9)."""
    c1 = np.cos(s)
    s1 = np.sin(s)
    c2 = c1 * c1 - s1 * s1
    s2 = 2.0 * s1 * c1
    out = np.empty(s.shape + (_NB,))
    out[..., 0] = 1.0
    out[..., 1] = c1
    out[..., 2] = s1
    out[..., 3] = c2
    out[..., 4] = s2
    out[..., 5] = c2 * c1 - s2 * s1
    out[..., 6] = s2 * c1 + c2 * s1
    out[..., 7] = c2 * c2 - s2 * s2
    out[..., 8] = 2.0 * s2 * c2
    return out


def _basis_derivative(s: np.ndarray) -> np.ndarray:
    """d/ds of ``_basis``."""
    b = _basis(s)
    d = np.zeros_like(b)
    for k in range(1, FOURIER_DEGREE + 1):
        d[..., 2 * k - 1] = -k * b[..., 2 * k]      # d/ds cos ks = -k sin ks
        d[..., 2 * k] = k * b[..., 2 * k - 1]       # d/ds sin ks = k cos ks
    return d


def _turn(i: int) -> np.ndarray:
    """6x6 map of a twist or inertia by i quarter turns about z_c (exact)."""
    c, s = [(1, 0), (0, 1), (-1, 0), (0, -1)][i]
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=float)
    q = np.zeros((6, 6))
    q[:3, :3] = rz
    q[3:, 3:] = rz
    return q


def _fourier(samples: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Least-squares Fourier coefficients (9, ...) of samples (K, ...)."""
    b = _basis(angles)  # (K, 9)
    flat = samples.reshape(len(angles), -1)
    coef, *_ = np.linalg.lstsq(b, flat, rcond=None)
    return coef.reshape((_NB,) + samples.shape[1:])


class Model:
    """N vehicles' equations of motion with their options.

    Parameters
    ----------
    vehicles:
        One ``Vehicle``/``VehicleParams`` (N = 1), or a sequence of them (a
        batch, e.g. a Monte Carlo over parameters). ``n`` copies of one
        vehicle share its precomputed tables.
    current, bottom:
        Optional water current and tank bottom (off by default).
    """

    def __init__(self, vehicles, n: Optional[int] = None,
                 current: Optional[Current] = None, bottom: Optional[Bottom] = None,
                 gravity: bool = True, drag: bool = True) -> None:
        if isinstance(vehicles, (Vehicle, VehicleParams)) or vehicles is None:
            vehicles = [vehicles]
        vlist = [v if isinstance(v, Vehicle) else Vehicle(v) for v in vehicles]
        if n is not None:
            if len(vlist) != 1:
                raise ValueError("n copies need exactly one vehicle, got %d" % len(vlist))
            self.n = int(n)
        else:
            self.n = len(vlist)
        if self.n < 1:
            raise ValueError("need at least one vehicle, got n=%d" % self.n)
        self.vehicles = vlist
        self.current = current
        self.bottom = bottom
        #: switches for validation: gravity and buoyancy, and all fluid drag
        self.gravity = gravity
        self.drag = drag
        self._tables(vlist)

    def single(self, i: int) -> "Model":
        """Vehicle i of this batch as a model of its own."""
        v = self.vehicles[i if len(self.vehicles) > 1 else 0]
        return Model(v, current=self.current, bottom=self.bottom, gravity=self.gravity, drag=self.drag)

    # ------------------------------------------------------------ tables
    def _tables(self, vlist: list[Vehicle]) -> None:
        """Per-vehicle constants for the kernels, stacked with a leading axis
        of 1 (shared) or N (a batch of different vehicles)."""
        angles = np.arange(16) * (2 * math.pi / 16)
        origin = np.zeros(3)
        c0, cvv, cvs, css, rows = [], [], [], [], []
        for v in vlist:
            p = v.p
            wings0 = np.zeros(4)
            # Centre body at O: everything but the wings (round-off cleared,
            # so a symmetric configuration stays exactly symmetric).
            centre = v.locked_inertia(wings0, origin) - sum(
                v.wing_inertia(i, wings0, origin) for i in range(4))
            centre[np.abs(centre) < 1e-14 * np.abs(centre).max()] = 0.0
            c0.append(centre.reshape(36))
            # Wing 1's inertia over a turn of its hinge, as a Fourier series;
            # wings 2-4 are wing 1 turned by 90 deg steps about z_c, which an
            # exact permutation-with-signs gives (no round-off between wings).
            samples = []
            for a in angles:
                w = np.zeros(4)
                w[0] = a
                samples.append(v.wing_inertia(0, w, origin))
            samples = np.array(samples)  # (16, 6, 6)
            twist0 = v.hinge_twists()[0]
            base_vv = _fourier(samples, angles)             # (9, 6, 6)
            base_vs = _fourier(samples @ twist0, angles)    # (9, 6)
            base_ss = _fourier(np.einsum("j,kjl,l->k", twist0, samples, twist0), angles)
            per_vv, per_vs, per_ss = [], [], []
            for i in range(4):
                q = _turn(i)
                per_vv.append(np.einsum("ab,kbc,dc->kad", q, base_vv, q).reshape(_NB, 36))
                per_vs.append(np.einsum("ab,kb->ka", q, base_vs))
                per_ss.append(base_ss)
            cvv.append(np.array(per_vv).reshape(4 * _NB, 36))
            cvs.append(np.array(per_vs))
            css.append(np.array(per_ss))
            row = np.zeros(kernels.NP)
            row[[kernels.P_MASS, kernels.P_RHO, kernels.P_G, kernels.P_CD, kernels.P_CF, kernels.P_VOLUME,
                 kernels.P_TAU, kernels.P_RATE, kernels.P_SMIN, kernels.P_SMAX, kernels.P_HW,
                 kernels.P_MWING, kernels.P_VWING, kernels.P_AREA_C, kernels.P_AREA_W,
                 kernels.P_KROT_C, kernels.P_KROT_W, kernels.P_HALF_SIDE]] = [
                v.mass, p.rho, p.g, p.cd, p.cf, v.volume, p.servo_tau, p.servo_rate, p.servo_min,
                p.servo_max, p.wing_height, v.mass_wing, v.volume_wing, v.area_center, v.area_wing,
                rotational_drag_coefficient(p.rho, p.cd, v.area_center),
                rotational_drag_coefficient(p.rho, p.cd, v.area_wing), 0.5 * p.plate_side]
            # First moments of mass and volume with the wings flat, less the
            # wings' centroid offsets (added back at each angle).
            row[kernels.P_MFIRST:kernels.P_MFIRST + 3] = sum(l.mass * l.centroid for l in v.lumps)
            row[kernels.P_VFIRST:kernels.P_VFIRST + 3] = sum(l.volume * l.volume_centroid for l in v.lumps)
            row[kernels.P_IMU:kernels.P_IMU + 3] = p.imu_position
            row[kernels.P_PORT:kernels.P_PORT + 3] = p.pressure_port
            row[kernels.P_MUNK] = p.munk_scale
            rows.append(row)
        self.C0 = np.ascontiguousarray(c0)      # (V, 36)
        self.Cvv = np.ascontiguousarray(cvv)    # (V, 36, 36)
        self.Cvs = np.ascontiguousarray(cvs)    # (V, 4, 9, 6)
        self.Css = np.ascontiguousarray(css)    # (V, 4, 9)
        self.P = np.ascontiguousarray(rows)     # (V, NP)
        # The kernels keep only the non-zero Fourier terms: the inertia is in
        # fact of degree 2 in each wing angle (a tenth of the dense table).
        tol = 1e-13 * max(1.0, float(np.abs(self.Cvv).max()))
        dense_vv = self.Cvv.reshape(-1, 4, _NB, 6, 6)
        upper = np.triu(np.ones((6, 6), bool))
        keep = (np.abs(dense_vv) > tol).any(axis=0) & upper
        vv_idx = np.argwhere(keep)                                  # (K, 4): wing, basis, row, col
        self.vv_idx = np.ascontiguousarray(np.column_stack([vv_idx[:, 0], vv_idx[:, 1],
                                                            vv_idx[:, 2] * 6 + vv_idx[:, 3]]))
        self.vv_val = np.ascontiguousarray(dense_vv[:, vv_idx[:, 0], vv_idx[:, 1], vv_idx[:, 2], vv_idx[:, 3]])
        keep_s = (np.abs(self.Cvs) > tol).any(axis=0)
        self.vs_idx = np.ascontiguousarray(np.argwhere(keep_s))    # (L, 3): wing, basis, row
        self.vs_val = np.ascontiguousarray(self.Cvs[:, self.vs_idx[:, 0], self.vs_idx[:, 1], self.vs_idx[:, 2]])
        vv_at = np.ascontiguousarray(vv_idx, dtype=np.uint32)            # the kernels' copies, unsigned
        vs_at = np.ascontiguousarray(self.vs_idx, dtype=np.uint32)
        col = lambda k: self.P[:, k:k + 1]      # noqa: E731 - (V, 1) views
        self.mass, self.rho, self.g = col(kernels.P_MASS), col(kernels.P_RHO), col(kernels.P_G)
        self.volume, self.tau, self.rate = col(kernels.P_VOLUME), col(kernels.P_TAU), col(kernels.P_RATE)
        self.smin, self.smax, self.hw = col(kernels.P_SMIN), col(kernels.P_SMAX), col(kernels.P_HW)
        self.m_wing, self.v_wing = col(kernels.P_MWING), col(kernels.P_VWING)
        self.m_first = self.P[:, kernels.P_MFIRST:kernels.P_MFIRST + 3]
        self.v_first = self.P[:, kernels.P_VFIRST:kernels.P_VFIRST + 3]
        self.imu = self.P[:, kernels.P_IMU:kernels.P_IMU + 3]
        self.port = self.P[:, kernels.P_PORT:kernels.P_PORT + 3]
        opt = np.zeros(kernels.NOPT)
        opt[kernels.O_GRAVITY] = 1.0 if self.gravity else 0.0
        opt[kernels.O_DRAG] = 1.0 if self.drag else 0.0
        if self.current is not None:
            opt[kernels.O_CURRENT] = 1.0
            opt[kernels.O_CUR_V:kernels.O_CUR_V + 3] = self.current.velocity
            opt[kernels.O_CUR_SHEAR:kernels.O_CUR_SHEAR + 3] = self.current.shear
        if self.bottom is not None:
            bt = self.bottom
            opt[[kernels.O_BOTTOM, kernels.O_DEPTH, kernels.O_STIFF, kernels.O_DAMP, kernels.O_MU,
                 kernels.O_SLIP]] = [1.0, bt.depth, bt.stiffness, bt.damping, bt.friction, bt.slip_speed]
        self.opt = opt
        #: everything the kernels need, as one tuple
        self.T = (self.C0, vv_at, self.vv_val, vs_at, self.vs_val, self.P, self.opt)

    # ------------------------------------------------------------ inertia
    def inertia(self, s: np.ndarray):
        """M_vv (N, 6, 6) and M_vs (N, 6, 4) at wing angles s (N, 4)."""
        s = np.ascontiguousarray(s, dtype=float)
        mvv = np.empty((len(s), 6, 6))
        mvs = np.empty((len(s), 6, 4))
        kernels.inertia(s, self.T, mvv, mvs)
        return mvv, mvs

    def inertia_rate(self, s: np.ndarray, s_dot: np.ndarray):
        """dM_vv/dt (N, 6, 6) and dM_vs/dt (N, 6, 4) for wing rates s_dot."""
        db = _basis_derivative(s) * s_dot[..., None]          # (N, 4, 9)
        dvv = np.einsum("...k,...km->...m", db.reshape(len(s), 4 * _NB), self.Cvv)
        dvs = np.einsum("...ij,...ijm->...mi", db, self.Cvs)
        return dvv.reshape(len(s), 6, 6), dvs

    def shape_inertia(self, s: np.ndarray) -> np.ndarray:
        """M_ss diagonal (N, 4): each wing's inertia about its hinge."""
        return np.einsum("...ij,...ij->...i", _basis(s), self.Css)

    def centres(self, s: np.ndarray):
        """r_G and r_B (N, 3) from O: the CG and CB move as the wings fold."""
        c, si = np.cos(s)[..., None], np.sin(s)[..., None]
        z = np.array([0.0, 0.0, 1.0])
        offset = ((self.hw / 3.0)[:, :, None] * (c * kernels.RADIAL - si * z)).sum(axis=1)   # (N, 3)
        r_g = (self.m_first + self.m_wing * offset) / self.mass
        r_b = (self.v_first + self.v_wing * offset) / self.volume
        return r_g, r_b

    def servo_rate(self, s: np.ndarray, command: np.ndarray) -> np.ndarray:
        """Wing rates (N, 4): first-order lag towards the command, rate-limited;
        commands beyond the travel are clipped to it."""
        target = np.clip(command, self.smin, self.smax)
        return np.clip((target - s) / self.tau, -self.rate, self.rate)

    # ------------------------------------------------------------ physics
    def velocities(self, x: np.ndarray, s_dot: np.ndarray) -> np.ndarray:
        """nu = (V, Omega) (N, 6) from the momenta, eq. (K3)."""
        out = np.empty((len(x), 6))
        kernels.velocities(np.ascontiguousarray(x, float), np.ascontiguousarray(s_dot, float), self.T, out)
        return out

    def body_rhs(self, x: np.ndarray, s_dot: np.ndarray) -> np.ndarray:
        """dx/dt (N, 17) for states x (N, 17) with the wings moving at s_dot."""
        out = np.empty_like(x, dtype=float)
        kernels.body_rhs(np.ascontiguousarray(x, float), np.ascontiguousarray(s_dot, float), self.T, out)
        return out

    def rhs(self, x: np.ndarray, command: np.ndarray) -> np.ndarray:
        """dx/dt (N, 17) with the servos as part of the ODE (wing commands (N, 4) rad)."""
        out = np.empty_like(x, dtype=float)
        kernels.rhs(np.ascontiguousarray(x, float), np.ascontiguousarray(command, float), self.T, out)
        return out

    def step(self, x: np.ndarray, command: np.ndarray, dt: float) -> np.ndarray:
        """One RK4 step of dt seconds, the servos solved exactly, commands held."""
        out = np.empty_like(x, dtype=float)
        kernels.rk4(np.ascontiguousarray(x, float), np.ascontiguousarray(command, float), float(dt), self.T, out)
        return out

    def water_velocity(self, x: np.ndarray) -> Optional[np.ndarray]:
        if self.current is None:
            return None
        return self.current.at(x[:, 2])

    def accelerations(self, x: np.ndarray, command: np.ndarray):
        """nu, nu_dot (N, 6) between servo command changes: differentiating (K3),
        nu_dot = M_vv^-1 (h_dot - dM_vv/dt nu - dM_vs/dt s_dot - M_vs s_ddot)."""
        s = x[:, WINGS]
        sd = self.servo_rate(s, command)
        target = np.clip(command, self.smin, self.smax)
        free = np.abs((target - s) / self.tau) < self.rate
        sdd = np.where(free, -sd / self.tau, 0.0)
        dx = self.body_rhs(x, sd)
        nu = self.velocities(x, sd)
        mvv, mvs = self.inertia(s)
        dvv, dvs = self.inertia_rate(s, sd)
        rhs = dx[:, MOM] - np.einsum("nij,nj->ni", dvv, nu) - np.einsum("nij,nj->ni", dvs, sd) \
            - np.einsum("nij,nj->ni", mvs, sdd)
        return nu, np.linalg.solve(mvv, rhs[..., None])[..., 0]

    def specific_force(self, x: np.ndarray, command: np.ndarray, point: np.ndarray) -> np.ndarray:
        """Instantaneous specific force (N, 3), body frame, at a body point (N, 3):
        a - g with a = V_dot + W x V + W_dot x r + W x (W x r)."""
        nu, nu_dot = self.accelerations(x, command)
        V, W = nu[:, :3], nu[:, 3:]
        r = np.broadcast_to(point, V.shape)
        acc = nu_dot[:, :3] + cross(W, V) + cross(nu_dot[:, 3:], r) + cross(W, cross(W, r))
        gamma = quat_to_rot(x[:, QUAT])[:, 2, :]
        return acc - self.g * gamma

    def contact_points(self, s: np.ndarray) -> np.ndarray:
        """Plate corners and wing tips (N, 8, 3), body frame."""
        n = len(s)
        half = self.P[:, kernels.P_HALF_SIDE][:, None, None]
        tips = half * kernels.RADIAL + self.hw[:, :, None] * (
            np.cos(s)[..., None] * kernels.RADIAL - np.sin(s)[..., None] * np.array([0.0, 0.0, 1.0]))
        corners = np.array([[1, 1, 0], [-1, 1, 0], [-1, -1, 0], [1, -1, 0]], float)
        pts = np.empty((n, 8, 3))
        pts[:, :4] = half * corners
        pts[:, 4:] = tips
        return pts

    def touching_bottom(self, x: np.ndarray) -> np.ndarray:
        """(N,) bool: a contact point is at or below the bottom."""
        if self.bottom is None:
            return np.zeros(len(x), dtype=bool)
        rot = quat_to_rot(x[:, QUAT])
        pts = self.contact_points(x[:, WINGS])
        z = x[:, None, 2] + np.einsum("nj,npj->np", rot[:, 2, :], pts)
        return (z >= self.bottom.depth).any(axis=1)

    # -------------------------------------------------------- constructors
    def state(self, position=(0, 0, 0), attitude=(1, 0, 0, 0), velocity=(0, 0, 0), rates=(0, 0, 0),
              wings=(0, 0, 0, 0), wing_rates=(0, 0, 0, 0)) -> np.ndarray:
        """States (N, 17) from velocities: momenta p, pi = M_vv nu + M_vs s_dot.
        Each argument is one vector for all vehicles or an (N, k) array."""
        n = self.n
        x = np.zeros((n, STATE_SIZE))
        x[:, POS] = np.broadcast_to(np.asarray(position, float), (n, 3))
        q = np.broadcast_to(np.asarray(attitude, float), (n, 4))
        x[:, QUAT] = q / np.linalg.norm(q, axis=1, keepdims=True)
        x[:, WINGS] = np.broadcast_to(np.asarray(wings, float), (n, 4))
        nu = np.concatenate([np.broadcast_to(np.asarray(velocity, float), (n, 3)),
                             np.broadcast_to(np.asarray(rates, float), (n, 3))], axis=1)
        mvv, mvs = self.inertia(x[:, WINGS])
        sd = np.broadcast_to(np.asarray(wing_rates, float), (n, 4))
        x[:, MOM] = np.einsum("nij,nj->ni", mvv, nu) + np.einsum("nij,nj->ni", mvs, sd)
        return x

    # ------------------------------------------------------- invariants
    def energy(self, x: np.ndarray, s_dot: Optional[np.ndarray] = None) -> np.ndarray:
        """Kinetic (body and fluid) plus potential energy (N,), J. Potential:
        weight at the CG and buoyancy at the CB, NED z down."""
        s_dot = np.zeros((len(x), 4)) if s_dot is None else s_dot
        nu = self.velocities(x, s_dot)
        mvv, mvs = self.inertia(x[:, WINGS])
        mss = self.shape_inertia(x[:, WINGS])
        kin = 0.5 * np.einsum("ni,nij,nj->n", nu, mvv, nu) + np.einsum("ni,nij,nj->n", nu, mvs, s_dot) \
            + 0.5 * (mss * s_dot * s_dot).sum(axis=1)
        rot = quat_to_rot(x[:, QUAT])
        r_g, r_b = self.centres(x[:, WINGS])
        z_g = x[:, 2] + np.einsum("nj,nj->n", rot[:, 2, :], r_g)
        z_b = x[:, 2] + np.einsum("nj,nj->n", rot[:, 2, :], r_b)
        pot = -(self.mass * self.g)[:, 0] * z_g + (self.rho * self.volume * self.g)[:, 0] * z_b
        return kin + pot

    def inertial_momenta(self, x: np.ndarray):
        """Linear impulse R p and angular impulse about the NED origin
        R pi + b x R p (N, 3) each: constant when no external force acts."""
        rot = quat_to_rot(x[:, QUAT])
        lin = np.einsum("nij,nj->ni", rot, x[:, LIN])
        ang = np.einsum("nij,nj->ni", rot, x[:, ANG]) + cross(x[:, POS], lin)
        return lin, ang


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis, broadcast; numpy's own cross is ~20x slower
    on the small arrays of one vehicle."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def quat_to_rot(q: np.ndarray) -> np.ndarray:
    """(N, 4) [w, x, y, z] -> (N, 3, 3) body -> NED."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    r = np.empty((len(q), 3, 3))
    r[:, 0, 0] = 1 - 2 * (y * y + z * z)
    r[:, 0, 1] = 2 * (x * y - w * z)
    r[:, 0, 2] = 2 * (x * z + w * y)
    r[:, 1, 0] = 2 * (x * y + w * z)
    r[:, 1, 1] = 1 - 2 * (x * x + z * z)
    r[:, 1, 2] = 2 * (y * z - w * x)
    r[:, 2, 0] = 2 * (x * z - w * y)
    r[:, 2, 1] = 2 * (y * z + w * x)
    r[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def quat_from_axis_angle(axis: Sequence[float], angle: float) -> np.ndarray:
    axis = np.asarray(axis, float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])
