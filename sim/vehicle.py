"""The vehicle: its parameters and the rigid and fluid properties they give.

``VehicleParams`` is everything a user can change (``sim/vehicles/`` holds
the reference vehicle as a file to copy and edit). ``Vehicle`` derives from
it, for any wing configuration, the quantities the dynamics and the analyses
use: plate geometry, rigid-body mass properties, added mass (thesis eqs.
2.2-2.4, Table 2.1), centres of gravity and buoyancy.

Frames (the thesis's sec. 2.1, with the origin moved to the plate): body origin O at the centre of the centre plate's
mid-plane, ``x_c`` towards wing 1, ``y_c`` towards wing 2, ``z_c`` along the
symmetry axis, down when the vehicle descends level; the dome is on the
``-z_c`` side. Wing ``i`` (1..4) is hinged on the side at azimuth
``(i-1)*90 deg``; its deflection ``s_i`` turns it about the hinge axis
``t_i = z_c x r_i``, positive folding it up (towards the dome), 0 = flat,
90 deg = folded up. SI units, radians.
"""

from __future__ import annotations

import math
import runpy
import traceback
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

WATER_DENSITY = {"fresh": 1000.0, "sea": 1025.0}  #: kg/m^3


@dataclass(frozen=True)
class VehicleParams:
    """Inputs of the model, all required: sim/vehicles/reference.py gives the
    reference values and why each was chosen; copy it to make another vehicle."""

    # Fluid and gravity
    rho: float  #: kg/m^3, fluid density
    g: float  #: m/s^2
    cd: float  #: -, flat plate normal to the flow (thesis sec. 2.2.1)
    cf: float  #: -, skin-friction coefficient (0 = off, thesis has none)

    # Centre plate (square) and wings (isosceles triangles, base on the hinge)
    plate_side: float  #: m, side a of the centre plate
    wing_height: float  #: m, hinge to apex
    thickness: float  #: m, plate and wing thickness
    plate_density: float  #: kg/m^3, centre plate (acrylic)
    wing_density: float  #: kg/m^3, wings

    # Added-mass coefficients, thesis Table 2.1 (eqs. 2.2-2.4)
    k_center: float
    dlambda_center: float
    kx_center: float
    ky_center: float
    k_wing: float
    dlambda_wing: float
    kx_wing: float
    ky_wing: float

    # Dome: hemispherical shell on the plate's top face
    dome_radius: float  #: m
    dome_shell_thickness: float  #: m
    dome_density: float  #: kg/m^3

    # Servos: one per wing, lumped at the hinge midpoint above the plate
    servo_mass: float  #: kg
    servo_volume: float  #: m^3
    servo_height: float  #: m above the plate's top face

    # Electronics, battery and ballast: a flat cylinder inside the dome.
    # Its mass makes up the vehicle mass, its height sets ell.
    total_mass: float  #: kg, m_v (thesis)
    payload_radius: float  #: m
    payload_thickness: float  #: m
    payload_height: float  #: m, centroid above the plate mid-plane

    # Servo model (each wing): first-order lag with a rate limit, travel 0..90 deg
    servo_tau: float  #: s, first-order lag
    servo_rate: float  #: rad/s, rate limit (0.17 s/60 deg)
    servo_min: float  #: rad
    servo_max: float  #: rad

    # Sensor positions on the centre body (body frame, from O)
    imu_position: tuple  #: m, in the dome
    pressure_port: tuple  #: m, on the plate's top face

    # Model switch: the added-mass (Munk) moment of translation, (A V) x V,
    # scaled (1: the Kirchhoff equations' own term; 0: the plate-drag model
    # without it, docs/design/glide-check.md). Which one the water obeys is
    # for a dive's log to say (``roboray-sim identify``).
    munk_scale: float = 1.0  #: -, 0..1 (any finite value: a fit needs room on both sides of 0 and 1)

    def problems(self) -> list[str]:
        """What makes these inputs unusable (empty when none): every field a
        finite number, positions three of them, and the signs physics needs."""
        out = []
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in ("imu_position", "pressure_port"):
                ok = isinstance(v, (tuple, list)) and len(v) == 3 and all(_finite_number(x) for x in v)
                if not ok:
                    out.append("%s must be three finite numbers (m), got %r" % (f.name, v))
            elif not _finite_number(v):
                out.append("%s must be a finite number, got %r" % (f.name, v))
            elif f.name in _POSITIVE and not v > 0:
                out.append("%s must be > 0, got %r" % (f.name, v))
            elif f.name in _NON_NEGATIVE and not v >= 0:
                out.append("%s must be >= 0, got %r" % (f.name, v))
        if not out and not self.servo_min < self.servo_max:
            out.append("servo_min (%r) must be below servo_max (%r)" % (self.servo_min, self.servo_max))
        return out

    def with_water(self, water: str) -> "VehicleParams":
        """The same vehicle in ``"fresh"`` or ``"sea"`` water."""
        if water not in WATER_DENSITY:
            raise ValueError("water must be one of %s, got %r" % (sorted(WATER_DENSITY), water))
        return replace(self, rho=WATER_DENSITY[water])


