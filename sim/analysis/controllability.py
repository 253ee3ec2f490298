"""Controllability at a steady descent: linear and Lie-algebraic (sec. 4.1).

Coordinates: position b (NED, 3), attitude error theta (3, q = q_trim *
exp(theta/2) so theta is a rotation vector in the body frame), momenta
(p, pi) (6), wing angles s (4); 16 states.

- **Linear**: the wing *commands* through the servo model are the inputs
  (4). A and B by central differences of the compiled model at the trim;
  rank of [B, AB, ..., A^15 B] by its singular values, states scaled to
  typical sizes (0.1 m, 0.1 rad, the trim's momenta, 0.1 rad) so the
  singular values compare.
- **Lie algebra**: the thesis's control-affine form, wing accelerations as
  inputs (s_ddot = u, eq. 2.10): 20 states (the 16 plus s_dot), drift f0
  and input fields g_i = d/d(s_dot_i). Brackets up to ``depth`` by
  directional central differences, [f, g](x) = Dg(x) f(x) - Df(x) g(x),
  step ``LIE_STEP`` (nested brackets differentiate differences, so the step
  is larger than a first derivative's). Rank from the singular values of
  the stacked, scaled fields.
"""

from __future__ import annotations

import numpy as np

from roboray.sim.analysis.trim import Trim, jacobian
from roboray.sim.dynamics import Model

#: Relative rank threshold on singular values.
RANK_TOL = 1e-7
#: Finite-difference step of the Lie brackets (scaled coordinates).
LIE_STEP = 1e-4
STATE_NAMES = ["north", "east", "down", "theta_x", "theta_y", "theta_z", "p_x", "p_y", "p_z",
               "pi_x", "pi_y", "pi_z", "s1", "s2", "s3", "s4"]


def _quat_exp(theta: np.ndarray) -> np.ndarray:
    angle = np.linalg.norm(theta)
    if angle < 1e-12:
        return np.array([1.0, 0.5 * theta[0], 0.5 * theta[1], 0.5 * theta[2]])
    axis = theta / angle
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


class Linearisation:
    """The model around a trim in the 16 chart coordinates."""

    def __init__(self, model: Model, trim: Trim) -> None:
        self.model = model
        self.trim = trim
        self.x_trim = trim.state(model)[0]
        self.q_trim = self.x_trim[3:7].copy()
        self.scale = np.concatenate([np.full(3, 0.1), np.full(3, 0.1),
                                     np.full(3, max(0.05, np.abs(self.x_trim[7:10]).max())),
                                     np.full(3, max(0.005, np.abs(self.x_trim[10:13]).max())),
                                     np.full(4, 0.1)])

    def full_state(self, d: np.ndarray) -> np.ndarray:
        x = self.x_trim.copy()
        x[0:3] += d[0:3]
        x[3:7] = _quat_mul(self.q_trim, _quat_exp(d[3:6]))
        x[7:13] += d[6:12]
        x[13:17] += d[12:16]
        return x

    def field(self, d: np.ndarray, command: np.ndarray, s_dot: np.ndarray | None = None) -> np.ndarray:
        """d/dt of the 16 coordinates; the servo model drives s unless s_dot is given."""
        x = self.full_state(d)[None, :]
        if s_dot is None:
            dx = self.model.rhs(x, command[None, :])[0]
            sd = dx[13:17]
        else:
            dx = self.model.body_rhs(x, s_dot[None, :])[0]
            sd = s_dot
        W = self.model.velocities(x, sd[None, :])[0, 3:]
        th = d[3:6]
        theta_dot = W + 0.5 * np.cross(th, W)   # right Jacobian inverse, first order
        return np.concatenate([dx[0:3], theta_dot, dx[7:13], sd])

    def matrices(self):
        u0 = self.trim.wings
        d0 = np.zeros(16)
        a = jacobian(lambda d: self.field(d, u0), d0)
        b = jacobian(lambda u: self.field(d0, u), u0.copy())
        return a, b


