"""``roboray-sim identify``: the vehicle learnt from its own dives' logs
(``sim/identify``)."""

from __future__ import annotations

import argparse

from roboray.sim import progress
from roboray.tools.cli import UsageError, add_json, command, emit, output_file

#: Jacobians a fit usually takes (the bar's scale; it may end early or late).
_EXPECTED_JACOBIANS = 40


def _names(text: str) -> tuple:
    from roboray.sim.identify.parameters import parse_names

    try:
        return parse_names(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


def do_identify(args: argparse.Namespace) -> None:
    from roboray.sim.identify import descent, outputs
    from roboray.sim.identify import fit as F
    from roboray.sim.identify import log as L
    from roboray.sim.identify.parameters import DEFAULT_FIT, PARAMETERS
    from roboray.sim.identify.shooting import UNITS
    from roboray.sim.vehicle import load_params

    try:
        base = load_params(args.vehicle)
    except (OSError, ValueError) as exc:
        raise UsageError("identify: cannot load vehicle %s: %s" % (args.vehicle, exc))
    try:
        logs = [L.read(path) for path in args.logs]
    except L.LogError as exc:
        raise UsageError("identify: %s" % exc)
    names = args.fit or DEFAULT_FIT
    with progress.bar(args, _EXPECTED_JACOBIANS + (len(descent.SEEDS) if args.params_out else 0),
                      "identify") as bar:
        try:
            result = F.identify(logs, base, names, progress=lambda: bar.update(1))
        except ValueError as exc:   # no segment with its input logged, and the like
            raise UsageError("identify: %s" % exc)
        table = descent.fit(result.fitted, done=lambda: bar.update(1)) if args.params_out else None
    out = {
        "logs": [l.summary() for l in logs],
        "vehicle": args.vehicle,
        "params": result.params_json(),
        "unidentifiable": result.unidentifiable,
        "correlations": result.correlations,
        "fit_rms_before": result.rms_before,
        "fit_rms_after": result.rms_after,
        "residual_sigma": result.sigma_used,
        "units": dict(UNITS),
        "segments": result.segments,
        "residuals": result.residual_count,
        "tilt_offset_rad": result.tilt_offsets,
        "release_late_s": result.release_late,
        "model_evaluations": result.iterations,
    }
    if table is not None:
        outputs.write_params(args.params_out, table, logs)
        out["descent_model"] = table
        out["params_file"] = args.params_out
    if args.out:
        outputs.write_vehicle(args.out, args.vehicle, result, logs)
        load_params(args.out)    # what was written loads
        out["vehicle_file"] = args.out
    if args.plot:
        outputs.plot(args.plot, result)
        out["plot"] = args.plot
    out["parameter_units"] = {n: PARAMETERS[n][0] for n in names}
    emit(args, out, _text)


def _text(r: dict) -> str:
    rows = ["%d log(s), %d segment(s), %d residuals" % (len(r["logs"]), len(r["segments"]), r["residuals"])]
    rows.append("%-18s %12s %10s %12s" % ("parameter", "value", "sigma", "initial"))
    for n, p in r["params"].items():
        value = "%.5g" % p["value"] if p["identifiable"] else "unseen"
        rows.append("%-18s %12s %10.2g %12.5g %s" % (n, value, p["sigma"], p["initial"], p["unit"]))
    if r["unidentifiable"]:
        rows.append("not identifiable from these logs (kept at the vehicle file's value): %s"
                    % ", ".join(r["unidentifiable"]))
    rows.append("fit RMS before -> after: " + ", ".join(
        "%s %.3g -> %.3g %s" % (g, r["fit_rms_before"][g], r["fit_rms_after"][g], r["units"][g])
        for g in r["fit_rms_after"] if r["fit_rms_after"][g] is not None))
    strong = sorted({tuple(sorted((a, b))) for a, row in r["correlations"].items() for b, c in row.items()
                     if abs(c) >= 0.9})
    if strong:
        rows.append("strongly correlated (|r| >= 0.9): %s" % ", ".join("%s/%s %.2f" % (a, b, r["correlations"][a][b])
                                                                   for a, b in strong))
    if r.get("descent_model"):
        d = r["descent_model"]
        rows.append("descent model: %s (residual %.4f m/s) -> %s" % (
            ", ".join("%s %.4g" % kv for kv in d["params"].items()), d["residual_mps"], r["params_file"]))
    for key, what in (("vehicle_file", "vehicle file"), ("plot", "plot")):
        if r.get(key):
            rows.append("%s: %s" % (what, r[key]))
    return "\n".join(rows)


def register(sub, bench) -> None:
    from roboray.sim.identify.parameters import DEFAULT_FIT, PARAMETERS

    p = command(sub, "identify", do_identify,
                "fit the vehicle file's uncertain parameters to dive logs (DataFlash .BIN)")
    p.add_argument("logs", nargs="+", metavar="LOG.BIN", help="the dives' flight logs (roboray-ground log download)")
    p.add_argument("--vehicle", required=True, metavar="FILE.py",
                   help="the vehicle file to start from (its uncertain parameters are fitted)")
    p.add_argument("--fit", type=_names, metavar="NAMES",
                   help="comma-separated parameters to fit, of %s (default all: %s)"
                        % (", ".join(PARAMETERS), ",".join(DEFAULT_FIT)))
    p.add_argument("--out", type=output_file, metavar="FITTED.py",
                   help="write the vehicle file with the fitted values (and where they came from)")
    p.add_argument("--params-out", type=output_file, metavar="FILE.parm",
                   help="write the firmware's descent model (DR_*) fitted to the identified vehicle, as a "
                        "parameter file roboray-ground param load takes")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot the logged and the fitted dives")
    add_json(p)
