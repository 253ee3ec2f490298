"""Design sweeps: what a vehicle-file parameter or a controller gain does
to the glide, the reach and the landings.

A **parameter** is a field of ``VehicleParams`` (``sim/vehicle.py``: what a
vehicle file defines, e.g. ``wing_height``, ``total_mass``) or a gain of
the controllers' parameter table (``shared/param_defs.CONTROL``, e.g.
``CTL_TGT_K``), given a range ``NAME=LO:HI`` (or a value ``NAME=V``, held
for every point). **Sampling**: ``grid`` takes N levels per parameter, every
combination (N^k points); ``latin_hypercube`` takes N points with one
sample in each of the N equal strata of every parameter, from a generator
seeded by ``seed``.

A **design point** is the base vehicle with its values put in, and its
controller's gains. Its evaluation is tasks of one campaign
(``sim/campaign``), point after point:

- one **design** task: the settled descents of the configurations the
  analyses refer to (wings flat: the straight fall; the controller's
  symmetric fold ``CTL_FOLD_DEG``; wings 3 and 4 folded up, the glide
  between two wings), each by a drop settled and polished
  (``trim.trim_by_settling``, a tenth of a second), and its envelope (the
  best stable glide, ``envelope.search`` on a coarse grid refined locally);
- ``runs`` **landing** tasks: ``sim/montecarlo.py``'s draws flown by this
  point's vehicle and gains. Draw ``j`` is the same for every point (its
  target, heading, sensor seed and its relative model errors, applied to
  the point's own values): points differ by their design alone, not by
  luck of the draw (common random numbers), so a few draws a point
  compare points fairly.

Every task is a function of its index alone, so the rows are the same on
any engine; ``summary`` reduces them to one entry a point (trims, reach,
landing error p50, p95, worst, landed fraction) and marks the points no
other beats on both reach and p95 landing error (the Pareto front);
``figure`` draws the trade-off.
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import itertools
import math
import re
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from roboray.sim import montecarlo as MC

#: VehicleParams fields that are not one number (sensor positions).
_NOT_SWEPT = ("imu_position", "pressure_port")
#: The analyses' reference configurations (deg) besides the controller's fold.
FLAT = (0.0, 0.0, 0.0, 0.0)
TWO_UP = (0.0, 0.0, 90.0, 90.0)
#: Seconds a design task's drops fall before their trim is polished.
SETTLE_S = 40.0
#: Envelope grid step (deg) of a sweep: coarse, then refined locally (6 s a
#: point here against 18 s at the envelope command's 15 deg, same optimum
#: on the reference and the buildable vehicle).
ENVELOPE_STEP_DEG = 30.0
#: A design task's columns: the trims and the envelope.
DESIGN_COLUMNS = [("fall_speed_mps", "float"), ("fold_deg", "float"), ("fold_descent_mps", "float"),
                  ("two_up_glide_ratio", "float"), ("two_up_descent_mps", "float"),
                  ("best_glide_ratio", "float"), ("best_glide_descent_mps", "float"),
                  ("best_glide_wings_deg", "str")]


# ------------------------------------------------------------ parameters
def vehicle_names() -> list[str]:
    from roboray.sim.vehicle import VehicleParams

    return [f.name for f in dataclasses.fields(VehicleParams) if f.name not in _NOT_SWEPT]


def controller_defs() -> dict:
    """Controller gains by name: ``(default, min, max)``."""
    from roboray.shared import param_defs

    return {d[0]: (float(d[2]), float(d[3]), float(d[4])) for d in param_defs.CONTROL}


@dataclass(frozen=True)
class Parameter:
    """A swept quantity: ``low`` to ``high`` (equal: held at that value)."""

    name: str
    low: float
    high: float

    @property
    def controller(self) -> bool:
        return self.name.startswith("CTL_")

    @property
    def fixed(self) -> bool:
        return self.low == self.high

    def spec(self) -> list:
        return [self.name, self.low, self.high]


def parse_parameter(text: str) -> Parameter:
    """``NAME=LO:HI`` or ``NAME=VALUE``; ValueError naming the problem (and,
    for an unknown name, every name there is)."""
    name, sep, rest = text.partition("=")
    name = name.strip()
    if not sep or not name or not rest.strip():
        raise ValueError("--param %r: give NAME=LO:HI (or NAME=VALUE)" % text)
    names = vehicle_names()
    gains = controller_defs()
    if name not in names and name not in gains:
        raise ValueError("--param %r: no parameter %r; vehicle: %s; controller: %s"
                         % (text, name, ", ".join(names), ", ".join(gains)))
    parts = rest.split(":")
    if len(parts) > 2:
        raise ValueError("--param %r: give one range LO:HI" % text)
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError("--param %r: %r is not a number or a range LO:HI" % (text, rest))
    if not all(math.isfinite(v) for v in values):
        raise ValueError("--param %r: the range must be finite numbers" % text)
    low, high = values[0], values[-1]
    if low > high:
        raise ValueError("--param %r: the range's low end %g is above its high end %g" % (text, low, high))
    if name in gains:
        _, lo, hi = gains[name]
        if low < lo or high > hi:
            raise ValueError("--param %r: %s takes %g to %g" % (text, name, lo, hi))
    return Parameter(name, low, high)


def check_parameters(parameters: Sequence[Parameter], base) -> None:
    """ValueError when a name is given twice or a range's end makes the
    base vehicle unusable (``VehicleParams.problems``)."""
    seen = set()
    for p in parameters:
        if p.name in seen:
            raise ValueError("--param %s is given twice" % p.name)
        seen.add(p.name)
        if p.controller:
            continue
        for value in (p.low, p.high):
            bad = dataclasses.replace(base, **{p.name: value}).problems()
            if bad:
                raise ValueError("--param %s=%g: %s" % (p.name, value, "; ".join(bad)))


def check_points(base, parameters: Sequence[Parameter], points: Sequence[tuple]) -> None:
    """ValueError for a point whose vehicle cannot be built or floats (it
    would never land: each of its flights would run to its time limit)."""
    from roboray.sim.vehicle import Vehicle

    for i, values in enumerate(points):
        where = ", ".join("%s=%.6g" % (p.name, v) for p, v in zip(parameters, values) if not p.controller)
        params = point_vehicle(base, parameters, values)
        bad = params.problems()
        try:
            vehicle = Vehicle(params) if not bad else None
        except ValueError as exc:
            bad = [str(exc)]
        if bad:
            raise ValueError("point %d (%s): %s" % (i, where, "; ".join(bad)))
        if vehicle.net_weight <= 0:
            raise ValueError("point %d (%s) floats: its weight in water is %.3f N, it would never land"
                             % (i, where, vehicle.net_weight))


# ------------------------------------------------------------ sampling
def grid(parameters: Sequence[Parameter], levels: int) -> list[tuple]:
    """Every combination of ``levels`` evenly spaced values of each varying
    parameter, both ends included (the last parameter changes fastest); a
    held one keeps its value."""
    if levels < 2:
        raise ValueError("a grid needs at least 2 levels, got %r" % levels)
    axes = [[p.low] if p.fixed else [float(v) for v in np.linspace(p.low, p.high, levels)] for p in parameters]
    return [tuple(values) for values in itertools.product(*axes)]


def latin_hypercube(parameters: Sequence[Parameter], n: int, seed: int = 0) -> list[tuple]:
    """``n`` points, each varying parameter's range cut into ``n`` equal
    strata with exactly one point in each; where in its stratum, and which
    strata go together, is drawn from a generator seeded by ``seed``."""
    if n < 2:
        raise ValueError("a Latin hypercube needs at least 2 points, got %r" % n)
    rng = np.random.default_rng([seed, 20])
    columns = []
    for p in parameters:
        if p.fixed:
            columns.append([p.low] * n)
            continue
        strata = rng.permutation(n)
        u = (strata + rng.uniform(size=n)) / n
        columns.append([float(p.low + (p.high - p.low) * x) for x in u])
    return [tuple(c[i] for c in columns) for i in range(n)]


def point_vehicle(base, parameters: Sequence[Parameter], values: Sequence[float]):
    """The base vehicle with the point's vehicle values put in."""
    changes = {p.name: float(v) for p, v in zip(parameters, values) if not p.controller}
    return dataclasses.replace(base, **changes) if changes else base


