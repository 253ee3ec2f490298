"""Steady descents of the full model (drag, weight, buoyancy) and their modes.

A steady motion of a body falling through still water keeps its velocity V
and the direction of gravity Gamma fixed in the body frame; its rotation
can only be about the vertical, Omega = omega Gamma (then Gamma_dot =
Gamma x Omega = 0). The unknowns (V, Gamma on the sphere, omega) are six,
like the equations p_dot = 0, pi_dot = 0 of (K1)-(K2): a trim is a straight
glide when omega = 0 (every configuration with a mirror plane has them) and
a steady spiral otherwise, whose horizontal velocity turns with the body and
makes no net headway.

Linearisation: about a trim, in the 9 coordinates (p, pi, Gamma) that the
dynamics depend on (position and heading do not matter in still water), by
central differences of the compiled right-hand side (step ``FD_STEP``
relative). |Gamma| = 1 is conserved, which adds one zero eigenvalue.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from roboray.sim.dynamics import Model

#: Relative step of the central differences.
FD_STEP = 1e-6
#: A trim's residual (N, N m) must fall below this.
TRIM_TOL = 1e-9
#: |Re| below this (1/s) is on the imaginary axis: flat plates put no drag
#: against spin, so the spin mode of a symmetric vehicle is neutral (0).
NEUTRAL_TOL = 1e-4


def attitude_from_gamma(gamma: np.ndarray) -> np.ndarray:
    """A quaternion (body -> NED) whose down axis in the body frame is gamma
    (heading chosen so body x points as far north as it can)."""
    g = np.asarray(gamma, float) / np.linalg.norm(gamma)
    ref = np.array([1.0, 0.0, 0.0]) if abs(g[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    north = ref - ref.dot(g) * g
    north /= np.linalg.norm(north)
    east = np.cross(g, north)
    rot = np.array([north, east, g])  # rows: NED axes in the body frame
    return rot_to_quat(rot)


def rot_to_quat(r: np.ndarray) -> np.ndarray:
    """Rotation matrix (body -> NED) to [w, x, y, z] (Shepperd)."""
    tr = np.trace(r)
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = math.sqrt(1.0 + r[i, i] - r[j, j] - r[k, k]) * 2
        q = [0.0, 0.0, 0.0, 0.0]
        q[0] = (r[k, j] - r[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (r[j, i] + r[i, j]) / s
        q[1 + k] = (r[k, i] + r[i, k]) / s
    q = np.array(q)
    return q / np.linalg.norm(q) * (1 if q[0] >= 0 else -1)


def gamma_of(theta: float, phi: float) -> np.ndarray:
    """Gravity in the body frame from tilt theta and its azimuth phi."""
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])


@dataclass
class Trim:
    """A steady descent of one wing configuration."""

    wings: np.ndarray       #: rad
    V: np.ndarray           #: body velocity of O, m/s
    gamma: np.ndarray       #: gravity direction in the body frame
    omega: float            #: rad/s about the vertical (0: straight glide)
    residual: float         #: max |p_dot|, |pi_dot| at the trim

    @property
    def descent_speed(self) -> float:
        return float(self.V @ self.gamma)

    @property
    def horizontal_velocity_body(self) -> np.ndarray:
        return self.V - (self.V @ self.gamma) * self.gamma

    @property
    def horizontal_speed(self) -> float:
        return float(np.linalg.norm(self.horizontal_velocity_body))

    @property
    def glide_ratio(self) -> float:
        return self.horizontal_speed / self.descent_speed if self.descent_speed > 0 else float("inf")

    @property
    def tilt_deg(self) -> float:
        return math.degrees(math.acos(max(-1.0, min(1.0, self.gamma[2]))))

    @property
    def glide_direction_deg(self) -> float:
        """Direction of travel in the body's x-y plane (0 = towards wing 1, 90 = wing 2)."""
        h = self.horizontal_velocity_body
        return math.degrees(math.atan2(h[1], h[0])) if self.horizontal_speed > 1e-9 else 0.0

    @property
    def straight(self) -> bool:
        return abs(self.omega) < 1e-6

    def state(self, model: Model) -> np.ndarray:
        """The trim as a model state (N = 1) at the NED origin."""
        return model.state(attitude=attitude_from_gamma(self.gamma), velocity=self.V,
                           rates=self.omega * self.gamma, wings=self.wings)

    def as_dict(self) -> dict:
        return {
            "wings_deg": np.degrees(self.wings).tolist(),
            "velocity_body": self.V.tolist(),
            "gamma_body": self.gamma.tolist(),
            "omega": self.omega,
            "kind": "straight glide" if self.straight else "steady spiral",
            "descent_speed": self.descent_speed,
            "horizontal_speed": self.horizontal_speed,
            "glide_ratio": self.glide_ratio,
            "glide_angle_deg": math.degrees(math.atan2(self.horizontal_speed, self.descent_speed)),
            "glide_direction_deg": self.glide_direction_deg,
            "tilt_deg": self.tilt_deg,
            "spiral_radius_m": (self.horizontal_speed / abs(self.omega)) if not self.straight else None,
            "residual": self.residual,
        }


