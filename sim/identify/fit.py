"""The fit: the vehicle's parameters and the segments' nodes by least
squares, the parameters' covariance from the Jacobian, and which of them
the data cannot see.

Unknowns: the chosen parameters (``parameters.PARAMETERS``), each scaled by
its typical change; per log, the logged attitude's tilt offset (x and y of
the gravity direction: the estimator's tilt is off by the accelerometer's
horizontal bias over g, up to ~0.02 rad for the twin's 20 mg, enough to
move ell by millimetres if the fit had to explain it); and the starting
body velocity of every segment that does not start at the release
(``shooting``); per log, how late the release was against the one the
log shows (``log.read`` finds it within an IMU record, 40 ms, and the
vehicle is 0.1 m/s fast 40 ms after it). ``scipy.optimize.
least_squares`` (trust-region reflective, within the parameters' bounds)
minimises the whitened residuals; the Jacobian is by forward differences,
one batch of the compiled model a Jacobian (``Shooter.fly``).

Weights: each residual group is divided by its sigma. The sigmas are not
guessed: after a first fit with starting values (``SIGMA0``) each group's
sigma becomes the RMS of its residuals inflated by the square root of
their integrated autocorrelation time (``group_sigma``), and the fit is
repeated. The covariance of the
parameters is then (J^T J)^-1 of the whitened Jacobian, the segments'
velocities marginalised (the parameters' block of the full inverse), plus
the covariance of what the log cannot say: the wing commands between its
5 Hz WING records (``input_covariance``). On the twin that second part is
the larger for ell and the Munk scale: the buildable vehicle's Munk moment
is 65 times its weight's moment in a glide (docs/design/glide-check.md),
so a degree of differential wing the log missed moves ell by millimetres.

Identifiability: a parameter whose sigma exceeds ``UNSEEN`` of its typical
change is one the data do not determine. It is reported as such (its
sigma, no value), held at the vehicle file's value, and the others are
fitted again without it, so that it does not lend them its freedom; each
of the others reports the widest sigma it had while the unseen ones were
free, as it leans on their held values (the net weight held 3 % off moves
the drag 3 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
from scipy.optimize import least_squares

from roboray.sim.identify import parameters as PM
from roboray.sim.identify.log import slew_limit
from roboray.sim.identify.shooting import GROUPS, NODE, UNITS, Shooter, segments
from roboray.sim.vehicle import VehicleParams

#: Starting sigma of each residual group (replaced by the fit's own).
SIGMA0 = {"depth": 0.01, "depth_rate": 0.03, "tilt": 0.01, "heading": 0.02, "track": 0.03}
#: sigma / typical change beyond which a parameter is not seen.
UNSEEN = 3.0
#: Forward-difference step, in typical changes.
STEP = 1e-3
#: Input draws for the covariance of the unknown commands between WING records.
INPUT_DRAWS = 16
#: rad: the scale of the tilt offsets' unknowns.
TILT_SCALE = 0.005
#: s: the scale of the release times' unknowns.
LATE_SCALE = 0.02
#: Scales of a node's unknowns: velocity (m/s), rates (rad/s), tilt (rad).
NODE_SCALE = np.array([0.1, 0.1, 0.1, 0.05, 0.05, 0.05, 0.01, 0.01])
#: Sigma of a continuity defect between segments (velocity m/s, rates
#: rad/s, gravity direction): the segments are one flight, so tight.
LINK_SIGMA = np.array([0.002, 0.002, 0.002, 0.002, 0.002, 0.002, 0.001, 0.001])


@dataclass
class Result:
    base: VehicleParams
    fitted: VehicleParams
    names: tuple
    initial: dict
    value: dict                 #: name -> value (identifiable ones)
    sigma: dict                 #: name -> 1-sigma (every fitted name)
    unidentifiable: list
    correlations: dict          #: name -> {name: r}
    rms_before: dict            #: group -> RMS (units in shooting.UNITS)
    rms_after: dict
    sigma_used: dict
    segments: list
    residual_count: int
    iterations: int
    tilt_offsets: list          #: per log, rad: the logged attitude's tilt bias (x, y of gravity in body)
    release_late: list          #: per log, s: the release after the detected one
    flown: dict = field(default_factory=dict)   #: for plots: the fitted segments

    def params_json(self) -> dict:
        out = {}
        for n in self.names:
            unit = PM.PARAMETERS[n][0]
            seen = n not in self.unidentifiable
            out[n] = {"value": self.value[n] if seen else None, "sigma": self.sigma[n],
                      "initial": self.initial[n], "unit": unit, "identifiable": seen}
        return out


class Problem:
    """The least-squares problem of some parameters over some segments.

    Unknowns, in order: the parameters (in typical changes), the logs' tilt
    offsets (2 each, in ``TILT_SCALE``), the logs' release delays (1 each,
    in ``LATE_SCALE``) and the nodes' free components (``NODE_SCALE``: a
    segment from rest has only its tilt free)."""

    def __init__(self, shooter: Shooter, base: VehicleParams, names: tuple, sigma: dict) -> None:
        self.sh = shooter
        self.base = base
        self.names = names
        self.sigma = sigma
        self.initial = PM.values(base, base)
        self.P = len(names)
        self.L = len(shooter.logs)
        self.T0 = self.P + 2 * self.L    #: first release-time unknown
        self.V0 = self.T0 + self.L       #: first node unknown
        #: (segment, component) of each node unknown
        self.slots = [(k, c) for k, seg in enumerate(shooter.segs) for c in range(NODE)
                      if not (seg.from_rest and c < 6)]
        self.n = self.V0 + len(self.slots)
        self.links = shooter.links()
        self.typical = np.array([PM.PARAMETERS[n][1] for n in names])
        self._cache: dict = {}
        self.evaluations = 0

    # ----------------------------------------------------------- unknowns
    def x0(self) -> np.ndarray:
        x = np.zeros(self.n)
        for i, (k, c) in enumerate(self.slots):
            seg = self.sh.segs[k]
            start = np.concatenate([seg.vel0, seg.rates0, np.zeros(2)])
            x[self.V0 + i] = start[c] / NODE_SCALE[c]
        return x

    def bounds(self):
        lo = np.full(self.n, -np.inf)
        hi = np.full(self.n, np.inf)
        for i, n in enumerate(self.names):
            _, typ, a, b = PM.PARAMETERS[n]
            lo[i] = (a - self.initial[n]) / typ
            hi[i] = (b - self.initial[n]) / typ
        lo[self.T0:self.V0] = -0.2 / LATE_SCALE      # the release is within an IMU record or two
        hi[self.T0:self.V0] = 0.2 / LATE_SCALE
        return lo, hi

    def physical(self, x: np.ndarray) -> dict:
        return {n: self.initial[n] + x[i] * self.typical[i] for i, n in enumerate(self.names)}

    def vehicle(self, x: np.ndarray) -> VehicleParams:
        return PM.apply(self.base, self.physical(x))

    def nodes(self, x: np.ndarray) -> np.ndarray:
        """(K, NODE) the segments' starts."""
        v = np.zeros((len(self.sh.segs), NODE))
        for i, (k, c) in enumerate(self.slots):
            v[k, c] = x[self.V0 + i] * NODE_SCALE[c]
        return v

    def offsets(self, x: np.ndarray) -> np.ndarray:
        """(L, 2) tilt offsets of the logs' attitude, rad."""
        return x[self.P:self.T0].reshape(self.L, 2) * TILT_SCALE

    def late(self, x: np.ndarray) -> np.ndarray:
        """(L,) s: each release's time after the detected one."""
        return x[self.T0:self.V0] * LATE_SCALE

    # ----------------------------------------------------------- residuals
    def stack(self, raw: dict, x: np.ndarray):
        """Whitened residual vector, each entry's segment, and for the tilt
        rows which component (0, 1; else -1)."""
        parts, owner, comp = [], [], []
        off = self.offsets(x)
        for g in GROUPS:
            for k, r in enumerate(raw[g]):
                c = np.full(len(r), -1)
                if g == "tilt":
                    c = np.tile([0, 1], len(r) // 2)
                    r = r + off[self.sh.segs[k].log][c]
                parts.append(r / self.sigma[g])
                owner.append(np.full(len(r), k))
                comp.append(c)
        return np.concatenate(parts), np.concatenate(owner), np.concatenate(comp)

    def defects(self, ends: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """Whitened continuity defects: each linked segment's start less the
        end of the one before."""
        if not self.links:
            return np.zeros(0)
        a = np.array([p for p, _ in self.links])
        b = np.array([q for _, q in self.links])
        return ((starts[b] - ends[a]) / LINK_SIGMA).reshape(-1)

    def _evaluate(self, x: np.ndarray):
        key = x.tobytes()
        if key in self._cache:
            return self._cache[key]
        self._cache.clear()
        nodes = self.nodes(x)
        vehicles = [self.vehicle(x)]
        nv = [nodes]
        for i in range(self.P):
            xi = x.copy()
            xi[i] += STEP
            vehicles.append(self.vehicle(xi))
            nv.append(nodes)
        comps = sorted({c for _, c in self.slots})
        for c in comps:
            v = nodes.copy()
            for k, cc in self.slots:
                if cc == c:
                    v[k, c] += STEP * NODE_SCALE[c]
            vehicles.append(vehicles[0])
            nv.append(v)
        flown = self.sh.fly(vehicles, np.array(nv))
        self.evaluations += 1
        late = self.late(x)
        r0, owner, comp = self.stack(self.sh.residuals(flown, 0, late), x)
        starts = self.sh.starts(nodes)
        ends0 = self.sh.ends(flown, 0)
        d0 = self.defects(ends0, starts)
        m = len(r0)
        J = np.zeros((m + len(d0), self.n))
        for i in range(self.P):
            J[:m, i] = (self.stack(self.sh.residuals(flown, 1 + i, late), x)[0] - r0) / STEP
            J[m:, i] = (self.defects(self.sh.ends(flown, 1 + i), starts) - d0) / STEP
        seg_log = np.array([s.log for s in self.sh.segs])[owner]
        for l in range(self.L):
            for c in range(2):
                J[:m][(seg_log == l) & (comp == c), self.P + 2 * l + c] = TILT_SCALE / self.sigma["tilt"]
            shifted = late.copy()
            shifted[l] += STEP * LATE_SCALE
            J[:m, self.T0 + l] = (self.stack(self.sh.residuals(flown, 0, shifted), x)[0] - r0) / STEP
        slot = {kc: i for i, kc in enumerate(self.slots)}
        for j, c in enumerate(comps):
            variant = 1 + self.P + j
            d = (self.stack(self.sh.residuals(flown, variant, late), x)[0] - r0) / STEP
            ends = self.sh.ends(flown, variant)
            moved = nodes.copy()
            for k, cc in self.slots:
                if cc == c:
                    moved[k, c] += STEP * NODE_SCALE[c]
            starts_moved = self.sh.starts(moved)
            for (k, cc), i in slot.items():
                if cc != c:
                    continue
                col = self.V0 + i
                J[:m][owner == k, col] = d[owner == k]
                # a defect moves with the end of the segment before it and
                # with the start of its own: each only through its own node
                for li, (a, b) in enumerate(self.links):
                    rows = slice(m + 8 * li, m + 8 * li + 8)
                    if a == k:
                        J[rows, col] = -(ends[a] - ends0[a]) / LINK_SIGMA / STEP
                    if b == k:
                        J[rows, col] = (starts_moved[b] - starts[b]) / LINK_SIGMA / STEP
        r = np.concatenate([r0, d0])
        self._cache[key] = (r, J, flown)
        return self._cache[key]

    def fun(self, x: np.ndarray) -> np.ndarray:
        return self._evaluate(x)[0]

    def jac(self, x: np.ndarray) -> np.ndarray:
        return self._evaluate(x)[1]

    def fly(self, x: np.ndarray) -> dict:
        return self.sh.fly([self.vehicle(x)], self.nodes(x)[None])

    def raw(self, x: np.ndarray) -> dict:
        """Unweighted residuals at x, the tilt offsets applied."""
        raw = self.sh.residuals(self.fly(x), 0, self.late(x))
        off = self.offsets(x)
        raw["tilt"] = [r + np.tile(off[self.sh.segs[k].log], len(r) // 2) for k, r in enumerate(raw["tilt"])]
        return raw


def group_rms(raw: dict) -> dict:
    out = {}
    for g in GROUPS:
        r = np.concatenate(raw[g]) if raw[g] else np.zeros(0)
        out[g] = float(np.sqrt(np.mean(r * r))) if len(r) else None
    return out


def group_sigma(raw: dict) -> dict:
    """RMS of each group inflated by its residuals' correlation in time:
    sqrt(tau), tau = 1 + 2 sum rho_k the integrated autocorrelation time
    in samples (Sokal's estimator: the lags summed up to the first that is
    not positive), pooled over the segments. n samples with correlation
    time tau hold as much as n / tau independent ones; a residual that is
    model error, slow and systematic, so weighs what it is worth."""
    out = {}
    for g in GROUPS:
        rs = [r for r in raw[g] if len(r)]
        if not rs:
            out[g] = SIGMA0[g]
            continue
        r2 = np.concatenate([r * r for r in rs])
        den = float(r2.sum())
        tau = 1.0
        for lag in range(1, max(len(r) for r in rs)):
            num = sum(float(np.dot(r[lag:], r[:-lag])) for r in rs if len(r) > lag)
            rho = num / den if den > 0 else 0.0
            if rho <= 0.0:
                break
            tau += 2.0 * rho
        rms = max(float(np.sqrt(np.mean(r2))), 1e-4 * SIGMA0[g])
        out[g] = rms * math.sqrt(tau)
    return out


def input_covariance(problem: Problem, x: np.ndarray, J: np.ndarray, draws: int = INPUT_DRAWS,
                     seed: int = 0) -> np.ndarray:
    """The parameters' covariance from not knowing the wing commands between
    WING records (``Shooter.commands_between``): the fitted vehicle flown
    with ``draws`` such inputs, each residual change mapped to the
    unknowns by the fit's least-squares step -pinv(J) dr (errors in the
    variables, linearised), their spread the covariance."""
    sh = problem.sh
    rng = np.random.default_rng(seed)
    slews = [slew_limit(log.params) for log in sh.logs]
    cmds = np.array([sh.cmd] + [sh.commands_between(rng, slews) for _ in range(draws)])
    nodes = problem.nodes(x)
    flown = sh.fly([problem.vehicle(x)] * (draws + 1), np.broadcast_to(nodes, (draws + 1,) + nodes.shape).copy(),
                   cmds)
    late = problem.late(x)
    starts = sh.starts(nodes)

    def whitened(j):
        return np.concatenate([problem.stack(sh.residuals(flown, j, late), x)[0],
                               problem.defects(sh.ends(flown, j), starts)])

    r0 = whitened(0)
    pinv = np.linalg.pinv(J)
    steps = np.array([-(pinv @ (whitened(j) - r0))[:problem.P] for j in range(1, draws + 1)])
    return steps.T @ steps / draws


def _solve(problem: Problem, x0: np.ndarray, done: Callable[[], None]):
    lo, hi = problem.bounds()
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)

    def jac(x):
        done()
        return problem.jac(x)

    sol = least_squares(problem.fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale=1.0,
                        xtol=1e-8, ftol=1e-10, gtol=1e-10, max_nfev=60)
    return sol


def identify(logs: list, base: VehicleParams, names: tuple = PM.DEFAULT_FIT,
             progress: Optional[Callable[[], None]] = None) -> Result:
    """Fit ``names`` of ``base`` to the dives in ``logs`` (``log.DiveLog``)."""
    done = progress or (lambda: None)
    segs = segments(logs, base)
    sh = Shooter(logs, segs, base)
    names = tuple(names)
    problem = Problem(sh, base, names, dict(SIGMA0))
    x_start = problem.x0()
    rms_before = group_rms(problem.raw(x_start))
    unseen: list = []
    unseen_sigma: dict = {}
    iterations = 0
    active = names
    x_rest = x_start[problem.P:]
    x_par = dict.fromkeys(names, 0.0)
    widest: dict = {}
    while True:
        problem = Problem(sh, base, active, dict(SIGMA0))
        # a refit without an unseen parameter starts where the last ended
        x = np.concatenate([[x_par[n] for n in active], x_rest])
        sol = _solve(problem, x, done)
        iterations += sol.nfev
        problem.sigma = group_sigma(problem.raw(sol.x))
        problem._cache.clear()
        sol = _solve(problem, sol.x, done)
        iterations += sol.nfev
        J = problem.jac(sol.x)
        cov = np.linalg.pinv(J.T @ J)[:problem.P, :problem.P] + input_covariance(problem, sol.x, J)
        sig = np.sqrt(np.maximum(np.diag(cov), 0.0))
        for i, n in enumerate(active):
            widest[n] = max(widest.get(n, 0.0), float(sig[i] * problem.typical[i]))
        worst = int(np.argmax(sig)) if problem.P else -1
        if problem.P and sig[worst] > UNSEEN:
            n = active[worst]
            unseen.append(n)
            unseen_sigma[n] = float(sig[worst] * problem.typical[worst])
            active = tuple(a for a in active if a != n)
            x_rest = sol.x[problem.P:]
            x_par = dict(zip(problem.names, sol.x[:problem.P]))
            if active:
                continue
        break
    value = problem.physical(sol.x) if active else {}
    # a parameter held at the file's value may be wrong by its own sigma, and
    # the others lean on it: each keeps the widest sigma it had while the
    # unseen ones were still free (their correlation spread into it)
    sigma = {n: widest[n] for n in active}
    sigma.update(unseen_sigma)
    d = np.sqrt(np.maximum(np.diag(cov), 1e-300)) if active else np.zeros(0)
    corr = cov / np.outer(d, d) if active else np.zeros((0, 0))
    correlations = {a: {b: float(corr[i, j]) for j, b in enumerate(active) if j != i} for i, a in enumerate(active)}
    fitted = problem.vehicle(sol.x) if active else base
    flown = problem.fly(sol.x) if active else {}
    start = PM.values(base, base)
    return Result(base=base, fitted=fitted, names=names, initial={n: start[n] for n in names},
                  value={n: float(v) for n, v in value.items()},
                  sigma=sigma, unidentifiable=unseen, correlations=correlations, rms_before=rms_before,
                  rms_after=group_rms(problem.raw(sol.x)), sigma_used=problem.sigma,
                  segments=[s.as_dict() for s in segs], residual_count=int(len(sol.fun)),
                  iterations=iterations, tilt_offsets=problem.offsets(sol.x).tolist(),
                  release_late=problem.late(sol.x).tolist(), flown={"shooter": sh, "flown": flown})
