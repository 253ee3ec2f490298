"""Monte Carlo target landings: the draws, one landing as a row, the summary.

``draws(runs, seed, ...)`` draws each run's model and sensor errors (plain,
picklable ``Draw`` objects: the ``FlightSpec`` and the relative errors it
was made from); ``landing_row(draw)`` flies one and returns its row, the
drawn errors beside the outcomes; ``campaign(...)`` makes them a
``sim/campaign`` campaign, which runs them on local processes or a Dask
cluster and keeps the rows in a results file; ``summary(rows)`` reduces the
rows to the landing error's percentiles.

Draw ``i`` is the ``i``-th of one generator seeded by ``seed`` and its
flight's sensors are seeded by ``seed * 100000 + i``: a run depends on its
index, and the first 50 draws of 200 runs are those of 50 runs.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from roboray.sim.flight import FlightSpec, fly

#: Relative spread (uniform, +-) of each model error of a Monte Carlo run.
MODEL_ERROR = 0.10
ADDED_MASS_FIELDS = ("k_center", "k_wing", "kx_center", "ky_center", "kx_wing", "ky_wing")
#: Each run's drawn errors as its row names them, in the order they are drawn.
ERRORS = ("added_mass_error", "cd_error", "ell_error", "servo_tau_error")

#: A landing's row: what was drawn, then what happened (None: not landed).
COLUMNS = (
    [("seed", "int"), ("heading_deg", "float"), ("target_north_m", "float"), ("target_east_m", "float"),
     ("tracker_noise_m", "float")]
    + [(name, "float") for name in ERRORS]
    + [("landed", "bool"), ("landing_error_m", "float"), ("landing_north_m", "float"), ("landing_east_m", "float"),
       ("descent_time_s", "float"), ("descent_speed_mps", "float"), ("max_tilt_deg", "float"),
       ("servo_travel_deg", "float"), ("settling_time_s", "float"), ("estimate_position_rms_m", "float"),
       ("estimate_velocity_rms_mps", "float"), ("estimate_error_at_landing_m", "float")])


@dataclass(frozen=True)
class Draw:
    """One run: its flight and the relative model errors behind it."""

    spec: FlightSpec
    errors: tuple   #: ERRORS' values, e.g. +0.034: 3.4 % more than the vehicle file's


def _payload_height_for_ell(params, factor: float) -> float:
    """payload_height that scales ell (flat wings) by ``factor``: ell is
    affine in it (the payload's mass is fixed), so two evaluations solve it."""
    from roboray.sim.vehicle import Vehicle

    flat = np.zeros(4)
    h0 = params.payload_height
    e0 = Vehicle(params).ell(flat)
    e1 = Vehicle(dataclasses.replace(params, payload_height=h0 + 1e-3)).ell(flat)
    return h0 + (factor - 1.0) * e0 * 1e-3 / (e1 - e0)


def draws(runs: int, seed: int = 0, depth: float = 10.0, distance: float = 2.0, controller: str = "cascade",
          truth: bool = False, link: Optional[tuple] = None, vehicle=None,
          firmware: Optional[dict] = None) -> list[Draw]:
    """``runs`` target landings under random model errors: added mass (every
    added-mass and added-inertia coefficient), C_D, ell (through the
    payload's height) and the servo lag each off by up to +-10 %, the
    sensors' biases and noises of their own seed, the fixes' noise 1-4 cm;
    a target ``distance`` m from the release in a random direction, a
    random heading at release. ``link``: (water, radio model, conductivity
    or None): the fixes cross the radio into that water
    (``FlightSpec.radio_model``); None: they all arrive. ``vehicle``: the
    truth's ``VehicleParams`` the errors are drawn around (None: the
    reference); ``firmware``: the firmware's parameters (a parameter file's),
    of which the flight uses the descent model (DR_*) and the controller's
    gains (CTL_*)."""
    if runs < 1:
        raise ValueError("runs must be at least 1, got %r" % runs)
    from roboray.sim.vehicle import load_params

    base = vehicle if vehicle is not None else load_params()
    whole = tuple((f.name, getattr(base, f.name)) for f in dataclasses.fields(base)) if vehicle is not None else ()
    firmware = firmware or {}
    descent = tuple(sorted((k, float(v)) for k, v in firmware.items() if k.startswith("DR_")))
    gains = tuple(sorted((k, float(v)) for k, v in firmware.items() if k.startswith("CTL_")))
    rng = np.random.default_rng([seed, 7])
    out = []
    for i in range(runs):
        e = rng.uniform(-MODEL_ERROR, MODEL_ERROR, 4)
        bearing = rng.uniform(0.0, 2.0 * math.pi)
        vehicle = [(name, getattr(base, name) * (1.0 + e[0])) for name in ADDED_MASS_FIELDS]
        vehicle.append(("cd", base.cd * (1.0 + e[1])))
        vehicle.append(("payload_height", _payload_height_for_ell(base, 1.0 + e[2])))
        vehicle.append(("servo_tau", base.servo_tau * (1.0 + e[3])))
        spec = FlightSpec(
            controller=controller, mode="target", target=(distance * math.cos(bearing), distance * math.sin(bearing)),
            depth=depth, truth=truth, seed=int(seed * 100000 + i), heading_deg=float(rng.uniform(0.0, 360.0)),
            vehicle=whole + tuple((k, float(v)) for k, v in vehicle),
            tracker_noise_m=float(rng.uniform(0.01, 0.04)), descent=descent, ctl=gains, **link_fields(link))
        out.append(Draw(spec, tuple(float(x) for x in e)))
    return out


def link_fields(link: Optional[tuple]) -> dict:
    """``FlightSpec``'s water and link fields for ``draws``' ``link``."""
    if link is None:
        return {}
    water, radio_model, conductivity = link
    return {"water": water, "radio_model": radio_model, "conductivity": conductivity}


def link_params(link: Optional[tuple]) -> dict:
    """How a campaign's parameters name its link (nothing without one, so
    results files of campaigns before the link model still resume)."""
    if link is None:
        return {}
    return {"water": link[0], "radio_model": link[1], "conductivity_s_per_m": link[2]}


def plan(runs: int, seed: int = 0, depth: float = 10.0, distance: float = 2.0, controller: str = "cascade",
         truth: bool = False, link: Optional[tuple] = None) -> list[FlightSpec]:
    """The flights of ``draws``."""
    return [d.spec for d in draws(runs, seed, depth, distance, controller, truth, link)]


def landing_row(draw: Draw) -> dict:
    """Fly one draw: its row (``COLUMNS``). The unit of work the campaign
    maps; a function of the draw alone."""
    spec = draw.spec
    f = fly(spec)
    m = f.metrics
    row = {"seed": spec.seed, "heading_deg": spec.heading_deg, "target_north_m": spec.target[0],
           "target_east_m": spec.target[1], "tracker_noise_m": spec.tracker_noise_m}
    row.update(zip(ERRORS, draw.errors))
    landing = m.get("landing_position")
    row.update(landed=bool(m["landed"]), landing_error_m=m.get("landing_error_m"),
               landing_north_m=landing[0] if landing else None, landing_east_m=landing[1] if landing else None,
               descent_time_s=m["descent_time_s"], descent_speed_mps=m.get("descent_speed_mps"),
               max_tilt_deg=m["max_tilt_deg"], servo_travel_deg=m["servo_travel_deg"],
               settling_time_s=m.get("settling_time_s"), estimate_position_rms_m=m.get("estimate_position_rms_m"),
               estimate_velocity_rms_mps=m.get("estimate_velocity_rms_mps"),
               estimate_error_at_landing_m=(float(np.hypot(*(f.estimate_nav[-1, 2:4] - f.position[-1, :2])))
                                            if len(f.t) else None))
    return row


def campaign(runs: int, seed: int = 0, depth: float = 10.0, distance: float = 2.0, controller: str = "cascade",
             truth: bool = False, link: Optional[tuple] = None, vehicle_file: Optional[str] = None,
             params_file: Optional[str] = None):
    """The landings of ``draws`` as a campaign (``sim/campaign``); its
    parameters name it in a results file (the vehicle and parameter
    files by their paths, only when given). ``vehicle_file``: the truth's
    vehicle (a Python vehicle file); ``params_file``: the firmware's
    parameters (ArduPilot's format, ``ground/paramfile.py``)."""
    from roboray.ground import paramfile
    from roboray.sim.campaign import Campaign
    from roboray.sim.vehicle import load_params

    vehicle = load_params(vehicle_file) if vehicle_file else None
    firmware = paramfile.load(params_file) if params_file else None
    files = {}
    if vehicle_file:
        files["vehicle"] = vehicle_file
    if params_file:
        files["params"] = params_file

    params = {"runs": runs, "seed": seed, "depth_m": depth, "distance_m": distance, "controller": controller,
              "estimator": "truth" if truth else "board estimator", "model_error": MODEL_ERROR,
              **link_params(link), **files}
    return Campaign("montecarlo", params, draws(runs, seed, depth, distance, controller, truth, link, vehicle,
                                                firmware), landing_row, COLUMNS)


def summary(rows: Sequence[dict]) -> dict:
    """p50, p95 and worst landing error of a batch, and its worst run (its
    index in ``run`` and its row)."""
    errors = np.array([r["landing_error_m"] for r in rows if r.get("landing_error_m") is not None])
    est = np.array([r.get("estimate_error_at_landing_m") if r.get("estimate_error_at_landing_m") is not None
                    else np.nan for r in rows], float)
    worst = int(np.argmax([r["landing_error_m"] if r.get("landing_error_m") is not None else np.inf
                           for r in rows])) if rows else None
    return {
        "runs": len(rows),
        "landed": int(len(errors)),
        "landing_error_p50_m": float(np.percentile(errors, 50)) if len(errors) else None,
        "landing_error_p95_m": float(np.percentile(errors, 95)) if len(errors) else None,
        "landing_error_worst_m": float(errors.max()) if len(errors) == len(rows) and len(errors) else None,
        "landing_error_mean_m": float(errors.mean()) if len(errors) else None,
        "estimate_error_at_landing_p95_m": float(np.nanpercentile(est, 95)) if np.isfinite(est).any() else None,
        "max_tilt_deg": float(max(r["max_tilt_deg"] for r in rows)) if rows else None,
        "worst_run": dict(rows[worst], run=worst) if worst is not None else None,
    }
