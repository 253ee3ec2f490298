"""A second, simpler model of the steady glide, to cross-check the main one.

The main model (``sim/dynamics.py``) finds a glide as a rest point of the
Kirchhoff equations (K1)-(K2). This one is written from the forces alone,
the way a quasi-steady falling-plate model is: it shares the vehicle's
geometry and mass properties (``sim/vehicle.py``: each plate's area,
centroid, normal and added mass; the CG, CB, mass and displaced volume) but
none of the dynamics, kernels or trim solver. A straight glide translates
without turning (Omega = 0), so every point of the vehicle moves at V, the
velocity in body axes, and the direction of gravity Gamma is fixed there.

Plate i (the centre plate and the four wings, each a flat plate at its fold
angle; area A_i, centroid c_i, unit normal n_i; thesis sec. 2.2.1):

    u_i = V . n_i                                        (G1) normal velocity
    D_i = -1/2 rho C_D A_i u_i |u_i| n_i                 (G2) drag at c_i

Weight at the CG, buoyancy at the CB (m the mass, Vol the displaced volume):

    W = m g Gamma at r_G,   B = -rho Vol g Gamma at r_B  (G3)

A steady glide is where the net force and the net moment vanish; the moment
is taken about the CB, where buoyancy has no arm (with no net force, any
point gives the same balance):

    sum_i D_i + (m - rho Vol) g Gamma = 0                          (G4)
    sum_i (c_i - r_B) x D_i + (r_G - r_B) x m g Gamma + k M_A = 0  (G5)

with the added-mass (Munk) moment of translation, scaled by k:

    M_A = (A V) x V,   A = sum_i m_a,i n_i n_i^T                  (G6)

A is the translational added-mass matrix (each plate's eq. 2.2 added mass
along its normal). In the Kirchhoff equations it is the p x V of (K2) at
Omega = 0 (p = (m I + A) V and m V x V = 0); in Fossen's form it is the
moment rows of -C_A(nu) nu. It vanishes only when V is along an eigenvector
of A, so an oblique glide of a body with unequal added masses carries it.
k = 1 is the main model's moment balance term for term: its other moments
(the plates' rotational drag, eq. 2.1 corrected, and drag from the flow the
body's own rotation makes) are zero at Omega = 0, and without skin friction
(cf = 0) its forces are (G2)-(G3). k = 0 is the plate-drag model with a
plain moment balance.

Unknowns: V (3) and Gamma (2 angles); equations (G4)-(G5): six. The moment
about the vertical vanishes by symmetry for a configuration with a mirror
plane; without one it does not, the vehicle turns, and there is no straight
glide to compare (the main model then finds a spiral).

``stroke_reaction`` is the other claim this module checks: where a wing
stroke moves the body, by the dynamics model, for three reference points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from roboray.sim.vehicle import Vehicle, VehicleParams

#: A glide's residual, max |force| (N) and |moment| (N m), must fall below this.
GLIDE_TOL = 1e-9
#: Two glides are the same when V (m/s) and Gamma agree to this.
SAME_TOL = 1e-6
#: Steps of the Munk moment's scale k from 1 to 0 (continuation keeps the branch).
MUNK_STEPS = 10


def gamma_of(theta: float, phi: float) -> np.ndarray:
    """Gravity in body axes: tilt theta from z_c, towards azimuth phi (from x_c)."""
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])


@dataclass
class PlateGlide:
    """A straight glide of the plate model."""

    wings: np.ndarray   #: rad
    V: np.ndarray       #: m/s, body axes
    gamma: np.ndarray   #: gravity direction in body axes
    munk: float         #: k of (G5)
    residual: float     #: max |(G4)|, |(G5)|

    @property
    def descent_speed(self) -> float:
        return float(self.V @ self.gamma)

    @property
    def horizontal_speed(self) -> float:
        return float(np.linalg.norm(self.V - self.descent_speed * self.gamma))

    @property
    def glide_ratio(self) -> float:
        return self.horizontal_speed / self.descent_speed

    @property
    def tilt_deg(self) -> float:
        return math.degrees(math.acos(max(-1.0, min(1.0, float(self.gamma[2])))))

    @property
    def glide_direction_deg(self) -> float:
        """Direction of travel in the body's x-y plane (0 = towards wing 1, 90 = wing 2)."""
        h = self.V - self.descent_speed * self.gamma
        return math.degrees(math.atan2(h[1], h[0])) if self.horizontal_speed > 1e-9 else 0.0

    def as_dict(self) -> dict:
        return {"munk_scale": self.munk, "descent_speed": self.descent_speed,
                "horizontal_speed": self.horizontal_speed, "glide_ratio": self.glide_ratio,
                "tilt_deg": self.tilt_deg, "glide_direction_deg": self.glide_direction_deg,
                "velocity_body": self.V.tolist(), "gamma_body": self.gamma.tolist(), "residual": self.residual}


