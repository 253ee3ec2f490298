"""``roboray-sim stability``, ``trim``, ``modes``, ``envelope``,
``stability-map``, ``controllability`` and ``glide-check``."""

from __future__ import annotations

import argparse

import numpy as np

from roboray.sim import progress
from roboray.sim.campaign.options import add_engine_options
from roboray.sim.commands.dynamics import add_vehicle_options, vehicle_params, wings_deg
from roboray.tools.cli import CliError, UsageError, add_json, command, emit, number, output_file, positive


def _model(args):
    from roboray.sim.dynamics import Model

    return Model(vehicle_params(args))


def _trims(args):
    from roboray.sim.analysis.trim import find_trims

    model = _model(args)
    trims = find_trims(model, np.radians(args.wings), settle_s=args.settle)
    if not trims:
        raise CliError("no steady descent found for wings %s deg" % ",".join("%g" % w for w in args.wings))
    return model, trims


# ------------------------------------------------------------ stability
def do_stability(args: argparse.Namespace) -> None:
    from roboray.sim.analysis import reduced
    from roboray.sim.vehicle import Vehicle

    vehicle = Vehicle(vehicle_params(args))
    if args.table:
        if args.wings is not None:
            raise UsageError("give either --table or --wings, not both")
        rows = reduced.table(vehicle, args.table)
        for r in rows:
            r.pop("eigenvalues", None)
        result = {"table": args.table, "rows": rows, "spectral_tolerance": reduced.SPECTRAL_TOL}
    else:
        if args.wings is None:
            raise UsageError("give --table 3.1|3.2 or --wings S1,S2,S3,S4")
        try:
            row = reduced.evaluate(vehicle, args.wings, v2=args.v2, v3=args.v3, omega3=args.omega3)
        except ValueError as exc:
            raise UsageError(str(exc))
        result = {"rows": [row], "spectral_tolerance": reduced.SPECTRAL_TOL}
    emit(args, result, _stability_text)


def _stability_text(result: dict) -> str:
    head = "%-3s %-11s %5s %5s %5s %5s %5s %7s %7s %7s %7s %-6s %-9s %-9s %-7s" % (
        "row", "wings", "v2", "v3", "w3", "", "", "m1", "m2", "m3", "ell_mm", "exists", "spectral", "max_re", "EC")
    lines = ["Table %s recomputed (reduced model of chapter 3, moment m_v g ell)" % result["table"]] \
        if "table" in result else ["Equilibrium of the reduced model (chapter 3)"]
    lines.append(head)
    for r in result["rows"]:
        lines.append("%-3s %-11s %5g %5g %5g %5s %5s %7.4f %7.4f %7.4f %7.2f %-6s %-9s %-9s %-7s" % (
            r.get("row", "-"), ",".join("%g" % w for w in r["wings_deg"]), r["v2"], r["v3"], r["omega3"], "", "",
            r["m1"], r["m2"], r["m3"], r["ell"] * 1e3, r["exists"],
            {True: "stable", False: "UNSTABLE", None: "-"}[r["spectrally_stable"]],
            "-" if r["max_real_eig"] is None else "%.2g" % r["max_real_eig"], r["energy_casimir"]))
        if "agrees_with_thesis" in r and not r["agrees_with_thesis"]:
            lines.append("    disagrees with the thesis: %s" % r["note"])
    return "\n".join(lines)


# ------------------------------------------------------------ trims, modes
def do_trim(args: argparse.Namespace) -> None:
    from roboray.sim.analysis.trim import modes

    model, trims = _trims(args)
    rows = []
    for t in trims:
        d = t.as_dict()
        info = modes(model, t)
        d["stable"] = info["stable"]
        d["max_real_eig"] = info["max_real_eig"]
        rows.append(d)
    result = {"wings_deg": list(args.wings), "trims": rows}

    def text(r):
        out = []
        for k, t in enumerate(r["trims"]):
            out.append("%d. %s, %s: descent %.4f m/s, horizontal %.4f m/s (glide ratio %.3f, %.1f deg from vertical), "
                       "towards %.0f deg from wing 1, tilt %.2f deg%s" % (
                           k + 1, t["kind"], "stable" if t["stable"] else "UNSTABLE", t["descent_speed"],
                           t["horizontal_speed"], t["glide_ratio"], t["glide_angle_deg"], t["glide_direction_deg"],
                           t["tilt_deg"], "" if t["spiral_radius_m"] is None else
                           ", turning at %.3f rad/s on a %.3f m circle" % (t["omega"], t["spiral_radius_m"])))
        return "\n".join(out)

    emit(args, result, text)