def base_values(base, parameters: Sequence[Parameter]) -> dict:
    """Each parameter's value before the sweep: the vehicle file's, or the
    controller's default."""
    gains = controller_defs()
    return {p.name: gains[p.name][0] if p.controller else float(getattr(base, p.name)) for p in parameters}


def point_gains(parameters: Sequence[Parameter], values: Sequence[float]) -> tuple:
    """The point's controller overrides, ``FlightSpec.ctl``'s form."""
    return tuple((p.name, float(v)) for p, v in zip(parameters, values) if p.controller)


def perturbed(params, errors: Sequence[float]) -> tuple:
    """A Monte Carlo draw's relative model errors (``MC.ERRORS``) applied to
    ``params``, as ``FlightSpec.vehicle``: every field, so that the flight
    flies this vehicle whatever the reference is. ``MC.draws`` does the
    same to the reference (a test holds the two together)."""
    e = errors
    values = {f.name: getattr(params, f.name) for f in dataclasses.fields(params)}
    for name in MC.ADDED_MASS_FIELDS:
        values[name] = getattr(params, name) * (1.0 + e[0])
    values["cd"] = params.cd * (1.0 + e[1])
    values["payload_height"] = MC._payload_height_for_ell(params, 1.0 + e[2])
    values["servo_tau"] = params.servo_tau * (1.0 + e[3])
    return tuple((k, tuple(float(x) for x in v) if isinstance(v, tuple) else float(v)) for k, v in values.items())