def linear(model: Model, trim: Trim, include_position: bool | None = None) -> dict:
    """Controllable subspace of the linearisation at a trim.

    [B, AB, A^2 B, ...] itself spans twenty orders of magnitude here (the
    servo poles at -1/tau), so its singular values cannot tell a weak
    direction from round-off. The subspace is built instead as an orthogonal
    Krylov basis: each new block A q is orthogonalised against the basis so
    far, and kept where its remainder exceeds ``RANK_TOL`` of its norm; the
    remainders are reported as ``direction_strengths``. A PBH test names the
    uncontrollable modes: eigenvalues lambda of A with rank [lambda I - A, B] < n.
    """
    lin = Linearisation(model, trim)
    a, b = lin.matrices()
    keep = np.arange(16)
    if include_position is None:
        include_position = trim.straight
    if not include_position:
        keep = keep[3:]  # a spiral's position is not time-invariant
    s = lin.scale[keep]
    a = a[np.ix_(keep, keep)] * (1.0 / s)[:, None] * s[None, :]
    b = b[keep] / s[:, None]
    n = len(keep)
    basis: list[np.ndarray] = []
    strengths: list[float] = []
    frontier = [b[:, k] for k in range(b.shape[1])]
    while frontier and len(basis) < n:
        new = []
        for v in frontier:
            norm0 = np.linalg.norm(v)
            if norm0 == 0:
                continue
            w = v.copy()
            for _ in range(2):  # re-orthogonalise once for accuracy
                for q in basis:
                    w -= (q @ w) * q
            rel = np.linalg.norm(w) / norm0
            if rel > RANK_TOL:
                q = w / np.linalg.norm(w)
                basis.append(q)
                strengths.append(float(rel))
                new.append(a @ q)
        frontier = new
    rank = len(basis)
    names = [STATE_NAMES[k] for k in keep]
    eig = np.linalg.eigvals(a)
    uncontrollable_modes = []
    seen: list[complex] = []
    for lam in eig:
        if any(abs(lam - other) < 1e-6 * max(1.0, abs(lam)) for other in seen):
            continue   # a repeated eigenvalue is tested once
        seen.append(lam)
        sv = np.linalg.svd(np.concatenate([lam * np.eye(n) - a, b], axis=1), compute_uv=False)
        missing = int(np.sum(sv < 1e-6 * max(1.0, sv[0])))
        if missing:
            uncontrollable_modes.append({"eigenvalue": [float(lam.real), float(lam.imag)],
                                         "uncontrollable_count": missing})
    if rank < n:
        q = np.array(basis).T if basis else np.zeros((n, 0))
        residual = np.eye(n) - q @ q.T
        weak = [names[k] for k in range(n) if np.linalg.norm(residual[:, k]) > 0.5]
    else:
        weak = []
    return {
        "state_dimension": n,
        "states": names,
        "inputs": ["s1_command", "s2_command", "s3_command", "s4_command"],
        "rank": rank,
        "direction_strengths": strengths,
        "uncontrollable_states": weak,
        "uncontrollable_modes": uncontrollable_modes,
        "rank_tolerance": RANK_TOL,
        "method": "orthogonal Krylov basis of (A, B), states scaled; PBH test per eigenvalue",
    }


def lie_rank(model: Model, trim: Trim, depth: int = 3) -> dict:
    """Rank of the distribution spanned by the input fields and their brackets
    with the drift up to ``depth`` (thesis sec. 4.1), at the trim."""
    lin = Linearisation(model, trim)
    scale = np.concatenate([lin.scale, np.full(4, 0.5)])   # s_dot scaled by 0.5 rad/s
    n = 20

    def f0(z):
        d = z[:16] * scale[:16]
        sd = z[16:] * scale[16:]
        return np.concatenate([lin.field(d, trim.wings, sd), np.zeros(4)]) / scale

    def g(i):
        e = np.zeros(n)
        e[16 + i] = 1.0 / scale[16 + i]
        return lambda z: e

    def bracket(f, h):
        def fh(z):
            vf, vh = f(z), h(z)
            dh = (h(z + LIE_STEP * vf) - h(z - LIE_STEP * vf)) / (2 * LIE_STEP)
            df = (f(z + LIE_STEP * vh) - f(z - LIE_STEP * vh)) / (2 * LIE_STEP)
            return dh - df
        return fh

    z0 = np.zeros(n)
    fields = {"g%d" % (i + 1): g(i) for i in range(4)}
    level = dict(fields)
    names = list(fields)
    for d in range(1, depth + 1):
        nxt = {}
        for name, fld in level.items():
            nxt["[f0,%s]" % name] = bracket(f0, fld)
            if d >= 2:
                for i in range(4):
                    key = "[g%d,%s]" % (i + 1, name)
                    nxt[key] = bracket(fields["g%d" % (i + 1)], fld)
        level = nxt
        fields.update(nxt)
        names.extend(nxt)
    vecs = np.array([fields[k](z0) for k in names])
    sv = np.linalg.svd(vecs, compute_uv=False)
    rank = int(np.sum(sv > 1e-5 * sv[0]))
    return {
        "state_dimension": n,
        "depth": depth,
        "fields": len(names),
        "rank": rank,
        "singular_values": sv.tolist(),
        "step": LIE_STEP,
        "rank_tolerance": 1e-5,
        "note": "inputs are the wing accelerations (thesis eq. 2.10); fields in coordinates scaled "
                "to typical sizes; brackets by directional central differences",
    }