def do_modes(args: argparse.Namespace) -> None:
    from roboray.sim.analysis.trim import modes

    model, trims = _trims(args)
    trim = trims[0]   # where a drop settles (or the straight fall)
    result = modes(model, trim)

    def text(r):
        t = r["trim"]
        out = ["%s at descent %.4f m/s, glide %.3f, tilt %.2f deg: %s" % (
            t["kind"], t["descent_speed"], t["glide_ratio"], t["tilt_deg"],
            "stable" if r["stable"] else "UNSTABLE (max Re %.3g 1/s)" % r["max_real_eig"])]
        out.append("%-24s %22s %10s %8s %10s" % ("mode", "eigenvalue 1/s", "freq Hz", "damping", "tau s"))
        for m in r["modes"]:
            lam = m["eigenvalue"]
            out.append("%-24s %10.4f %+10.4fi %10.4f %8s %10s" % (
                m["mode"], lam[0], lam[1], m["frequency_hz"],
                "-" if m["damping_ratio"] is None else "%.3f" % m["damping_ratio"],
                "-" if m["time_constant_s"] is None else "%.3f" % m["time_constant_s"]))
        return "\n".join(out)

    emit(args, result, text)


# ------------------------------------------------------------ envelope, map
def do_envelope(args: argparse.Namespace) -> None:
    from roboray.sim.analysis import envelope
    from roboray.sim.campaign import cli_errors, engine_from_args
    from roboray.sim.campaign.grid import settler

    engine = engine_from_args(args)
    with progress.bar(args, envelope.search_cost(args.step, args.settle, not args.no_refine), "envelope") as bar, \
            cli_errors(), engine:
        result = envelope.search(vehicle_params(args), step_deg=args.step, settle_s=args.settle,
                                 refine=not args.no_refine, progress=bar, settle=settler(engine))
    result["engine"] = engine.describe()
    candidates = result.pop("candidates")
    if args.plot:
        _plot_envelope(candidates, result, args.plot)
        result["plot"] = args.plot

    def text(r):
        return ("reachable glide ratio %.3f (stable: %s) with wings %s deg: descent %.3f m/s, travelling %.0f deg "
                "from wing 1; %.1f m sideways from 10 m depth.\n%d configurations on a %g deg grid, %d stable glides; "
                "%s" % (r["max_glide_ratio"], r["stable"], ",".join("%.1f" % w for w in r["wings_deg"]),
                        r["descent_speed"], r["glide_direction_deg"], 10 * r["max_glide_ratio"],
                        r["configurations_tried"], r["grid_step_deg"], r["stable_glides_found"], r["confidence"]))

    emit(args, result, text)


