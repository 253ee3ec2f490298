"""Cutting drawings of the plate and a wing, to scale, from a vehicle file.

One SVG in millimetres (``width="...mm"``, one user unit a millimetre, so
it prints or imports into a laser cutter's or CNC program at 1:1): the
centre plate seen from above with the dome's footprint, the flange's O-ring
groove and clamp-ring screws, and a hole for each part the file lists as
passing through the plate (penetrators, the depth sensor, the switch); and
one wing (all four are the same triangle), its hinge edge along the plate's
side. Dimensions come from the file: ``plate_side``, ``wing_height``,
``thickness`` and ``dome_radius`` of its ``VEHICLE``, the through-plate
parts and their centres from its ``PARTS`` (``sim/vehicles/buildable.py``'s
layout: name, part, mass, centre (x, y, z) m, ...; body x towards wing 1,
y towards wing 2).

The seal (docs/user/hardware.md, "Mechanics"): an AS568-041 O-ring (ID
101.19 mm, cross-section 1.78 mm) in a face-seal groove cut in the plate
under the dome's flange, sized from Parker's O-Ring Handbook (ORD 5700,
static face-seal glands for a 0.070 in cross-section: gland depth
0.050-0.054 in, 1.27-1.37 mm; groove width for liquids 0.101-0.107 in,
2.57-2.72 mm). Water presses from outside, so the ring sits against the
groove's inner wall (Parker: for external pressure, the groove's inside
diameter equals the O-ring's), and the groove's inner edge is the ring's
ID. The flange is clamped down by a ring with screws outside it.
"""

from __future__ import annotations

import math
import runpy
from pathlib import Path
from typing import Optional

from roboray.sim.vehicle import VehicleParams, load_params

#: AS568-041 (SAE AS568 dash size): inside diameter and cross-section, mm.
ORING_ID_MM = 101.19
ORING_CS_MM = 1.78
#: Parker ORD 5700 face-seal gland for a 0.070 in cross-section, mm (mid-range).
GROOVE_DEPTH_MM = 1.32     # 0.050-0.054 in
GROOVE_WIDTH_MM = 2.64     # 0.101-0.107 in (liquids)
#: The dome's flange is this much wider than the dome, mm (buildable.py's "dome lip").
FLANGE_MM = 6.0
#: The clamp ring over the flange: screws on this circle, mm beyond the flange.
CLAMP_SCREW_GAP_MM = 3.0
CLAMP_SCREWS = 8
#: M3 tapping drill (ISO 261 coarse thread: 2.5 mm) and M10 clearance (ISO 273 medium: 11 mm), mm.
M3_TAP_MM = 2.5
M10_CLEAR_MM = 11.0
#: Names of the parts that pass through the plate (one M10 hole each).
THROUGH = ("penetrator", "depth sensor", "power switch")


def through_holes(parts) -> list[tuple[str, float, float]]:
    """(name, x mm, y mm) of each part in ``parts`` that passes through the plate."""
    out = []
    for p in parts or ():
        if any(key in p[0] for key in THROUGH):
            out.append((p[0], 1000.0 * p[3][0], 1000.0 * p[3][1]))
    return out


def groove() -> tuple[float, float]:
    """Inner and outer diameters of the O-ring groove, mm."""
    return ORING_ID_MM, ORING_ID_MM + 2.0 * GROOVE_WIDTH_MM


def check(params: VehicleParams) -> list[str]:
    """What does not fit: the groove must lie under the flange, the clamp
    screws on the plate."""
    r_dome = 1000.0 * params.dome_radius
    half = 500.0 * params.plate_side
    inner, outer = groove()
    bad = []
    if inner / 2.0 < r_dome or outer / 2.0 > r_dome + FLANGE_MM:
        bad.append("the O-ring groove (%.1f-%.1f mm) is not under the dome's flange (%.1f-%.1f mm)"
                   % (inner, outer, 2 * r_dome, 2 * (r_dome + FLANGE_MM)))
    if r_dome + FLANGE_MM + CLAMP_SCREW_GAP_MM + M3_TAP_MM > half:
        bad.append("the clamp screws do not fit on a %.0f mm plate" % (2 * half))
    return bad


def _fmt(v: float) -> str:
    return ("%.3f" % v).rstrip("0").rstrip(".")