def _unpack(z: np.ndarray):
    V = z[0:3]
    gamma = gamma_of(z[3], z[4])
    return V, gamma, z[5]


def trim_residual(model: Model, wings: np.ndarray, z: np.ndarray) -> np.ndarray:
    """p_dot and pi_dot (6,) at the steady-motion guess z = (V, theta, phi, omega)."""
    V, gamma, omega = _unpack(z)
    x = model.state(attitude=attitude_from_gamma(gamma), velocity=V, rates=omega * gamma, wings=wings)
    return model.body_rhs(x, np.zeros((1, 4)))[0, 7:13]


def solve_trim(model: Model, wings: np.ndarray, guess: Trim | None = None, spiral: bool | None = None) -> Trim | None:
    """The steady descent nearest to ``guess`` (default: falling straight down
    at the terminal speed). ``spiral=False`` holds omega at 0; by default a
    straight glide is tried first and a spiral only if there is none (with
    little drag against spin, omega is nearly free and a spiral solve of a
    symmetric vehicle would wander to a meaningless small rate)."""
    if spiral is None:
        return solve_trim(model, wings, guess, False) or solve_trim(model, wings, guess, True)
    wings = np.asarray(wings, float)
    if guess is None:
        vt = model.vehicles[0].terminal_speed(wings)
        z0 = np.array([0.0, 0.0, vt, 0.0, 0.0, 0.0])
    else:
        g = guess.gamma
        z0 = np.concatenate([guess.V, [math.acos(max(-1, min(1, g[2]))), math.atan2(g[1], g[0]), guess.omega]])
    if not spiral:
        fun = lambda z: trim_residual(model, wings, np.concatenate([z, [0.0]]))  # noqa: E731
        z0 = z0[:5]
    else:
        fun = lambda z: trim_residual(model, wings, z)  # noqa: E731
    sol = least_squares(fun, z0, xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
    z = sol.x if spiral else np.concatenate([sol.x, [0.0]])
    res = float(np.abs(trim_residual(model, wings, z)).max())
    if res > TRIM_TOL:
        return None
    V, gamma, omega = _unpack(z)
    if V @ gamma < 0:
        return None  # rising: not a descent
    return Trim(wings, V, gamma, float(omega), res)


def trim_by_settling(model: Model, wings: np.ndarray, duration: float = 60.0, tilt: float = 0.05) -> Trim | None:
    """Let the vehicle fall from a slightly tilted start and polish where it
    settles: finds the stable trim a real drop would reach."""
    from roboray.sim.dynamics import quat_from_axis_angle
    from roboray.sim.simulate import simulate

    wings = np.asarray(wings, float)
    vt = model.vehicles[0].terminal_speed(wings)
    x0 = model.state(attitude=quat_from_axis_angle([1, 1, 0], tilt), velocity=(0, 0, vt), wings=wings)
    run = simulate(model, x0, duration, dt=0.01)
    return polish_from_state(model, wings, run.x[-1, 0], run.nu[-1, 0])


def polish_from_state(model: Model, wings: np.ndarray, x: np.ndarray, nu: np.ndarray) -> Trim | None:
    from roboray.sim.dynamics import quat_to_rot

    gamma = quat_to_rot(x[None, 3:7])[0, 2, :]
    omega = float(nu[3:] @ gamma)
    guess = Trim(np.asarray(wings, float), nu[:3].copy(), gamma, omega, float("nan"))
    return solve_trim(model, wings, guess)


# ------------------------------------------------------------ linearisation
def reduced_field(model: Model, wings: np.ndarray, y: np.ndarray) -> np.ndarray:
    """d/dt of y = (p, pi, Gamma) with the wings held (9,)."""
    gamma = y[6:9]
    norm = np.linalg.norm(gamma)
    x = np.zeros((1, 17))
    x[0, 3:7] = attitude_from_gamma(gamma / norm)
    x[0, 7:13] = y[0:6]
    x[0, 13:17] = wings
    dx = model.body_rhs(x, np.zeros((1, 4)))[0]
    W = model.velocities(x, np.zeros((1, 4)))[0, 3:]
    return np.concatenate([dx[7:13], np.cross(gamma, W)])


def trim_point(model: Model, trim: Trim) -> np.ndarray:
    x = trim.state(model)
    return np.concatenate([x[0, 7:13], trim.gamma])


def jacobian(fun, y: np.ndarray, step: float = FD_STEP) -> np.ndarray:
    """Central-difference Jacobian of fun at y."""
    n = len(y)
    j = np.empty((len(fun(y)), n))
    for k in range(n):
        h = step * max(1.0, abs(y[k]))
        e = np.zeros(n)
        e[k] = h
        j[:, k] = (fun(y + e) - fun(y - e)) / (2 * h)
    return j


MODE_GROUPS = {
    "heave": [2],
    "spin": [5],
    "feathering along the glide": [0, 4, 6],
    "feathering across the glide": [1, 3, 7],
}


def modes(model: Model, trim: Trim) -> dict:
    """Eigenvalues of the linearisation at a trim, named by the motion they
    carry most of, in body axes turned about z_c to the glide direction:
    heave (p3), spin (pi3), feathering along the glide (surge, pitch and
    Gamma along it) or across it. Without a glide, "along" is x_c."""
    y0 = trim_point(model, trim)
    jac = jacobian(lambda y: reduced_field(model, trim.wings, y), y0)
    eig, vec = np.linalg.eig(jac)
    a = math.radians(trim.glide_direction_deg)
    turn = np.array([[math.cos(a), math.sin(a), 0], [-math.sin(a), math.cos(a), 0], [0, 0, 1]])
    vec = np.concatenate([turn @ vec[0:3], turn @ vec[3:6], turn @ vec[6:9]])
    # typical sizes: momentum of the descent, its moment at the plate's edge, a radian
    p_typ = max(0.05, float(np.linalg.norm(y0[0:3])))
    scale = np.concatenate([np.full(3, 1.0 / p_typ), np.full(3, 1.0 / (p_typ * 0.05)), np.ones(3)])
    rows = []
    constraint = None
    for k in range(len(eig)):
        lam = eig[k]
        v = np.abs(vec[:, k]) * scale
        # the |Gamma| direction: an eigenvector along Gamma with lambda = 0
        along = abs(vec[6:9, k] @ (turn @ trim.gamma)) / max(1e-12, np.linalg.norm(vec[:, k]))
        if abs(lam) < 1e-6 and along > 0.9 and constraint is None:
            constraint = k
            continue
        shares = {name: float(np.sum(v[idx] ** 2)) for name, idx in MODE_GROUPS.items()}
        name = max(shares, key=shares.get)
        mag = abs(lam)
        rows.append({
            "mode": name,
            "eigenvalue": [float(lam.real), float(lam.imag)],
            "frequency_hz": float(abs(lam.imag) / (2 * math.pi)),
            "natural_frequency": float(mag),
            # a neutral mode (spin of a symmetric vehicle) has neither
            "damping_ratio": float(-lam.real / mag) if mag > 1e-9 else None,
            "time_constant_s": float(-1.0 / lam.real) if abs(lam.real) > 1e-9 else None,
        })
    rows.sort(key=lambda r: (r["mode"], r["eigenvalue"][1]))
    max_real = max(r["eigenvalue"][0] for r in rows)
    return {
        "trim": trim.as_dict(),
        "modes": rows,
        "max_real_eig": float(max_real),
        # no growing mode; neutral ones (spin of a symmetric vehicle) allowed
        "stable": bool(max_real <= NEUTRAL_TOL),
        "asymptotically_stable": bool(max_real < -NEUTRAL_TOL),
        "linearisation": "central differences of the compiled model in (p, pi, Gamma), relative step %g" % FD_STEP,
    }


def find_trims(model: Model, wings: np.ndarray, settle_s: float = 60.0) -> list[Trim]:
    """Steady descents of one configuration: where a drop settles, the
    straight fall and glides from a few tilted guesses (unstable ones too)."""
    wings = np.asarray(wings, float)
    found: list[Trim] = []

    def add(t: Trim | None) -> None:
        if t is None:
            return
        for f in found:
            if np.allclose(f.V, t.V, atol=1e-6) and np.allclose(f.gamma, t.gamma, atol=1e-6):
                return
        found.append(t)

    add(trim_by_settling(model, wings, settle_s))
    add(solve_trim(model, wings))
    vt = model.vehicles[0].terminal_speed(wings)
    for theta in (0.2, 0.5):
        for phi in np.arange(4) * (math.pi / 2):
            g = gamma_of(theta, phi)
            add(solve_trim(model, wings, Trim(wings, vt * g, g, 0.0, float("nan"))))
    return found
