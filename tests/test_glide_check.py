"""The second glide model (sim/analysis/glide_check.py), the stroke's
reaction at three reference points, and roboray-sim glide-check against
the figures docs/design/glide-check.md quotes."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from roboray.sim.analysis.glide_check import PlateModel, stroke_reaction
from roboray.sim.vehicle import Vehicle, load_params

ROOT = Path(__file__).resolve().parent.parent
BUILDABLE = str(ROOT / "sim" / "vehicles" / "buildable.py")
NOTE = ROOT / "docs" / "design" / "glide-check.md"


def sim(*args: str):
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", *args], capture_output=True, text=True,
                          timeout=300)


@pytest.fixture(scope="module")
def reference():
    return PlateModel(load_params())


def balances(model: PlateModel, glide):
    """Net force and net moment about the CB, summed here from the plates
    (not through the model's own residual)."""
    v = model.vehicle
    p = v.p
    cb = v.centre_of_buoyancy(glide.wings)
    force = (v.mass - p.rho * v.volume) * p.g * glide.gamma
    moment = np.cross(v.centre_of_gravity(glide.wings) - cb, v.mass * p.g * glide.gamma)
    for pl in v.plates(glide.wings):
        un = float(pl.normal @ glide.V)
        d = -0.5 * p.rho * p.cd * pl.area * un * abs(un) * pl.normal
        force = force + d
        moment = moment + np.cross(pl.centroid - cb, d)
        moment = moment + glide.munk * pl.added_mass * un * np.cross(pl.normal, glide.V)
    return force, moment


@pytest.mark.parametrize("munk", [1.0, 0.0])
@pytest.mark.parametrize("wings", [(0, 0, 90, 90), (0, 45, 90, 45), (30, 30, 60, 60)])
def test_force_and_moment_balance_hold_at_every_solution(reference, wings, munk):
    glides = reference.glides(np.radians(wings), munk)
    assert glides, "no glide found"
    for g in glides:
        force, moment = balances(reference, g)
        assert np.abs(force).max() < 1e-9
        assert np.abs(moment).max() < 1e-9
        assert g.descent_speed > 0.1


@pytest.mark.parametrize("fold", [0.0, 30.0, 60.0, 80.0])
@pytest.mark.parametrize("munk", [1.0, 0.0])
def test_symmetric_wings_fall_straight_down_at_the_analytic_terminal_speed(reference, fold, munk):
    v = reference.vehicle
    p = v.p
    wings = np.radians([fold] * 4)
    g = reference.solve(wings, munk)
    assert g is not None
    assert g.horizontal_speed < 1e-9
    assert g.tilt_deg < 1e-6
    # A wing at fold s meets the fall at V cos s: its drag is cos^2 s and the
    # vertical share of its normal cos s, so it counts A_w cos^3 s.
    area = v.area_center + 4 * v.area_wing * math.cos(math.radians(fold)) ** 3
    expected = math.sqrt(2 * (v.mass - p.rho * v.volume) * p.g / (p.rho * p.cd * area))
    assert g.descent_speed == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("munk", [1.0, 0.0])
def test_mirrored_wings_glide_the_opposite_way_with_the_same_ratio(reference, munk):
    a = reference.glides(np.radians([0, 0, 90, 90]), munk)
    b = reference.glides(np.radians([90, 90, 0, 0]), munk)
    assert len(a) == len(b) == 1
    a, b = a[0], b[0]
    assert a.glide_ratio > 0.4
    assert b.glide_ratio == pytest.approx(a.glide_ratio, rel=1e-9)
    assert b.descent_speed == pytest.approx(a.descent_speed, rel=1e-9)
    assert a.glide_direction_deg == pytest.approx(-135.0, abs=1e-6)   # towards the folded wings 3 and 4
    assert b.glide_direction_deg == pytest.approx(45.0, abs=1e-6)     # towards the folded wings 1 and 2


def test_without_the_munk_moment_the_glide_is_the_issues_and_the_term_is_the_whole_difference():
    out = json.loads(sim("glide-check", "--wings", "0,0,90,90", "--json").stdout)
    main, full, bare = out["main_model"], out["plate_model_munk"], out["plate_model_no_munk"]
    # the plate model with the Munk moment is the main model's trim ...
    for key in ("descent_speed", "horizontal_speed", "glide_ratio", "tilt_deg"):
        assert full[key] == pytest.approx(main[key], rel=1e-7, abs=1e-9)
    assert out["plate_vs_main_max_difference"] < 1e-9
    # ... and without it the issue's independent figure: 0.59 at 0.47-0.49 m/s
    assert bare["glide_ratio"] == pytest.approx(0.59, abs=0.005)
    assert 0.47 <= bare["descent_speed"] <= 0.49
    # the main model at that glide: forces balance, the moment left is the Munk moment
    there = out["main_model_at_plate_glide"]
    assert there["force_n"] < 1e-9
    assert np.linalg.norm(there["moment_nm"]) > 0.01
    assert there["difference_nm"] < 1e-9
    # taking k from 1 to 0 raises the ratio step by step
    ratios = [row["glide_ratio"] for row in out["munk_scan"]]
    assert out["munk_scan"][0]["munk_scale"] == 1.0 and out["munk_scan"][-1]["munk_scale"] == 0.0
    assert all(b > a for a, b in zip(ratios, ratios[1:]))


def test_a_small_stroke_moves_each_point_as_the_momentum_argument_says():
    r = stroke_reaction(load_params(), fold_deg=45.0, stroke_deg=1.0)
    per_rad = math.radians(1.0)
    for name in ("plate_centre", "cg", "cb"):
        moved = r["displacement_m"][name][0] / per_rad
        assert moved == pytest.approx(r["per_radian_m"][name][0], rel=0.02), name
    assert r["pitch_deg"] / per_rad == pytest.approx(r["pitch_deg_per_radian"], rel=0.02)
    assert r["wings_after_deg"] == pytest.approx([46.0, 45.0, 44.0, 45.0], abs=1e-6)


def test_the_reference_point_decides_the_reactions_direction():
    ref = stroke_reaction(load_params())
    d = ref["displacement_m"]
    assert d["plate_centre"][0] < 0 < d["cg"][0] < d["cb"][0]     # plate away, CG and CB towards wing 1
    assert ref["pitch_deg"] < 0                                    # the folded wing's side down
    assert ref["per_radian_m"]["plate_centre"][0] == pytest.approx(ref["plate_centre_accel_per_wing_accel"])
    built = stroke_reaction(load_params(BUILDABLE))
    assert 0 < built["displacement_m"]["plate_centre"][0]          # every point towards wing 1 there


def test_with_the_wings_still_the_body_is_at_rest_after_a_stroke():
    from roboray.sim.dynamics import Model

    r = stroke_reaction(load_params(), fold_deg=30.0)
    assert r["stroke_deg"] == 30.0
    assert r["wings_after_deg"] == pytest.approx([60.0, 30.0, 0.0, 30.0], abs=1e-6)
    m = Model(load_params(), gravity=False, drag=False)
    x = m.state(wings=np.radians(r["wings_after_deg"]))
    assert np.abs(m.velocities(x, np.zeros((1, 4)))).max() == 0.0   # zero momenta: zero velocity


#: Each figure docs/design/glide-check.md quotes, as written there, and where
#: glide-check --json prints it.
NOTE_FIGURES = {
    "reference": [
        ("0.4156 m/s", ("main_model", "descent_speed")),
        ("0.488", ("main_model", "glide_ratio")),
        ("5.6 deg", ("main_model", "tilt_deg")),
        ("0.4789 m/s", ("plate_model_no_munk", "descent_speed")),
        ("0.589", ("plate_model_no_munk", "glide_ratio")),
        ("15.3 deg", ("plate_model_no_munk", "tilt_deg")),
        ("0.0512", ("moments_at_main_glide_nm", "drag_moment")),
        ("0.0144", ("moments_at_main_glide_nm", "weight_moment")),
        ("0.0368", ("moments_at_main_glide_nm", "munk_moment")),
        ("-0.53 mm", ("stroke", "displacement_m", "plate_centre", 0)),
        ("+3.96 mm", ("stroke", "displacement_m", "cg", 0)),
        ("+11.13 mm", ("stroke", "displacement_m", "cb", 0)),
        ("-25.3 deg", ("stroke", "pitch_deg")),
        ("-1.56 mm", ("stroke", "per_radian_m", "plate_centre", 0)),
        ("+4.43 mm", ("stroke", "per_radian_m", "cg", 0)),
        ("+14.01 mm", ("stroke", "per_radian_m", "cb", 0)),
        ("-32.7 deg", ("stroke", "pitch_deg_per_radian")),
    ],
    "buildable": [
        ("0.3169 m/s", ("main_model", "descent_speed")),
        ("0.466", ("main_model", "glide_ratio")),
        ("3.3 deg", ("main_model", "tilt_deg")),
        ("0.5632 m/s", ("plate_model_no_munk", "descent_speed")),
        ("0.445", ("plate_model_no_munk", "glide_ratio")),
        ("40.1 deg", ("plate_model_no_munk", "tilt_deg")),
        ("0.678", ("munk_scan", 7, "glide_ratio")),
        ("8.9 mm", ("stroke", "displacement_m", "plate_centre", 0)),
        ("8.1 mm", ("stroke", "per_radian_m", "plate_centre", 0)),
    ],
}


def _dig(doc, path):
    for k in path:
        doc = doc[k]
    return doc


@pytest.mark.parametrize("vehicle", sorted(NOTE_FIGURES))
def test_the_design_notes_figures_are_what_the_command_prints(vehicle):
    args = ["glide-check", "--wings", "0,0,90,90", "--json"]
    if vehicle == "buildable":
        args += ["--vehicle", BUILDABLE]
    proc = sim(*args)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    note = NOTE.read_text(encoding="utf-8")
    for text, path in NOTE_FIGURES[vehicle]:
        assert text in note, text
        value = float(text.split()[0])
        printed = _dig(out, path)
        if path[-2:] in (("plate_centre", 0), ("cg", 0), ("cb", 0)):
            printed *= 1e3   # m -> mm
        scale = 10.0 ** -len(text.split()[0].split(".")[1])   # the last digit written
        assert printed == pytest.approx(value, abs=0.5 * scale + 1e-12), (text, printed)


def test_glide_check_says_in_one_line_what_it_cannot_compare():
    proc = sim("glide-check", "--wings", "0,10,20,30")
    assert proc.returncode == 1
    assert "no straight glide" in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    proc = sim("glide-check", "--fold", "90")
    assert proc.returncode == 2
    assert "--fold" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