class PlateModel:
    """The quasi-steady plate-drag glide of one vehicle, (G1)-(G6)."""

    def __init__(self, params: VehicleParams | Vehicle | None = None) -> None:
        self.vehicle: Vehicle = params if isinstance(params, Vehicle) else Vehicle(params)
        self._geometry_cache: dict = {}

    def _geometry(self, wings: np.ndarray):
        key = tuple(np.asarray(wings, float))
        if key not in self._geometry_cache:
            v = self.vehicle
            plates = v.plates(np.asarray(wings, float))
            cb = v.centre_of_buoyancy(wings)
            self._geometry_cache[key] = (
                np.array([pl.area for pl in plates]),
                np.array([pl.centroid - cb for pl in plates]),   # arms about the CB
                np.array([pl.normal for pl in plates]),
                np.array([pl.added_mass for pl in plates]),
                v.centre_of_gravity(wings) - cb)
        return self._geometry_cache[key]

    def added_mass_matrix(self, wings: np.ndarray) -> np.ndarray:
        """A of (G6), kg."""
        _, _, normals, added, _ = self._geometry(wings)
        return np.einsum("i,ij,ik->jk", added, normals, normals)

    def terms(self, wings: np.ndarray, V: np.ndarray, gamma: np.ndarray) -> dict:
        """Each force (N) and each moment about the CB (N m) of (G4)-(G6), body axes."""
        p = self.vehicle.p
        areas, arms, normals, _, arm_g = self._geometry(wings)
        u = normals @ V                                                    # (G1)
        drag = (-0.5 * p.rho * p.cd * areas * u * np.abs(u))[:, None] * normals   # (G2)
        weight = self.vehicle.mass * p.g * gamma                           # (G3)
        buoyancy = -p.rho * self.vehicle.volume * p.g * gamma
        return {
            "drag_force": drag.sum(axis=0),
            "net_weight_force": weight + buoyancy,
            "drag_moment": np.cross(arms, drag).sum(axis=0),
            "weight_moment": np.cross(arm_g, weight),
            "munk_moment": np.cross(self.added_mass_matrix(wings) @ V, V),   # (G6)
        }

    def residual(self, wings: np.ndarray, V: np.ndarray, gamma: np.ndarray, munk: float) -> np.ndarray:
        """(G4) and (G5), stacked (6,)."""
        t = self.terms(wings, V, gamma)
        return np.concatenate([t["drag_force"] + t["net_weight_force"],
                               t["drag_moment"] + t["weight_moment"] + munk * t["munk_moment"]])

    def solve(self, wings: np.ndarray, munk: float = 1.0, guess: PlateGlide | None = None) -> PlateGlide | None:
        """The straight glide nearest to ``guess`` (default: straight down at
        the speed where the plates' drag carries the net weight), or None."""
        wings = np.asarray(wings, float)
        if guess is None:
            z0 = np.array([0.0, 0.0, self.vehicle.terminal_speed(wings), 0.0, 0.0])
        else:
            g = guess.gamma
            z0 = np.concatenate([guess.V, [math.acos(max(-1.0, min(1.0, float(g[2])))), math.atan2(g[1], g[0])]])

        def fun(z):
            return self.residual(wings, z[:3], gamma_of(z[3], z[4]), munk)

        sol = least_squares(fun, z0, xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
        res = float(np.abs(fun(sol.x)).max())
        V, gamma = sol.x[:3], gamma_of(sol.x[3], sol.x[4])
        if res > GLIDE_TOL or V @ gamma <= 0:
            return None
        return PlateGlide(wings, V, gamma, float(munk), res)

    def glides(self, wings: np.ndarray, munk: float = 1.0) -> list[PlateGlide]:
        """Every distinct straight glide reached from straight down and from
        tilted starts (0.1 and 0.4 rad, eight azimuths), stable or not."""
        wings = np.asarray(wings, float)
        vt = self.vehicle.terminal_speed(wings)
        starts: list[PlateGlide | None] = [None]
        for theta in (0.1, 0.4):
            for phi in np.arange(8) * (math.pi / 4):
                g = gamma_of(theta, phi)
                starts.append(PlateGlide(wings, vt * g, g, munk, float("nan")))
        found: list[PlateGlide] = []
        for s in starts:
            t = self.solve(wings, munk, s)
            if t is not None and not any(_same(t, f) for f in found):
                found.append(t)
        return found

    def continue_to(self, glide: PlateGlide, munk: float, steps: int = MUNK_STEPS) -> list[PlateGlide]:
        """Follow ``glide`` as the Munk moment's scale goes to ``munk`` in
        ``steps`` steps: the same branch, each step started from the last."""
        path = [glide]
        for k in np.linspace(glide.munk, munk, steps + 1)[1:]:
            nxt = self.solve(glide.wings, float(k), path[-1])
            if nxt is None:
                break
            path.append(nxt)
        return path


def _same(a: PlateGlide, b: PlateGlide) -> bool:
    return bool(np.allclose(a.V, b.V, atol=SAME_TOL) and np.allclose(a.gamma, b.gamma, atol=SAME_TOL))


def _moments(model: PlateModel, g: PlateGlide) -> dict:
    t = model.terms(g.wings, g.V, g.gamma)
    return {k: float(np.linalg.norm(t[k])) for k in ("drag_moment", "weight_moment", "munk_moment")}


def compare(params: VehicleParams, wings_deg, settle_s: float = 40.0) -> dict:
    """The main model's glide beside the plate model's, with and without the
    Munk moment, and what each moment term amounts to.

    The main model's glide is the one ``roboray-sim trim`` lists first (where
    a drop settles). The plate model with k = 1 is solved on its own, from its
    own starts, and the glide nearest the main one is paired with it; k is
    then taken to 0 along that branch. ValueError when the main model does
    not settle into a straight glide (no mirror plane: it spirals)."""
    from roboray.sim.analysis.trim import find_trims
    from roboray.sim.dynamics import Model

    wings = np.radians(np.asarray(wings_deg, float))
    model = Model(params)
    trims = [t for t in find_trims(model, wings, settle_s=settle_s) if t.straight]
    if not trims:
        raise ValueError("wings %s deg have no straight glide in the main model (a configuration without a "
                         "mirror plane spirals): nothing to compare" % ",".join("%g" % w for w in wings_deg))
    main = trims[0]
    plate = PlateModel(params)
    full = plate.glides(wings, 1.0)
    if not full:
        raise ValueError("the plate model finds no straight glide for wings %s deg"
                         % ",".join("%g" % w for w in wings_deg))
    paired = min(full, key=lambda g: float(np.abs(g.V - main.V).max() + np.abs(g.gamma - main.gamma).max()))
    path = plate.continue_to(paired, 0.0)
    if path[-1].munk != 0.0:
        raise ValueError("the plate model's glide for wings %s deg is lost at Munk scale %.2f"
                         % (",".join("%g" % w for w in wings_deg), path[-1].munk))
    bare = path[-1]
    # The main model's own moment at the plate-only glide: if (G5) with k = 1
    # is the main model's balance, this is the Munk moment and nothing else.
    x = model.state(attitude=_attitude(bare.gamma), velocity=bare.V, wings=wings)
    main_there = model.body_rhs(x, np.zeros((1, 4)))[0, 7:13]
    munk_there = plate.terms(wings, bare.V, bare.gamma)["munk_moment"]
    main_row = {"descent_speed": main.descent_speed, "horizontal_speed": main.horizontal_speed,
                "glide_ratio": main.glide_ratio, "tilt_deg": main.tilt_deg,
                "glide_direction_deg": main.glide_direction_deg, "velocity_body": main.V.tolist(),
                "gamma_body": main.gamma.tolist(), "residual": main.residual}
    return {
        "wings_deg": [float(w) for w in wings_deg],
        "main_model": main_row,
        "plate_model_munk": paired.as_dict(),
        "plate_model_no_munk": bare.as_dict(),
        "plate_glides_found": {"munk": len(full), "no_munk": len(plate.glides(wings, 0.0))},
        "plate_vs_main_max_difference": float(max(np.abs(paired.V - main.V).max(),
                                                  np.abs(paired.gamma - main.gamma).max())),
        "munk_scan": [{"munk_scale": g.munk, "glide_ratio": g.glide_ratio, "descent_speed": g.descent_speed,
                       "tilt_deg": g.tilt_deg} for g in path],
        "moments_at_main_glide_nm": _moments(plate, paired),
        "moments_at_plate_glide_nm": _moments(plate, bare),
        "main_model_at_plate_glide": {
            "force_n": float(np.linalg.norm(main_there[:3])),
            "moment_nm": main_there[3:].tolist(),
            "munk_moment_nm": munk_there.tolist(),
            "difference_nm": float(np.abs(main_there[3:] - munk_there).max())},
        "added_mass_matrix_kg": plate.added_mass_matrix(wings).tolist(),
    }


def _attitude(gamma: np.ndarray) -> np.ndarray:
    """A body -> NED quaternion [w, x, y, z] whose down axis in body axes is gamma."""
    g = np.asarray(gamma, float)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(g, z)          # turns body z_c onto NED down
    s = float(np.linalg.norm(axis))
    if s < 1e-15:
        return np.array([1.0, 0.0, 0.0, 0.0])
    angle = math.atan2(s, float(g @ z))
    axis = axis / s
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])


