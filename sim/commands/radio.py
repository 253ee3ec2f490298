"""``roboray-sim radio-reach``: how deep the radio reaches into a water.

Also the link options the twin and the campaigns share (``--conductivity``,
``--radio-model``, ``--ground-distance``; ``--water`` is the vehicle
options'), and ``link_of(args)`` turning them into a ``sim/radio`` link.
"""

from __future__ import annotations

import argparse
import math

from roboray.tools.cli import CliError, add_json, command, emit, number, output_file

#: S/m: above this no natural water goes (sea water is 4-6; brines are not modelled)
MAX_CONDUCTIVITY = 10.0


def conductivity(text: str) -> float:
    value = number(text)
    if not 0.0 <= value <= MAX_CONDUCTIVITY:
        raise argparse.ArgumentTypeError("--conductivity %r: 0..%g S/m (fresh water 0.005-0.05, sea 4-5)"
                                         % (text, MAX_CONDUCTIVITY))
    return value


def ground_distance(text: str) -> float:
    value = number(text)
    if not 1.0 <= value <= 100000.0:
        raise argparse.ArgumentTypeError("--ground-distance %r: 1..100000 m of air to the point above the "
                                         "vehicle" % text)
    return value


def add_link_options(p: argparse.ArgumentParser, radio_flags: tuple = ("--radio-model",), ground: bool = True) -> None:
    """``--conductivity``, the radio (``radio_flags``) and (``ground``) ``--ground-distance``."""
    from roboray.sim.radio.radios import NAMES, vehicle_radio

    p.add_argument("--conductivity", type=conductivity, metavar="S_PER_M",
                   help="the water's conductivity, overriding --water's (fresh 0.02, sea 4.5 S/m)")
    p.add_argument(*radio_flags, choices=NAMES, default=None, dest="radio_model",
                   help="the radio whose link crosses the water (default %s, the buildable vehicle's)"
                        % vehicle_radio())
    if not ground:
        return
    p.add_argument("--ground-distance", type=ground_distance, default=None, metavar="M",
                   help="air from the ground station's antenna to the point above the vehicle (default 10 m)")


def link_of(args: argparse.Namespace):
    """The ``sim/radio`` link the arguments name."""
    from roboray.sim.radio import link

    d = getattr(args, "ground_distance", None)
    try:
        return link.make(getattr(args, "radio_model", None), getattr(args, "water", "fresh"),
                         getattr(args, "conductivity", None), link.GROUND_DISTANCE_M if d is None else d)
    except ValueError as exc:
        raise CliError(str(exc))


def campaign_link(args: argparse.Namespace):
    """A campaign's link, ``(water, radio model, conductivity)`` for
    ``sim/montecarlo.py``'s draws, or None (every fix arrives, at any depth)
    when none of ``--radio-model``, ``--conductivity`` or ``--water sea``
    was given."""
    from roboray.sim.radio.radios import vehicle_radio

    water = getattr(args, "water", "fresh")
    radio_model = getattr(args, "radio_model", None)
    sigma = getattr(args, "conductivity", None)
    if radio_model is None and sigma is None and water == "fresh":
        return None
    link = (water, radio_model or vehicle_radio(), sigma)
    link_of(argparse.Namespace(water=water, radio_model=link[1], conductivity=sigma))   # checked here, not in a worker
    return link


def reach_table(lk, rows: int = 11) -> list[dict]:
    """Depth against margin and frame loss, from the surface to 1.5 times the reach."""
    from roboray.sim.radio.link import frame_loss

    top = max(1.5 * lk.reach_m, 0.01)
    step = top / (rows - 1)
    # a round step: 1, 2 or 5 times a power of ten
    p = 10.0 ** math.floor(math.log10(step))
    step = next(m * p for m in (1.0, 2.0, 5.0, 10.0) if m * p >= step)
    out = []
    for k in range(rows):
        d = k * step
        m = lk.margin_db(d)
        out.append({"depth_m": d, "margin_db": m, "frame_loss": frame_loss(m)})
    return out