# ------------------------------------------------------------ tasks
@dataclass(frozen=True)
class DesignTask:
    """A point's trims and envelope."""

    point: int
    values: tuple
    params: object          #: VehicleParams of the point
    fold_deg: float
    envelope_step_deg: float


@dataclass(frozen=True)
class LandingTask:
    """One draw flown by a point's vehicle and gains."""

    point: int
    values: tuple
    index: int              #: the draw's index, the same draw at every point
    draw: MC.Draw


def _settled(model, wings_deg):
    from roboray.sim.analysis.trim import trim_by_settling

    return trim_by_settling(model, np.radians(wings_deg), SETTLE_S)


def design_row(task: DesignTask) -> dict:
    """The trims and the best stable glide of a point's vehicle."""
    from roboray.sim.analysis import envelope
    from roboray.sim.dynamics import Model

    model = Model(task.params)
    flat = _settled(model, FLAT)
    fold = _settled(model, (task.fold_deg,) * 4)
    two = _settled(model, TWO_UP)
    env = envelope.search(task.params, step_deg=task.envelope_step_deg, settle_s=SETTLE_S)
    straight = two is not None and two.straight
    return {
        "fall_speed_mps": flat.descent_speed if flat is not None else None,
        "fold_deg": task.fold_deg,
        "fold_descent_mps": fold.descent_speed if fold is not None else None,
        "two_up_glide_ratio": (two.glide_ratio if straight else 0.0) if two is not None else None,
        "two_up_descent_mps": two.descent_speed if two is not None else None,
        "best_glide_ratio": env["max_glide_ratio"],
        "best_glide_descent_mps": env["descent_speed"],
        "best_glide_wings_deg": (",".join("%.1f" % w for w in env["wings_deg"])
                                 if env["wings_deg"] is not None else None),
    }


def columns(parameters: Sequence[Parameter]) -> list:
    """A row: which task (``kind`` design or landing, ``point``, ``draw``),
    the point's values, the design task's figures, the landing's."""
    return ([("kind", "str"), ("point", "int"), ("draw", "int")] + [(p.name, "float") for p in parameters]
            + DESIGN_COLUMNS + list(MC.COLUMNS))


def task_row(task) -> dict:
    """The unit of work a sweep's campaign maps: one row of ``columns``,
    the other kind's columns empty."""
    row = {"kind": "design" if isinstance(task, DesignTask) else "landing", "point": task.point,
           "draw": None if isinstance(task, DesignTask) else task.index}
    row.update(task.values)
    if isinstance(task, DesignTask):
        row.update(design_row(task))
        row.update({name: None for name, _ in MC.COLUMNS})
    else:
        row.update({name: None for name, _ in DESIGN_COLUMNS})
        row.update(MC.landing_row(task.draw))
    return row