# ------------------------------------------------------------ the reaction
def stroke_reaction(params: VehicleParams, fold_deg: float = 45.0, stroke_deg: float | None = None,
                    dt: float = 1e-3, settle_s: float = 1.5) -> dict:
    """Where a differential stroke moves the body, by the dynamics model.

    From rest, level, the wings at ``fold_deg``, wing 1 folds up by
    ``stroke_deg`` and wing 3 down by as much (default: the whole travel
    left, min(fold, 90 - fold)), through the servo model, with gravity and
    drag off so the added-mass reaction acts alone: the momenta stay zero
    and the body is at rest again once the wings stop. Returns the
    displacements (m, along x_c towards wing 1, the wing folded up, and z_c)
    of three points: the plate's centre O, the CG and the CB (both move in
    the body as the wings fold), and the body's rotation about y_c (deg,
    positive lifting wing 1's side). Also, per radian of a small stroke, the
    momentum argument's figures: with zero momenta, (K3) gives
    nu = -M_vv^-1 M_vs s_dot, so a point r moves V + Omega x r + dr/ds per
    radian of s."""
    from roboray.sim.dynamics import Model, quat_to_rot

    if stroke_deg is None:
        stroke_deg = min(fold_deg, 90.0 - fold_deg)
    if not (stroke_deg > 0.0 and fold_deg - stroke_deg >= 0.0 and fold_deg + stroke_deg <= 90.0):
        raise ValueError("a stroke of %g deg about %g deg leaves the servo travel 0..90 deg" % (stroke_deg, fold_deg))
    vehicle = Vehicle(params)
    model = Model(params, gravity=False, drag=False)
    s0 = np.full(4, math.radians(fold_deg))
    e = np.array([1.0, 0.0, -1.0, 0.0])
    x = model.state(wings=s0)
    command = (s0 + math.radians(stroke_deg) * e)[None, :]

    def points(state):
        rot = quat_to_rot(state[:, 3:7])[0]
        s = state[0, 13:17]
        b = state[0, 0:3]
        return rot, {"plate_centre": b.copy(), "cg": b + rot @ vehicle.centre_of_gravity(s),
                     "cb": b + rot @ vehicle.centre_of_buoyancy(s)}

    _, before = points(x)
    for _ in range(int(round(settle_s / dt))):
        x = model.step(x, command, dt)
    rot, after = points(x)
    moved = {k: (after[k] - before[k]).tolist() for k in before}
    # Rotation about y_c: the body's x_c axis in NED, its fall below the horizontal.
    pitch = math.degrees(math.atan2(-rot[2, 0], rot[0, 0]))

    # Momentum argument, linear in the stroke (per radian of s1 = -s3).
    mvv, mvs = model.inertia(s0[None])
    nu = -np.linalg.solve(mvv[0], mvs[0] @ e)
    h = 1e-6
    per_rad = {}
    for name, where in (("plate_centre", lambda s: np.zeros(3)), ("cg", vehicle.centre_of_gravity),
                        ("cb", vehicle.centre_of_buoyancy)):
        r = where(s0)
        drds = (where(s0 + h * e) - where(s0 - h * e)) / (2 * h)
        per_rad[name] = (nu[:3] + np.cross(nu[3:], r) + drds).tolist()
    return {
        "fold_deg": fold_deg,
        "stroke_deg": stroke_deg,
        "wings_after_deg": np.degrees(x[0, 13:17]).tolist(),
        "displacement_m": moved,
        "pitch_deg": pitch,
        "per_radian_m": per_rad,
        "pitch_deg_per_radian": math.degrees(nu[4]),
        "plate_centre_accel_per_wing_accel": float(nu[0]),
        "method": "dynamics model, gravity and drag off, RK4 dt %g s for %g s; per radian from (K3) at zero "
                  "momenta" % (dt, settle_s),
    }