def reach_report(lk) -> dict:
    from roboray.sim.radio import water as water_mod

    r, w = lk.radio, lk.water
    return {
        "radio": r.name, "part": r.part, "frequency_mhz": r.freq_hz / 1e6, "tx_dbm": r.tx_dbm,
        "sensitivity_dbm": r.sensitivity_dbm, "air_rate_bps": r.air_rate_bps, "antenna_dbi": r.antenna_dbi,
        "radio_source": r.source,
        "water": w.name, "conductivity_s_per_m": w.conductivity, "temperature_c": w.temperature_c,
        "effective_conductivity_s_per_m": water_mod.effective_conductivity(r.freq_hz, w),
        "relative_permittivity": water_mod.permittivity(r.freq_hz, w.temperature_c).real,
        "attenuation_db_per_m": lk.attenuation_db_per_m,
        "skin_depth_m": water_mod.skin_depth(r.freq_hz, w),
        "surface_loss_db": lk.surface_loss_db,
        "ground_distance_m": lk.ground_distance_m, "air_loss_db": lk.air_loss_db,
        "margin_at_surface_db": lk.air_margin_db,
        "reach_m": lk.reach_m, "holds_to_m": lk.holds_to_m,
        "rows": reach_table(lk),
    }


def do_radio_reach(args: argparse.Namespace) -> None:
    lk = link_of(args)
    report = reach_report(lk)
    if args.plot:
        _plot(lk, report, args.plot)
        report["plot"] = args.plot

    def text(r: dict) -> str:
        lines = [
            "%s (%g MHz, %g dBm, %g dBm sensitivity at %g kbps) in %s water (%g S/m, %g C)" % (
                r["radio"], r["frequency_mhz"], r["tx_dbm"], r["sensitivity_dbm"], r["air_rate_bps"] / 1000.0,
                r["water"], r["conductivity_s_per_m"], r["temperature_c"]),
            "attenuation_db_per_m  %.2f dB/m (skin depth %.3g m; eps' %.1f, with its dielectric loss %.3g S/m)" % (
                r["attenuation_db_per_m"], r["skin_depth_m"], r["relative_permittivity"],
                r["effective_conductivity_s_per_m"]),
            "surface_loss_db       %.2f dB" % r["surface_loss_db"],
            "air                   %.1f dB over %g m; margin just above the surface %.1f dB" % (
                r["air_loss_db"], r["ground_distance_m"], r["margin_at_surface_db"]),
            "reach_m               %.3f m (half the frames lost); nine in ten cross to %.3f m" % (
                r["reach_m"], r["holds_to_m"]),
            "%10s %10s %10s" % ("depth m", "margin dB", "frame loss"),
        ]
        for row in r["rows"]:
            lines.append("%10.3g %10.1f %9.1f%%" % (row["depth_m"], row["margin_db"], 100.0 * row["frame_loss"]))
        if r.get("plot"):
            lines.append("wrote %s" % r["plot"])
        return "\n".join(lines)

    emit(args, report, text)


def _plot(lk, report: dict, path: str) -> None:
    import numpy as np

    from roboray.sim.plots import plt
    from roboray.sim.radio.link import frame_loss

    depth = np.linspace(0.0, max(1.5 * lk.reach_m, 0.01), 300)
    margin = np.array([lk.margin_db(d) for d in depth])
    loss = np.array([frame_loss(m) for m in margin])
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    a.plot(depth, margin)
    a.axhline(0.0, color="k", lw=0.5)
    a.set_ylabel("margin (dB)")
    a.set_title("%s in %s water (%g S/m): reach %.3g m" % (report["radio"], report["water"],
                                                           report["conductivity_s_per_m"], lk.reach_m))
    b.plot(depth, 100.0 * loss)
    b.axvline(lk.reach_m, color="k", lw=0.5, ls="--")
    b.set_ylabel("frames lost (%)")
    b.set_xlabel("antenna depth (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def register(sub, bench) -> None:
    from roboray.sim.radio.water import WATERS

    p = command(sub, "radio-reach", do_radio_reach,
                "how deep the radio reaches into a water: attenuation, surface loss, margin and frame loss by depth")
    add_link_options(p, radio_flags=("--radio", "--radio-model"))
    p.add_argument("--water", choices=sorted(WATERS), default="fresh",
                   help="fresh (0.02 S/m, the default) or sea (4.5 S/m) water, both at 18 C")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot margin and frame loss against depth")
    add_json(p)