def _digest(params) -> str:
    """Names the base vehicle's numbers in a results file: an edited
    vehicle file is another campaign."""
    return hashlib.sha1(repr(params).encode()).hexdigest()[:12]


def campaign(base, parameters: Sequence[Parameter], points: Sequence[tuple], runs: int, seed: int = 0,
             depth: float = 10.0, distance: float = 2.0, controller: str = "cascade", truth: bool = False,
             envelope_step_deg: float = ENVELOPE_STEP_DEG, vehicle: str = "reference", sampling: str = "grid",
             link: Optional[tuple] = None):
    """Every point's design task and ``runs`` landings, point after point
    (task ``p * (runs + 1)`` is point ``p``'s design, the next ``runs`` its
    landings: the long and the short tasks mix evenly, so a progress bar
    counting tasks keeps a true ETA). ``link`` as ``MC.draws``'."""
    from roboray.sim.campaign import Campaign

    if not points:
        raise ValueError("a sweep needs at least one point")
    draws = MC.draws(runs, seed, depth, distance, controller, truth, link)
    default_fold = controller_defs()["CTL_FOLD_DEG"][0]
    tasks = []
    for i, values in enumerate(points):
        named = tuple((p.name, float(v)) for p, v in zip(parameters, values))
        params = point_vehicle(base, parameters, values)
        gains = point_gains(parameters, values)
        fold = dict(gains).get("CTL_FOLD_DEG", default_fold)
        tasks.append(DesignTask(i, named, params, fold, envelope_step_deg))
        for j, d in enumerate(draws):
            spec = dataclasses.replace(d.spec, vehicle=perturbed(params, d.errors), ctl=gains)
            tasks.append(LandingTask(i, named, j, MC.Draw(spec, d.errors)))
    run_params = {"vehicle": vehicle, "vehicle_sha1": _digest(base), "parameters": [p.spec() for p in parameters],
                  "sampling": sampling, "points": len(points), "seed": seed, "runs": runs, "depth_m": depth,
                  "distance_m": distance, "controller": controller,
                  "estimator": "truth" if truth else "board estimator", "model_error": MC.MODEL_ERROR,
                  "envelope_step_deg": envelope_step_deg, **MC.link_params(link)}
    return Campaign("sweep", run_params, tasks, task_row, columns(parameters))


# ------------------------------------------------------------ summary
def pareto(points: Sequence[dict]) -> list[int]:
    """Indices of the points no other point beats on both reach (best
    glide ratio, more is better) and p95 landing error (less is better);
    a point with a run that never landed counts as infinitely far off."""
    def cost(p):
        p95 = p.get("landing_error_p95_m")
        return (-(p.get("best_glide_ratio") or 0.0),
                p95 if p95 is not None and p.get("landed_fraction") == 1.0 else math.inf)

    out = []
    for i, p in enumerate(points):
        a = cost(p)
        if not any(b[0] <= a[0] and b[1] <= a[1] and b != a for b in (cost(q) for q in points)):
            out.append(i)
    return out


def summary(rows: Sequence[dict], parameters: Sequence[Parameter], depth: float) -> dict:
    """One entry a point: its values, its design row's figures, its
    landings' statistics (``MC.summary``) and whether it is on the front."""
    from roboray.sim.flight import FlightSpec

    by_point: dict = {}
    for r in rows:
        by_point.setdefault(r["point"], {"design": None, "landings": []})
        if r["kind"] == "design":
            by_point[r["point"]]["design"] = r
        else:
            by_point[r["point"]]["landings"].append(r)
    height = depth - FlightSpec.start_depth
    points = []
    for i in sorted(by_point):
        d = by_point[i]["design"] or {}
        landings = by_point[i]["landings"]
        stats = MC.summary(landings)
        speeds = [r["descent_speed_mps"] for r in landings if r.get("descent_speed_mps") is not None]
        entry = {"point": i, "values": {p.name: d.get(p.name) if d else landings[0][p.name] for p in parameters}}
        entry.update({name: d.get(name) for name, _ in DESIGN_COLUMNS})
        entry["reach_m"] = entry["best_glide_ratio"] * height if entry["best_glide_ratio"] is not None else None
        entry.update({k: stats[k] for k in ("runs", "landed", "landing_error_p50_m", "landing_error_p95_m",
                                            "landing_error_worst_m", "landing_error_mean_m", "max_tilt_deg")})
        entry["landed_fraction"] = stats["landed"] / stats["runs"] if stats["runs"] else None
        entry["landing_descent_mps"] = float(np.mean(speeds)) if speeds else None
        travel = [r["servo_travel_deg"] for r in landings if r.get("servo_travel_deg") is not None]
        entry["servo_travel_mean_deg"] = float(np.mean(travel)) if travel else None
        points.append(entry)
    front = pareto(points)
    for k, p in enumerate(points):
        p["pareto"] = k in front
    return {"points": points, "pareto": [points[k]["point"] for k in front]}


