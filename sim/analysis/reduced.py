"""The reduced model of thesis chapter 3: neutrally buoyant, no drag, wings fixed.

State ``y = (Pi, P, Gamma)``: angular and linear impulse about the centre of
buoyancy and the direction of gravity in the body frame (``Gamma = R^T k``).
With the locked inertia about the CB, ``[P; Pi] = [[M, D^T], [D, J]] [V; Omega]``
(sec. 3.1), weight at the CG (``ell z_c`` from the CB) and buoyancy at the CB
cancelling as forces, Leonard's equations [9] read

    Pi_dot    = Pi x Omega + P x V + m_v g ell (z_c x Gamma)     (the moment is
    P_dot     = P x Omega                                         m_v g ell, not
    Gamma_dot = Gamma x Omega                                     m_v a_w ell: see dynamics.py)

Equilibria (sec. 3.1.2-3.1.3):

- (3.2) no spin: ``Omega = 0``, ``V = (0, v2, v3)``,
  ``Gamma = (0, Gamma_2, sqrt(1 - Gamma_2^2))`` with
  ``Gamma_2 = (m2 - m3) v2 v3 / (m_v g ell)``; it exists only if
  ``|Gamma_2| <= 1``;
- (3.3) spin: ``Omega = (0, 0, w3)``, ``V = (0, 0, v3)``, ``Gamma = (0, 0, 1)``.

Spectral stability: these equilibria are marginal at best (the Casimirs
|Gamma|^2, P.Gamma, |P|^2 give zero eigenvalues, the rest come in +-i w
pairs), so "stable" means every eigenvalue has |Re| <= ``SPECTRAL_TOL``
relative to the largest |eigenvalue|. The Jacobian is analytic (the field is
bilinear in (Pi, P) and Gamma once the inertia is inverted), so round-off,
not a difference step, is what the tolerance absorbs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roboray.sim.vehicle import Vehicle, skew

#: |Re(lambda)| / max|lambda| below which an eigenvalue counts as on the axis.
#: Zero eigenvalues of the Casimirs may form Jordan blocks, whose computed
#: eigenvalues spread by ~sqrt(machine eps) ~ 1e-8.
SPECTRAL_TOL = 1e-6
Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class ReducedModel:
    """Locked inertia about the CB and the restoring coefficient of one configuration."""

    wings: np.ndarray        #: rad
    inertia: np.ndarray      #: 6x6 about the CB, order (V, Omega)
    mass: float              #: m_v, kg
    g: float
    ell: float               #: m, CB to CG along z_c

    @classmethod
    def of(cls, vehicle: Vehicle, wings: np.ndarray) -> "ReducedModel":
        wings = np.asarray(wings, float)
        return cls(wings, vehicle.locked_inertia(wings), vehicle.mass, vehicle.p.g, vehicle.ell(wings))

    @property
    def m(self) -> np.ndarray:
        return np.diag(self.inertia[:3, :3]).copy()

    @property
    def restoring(self) -> float:
        """m_v g ell, N m per unit tilt."""
        return self.mass * self.g * self.ell

    # ---------------------------------------------------------------- field
    def velocities(self, y: np.ndarray):
        """(V, Omega) from (Pi, P)."""
        nu = np.linalg.solve(self.inertia, np.concatenate([y[3:6], y[0:3]]))
        return nu[:3], nu[3:]

    def impulses(self, V, W) -> np.ndarray:
        """(Pi, P) as the first six entries of a state, from velocities."""
        pv = self.inertia @ np.concatenate([V, W])
        return np.concatenate([pv[3:], pv[:3]])

    def field(self, y: np.ndarray) -> np.ndarray:
        Pi, P, G = y[0:3], y[3:6], y[6:9]
        V, W = self.velocities(y)
        return np.concatenate([
            np.cross(Pi, W) + np.cross(P, V) + self.restoring * np.cross(Z, G),
            np.cross(P, W),
            np.cross(G, W),
        ])

    def jacobian(self, y: np.ndarray) -> np.ndarray:
        """Analytic d(field)/dy, 9x9."""
        Pi, P, G = y[0:3], y[3:6], y[6:9]
        V, W = self.velocities(y)
        inv = np.linalg.inv(self.inertia)      # maps (P, Pi) -> (V, Omega)
        a_vp, a_vpi = inv[:3, :3], inv[:3, 3:]
        a_wp, a_wpi = inv[3:, :3], inv[3:, 3:]
        sPi, sP, sG, sW, sV = skew(Pi), skew(P), skew(G), skew(W), skew(V)
        j = np.zeros((9, 9))
        # d(a x b) = -skew(b) da + skew(a) db
        j[0:3, 0:3] = -sW + sPi @ a_wpi + sP @ a_vpi
        j[0:3, 3:6] = sPi @ a_wp - sV + sP @ a_vp
        j[0:3, 6:9] = self.restoring * skew(Z)
        j[3:6, 0:3] = sP @ a_wpi
        j[3:6, 3:6] = -sW + sP @ a_wp
        j[6:9, 0:3] = sG @ a_wpi
        j[6:9, 3:6] = sG @ a_wp
        j[6:9, 6:9] = -sW
        return j

    # ----------------------------------------------------------- equilibria
    def gamma2(self, v2: float, v3: float) -> float:
        """Gamma_2 of eq. 3.2 (with the full weight m_v g ell)."""
        m = self.m
        return (m[1] - m[2]) * v2 * v3 / self.restoring

    def no_spin_state(self, v2: float, v3: float):
        """Equilibrium (3.2) as a state, or None when |Gamma_2| > 1."""
        g2 = self.gamma2(v2, v3)
        if abs(g2) > 1.0:
            return None
        G = np.array([0.0, g2, math.sqrt(1.0 - g2 * g2)])
        return np.concatenate([self.impulses(np.array([0.0, v2, v3]), np.zeros(3)), G])

    def spin_state(self, v3: float, w3: float) -> np.ndarray:
        """Equilibrium (3.3) as a state."""
        return np.concatenate([self.impulses(np.array([0.0, 0.0, v3]), np.array([0.0, 0.0, w3])), Z])

    def energy_casimir(self) -> bool:
        """The thesis's sufficient conditions: ell > 0, m3 > m1, m3 > m2."""
        m = self.m
        return bool(self.ell > 0 and m[2] > m[0] and m[2] > m[1])