#: Fields that must be strictly positive, and those that may be zero.
_POSITIVE = frozenset(("rho", "g", "plate_side", "wing_height", "thickness", "plate_density", "wing_density",
                       "dome_radius", "dome_shell_thickness", "dome_density", "total_mass", "payload_radius",
                       "payload_thickness", "servo_tau", "servo_rate"))
_NON_NEGATIVE = frozenset(("cd", "cf", "servo_mass", "servo_volume", "servo_height"))


def _finite_number(x) -> bool:
    return isinstance(x, (int, float, np.floating, np.integer)) and not isinstance(x, bool) and math.isfinite(x)


def load_params(path: str | Path | None = None) -> VehicleParams:
    """The reference vehicle, or the ``VEHICLE`` defined in a Python file.

    ``ValueError`` names the file and says what is wrong with it: an error
    raised while running it (with its line), no ``VEHICLE``, or fields
    that are not finite numbers of the right sign."""
    if path is None:
        from roboray.sim.vehicles.reference import VEHICLE

        return VEHICLE
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(2, "no such vehicle file", str(path))
    try:
        namespace = runpy.run_path(str(path))
    except SyntaxError as exc:
        raise ValueError("%s:%s: %s" % (path, exc.lineno, exc.msg))
    except Exception as exc:  # noqa: BLE001 - any error in the user's file is reported, not a traceback
        line = next((f.lineno for f in reversed(traceback.extract_tb(exc.__traceback__))
                     if Path(f.filename) == path), None)
        raise ValueError("%s%s: %s: %s" % (path, "" if line is None else ":%d" % line, type(exc).__name__, exc))
    vehicle = namespace.get("VEHICLE")
    if not isinstance(vehicle, VehicleParams):
        raise ValueError("%s must define VEHICLE = VehicleParams(...)" % path)
    bad = vehicle.problems()
    if bad:
        raise ValueError("%s: %s" % (path, "; ".join(bad)))
    return vehicle


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix: skew(a) @ b == cross(a, b). Works on (..., 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about a unit ``axis`` by ``angle`` (Rodrigues)."""
    k = skew(axis)
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


@dataclass(frozen=True)
class Plate:
    """One plate in a given configuration, in body coordinates."""

    area: float             #: m^2
    centroid: np.ndarray    #: m, from O
    normal: np.ndarray      #: unit, +z_c when flat
    rotation: np.ndarray    #: local (x along the chord, y along the hinge, z normal) -> body
    added_mass: float       #: kg, along the normal (eq. 2.2)
    added_inertia: np.ndarray  #: kg m^2, (Jx, Jy) about the centroid's in-plane axes (eqs. 2.3-2.4)
    mass: float             #: kg, rigid
    inertia: np.ndarray     #: kg m^2, rigid, about the centroid, local axes (3x3)
    volume: float           #: m^3


@dataclass(frozen=True)
class Lump:
    """A rigid part of the centre body (dome, servos, payload)."""

    mass: float
    centroid: np.ndarray
    inertia: np.ndarray     #: about the centroid, body axes
    volume: float           #: displaced volume (m^3)
    volume_centroid: np.ndarray


class Vehicle:
    """Mass, fluid and geometric properties derived from ``VehicleParams``."""

    def __init__(self, params: VehicleParams | None = None) -> None:
        self.p = params if params is not None else load_params()
        p = self.p
        bad = p.problems()
        if bad:
            raise ValueError("VehicleParams: %s" % "; ".join(bad))
        a, h, t = p.plate_side, p.wing_height, p.thickness
        self.azimuths = np.arange(4) * (math.pi / 2)
        #: radial unit vectors r_i and hinge axes t_i = z x r_i
        self.radial = np.stack([np.cos(self.azimuths), np.sin(self.azimuths), np.zeros(4)], axis=1)
        self.hinge_axis = np.stack([-np.sin(self.azimuths), np.cos(self.azimuths), np.zeros(4)], axis=1)
        #: hinge midpoints (on the plate's edge, mid-plane)
        self.hinge_point = 0.5 * a * self.radial

        self.area_center = a * a
        self.area_wing = 0.5 * a * h
        # Eq. 2.2: m = pi/4 rho k cbar^2 b. Centre: cbar = b = a. Wing: the span
        # b runs along the hinge (b = a) and the mean chord is measured outwards
        # from the hinge, the leading edge (cbar = area / span = h / 2).
        self.cbar_wing = h / 2.0
        self.added_mass_center = math.pi / 4 * p.rho * p.k_center * a * a * a
        self.added_mass_wing = math.pi / 4 * p.rho * p.k_wing * self.cbar_wing ** 2 * a
        # Eqs. 2.3-2.4 about the centroid. Eq. 2.4's "+ m l^2" moves J_y to the
        # leading edge; here the translational added mass sits at the centroid,
        # so the kinematics produce that parallel-axis term by themselves.
        self.added_inertia_center = np.array([
            math.pi / 48 * p.rho * p.dlambda_center * p.kx_center * a ** 2 * a ** 3,
            math.pi / 48 * p.rho * p.dlambda_center * p.ky_center * a ** 3 * a ** 2,
        ])
        self.added_inertia_wing = np.array([
            math.pi / 48 * p.rho * p.dlambda_wing * p.kx_wing * self.cbar_wing ** 2 * a ** 3,
            math.pi / 48 * p.rho * p.dlambda_wing * p.ky_wing * self.cbar_wing ** 3 * a ** 2,
        ])

        # Rigid plates (thin laminae; thickness only in the normal inertia).
        self.mass_center_plate = p.plate_density * self.area_center * t
        self.mass_wing = p.wing_density * self.area_wing * t
        self.volume_center_plate = self.area_center * t
        self.volume_wing = self.area_wing * t
        m = self.mass_center_plate
        self.inertia_center_plate = np.diag([m * (a * a + t * t) / 12, m * (a * a + t * t) / 12, m * a * a / 6])
        self.inertia_wing_local = _triangle_inertia(self.mass_wing, a, h, t)

        self.lumps = self._lumps()
        rigid = self.mass_center_plate + 4 * self.mass_wing + sum(l.mass for l in self.lumps)
        if abs(rigid - p.total_mass) > 1e-9:
            raise ValueError("parts weigh %.6f kg but total_mass is %.6f kg" % (rigid, p.total_mass))
        self.mass = p.total_mass
        self.volume = self.volume_center_plate + 4 * self.volume_wing + sum(l.volume for l in self.lumps)
        self.net_weight = (self.mass - p.rho * self.volume) * p.g  #: N, weight minus buoyancy
        self.a_w = self.net_weight / self.mass  #: m/s^2, the thesis's a_w

    # ------------------------------------------------------------------ parts
    def _lumps(self) -> list[Lump]:
        p = self.p
        t = p.thickness
        top = -0.5 * t  # the plate's top face (z down)
        lumps = []
        # Dome: hemispherical shell; its outer volume displaces water.
        R = p.dome_radius
        r_in = R - p.dome_shell_thickness
        m_shell = p.dome_density * (2.0 / 3.0) * math.pi * (R ** 3 - r_in ** 3)
        # thick shell centroid: difference of solid hemispheres (3R/8 each)
        z_c = (R ** 4 - r_in ** 4) * 3.0 / 8.0 / (R ** 3 - r_in ** 3)
        # inertia about the base centre: 2/5 m (R^5 - r^5)/(R^3 - r^3) for every axis
        i_base = 0.4 * m_shell * (R ** 5 - r_in ** 5) / (R ** 3 - r_in ** 3)
        i_c = np.diag([i_base - m_shell * z_c ** 2, i_base - m_shell * z_c ** 2, i_base])
        v_dome = (2.0 / 3.0) * math.pi * R ** 3
        lumps.append(Lump(m_shell, np.array([0, 0, top - z_c]), i_c, v_dome, np.array([0, 0, top - 3.0 * R / 8.0])))
        # Servos at the hinge midpoints, above the plate.
        for i in range(4):
            c = self.hinge_point[i] + np.array([0, 0, top - p.servo_height])
            lumps.append(Lump(p.servo_mass, c, np.zeros((3, 3)), p.servo_volume, c))
        # Payload: what is left of the total mass, as a flat cylinder (inside the dome).
        fixed = self.mass_center_plate + 4 * self.mass_wing + sum(l.mass for l in lumps)
        m_pay = p.total_mass - fixed
        if m_pay <= 0:
            raise ValueError("the parts already weigh %.4f kg, more than total_mass %.4f kg" % (fixed, p.total_mass))
        r, hh = p.payload_radius, p.payload_thickness
        i_pay = np.diag([m_pay * (3 * r * r + hh * hh) / 12, m_pay * (3 * r * r + hh * hh) / 12, m_pay * r * r / 2])
        lumps.append(Lump(m_pay, np.array([0, 0, -p.payload_height]), i_pay, 0.0, np.zeros(3)))
        return lumps

    def wing_rotation(self, i: int, s: float) -> np.ndarray:
        """Wing i's local frame (x chordwise outwards, y along the hinge, z normal) in body axes."""
        flat = np.stack([self.radial[i], self.hinge_axis[i], np.array([0.0, 0.0, 1.0])], axis=1)
        return axis_rotation(self.hinge_axis[i], s) @ flat

    def plates(self, wings: np.ndarray) -> list[Plate]:
        """The centre plate and the four wings in configuration ``wings`` (rad)."""
        wings = _wings(wings)
        h = self.p.wing_height
        out = [Plate(self.area_center, np.zeros(3), np.array([0.0, 0.0, 1.0]), np.eye(3),
                     self.added_mass_center, self.added_inertia_center, self.mass_center_plate,
                     self.inertia_center_plate, self.volume_center_plate)]
        for i in range(4):
            rot = self.wing_rotation(i, wings[i])
            centroid = self.hinge_point[i] + rot @ np.array([h / 3.0, 0.0, 0.0])
            out.append(Plate(self.area_wing, centroid, rot[:, 2].copy(), rot, self.added_mass_wing,
                             self.added_inertia_wing, self.mass_wing, self.inertia_wing_local, self.volume_wing))
        return out

    # ----------------------------------------------------- mass properties
    def centre_of_gravity(self, wings: np.ndarray) -> np.ndarray:
        """r_G from O (m, body frame)."""
        total = np.zeros(3)
        for pl in self.plates(wings):
            total += pl.mass * pl.centroid
        for l in self.lumps:
            total += l.mass * l.centroid
        return total / self.mass

    def centre_of_buoyancy(self, wings: np.ndarray) -> np.ndarray:
        """r_B from O (m, body frame)."""
        total = np.zeros(3)
        for pl in self.plates(wings):
            total += pl.volume * pl.centroid
        for l in self.lumps:
            total += l.volume * l.volume_centroid
        return total / self.volume

    def ell(self, wings: np.ndarray) -> float:
        """Distance from CB to CG along z_c (m); > 0 is bottom-heavy."""
        return float((self.centre_of_gravity(wings) - self.centre_of_buoyancy(wings))[2])

    def rigid_inertia(self, wings: np.ndarray, point: np.ndarray) -> np.ndarray:
        """6x6 rigid-body inertia about ``point`` (body axes), twist order (v, w)."""
        total = sum(plate_rigid_inertia(pl, point) for pl in self.plates(wings))
        for l in self.lumps:
            total = total + spatial_inertia(l.mass, l.centroid - point, l.inertia)
        return total

    def added_inertia(self, wings: np.ndarray, point: np.ndarray) -> np.ndarray:
        """6x6 added (fluid) inertia about ``point``: rank one along each plate's
        normal for translation (eq. 2.2) plus the added inertias (eqs. 2.3-2.4)."""
        return sum(plate_added_inertia(pl, point) for pl in self.plates(wings))

    def locked_inertia(self, wings: np.ndarray, point: np.ndarray | None = None) -> np.ndarray:
        """Rigid plus added 6x6 inertia of the vehicle with the wings locked,
        about ``point`` (default: the centre of buoyancy)."""
        if point is None:
            point = self.centre_of_buoyancy(wings)
        return self.rigid_inertia(wings, point) + self.added_inertia(wings, point)

    def hinge_twists(self) -> np.ndarray:
        """(4, 6) unit twists of the hinge rotations, at O: (h_i x a_i, a_i)."""
        lin = np.cross(self.hinge_point, self.hinge_axis)
        return np.concatenate([lin, self.hinge_axis], axis=1)

    def wing_inertia(self, i: int, wings: np.ndarray, point: np.ndarray) -> np.ndarray:
        """6x6 rigid plus added inertia of wing i alone, about ``point``."""
        pl = self.plates(wings)[i + 1]
        return plate_rigid_inertia(pl, point) + plate_added_inertia(pl, point)

    def generalized_inertia(self, wings: np.ndarray) -> np.ndarray:
        """10x10 inertia of (V, Omega, s_dot) at O: kinetic energy is
        0.5 xi^T M xi with xi = (V_O, Omega, s_dot_1..4), body frame."""
        wings = _wings(wings)
        origin = np.zeros(3)
        m = np.zeros((10, 10))
        m[:6, :6] = self.locked_inertia(wings, origin)
        twists = self.hinge_twists()
        for i in range(4):
            mw = self.wing_inertia(i, wings, origin)
            col = mw @ twists[i]
            m[:6, 6 + i] = col
            m[6 + i, :6] = col
            m[6 + i, 6 + i] = twists[i] @ col
        return m

    def projected_area(self, wings: np.ndarray) -> float:
        """Plate area seen along z_c (m^2)."""
        return float(sum(pl.area * abs(pl.normal[2]) for pl in self.plates(wings)))

    def terminal_speed(self, wings: np.ndarray) -> float:
        """Straight-down descent speed (m/s): net weight equals the summed
        plate-normal drag; a wing deflected by s meets the flow at v cos s, so
        its normal force scales with cos^2 s and its vertical share with cos s."""
        wings = _wings(wings)
        area = self.area_center + self.area_wing * float(np.sum(np.cos(wings) ** 3))
        if self.net_weight <= 0:
            return 0.0
        return math.sqrt(2.0 * self.net_weight / (self.p.rho * self.p.cd * area))

    def properties(self, wings: np.ndarray) -> dict:
        """The configuration's properties about the CB, as `roboray-sim vehicle` prints them."""
        wings = _wings(wings)
        cb = self.centre_of_buoyancy(wings)
        mm = self.locked_inertia(wings, cb)
        d = mm[3:, :3]  # Omega^T D V coupling block
        return {
            "wings_deg": [math.degrees(w) for w in wings],
            "mass": self.mass,
            "rho": self.p.rho,
            "cd": self.p.cd,
            "g": self.p.g,
            "a_w": self.a_w,
            "displaced_volume": self.volume,
            "net_weight": self.net_weight,
            "ell": self.ell(wings),
            "m1": mm[0, 0], "m2": mm[1, 1], "m3": mm[2, 2],
            "I1": mm[3, 3], "I2": mm[4, 4], "I3": mm[5, 5],
            # Thesis sec. 3.1 form: D = [[0, -d1, 0], [d2, 0, 0], [0, 0, 0]]
            "d1": -d[0, 1], "d2": d[1, 0],
            "M": mm[:3, :3].tolist(), "D": d.tolist(), "J": mm[3:, 3:].tolist(),
            "area_center": self.area_center,
            "area_wing": self.area_wing,
            "added_mass_center": self.added_mass_center,
            "added_mass_wing": self.added_mass_wing,
            "cg": self.centre_of_gravity(wings).tolist(),
            "cb": cb.tolist(),
            "terminal_speed": self.terminal_speed(wings),
        }


def spatial_inertia(m: float, c: np.ndarray, i_c: np.ndarray) -> np.ndarray:
    """6x6 rigid inertia about a point P for a body of mass m whose centroid is
    at c from P and whose inertia about its centroid is i_c (twist order v, w)."""
    cx = skew(c)
    out = np.zeros((6, 6))
    out[:3, :3] = m * np.eye(3)
    out[:3, 3:] = -m * cx
    out[3:, :3] = m * cx
    out[3:, 3:] = i_c - m * cx @ cx
    return out


def plate_rigid_inertia(pl: Plate, point: np.ndarray) -> np.ndarray:
    """A plate's 6x6 rigid inertia about ``point``."""
    return spatial_inertia(pl.mass, pl.centroid - point, pl.rotation @ pl.inertia @ pl.rotation.T)


def plate_added_inertia(pl: Plate, point: np.ndarray) -> np.ndarray:
    """A plate's 6x6 added inertia about ``point``: its added mass along the
    normal and its added inertias about the in-plane axes, at the centroid."""
    local = np.zeros((6, 6))
    local[:3, :3] = pl.added_mass * np.outer(pl.normal, pl.normal)
    local[3:, 3:] = pl.rotation @ np.diag([pl.added_inertia[0], pl.added_inertia[1], 0.0]) @ pl.rotation.T
    x = twist_transform(pl.centroid - point)
    return x.T @ local @ x


def twist_transform(c: np.ndarray) -> np.ndarray:
    """Maps a twist at P to the twist at P + c: v_c = v - c x w."""
    x = np.eye(6)
    x[:3, 3:] = -skew(c)
    return x


def _triangle_inertia(m: float, base: float, height: float, t: float) -> np.ndarray:
    """Inertia about the centroid of an isosceles triangle lamina, local axes
    x (outwards, along the height), y (along the base), z (normal)."""
    # About the centroid: Ixx' (about x, spread along y) = m b^2/24,
    # Iyy' (about y, spread along x) = m h^2/18.
    i_x = m * base * base / 24.0 + m * t * t / 12.0
    i_y = m * height * height / 18.0 + m * t * t / 12.0
    return np.diag([i_x, i_y, m * base * base / 24.0 + m * height * height / 18.0])


def _wings(wings) -> np.ndarray:
    w = np.asarray(wings, dtype=float).reshape(-1)
    if w.shape != (4,):
        raise ValueError("wings must be 4 angles (rad), got shape %s" % (np.shape(wings),))
    if not np.all(np.isfinite(w)):
        raise ValueError("wing angles must be finite, got %s" % (w,))
    return w
