"""The reachable glide: how far sideways a steady descent can carry the vehicle.

Only straight glides make headway (a spiral's horizontal velocity turns with
the body), and a configuration with a mirror plane glides in that plane.
With four-fold symmetry, two families cover every mirror plane:

- ``axis``: s2 = s4 (mirror x_c z_c), s1 and s3 free: glides towards wing 1 or 3;
- ``diagonal``: s1 = s2 and s3 = s4 (mirror x_c = y_c): glides between wings.

Each family is sampled on a grid (every configuration dropped at once as a
batch on the compiled model, where it settles polished into a trim), then
the best stable glide is refined by a local optimiser (Nelder-Mead) on the
family's parameters. Configurations without a mirror plane were found to
spiral (see ``trim.find_trims``); the optimum is checked against small
asymmetric perturbations, which must not glide further.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize

from roboray.sim.analysis.trim import Trim, modes, polish_from_state
from roboray.sim.dynamics import Model, quat_from_axis_angle
from roboray.sim.progress import QUIET
from roboray.sim.simulate import simulate

FAMILIES = ("axis", "diagonal")

#: What the steps cost, in seconds of one core (measured on a batch of 196
#: configurations): the weights of the progress bar, so that its ETA holds.
COST_SETTLE_S = 1e-3     #: a configuration falling one simulated second
COST_POLISH_S = 0.08     #: polishing where it settled into a trim
COST_MODES_S = 0.02      #: linearising the trim
COST_FIND_TRIMS_S = 1.0  #: ``trim.find_trims``: a drop and ten guesses
#: Simulated seconds between two updates of a batch's progress.
SETTLE_CHUNK_S = 5.0
#: Evaluations the local optimiser may spend.
REFINE_EVALUATIONS = 80


def family_wings(family: str, params) -> np.ndarray:
    """Wing angles (deg) of a family member."""
    if family == "axis":
        s1, s3, s24 = params
        return np.array([s1, s24, s3, s24], float)
    if family == "diagonal":
        a, b = params
        return np.array([a, a, b, b], float)
    raise ValueError("family must be one of %s, got %r" % (FAMILIES, family))


def settle_batch(model_params, wings_deg: np.ndarray, duration: float = 40.0, progress=QUIET):
    """Drop every configuration (K, 4) at once and polish where each settles
    into a trim (None where it does not).

    The fall runs in chunks of ``SETTLE_CHUNK_S`` that keep only their last
    state (the same steps as one run, bit for bit, and without recording
    every 10 ms: the polish needs only where each ended), reporting each
    to ``progress`` in ``COST_*`` weights."""
    dt = 0.01
    wings = np.radians(np.asarray(wings_deg, float))
    batch = Model(model_params, n=len(wings))
    x = batch.state(attitude=quat_from_axis_angle([1, 0.3, 0], 0.05), velocity=(0, 0, 0.35), wings=wings)
    nu = None
    steps = int(round(duration / dt))
    per_chunk = max(1, int(round(SETTLE_CHUNK_S / dt)))
    done = 0
    while done < steps or nu is None:
        n = min(per_chunk, steps - done)
        run = simulate(batch, x, n * dt, dt=dt, command=wings, record_every=max(n, 1))
        x, nu = run.x[-1], run.nu[-1]
        done += n
        progress.update(len(wings) * n * dt * COST_SETTLE_S)
    single = Model(model_params)
    trims = []
    for i in range(len(wings)):
        trims.append(polish_from_state(single, wings[i], x[i], nu[i]))
        progress.update(COST_POLISH_S)
    return trims


def settle_cost(configurations: int, duration: float) -> float:
    """``settle_batch``'s weight in the progress bar."""
    return configurations * (duration * COST_SETTLE_S + COST_POLISH_S)


def evaluate(model: Model, trim: Trim | None) -> dict | None:
    if trim is None:
        return None
    info = modes(model, trim)
    return {"trim": trim, "stable": info["stable"], "max_real_eig": info["max_real_eig"]}


def glide_score(entry: dict | None) -> float:
    """Glide ratio of a stable straight glide, else 0."""
    if entry is None or not entry["stable"] or not entry["trim"].straight:
        return 0.0
    return entry["trim"].glide_ratio


def _grid(family: str, grid: np.ndarray) -> list:
    if family == "axis":
        return [(a, b, c) for a in grid for b in grid for c in grid if a <= b]   # s1 <= s3: mirror image
    return [(a, b) for a in grid for b in grid if a <= b]


def search_cost(step_deg: float = 15.0, settle_s: float = 40.0, refine: bool = True) -> float:
    """What ``search`` will cost, in the weights it reports to its progress."""
    grid = np.arange(0.0, 90.0 + 1e-9, step_deg)
    n = sum(len(_grid(f, grid)) for f in FAMILIES)
    return (settle_cost(n, settle_s) + n * COST_MODES_S
            + (REFINE_EVALUATIONS * (COST_POLISH_S + COST_MODES_S) if refine else 0.0) + 4 * COST_FIND_TRIMS_S)