def spectrum(jac: np.ndarray) -> dict:
    """Eigenvalues and the stability verdict of a Jacobian."""
    eig = np.linalg.eigvals(jac)
    scale = max(1.0, float(np.abs(eig).max()))
    max_real = float(eig.real.max())
    return {
        "eigenvalues": eig,
        "max_real_eig": max_real,
        "spectrally_stable": bool(max_real <= SPECTRAL_TOL * scale),
    }


def straight_fall_tilt_condition(red: ReducedModel, v3: float) -> tuple[bool, bool]:
    """Closed form for the two tilt modes of a straight fall without spin.

    Linearising about Omega = 0, V = (0, 0, v3), Gamma = z_c for a
    configuration symmetric in each plane (s1 = s3, s2 = s4, so M and J are
    diagonal and D = [[0, -d1, 0], [d2, 0, 0], [0, 0, 0]]), the pitch mode
    (x translation, y rotation, Gamma_1) has the characteristic polynomial

        lambda [ (m1 I2 - d2^2) lambda^2 + m1 m_v g ell + m3 (m3 - m1) v3^2 ] = 0

    and the roll mode the same with (m2, I1, d1). Since m1 I2 - d2^2 > 0 (the
    inertia is positive definite), each tilt mode oscillates (purely
    imaginary roots) iff

        m_i m_v g ell + m3 (m3 - m_i) v3^2 > 0,   i = 1 (pitch), 2 (roll),

    and has a real root > 0 otherwise: a bottom-light vehicle (ell < 0) can
    be stabilised by speed when m3 > m_i, and a bottom-heavy one destabilised
    by speed when m3 < m_i (the Munk moment). Returns (pitch, roll) stable.
    """
    m = red.m
    mg_l = red.restoring
    return (bool(m[0] * mg_l + m[2] * (m[2] - m[0]) * v3 ** 2 > 0),
            bool(m[1] * mg_l + m[2] * (m[2] - m[1]) * v3 ** 2 > 0))


# ------------------------------------------------------------ thesis tables
THESIS_MASS = 1.0625   #: kg, m_v
THESIS_G = 9.80665     #: m/s^2
#: Table 3.1 (no spin): ell, s1 = s3, s2 = s4 (deg), v2, v3, m1, m2, m3.
TABLE_3_1 = [
    (0.0167, 0, 0, 0, 1, 1.0625, 1.0625, 2.2645),
    (0.0167, 0, 0, 0, 2, 1.0625, 1.0625, 2.2645),
    (0.0167, 0, 0, 1, 1, 1.0625, 1.0625, 2.2645),
    (0.0167, 0, 0, 1, 2, 1.0625, 1.0625, 2.2645),
    (0.0171, 0, 90, 1, 1, 1.0625, 1.6069, 1.7201),
    (0.0171, 0, 90, 1, 2, 1.0625, 1.6069, 1.7201),
]
#: Table 3.2 (spin): ell, s1 = s3, s2 = s4 (deg), v3, omega3, m1, m2, m3.
TABLE_3_2 = [(0.0167, 0, 0, v3, w3, 1.0625, 1.0625, 2.2645)
             for v3 in (0.3, 0.5, 1.0) for w3 in (0.1, 0.5, 1.0)]


