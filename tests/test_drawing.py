"""``roboray-sim drawing``: the plate and wing drawing is the vehicle file's
geometry at 1:1, and its O-ring gland is one Parker's handbook allows."""

import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from roboray.sim import drawing
from roboray.sim.vehicle import load_params

ROOT = Path(__file__).resolve().parent.parent
BUILDABLE = ROOT / "sim" / "vehicles" / "buildable.py"
NS = "{http://www.w3.org/2000/svg}"


def _svg(tmp_path, vehicle=BUILDABLE):
    out = tmp_path / "d.svg"
    args = [sys.executable, "-m", "roboray.sim.cli", "drawing", "--out", str(out)]
    if vehicle is not None:
        args += ["--vehicle", str(vehicle)]
    done = subprocess.run(args, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return ET.parse(out).getroot(), done.stdout


def test_the_drawing_is_the_vehicle_files_plate_and_wing_at_one_to_one(tmp_path):
    root, text = _svg(tmp_path)
    params = load_params(BUILDABLE)
    side = 1000.0 * params.plate_side
    assert root.get("width").endswith("mm")
    w = float(root.get("width")[:-2])
    assert root.get("viewBox").split()[2] == ("%g" % w)          # one user unit a millimetre
    plate = root.find(NS + "rect[@id='plate']")
    assert float(plate.get("width")) == pytest.approx(side) and float(plate.get("height")) == pytest.approx(side)
    pts = [tuple(map(float, p.split(","))) for p in root.find(NS + "polygon[@id='wing']").get("points").split()]
    xs, ys = zip(*pts)
    assert max(xs) - min(xs) == pytest.approx(side)
    assert max(ys) - min(ys) == pytest.approx(1000.0 * params.wing_height)
    # a hole for each part through the plate, where the file puts it
    cx = float(plate.get("x")) + side / 2
    cy = float(plate.get("y")) + side / 2
    ns = {}
    exec(compile(BUILDABLE.read_text(), str(BUILDABLE), "exec"), ns)
    through = [p for p in ns["PARTS"] if "penetrator" in p[0] or p[0] in ("depth sensor", "power switch")]
    holes = {c.get("data-part"): c for c in root.iter(NS + "circle") if c.get("class") == "m10"}
    assert set(holes) == {p[0] for p in through} and len(holes) == 6
    for p in through:
        c = holes[p[0]]
        assert float(c.get("cx")) - cx == pytest.approx(1000.0 * p[3][0], abs=0.01)
        assert float(c.get("cy")) - cy == pytest.approx(1000.0 * p[3][1], abs=0.01)
        # clear of the dome's inside wall (3 mm) and of the other holes
        assert math.hypot(1000 * p[3][0], 1000 * p[3][1]) + drawing.M10_CLEAR_MM / 2 < 1000 * (
            params.dome_radius - params.dome_shell_thickness)
    assert "6 holes through the plate" in text


def test_the_oring_gland_is_within_parkers_face_seal_limits_and_under_the_flange(tmp_path):
    root, _ = _svg(tmp_path)
    inner = float(root.find(NS + "circle[@id='groove-inner']").get("r")) * 2
    outer = float(root.find(NS + "circle[@id='groove-outer']").get("r")) * 2
    dome = float(root.find(NS + "circle[@id='dome']").get("r"))
    flange = float(root.find(NS + "circle[@id='flange']").get("r"))
    assert inner == pytest.approx(drawing.ORING_ID_MM)           # external pressure: the ring on the inner wall
    assert dome <= inner / 2 and outer / 2 <= flange              # under the flange, not under the dome wall
    # Parker ORD 5700, face seal, 0.070 in section: depth 0.050-0.054 in, width 0.101-0.107 in
    assert 0.050 * 25.4 <= drawing.GROOVE_DEPTH_MM <= 0.054 * 25.4
    assert 0.101 * 25.4 <= (outer - inner) / 2 <= 0.107 * 25.4
    squeeze = (drawing.ORING_CS_MM - drawing.GROOVE_DEPTH_MM) / drawing.ORING_CS_MM
    assert 0.19 <= squeeze <= 0.32
    fill = math.pi * (drawing.ORING_CS_MM / 2) ** 2 / (drawing.GROOVE_DEPTH_MM * (outer - inner) / 2)
    assert fill < 0.85                                            # room for the ring to swell
    # the gland leaves the 3 mm plate more than half its thickness
    assert drawing.GROOVE_DEPTH_MM < 0.5 * 1000 * load_params(BUILDABLE).thickness


def test_a_vehicle_whose_dome_seal_does_not_fit_its_plate_is_refused_in_one_line(tmp_path):
    # the thesis's reference vehicle is fitted to its tables, not built: its
    # 149 mm dome does not sit on its 59 mm plate
    out = tmp_path / "d.svg"
    done = subprocess.run([sys.executable, "-m", "roboray.sim.cli", "drawing", "--out", str(out)],
                          capture_output=True, text=True)
    assert done.returncode == 2 and not out.exists()
    assert len(done.stderr.strip().splitlines()) == 1 and "not under the dome's flange" in done.stderr