def _plot_envelope(candidates, result, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roboray.sim.analysis.envelope import glide_score

    fig, ax = plt.subplots(figsize=(7, 5))
    for family, marker in (("axis", "o"), ("diagonal", "s")):
        pts = [c for c in candidates if c["family"] == family and c["trim"] is not None]
        desc = [c["trim"].descent_speed for c in pts]
        glide = [c["trim"].glide_ratio if c["trim"].straight else 0.0 for c in pts]
        stable = [glide_score(c) > 0 for c in pts]
        ax.scatter([d for d, s in zip(desc, stable) if s], [g for g, s in zip(glide, stable) if s], marker=marker,
                   label="%s family, stable" % family)
        ax.scatter([d for d, s in zip(desc, stable) if not s], [g for g, s in zip(glide, stable) if not s],
                   marker=marker, facecolors="none", edgecolors="grey", label="%s family, unstable" % family)
    ax.scatter([result["descent_speed"]], [result["max_glide_ratio"]], marker="*", s=250, c="red",
               label="reachable glide %.3f" % result["max_glide_ratio"])
    ax.set_xlabel("descent speed (m/s)")
    ax.set_ylabel("glide ratio (horizontal / vertical)")
    ax.set_title("Steady descents over wing configurations")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def do_stability_map(args: argparse.Namespace) -> None:
    from roboray.sim.analysis import stability_map
    from roboray.sim.campaign import cli_errors, engine_from_args
    from roboray.sim.campaign.grid import settler

    engine = engine_from_args(args)
    with progress.bar(args, stability_map.compute_cost(args.step, args.settle), "stability-map") as bar, \
            cli_errors(), engine:
        result = stability_map.compute(vehicle_params(args), step_deg=args.step, settle_s=args.settle, progress=bar,
                                       settle=settler(engine))
    result["engine"] = engine.describe()
    stability_map.plot(result, args.out)
    result["plot"] = args.out
    summary = {}
    for name, sl in result["slices"].items():
        red = np.array(sl["reduced_max_real_eig"], float)
        trim = np.array(sl["trim_max_real_eig"], float)
        summary[name] = {"reduced_no_equilibrium_fraction": float(np.mean(np.isnan(red))),
                         "reduced_unstable_fraction": float(np.mean(red[np.isfinite(red)] > 1e-6)),
                         "trim_unstable_fraction": float(np.mean(trim[np.isfinite(trim)] > 1e-4))}
    result["summary"] = summary
    emit(args, result, lambda r: "\n".join(
        ["wrote %s" % r["plot"]] + ["%s: unstable in %.0f%% of equilibria (reduced model), %.0f%% of settled "
                                    "descents (with drag)" % (k, 100 * v["reduced_unstable_fraction"],
                                                              100 * v["trim_unstable_fraction"])
                                    for k, v in r["summary"].items()]))


# ------------------------------------------------------------ controllability
def do_controllability(args: argparse.Namespace) -> None:
    from roboray.sim.analysis import controllability

    model, trims = _trims(args)
    trim = trims[0]
    result = {"trim": trim.as_dict(), "linear": controllability.linear(model, trim),
              "lie": controllability.lie_rank(model, trim, depth=args.bracket_depth)}

    def text(r):
        lin, lie = r["linear"], r["lie"]
        return ("at the %s (descent %.3f m/s):\n  linear, wing commands as inputs: rank %d of %d%s\n"
                "  Lie algebra (sec. 4.1), wing accelerations as inputs, brackets to depth %d: rank %d of %d; "
                "smallest singular values %s" % (
                    r["trim"]["kind"], r["trim"]["descent_speed"], lin["rank"], lin["state_dimension"],
                    "" if not lin["uncontrollable_states"] else " (cannot move %s)" % ", ".join(
                        lin["uncontrollable_states"]),
                    lie["depth"], lie["rank"], lie["state_dimension"],
                    ", ".join("%.2e" % v for v in lie["singular_values"][-3:])))

    emit(args, result, text)


# ------------------------------------------------------------ glide check
def do_glide_check(args: argparse.Namespace) -> None:
    from roboray.sim.analysis import glide_check

    if not 0.0 < args.fold < 90.0:
        raise UsageError("--fold %g: the stroke's mean fold must be between 0 and 90 deg (exclusive)" % args.fold)
    params = vehicle_params(args)
    try:
        result = glide_check.compare(params, args.wings, settle_s=args.settle)
        result["stroke"] = glide_check.stroke_reaction(params, fold_deg=args.fold)
    except ValueError as exc:
        raise CliError(str(exc))
    result["vehicle"] = args.vehicle or "reference"
    emit(args, result, _glide_check_text)


def _glide_check_text(r: dict) -> str:
    out = ["wings %s deg, vehicle %s: straight glide" % (",".join("%g" % w for w in r["wings_deg"]), r["vehicle"]),
           "%-34s %11s %11s %7s %8s %9s" % ("", "descent", "horizontal", "glide", "tilt", "towards")]
    for key, name in (("main_model", "main model (Kirchhoff, trim)"),
                      ("plate_model_munk", "plate drag + Munk moment (k = 1)"),
                      ("plate_model_no_munk", "plate drag alone (k = 0)")):
        g = r[key]
        out.append("%-34s %7.4f m/s %7.4f m/s %7.3f %4.1f deg %5.0f deg" % (
            name, g["descent_speed"], g["horizontal_speed"], g["glide_ratio"], g["tilt_deg"],
            g["glide_direction_deg"]))
    out.append("plate model with Munk vs main model: largest difference in V and Gamma %.1e"
               % r["plate_vs_main_max_difference"])
    out.append("Munk scale k 1 -> 0: glide ratio %s" % " ".join("%.3f" % g["glide_ratio"] for g in r["munk_scan"]))
    for key, where in (("moments_at_main_glide_nm", "main glide"), ("moments_at_plate_glide_nm", "plate-only glide")):
        m = r[key]
        out.append("moments about the CB at the %s: drag %.4f, weight %.4f, Munk %.4f N m" % (
            where, m["drag_moment"], m["weight_moment"], m["munk_moment"]))
    c = r["main_model_at_plate_glide"]
    out.append("main model at the plate-only glide: net force %.1e N, moment %s N m = the Munk moment there "
               "(differs by %.1e N m)" % (c["force_n"], ", ".join("%.4f" % v for v in c["moment_nm"]),
                                          c["difference_nm"]))
    s = r["stroke"]
    d = s["displacement_m"]
    pr = s["per_radian_m"]
    out.append("stroke: wings 1 and 3 from %g deg by +-%g deg (gravity and drag off): along x_c (towards the folded "
               "wing 1) the plate's centre moves %+.2f mm, the CG %+.2f mm, the CB %+.2f mm; the body turns %+.1f "
               "deg about y_c (%s)" % (
                   s["fold_deg"], s["stroke_deg"], d["plate_centre"][0] * 1e3, d["cg"][0] * 1e3, d["cb"][0] * 1e3,
                   s["pitch_deg"], "wing 1's side down" if s["pitch_deg"] < 0 else "wing 1's side up"))
    out.append("  per radian of a small stroke: plate's centre %+.2f mm, CG %+.2f mm, CB %+.2f mm, %+.1f deg" % (
        pr["plate_centre"][0] * 1e3, pr["cg"][0] * 1e3, pr["cb"][0] * 1e3, s["pitch_deg_per_radian"]))
    return "\n".join(out)


def register(sub, bench) -> None:
    p = command(sub, "stability", do_stability,
                "stability of the thesis's equilibria (reduced model, chapter 3): a table or any equilibrium")
    p.add_argument("--table", choices=("3.1", "3.2"), help="recompute every row of Table 3.1 or 3.2")
    p.add_argument("--wings", type=wings_deg, metavar="S1,S2,S3,S4", help="wing deflections, degrees")
    p.add_argument("--v2", type=number, default=0.0, help="body y velocity of eq. 3.2, m/s (default 0)")
    p.add_argument("--v3", type=number, default=0.3, help="body z velocity, m/s (default 0.3)")
    p.add_argument("--omega3", type=number, default=0.0, help="spin of eq. 3.3, rad/s (default 0: eq. 3.2)")
    add_vehicle_options(p)
    add_json(p)

    for name, handler, text in (
            ("trim", do_trim, "steady descents with drag of a wing configuration: glide, speed, spiral"),
            ("modes", do_modes, "eigenvalues of the settled descent: feathering, heave, spin"),
            ("controllability", do_controllability, "controllability at the settled descent: linear and Lie rank")):
        p = command(sub, name, handler, text)
        p.add_argument("--wings", type=wings_deg, default=[0.0] * 4, metavar="S1,S2,S3,S4",
                       help="wing deflections, degrees (default 0,0,0,0)")
        p.add_argument("--settle", type=positive, default=40.0, help="seconds of free fall to settle (default 40)")
        if name == "controllability":
            p.add_argument("--bracket-depth", type=int, default=3, choices=(1, 2, 3, 4), metavar="N",
                           help="Lie brackets nested up to N deep, 1 to 4 (default 3; --depth is metres elsewhere)")
        add_vehicle_options(p)
        add_json(p)

    p = command(sub, "envelope", do_envelope, "the reachable glide: largest stable glide ratio over configurations")
    p.add_argument("--step", type=positive, default=15.0, help="grid step, degrees (default 15)")
    p.add_argument("--settle", type=positive, default=40.0, help="seconds of free fall to settle (default 40)")
    p.add_argument("--no-refine", action="store_true", help="skip the local optimiser")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="glide ratio against descent speed of every trim")
    add_engine_options(p, "grid's drops")
    add_vehicle_options(p)
    add_json(p)

    p = command(sub, "glide-check", do_glide_check,
                "the glide by a second model (plate drag, moment balance, Munk moment on or off) and a stroke's reaction")
    p.add_argument("--wings", type=wings_deg, default=[0.0, 0.0, 90.0, 90.0], metavar="S1,S2,S3,S4",
                   help="wing deflections with a mirror plane, degrees (default 0,0,90,90)")
    p.add_argument("--settle", type=positive, default=40.0,
                   help="seconds of free fall to settle the main model's glide (default 40)")
    p.add_argument("--fold", type=number, default=45.0, metavar="DEG",
                   help="mean fold of the stroke, 0..90 deg; wings 1 and 3 move the whole travel left (default 45)")
    add_vehicle_options(p)
    add_json(p)

    p = command(sub, "stability-map", do_stability_map, "heat maps of stability over wing configurations")
    p.add_argument("--out", required=True, type=output_file, metavar="FILE.png", help="the figure to write")
    p.add_argument("--step", type=positive, default=10.0, help="grid step, degrees (default 10)")
    p.add_argument("--settle", type=positive, default=30.0, help="seconds of free fall to settle (default 30)")
    add_engine_options(p, "grid's drops")
    add_vehicle_options(p)
    add_json(p)