# ------------------------------------------------------------ figure
def units() -> dict:
    """Each parameter's unit, from the comments that declare it
    (``#: kg, ...`` in VehicleParams, ``# m/s, ...`` in param_defs)."""
    from roboray.shared import param_defs
    from roboray.sim.vehicle import VehicleParams

    out = {}
    for m in re.finditer(r"^\s*(\w+): \w+\s+#: ([^,\n]+),", inspect.getsource(VehicleParams), re.M):
        out[m.group(1)] = m.group(2).strip()
    for m in re.finditer(r'\("(CTL_\w+)",.*?#\s*([^,\n]+),', inspect.getsource(param_defs)):
        out[m.group(1)] = m.group(2).strip()
    for name in controller_defs():
        if name.endswith("_DEG"):
            out.setdefault(name, "deg")
    return {k: v for k, v in out.items() if len(v) <= 8 and " " not in v}


def label(name: str) -> str:
    unit = units().get(name)
    return "%s (%s)" % (name, unit) if unit and unit != "-" else name


def figure(result: dict):
    """The trade-off a sweep found, as a matplotlib figure: for one varying
    parameter, the landing error and the reach against it; for more, reach
    against p95 landing error, each point coloured by the first parameter
    and sized by the second, the Pareto front drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = result["points"]
    varying = [p for p in result["parameters"] if p[1] != p[2]]
    title = "Design sweep of the %s vehicle\n%d points, %d landings each from %g m onto targets %g m away" % (
        result["vehicle"], len(points), result["runs_per_point"], result["depth_m"], result["distance_m"])
    held = [p for p in result["parameters"] if p[1] == p[2]]
    notes = []
    if held:
        notes.append("held: %s" % ", ".join("%s = %g" % (p[0], p[1]) for p in held))
    if len(varying) > 2:
        notes.append("also varied, not drawn: %s (the summary has every value)" % ", ".join(p[0] for p in varying[2:]))
    if notes:
        title += " (%s)" % "; ".join(notes)
    height = result["depth_m"] - result["release_depth_m"]

    def get(key):
        return np.array([p[key] if p[key] is not None else np.nan for p in points], float)

    if len(varying) <= 1:
        name = varying[0][0] if varying else result["parameters"][0][0]
        x = np.array([p["values"][name] for p in points], float)
        order = np.argsort(x)
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
        for key, style, what in (("landing_error_p95_m", "o-", "p95"), ("landing_error_p50_m", "s--", "p50"),
                                 ("landing_error_worst_m", "v:", "worst")):
            ax1.plot(x[order], get(key)[order] * 100, style, label=what)
        ax1.set_ylabel("landing error (cm)")
        ax1.set_ylim(bottom=0)
        ax1.legend(title="of %d landings a point" % result["runs_per_point"], fontsize=8)
        ax1.grid(True, alpha=0.3)
        ratio = get("best_glide_ratio")
        # drawn wide beneath: where the best glide is the two-wing fold the lines coincide
        ax2.plot(x[order], ratio[order], "o-", color="C2", lw=5, ms=10, alpha=0.45,
                 label="best stable glide (envelope)")
        ax2.plot(x[order], get("two_up_glide_ratio")[order], "s--", color="C4", label="wings 3, 4 folded up")
        base = result.get("base_values", {}).get(name)
        if base is not None and x.min() <= base <= x.max():
            for ax in (ax1, ax2):
                ax.axvline(base, color="grey", lw=1, ls="-.")
            ax2.plot([], [], color="grey", lw=1, ls="-.", label="the vehicle's own value (%.4g)" % base)
        ax2.set_ylabel("glide ratio (horizontal / vertical)")
        ax2.set_xlabel(label(name))
        ax2.grid(True, alpha=0.3)
        ax2.legend(fontsize=8, loc="lower right")
        reach = ax2.secondary_yaxis("right", functions=(lambda r: r * height, lambda m: m / height))
        reach.set_ylabel("reach from %g m (m)" % result["depth_m"])
        lo, hi = np.nanmin(ratio), np.nanmax(ratio)
        if np.isfinite(lo) and hi - lo < 0.02:   # a flat line at full scale would show only round-off
            ax2.set_ylim(lo - 0.05, hi + 0.05)
        for k in result["pareto"]:
            p = points[[q["point"] for q in points].index(k)]
            if p["landing_error_p95_m"] is None:
                continue
            ax1.plot([p["values"][name]], [p["landing_error_p95_m"] * 100], "o", ms=13, mfc="none", mec="C3")
        ax1.plot([], [], "o", ms=10, mfc="none", mec="C3", label="Pareto front (reach vs p95)")
        ax1.legend(title="of %d landings a point" % result["runs_per_point"], fontsize=8)
        fig.suptitle(title, fontsize=10)
        fig.tight_layout()
        return fig

    reach_m = get("best_glide_ratio") * height
    p95 = get("landing_error_p95_m") * 100
    c_name, s_name = varying[0][0], varying[1][0]
    c = np.array([p["values"][c_name] for p in points], float)
    s = np.array([p["values"][s_name] for p in points], float)
    span = (s - s.min()) / (s.max() - s.min()) if s.max() > s.min() else np.full(len(s), 0.5)
    sizes = 40 + 260 * span
    fig, ax = plt.subplots(figsize=(8.5, 6))
    sc = ax.scatter(reach_m, p95, c=c, s=sizes, cmap="viridis", edgecolors="k", linewidths=0.5, zorder=3)
    fig.colorbar(sc, ax=ax, label=label(c_name))
    front = [q for q in points if q["pareto"] and q["landing_error_p95_m"] is not None]
    front.sort(key=lambda q: q["best_glide_ratio"])
    if front:
        ax.plot([q["best_glide_ratio"] * height for q in front], [q["landing_error_p95_m"] * 100 for q in front],
                "--", color="C3", lw=1.5, zorder=2, label="Pareto front: nothing reaches farther and lands closer")
        ax.scatter([q["best_glide_ratio"] * height for q in front], [q["landing_error_p95_m"] * 100 for q in front],
                   s=[sizes[points.index(q)] + 120 for q in front], facecolors="none", edgecolors="C3", zorder=4)
    for k, p in enumerate(points):
        if np.isfinite(reach_m[k]) and np.isfinite(p95[k]):
            ax.annotate("%d" % p["point"], (reach_m[k], p95[k]), textcoords="offset points", xytext=(7, 5),
                        fontsize=7)
    for v in (s.min(), s.max()):
        ax.scatter([], [], s=40 + 260 * (0.0 if v == s.min() else 1.0), c="none", edgecolors="k",
                   label="%s = %.4g" % (label(s_name), v))
    unlanded = [p["point"] for p in points if p["landed_fraction"] != 1.0]
    if unlanded:
        ax.text(0.01, 0.01, "points with runs that did not land: %s" % ", ".join(map(str, unlanded)),
                transform=ax.transAxes, fontsize=8, color="C3")
    ax.set_xlabel("reach: best stable glide ratio x %g m of height (m)" % height)
    ax.set_ylabel("landing error p95 (cm)")
    top = np.nanmax(p95) if np.isfinite(p95).any() else 1.0
    ax.set_ylim(0, 1.12 * top)
    ax.text(0.99, 0.01, "numbers: the summary's points", transform=ax.transAxes, ha="right", fontsize=7,
            color="grey")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=3)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot(result: dict, path: str) -> None:
    import matplotlib.pyplot as plt

    fig = figure(result)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def point_count(parameters: Sequence[Parameter], grid_levels: Optional[int], lhs: Optional[int]) -> int:
    """How many points a sampling gives, before it is made."""
    if lhs is not None:
        return lhs
    return int(np.prod([1 if p.fixed else grid_levels for p in parameters]))
