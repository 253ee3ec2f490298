"""The buildable vehicle (sim/vehicles/buildable.py): its mass properties are
the sums of its parts, its parts fit in its dome, its trims exist and are
stable, and the firmware in the twin lands it on the target."""

from __future__ import annotations

import json
import math
import runpy
from pathlib import Path

import numpy as np
import pytest

from roboray.sim import cli
from roboray.sim.analysis.trim import find_trims, modes
from roboray.sim.dynamics import Model
from roboray.sim.vehicle import Vehicle, load_params

FILE = Path(__file__).resolve().parent.parent / "sim" / "vehicles" / "buildable.py"
NS = runpy.run_path(str(FILE))
P = NS["VEHICLE"]
PARTS = NS["PARTS"]


def _sheet_parts():
    """(mass, centroid z, volume, volume centroid z) of the plate, the four flat
    wings, the dome shell and the four servos, from the file's stock sizes and
    densities, computed here without the model."""
    a, h, t = NS["PLATE_SIDE"], NS["WING_HEIGHT"], NS["THICKNESS"]
    top = -0.5 * t
    big, small = 0.5 * NS["DOME_OD"], 0.5 * NS["DOME_OD"] - NS["DOME_WALL"]
    shell = 2.0 / 3.0 * math.pi * (big ** 3 - small ** 3)
    shell_z = top - 3.0 / 8.0 * (big ** 4 - small ** 4) / (big ** 3 - small ** 3)
    servo_z = top - NS["SERVO_HEIGHT"]
    return [
        (NS["RHO_AL5052"] * a * a * t, 0.0, a * a * t, 0.0),
        (4 * NS["RHO_PVC"] * 0.5 * a * h * t, 0.0, 4 * 0.5 * a * h * t, 0.0),
        (NS["RHO_ACRYLIC"] * shell, shell_z, 2.0 / 3.0 * math.pi * big ** 3, top - 3.0 / 8.0 * big),
        (4 * NS["SERVO_MASS"], servo_z, 4 * 0.029 * 0.013 * 0.030, servo_z),
    ]


def test_the_vehicles_mass_is_the_sum_of_its_parts():
    sheet = _sheet_parts()
    dry = sum(p[2] for p in PARTS)
    assert P.total_mass == pytest.approx(sum(s[0] for s in sheet) + dry, rel=1e-12)
    # the 2S pack of 18650s, the two steel bars and a Pico are all in there
    names = {p[0] for p in PARTS}
    assert {"battery cell 1", "battery cell 2", "ballast bar 1", "ballast bar 2", "microcontroller", "IMU",
            "depth sensor", "radio"} <= names
    v = Vehicle(P)
    assert v.mass == pytest.approx(P.total_mass, rel=1e-12)
    assert v.lumps[-1].mass == pytest.approx(dry, rel=1e-12)    # the payload is exactly the dry parts
    # a real vehicle between 0.5 and 1.5 kg that sinks, not a fitted one
    assert 0.5 < v.mass < 1.5 and v.net_weight > 0


def test_cg_and_cb_are_the_parts_moments():
    sheet = _sheet_parts()
    mass = sum(s[0] for s in sheet) + sum(p[2] for p in PARTS)
    cg_z = (sum(s[0] * s[1] for s in sheet) + sum(p[2] * p[3][2] for p in PARTS)) / mass
    volume = sum(s[2] for s in sheet)
    cb_z = sum(s[2] * s[3] for s in sheet) / volume
    v = Vehicle(P)
    flat = np.zeros(4)
    assert v.volume == pytest.approx(volume, rel=1e-12)
    assert v.centre_of_gravity(flat) == pytest.approx([0.0, 0.0, cg_z], abs=1e-12)
    assert v.centre_of_buoyancy(flat) == pytest.approx([0.0, 0.0, cb_z], abs=1e-12)
    # bottom-heavy: the CG below the CB (z down), by the parts' layout alone
    assert v.ell(flat) == pytest.approx(cg_z - cb_z) and v.ell(flat) > 0.003


def test_the_dry_parts_fit_under_the_dome_and_balance_on_its_axis():
    r_in = 0.5 * NS["DOME_OD"] - NS["DOME_WALL"]
    top = -0.5 * NS["THICKNESS"]
    boxed = [p for p in PARTS if p[4] is not None]
    assert len(boxed) >= 8
    for name, _, _, c, box, _ in boxed:
        for sx in (-1, 1):
            for sy in (-1, 1):
                for sz in (-1, 1):
                    x, y = c[0] + sx * box[0] / 2, c[1] + sy * box[1] / 2
                    h = top - (c[2] + sz * box[2] / 2)    # height above the plate's top face
                    assert h >= -1e-9, name
                    assert x * x + y * y + h * h <= r_in * r_in, name
    m = sum(p[2] for p in PARTS)
    for k in (0, 1):   # the model puts the dry parts on the axis; the ballast bars put them there
        assert sum(p[2] * p[3][k] for p in PARTS) / m == pytest.approx(0.0, abs=1e-9)
    # the wings fold up beside the dome, not into it: a servo's 13 mm between its rim and the hinge
    assert NS["PLATE_SIDE"] / 2 - 0.5 * NS["DOME_OD"] >= 0.013


def test_every_part_names_its_source():
    for p in PARTS:
        assert p[5].split(":")[0] in ("part", "assumed", "chosen"), p[0]
    text = FILE.read_text()
    for word in ("HS-5086WP", "INR18650-35E", "Pico 2", "4517", "Bar30", "433 MHz"):
        assert word in text


def test_the_vehicle_command_loads_it(capsys):
    assert load_params(FILE) == P
    assert cli.main(["vehicle", "--vehicle", str(FILE), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mass"] == pytest.approx(P.total_mass, rel=1e-3)
    assert 0.15 < out["terminal_speed"] < 0.4


@pytest.mark.slow
def test_its_trims_exist_and_are_stable():
    model = Model(P)
    flat = find_trims(model, np.zeros(4))
    assert flat, "no straight descent"
    fall = modes(model, flat[0])
    assert fall["stable"] and fall["trim"]["descent_speed"] > 0.1
    glide = find_trims(model, np.radians([0.0, 0.0, 90.0, 90.0]))
    assert glide
    best = max(glide, key=lambda t: t.glide_ratio)
    assert modes(model, best)["stable"]
    # two wings up glide away from them at a usable ratio (the target-landing reach)
    assert 0.3 < best.glide_ratio < 0.7


@pytest.mark.slow
def test_the_twin_lands_it_on_the_target():
    from roboray.sim.twin.runner import Options, run

    out = run(Options(scenario="target-landing", interpreter="cpython", vehicle=str(FILE)))
    assert out["landed"]
    assert out["landing_error_m"] < 0.25
    assert [m[1] for m in out["modes"]][-1] == "TARGET"