def svg(params: VehicleParams, parts=None, title: str = "RoboRay") -> str:
    """The drawing as SVG text, in mm. The plate as seen from above (the
    dome's side): body x to the right (wing 1), body y down the page
    (wing 2), so wings 1 to 4 run clockwise, as docs/user/hardware.md
    says."""
    side = 1000.0 * params.plate_side
    half = side / 2.0
    height = 1000.0 * params.wing_height
    thick = 1000.0 * params.thickness
    r_dome = 1000.0 * params.dome_radius
    margin = 15.0
    gap = 25.0
    width = margin + side + gap + side + margin
    tall = margin + 12.0 + max(side, height) + 40.0 + margin
    cx, cy = margin + half, margin + 12.0 + half        # plate centre on paper
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%smm" height="%smm" viewBox="0 0 %s %s" '
           'font-family="sans-serif">' % (_fmt(width), _fmt(tall), _fmt(width), _fmt(tall)),
           '<title>%s: plate and wing, 1:1, mm</title>' % title,
           '<rect x="0" y="0" width="%s" height="%s" fill="white"/>' % (_fmt(width), _fmt(tall))]
    cut = 'fill="none" stroke="black" stroke-width="0.3"'
    mark = 'fill="none" stroke="#1f77b4" stroke-width="0.25" stroke-dasharray="2,1.5"'
    text = 'font-size="3.2" fill="black"'
    small = 'font-size="2.6" fill="#444"'

    # ---- plate: body x to the right (wing 1), body y down the page (wing 2)
    def at(x_mm, y_mm):
        return cx + x_mm, cy + y_mm

    out.append('<text x="%s" y="%s" %s>centre plate, %s x %s x %s mm (cut)</text>'
               % (_fmt(margin), _fmt(margin + 6.0), text, _fmt(side), _fmt(side), _fmt(thick)))
    out.append('<rect id="plate" x="%s" y="%s" width="%s" height="%s" %s/>'
               % (_fmt(cx - half), _fmt(cy - half), _fmt(side), _fmt(side), cut))
    out.append('<circle id="dome" cx="%s" cy="%s" r="%s" %s/>' % (_fmt(cx), _fmt(cy), _fmt(r_dome), mark))
    out.append('<circle id="flange" cx="%s" cy="%s" r="%s" %s/>'
               % (_fmt(cx), _fmt(cy), _fmt(r_dome + FLANGE_MM), mark))
    inner, outer = groove()
    for name, d in (("groove-inner", inner), ("groove-outer", outer)):
        out.append('<circle id="%s" cx="%s" cy="%s" r="%s" fill="none" stroke="#d62728" stroke-width="0.3"/>'
                   % (name, _fmt(cx), _fmt(cy), _fmt(d / 2.0)))
    r_screw = r_dome + FLANGE_MM + CLAMP_SCREW_GAP_MM
    for k in range(CLAMP_SCREWS):
        a = 2.0 * math.pi * (k + 0.5) / CLAMP_SCREWS
        x, y = at(r_screw * math.cos(a), r_screw * math.sin(a))
        out.append('<circle class="m3" cx="%s" cy="%s" r="%s" %s/>' % (_fmt(x), _fmt(y), _fmt(M3_TAP_MM / 2), cut))
    for name, x_mm, y_mm in through_holes(parts):
        x, y = at(x_mm, y_mm)
        out.append('<circle class="m10" data-part="%s" cx="%s" cy="%s" r="%s" %s/>'
                   % (name, _fmt(x), _fmt(y), _fmt(M10_CLEAR_MM / 2), cut))
        out.append('<text x="%s" y="%s" text-anchor="middle" %s>%s</text>' % (_fmt(x), _fmt(y + 9.0), small, name))
    for k, (x0, y0, x1, y1) in enumerate(((half, -half, half, half), (-half, half, half, half),
                                          (-half, -half, -half, half), (-half, -half, half, -half))):
        a, b = at(x0, y0)
        c, d = at(x1, y1)
        mx, my = (a + c) / 2.0, (b + d) / 2.0
        dx = 4.0 if k == 0 else (-13.0 if k == 2 else -6.0)
        dy = 5.0 if k == 1 else (-2.0 if k == 3 else 1.0)
        out.append('<text x="%s" y="%s" %s>hinge, wing %d</text>' % (_fmt(mx + dx - (12 if k in (1, 3) else 0)),
                                                                     _fmt(my + dy), small, [1, 2, 3, 4][k]))
    notes = ["red: O-ring groove, AS568-041 (ID %s mm, section %s mm): groove %s-%s mm dia., %s mm deep"
             % (_fmt(ORING_ID_MM), _fmt(ORING_CS_MM), _fmt(inner), _fmt(outer), _fmt(GROOVE_DEPTH_MM)),
             "(Parker O-Ring Handbook ORD 5700, static face-seal gland); blue dashed: dome %s mm and flange %s mm"
             % (_fmt(2 * r_dome), _fmt(2 * (r_dome + FLANGE_MM))),
             "%d x M3 tapped (%s mm drill) on a %s mm circle for the clamp ring; M10 holes %s mm"
             % (CLAMP_SCREWS, _fmt(M3_TAP_MM), _fmt(2 * r_screw), _fmt(M10_CLEAR_MM))]
    for i, line in enumerate(notes):
        out.append('<text x="%s" y="%s" %s>%s</text>' % (_fmt(margin), _fmt(cy + half + 9.0 + 4.0 * i), small, line))

    # ---- wing: the hinge edge (base) at the top, the tip below
    wx = margin + side + gap
    wy = margin + 12.0
    out.append('<text x="%s" y="%s" %s>wing (4 off), %s mm base, %s mm high, %s mm sheet</text>'
               % (_fmt(wx), _fmt(margin + 6.0), text, _fmt(side), _fmt(height), _fmt(thick)))
    out.append('<polygon id="wing" points="%s,%s %s,%s %s,%s" %s/>'
               % (_fmt(wx), _fmt(wy), _fmt(wx + side), _fmt(wy), _fmt(wx + half), _fmt(wy + height), cut))
    out.append('<text x="%s" y="%s" %s>hinge edge (on the plate\'s side)</text>'
               % (_fmt(wx + half - 20.0), _fmt(wy + 4.0), small))
    out.append('</svg>')
    return "\n".join(out) + "\n"


def load(path: Optional[str]) -> tuple[VehicleParams, object]:
    """The vehicle file's ``VEHICLE`` and its ``PARTS`` (None if it has none)."""
    params = load_params(path)
    parts = None
    if path is not None:
        parts = runpy.run_path(str(Path(path))).get("PARTS")
    return params, parts