def search(params=None, step_deg: float = 15.0, settle_s: float = 40.0, refine: bool = True,
           progress=QUIET, settle=settle_batch) -> dict:
    """Grid over both families, then local refinement of the best stable
    glide. ``progress`` (``sim/progress.py``) advances by ``search_cost``;
    ``settle``, ``settle_batch`` or one that runs the grid elsewhere
    (``sim/campaign/grid.py``)."""
    model = Model(params)
    grid = np.arange(0.0, 90.0 + 1e-9, step_deg)
    candidates = []
    for family in FAMILIES:
        pts = _grid(family, grid)
        wings = np.array([family_wings(family, p) for p in pts])
        progress.set_postfix_str("%s family, %d configurations" % (family, len(pts)))
        trims = settle(params, wings, settle_s, progress)
        for p, w, t in zip(pts, wings, trims):
            candidates.append({"family": family, "params": p, "wings_deg": w, **(evaluate(model, t) or {"trim": None,
                               "stable": False, "max_real_eig": None})})
            progress.update(COST_MODES_S)
    scored = sorted(candidates, key=lambda c: glide_score(c if c["trim"] is not None else None), reverse=True)
    best = scored[0]
    grid_best = glide_score(best)
    refined = None
    if refine:
        progress.set_postfix_str("refining")
        if grid_best > 0:
            refined = _refine(model, best, progress)
            if refined is not None and glide_score(refined) > grid_best:
                best = refined
        else:
            progress.update(REFINE_EVALUATIONS * (COST_POLISH_S + COST_MODES_S))
    progress.set_postfix_str("asymmetric checks")
    trim = best["trim"]
    # Does breaking the mirror symmetry help? Small asymmetric nudges.
    asym = []
    if trim is not None:
        for k in range(4):
            w = np.degrees(trim.wings).copy()
            w[k] = min(90.0, max(0.0, w[k] + 3.0))
            from roboray.sim.analysis.trim import find_trims

            for t in find_trims(model, np.radians(w), settle_s=settle_s)[:1]:
                e = evaluate(model, t)
                asym.append({"wings_deg": w.tolist(), "kind": t.as_dict()["kind"], "glide_score": glide_score(e)})
            progress.update(COST_FIND_TRIMS_S)
    else:
        progress.update(4 * COST_FIND_TRIMS_S)
    return {
        "max_glide_ratio": glide_score(best),
        "wings_deg": np.degrees(trim.wings).tolist() if trim else None,
        "descent_speed": trim.descent_speed if trim else None,
        "horizontal_speed": trim.horizontal_speed if trim else None,
        "glide_direction_deg": trim.glide_direction_deg if trim else None,
        "tilt_deg": trim.tilt_deg if trim else None,
        "stable": bool(best["stable"]),
        "max_real_eig": best["max_real_eig"],
        "family": best["family"],
        "grid_step_deg": step_deg,
        "grid_best_glide_ratio": grid_best,
        "refined_by": "Nelder-Mead on the family's parameters" if refined is not None else None,
        "configurations_tried": len(candidates),
        "stable_glides_found": sum(1 for c in candidates if glide_score(c) > 0),
        "asymmetric_checks": asym,
        "confidence": ("grid of %g deg on both mirror families (%d configurations), best refined locally; "
                       "a finer grid or another local optimum could still add a few percent"
                       % (step_deg, len(candidates))),
        "candidates": candidates,
    }


def _refine(model: Model, start: dict, progress=QUIET) -> dict | None:
    family = start["family"]
    best = {"score": glide_score(start), "entry": start}
    spent = [0]

    def objective(x):
        spent[0] += 1
        if spent[0] <= REFINE_EVALUATIONS:
            progress.update(COST_POLISH_S + COST_MODES_S)
        p = np.clip(x, 0.0, 90.0)
        w = family_wings(family, p)
        guess = best["entry"]["trim"]
        from roboray.sim.analysis.trim import solve_trim

        t = solve_trim(model, np.radians(w), Trim(np.radians(w), guess.V, guess.gamma, 0.0, float("nan")), spiral=False)
        e = evaluate(model, t)
        score = glide_score(e)
        if score > best["score"]:
            best["score"] = score
            best["entry"] = {"family": family, "params": tuple(p), "wings_deg": w, **e}
        return -score

    minimize(objective, np.array(start["params"], float), method="Nelder-Mead",
             options={"xatol": 0.5, "fatol": 1e-4, "maxfev": REFINE_EVALUATIONS,
                      "initial_simplex": _simplex(start["params"])})
    progress.update(max(0, REFINE_EVALUATIONS - spent[0]) * (COST_POLISH_S + COST_MODES_S))   # converged early
    return best["entry"] if best["entry"] is not start else None


def _simplex(p) -> np.ndarray:
    p = np.array(p, float)
    pts = [p]
    for k in range(len(p)):
        q = p.copy()
        q[k] = q[k] - 7.5 if q[k] >= 45 else q[k] + 7.5
        pts.append(q)
    return np.array(pts)


def travel_from_depth(depth_m: float, glide_ratio: float) -> float:
    """Horizontal reach from a release at the surface to a bottom at depth_m."""
    return depth_m * glide_ratio if math.isfinite(glide_ratio) else float("inf")