def evaluate(vehicle: Vehicle, wings_deg, v2: float = 0.0, v3: float = 0.3, omega3: float = 0.0) -> dict:
    """Existence, spectral and energy-Casimir verdicts of one equilibrium:
    (3.3) when omega3 != 0 (then v2 must be 0), else (3.2)."""
    wings = np.radians(np.asarray(wings_deg, float))
    red = ReducedModel.of(vehicle, wings)
    m = red.m
    row = {
        "wings_deg": [float(w) for w in wings_deg],
        "s1": float(wings_deg[0]), "s2": float(wings_deg[1]),
        "v2": float(v2), "v3": float(v3), "omega3": float(omega3),
        "m1": float(m[0]), "m2": float(m[1]), "m3": float(m[2]), "ell": red.ell,
        "I1": float(red.inertia[3, 3]), "I2": float(red.inertia[4, 4]), "I3": float(red.inertia[5, 5]),
        "energy_casimir": red.energy_casimir(),
    }
    if omega3 != 0.0:
        if v2 != 0.0:
            raise ValueError("the spin equilibrium (3.3) has v2 = 0; got v2 = %g" % v2)
        state = red.spin_state(v3, omega3)
        row["equilibrium"] = "3.3 (spin)"
    else:
        row["gamma2"] = red.gamma2(v2, v3)
        state = red.no_spin_state(v2, v3)
        row["equilibrium"] = "3.2 (no spin)"
    row["exists"] = state is not None
    if state is None:
        row.update(spectrally_stable=None, max_real_eig=None, eigenvalues=None)
        return row
    residual = float(np.abs(red.field(state)).max())
    if residual > 1e-9:
        raise RuntimeError("not an equilibrium: residual %.3g" % residual)
    spec = spectrum(red.jacobian(state))
    row["spectrally_stable"] = spec["spectrally_stable"]
    row["max_real_eig"] = spec["max_real_eig"]
    row["eigenvalues"] = [[float(e.real), float(e.imag)] for e in spec["eigenvalues"]]
    return row


def table(vehicle: Vehicle, number: str) -> list[dict]:
    """Every row of Table 3.1 or 3.2, recomputed and compared with the thesis
    (which lists every row as spectrally stable)."""
    rows = []
    if number == "3.1":
        for i, (ell, s13, s24, v2, v3, m1, m2, m3) in enumerate(TABLE_3_1, 1):
            row = evaluate(vehicle, (s13, s24, s13, s24), v2=v2, v3=v3)
            rows.append(_compare(row, i, ell, m1, m2, m3))
    elif number == "3.2":
        for i, (ell, s13, s24, v3, w3, m1, m2, m3) in enumerate(TABLE_3_2, 1):
            row = evaluate(vehicle, (s13, s24, s13, s24), v3=v3, omega3=w3)
            rows.append(_compare(row, i, ell, m1, m2, m3))
    else:
        raise ValueError("table must be '3.1' or '3.2', got %r" % number)
    return rows


def _compare(row: dict, index: int, ell: float, m1: float, m2: float, m3: float) -> dict:
    row["row"] = index
    row["thesis"] = {"ell": ell, "m1": m1, "m2": m2, "m3": m3, "spectrally_stable": True}
    notes = []
    if not row["exists"]:
        g2 = (m2 - m3) * row["v2"] * row["v3"] / (THESIS_MASS * THESIS_G * ell)
        notes.append("no such equilibrium: eq. 3.2 needs |Gamma_2| <= 1, but with the table's own masses "
                     "and ell Gamma_2 = (m2 - m3) v2 v3 / (m_v g ell) = %.3g" % g2)
    elif not row["spectrally_stable"]:
        notes.append("an eigenvalue has real part %.3g > 0: the linearisation is unstable" % row["max_real_eig"])
    row["agrees_with_thesis"] = not notes
    if notes:
        row["note"] = "; ".join(notes)
    return row
