"""A RoboRay you can build: every mass and volume from a part you can buy.

Unlike ``reference.py`` (the thesis's vehicle, five numbers fitted to its
tables), nothing here is fitted: ``PARTS`` lists what goes into the vehicle,
and the model's inputs (total mass, the payload's height, radius and
thickness) are sums over it, so the CG and the CB follow from the parts.
Pass it to any command: ``roboray-sim vehicle --vehicle
sim/vehicles/buildable.py --json``.

What each number is, in the comments:

- **part**: the maker's datasheet or listing (named), or the geometry of a
  stock size times the material's handbook density;
- **assumed**: not published; a measured or estimated value a builder should
  replace with the scale reading of their own part (the file is meant to be
  copied and edited);
- **chosen**: a design decision (plate size, wing size, the ballast bars
  and where the parts sit), with the reason.

Layout (body frame of ``sim/vehicle.py``: origin at the centre of the plate's
mid-plane, z down, the dome on the -z side): a 3 mm 5052 aluminium plate
carries a 100 mm acrylic dome; everything dry sits inside the dome on the
plate; the four servos stand on the plate's edges outside the dome, each
driving a wing of 3 mm rigid PVC hinged along that edge. The wings fold up
beside the dome, never into it: the dome's rim (50 mm from the axis) is
20 mm inside the hinges (70 mm).

Depth: the vehicle is for pools and lakes to 10 m (the twin's scenarios go
to 10 m). The servos limit it, not the dome: the HS-5086WP is rated IP67
(immersion to 1 m for 30 min, IEC 60529); below that its output-shaft
O-ring and case seams see 1 bar per 10 m and water creeps in over a dive.
For 10 m, fill each servo with mineral oil (pressure-compensated, the common
ROV practice: the oil has no air to compress, so the case sees no pressure
difference) or accept re-sealing after a few dives. The oil adds about 2 g
a servo (assumed: some 3 cm^3 of free air at 0.85 g/cm^3), not counted
here: add it to ``SERVO_MASS`` if you fill them. Torque and speed do not
change with depth (the pressure acts on all sides); an oil fill slows the
servo a little, which ``servo_rate`` below allows for. The dome (acrylic,
3 mm wall) fails near 29 bar by DeepSea's "Under Pressure" calculation for
a 100 mm, 3 mm acrylic dome (philipmcgaw.com, "ROV viewport dome", whose
author calls his dimensions approximate), far below 10 m's 1 bar; the Bar30
is rated to 30 bar (Blue Robotics).

Flying it: the firmware takes no vehicle file. Two tables compiled into the
board code come from one, the reference's as committed:
``shared/control/allocation_table.py`` (which wing angles give a glide) and
``shared/control/plant_tables.py`` (the thesis controller's model). The
cascade controller closes its guidance loop on the estimated position, so
the reference's tables fly this vehicle too: ``roboray-sim sil --scenario
target-landing --vehicle sim/vehicles/buildable.py`` lands 0.016 m from the
target (seed 0, WebAssembly and CPython alike). Its own tables come from the
generators, ``python -m roboray.tools.gen_allocation --vehicle
sim/vehicles/buildable.py`` and ``python -m roboray.tools.gen_plant
--vehicle sim/vehicles/buildable.py`` (they overwrite the committed files;
``--out`` writes elsewhere), then ``roboray-flash``; with them the same run
lands 0.015 m off (measured before the parts list gained the logic
regulator, switch, leak probe and penetrators, 2026-12-01; the committed
tables' landing, 0.016 m, is the same after). They differ where the vehicles do: its symmetric fall is
slower (0.29 m/s at 30 deg mean fold against 0.36) and its reach a little
shorter (glide ratio 0.47 with two wings up against the reference's 0.49).
Those are the main model's glides, which carry the added-mass (Munk) moment
of an oblique glide; a plate-drag model without it gives 0.45 here (0.59
for the reference) and tilts this vehicle 40 deg where the main model tilts
it 3.3 deg, so a first dive's tilt says which holds (``roboray-sim
glide-check --vehicle sim/vehicles/buildable.py``, docs/design/glide-check.md).
Targets at (0, 3) and (-2.5, -2.5) m from 10 m land within 0.02 m with
either pair of tables. No parameter needs changing.
"""

import math

from roboray.sim.vehicle import VehicleParams

# --------------------------------------------------------------- materials
RHO_PVC = 1400.0        # kg/m^3, rigid (unplasticised) PVC sheet: 1.38-1.45 g/cm^3 (handbook range, e.g. Vink, Plastics)
RHO_AL5052 = 2680.0     # kg/m^3, aluminium 5052-H32 (ASM handbook)
RHO_ACRYLIC = 1190.0    # kg/m^3, cast PMMA (Evonik PLEXIGLAS datasheet: 1.19 g/cm^3)
RHO_STEEL = 7850.0      # kg/m^3, structural steel S235 (EN 10025)

# ----------------------------------------------------------------- geometry
THICKNESS = 0.003       # m, chosen: 3 mm sheet for plate and wings (stock size of both)
PLATE_SIDE = 0.140      # m, chosen: the dome (100 mm) plus a 13 mm servo and its wing hinge on each side
# m, chosen: hinge to tip, 0.50 m tip to tip, for reach: two wings up glide at 0.47 (150 mm wings: 0.43; main model)
WING_HEIGHT = 0.180
DOME_OD = 0.100         # m, part: 100 mm clear acrylic hemisphere (ROV/CCTV viewport dome, philipmcgaw.com)
DOME_WALL = 0.003       # m, part: "about 3 mm thick" (same source)

TOP = -0.5 * THICKNESS  # z of the plate's top face, where the dome and the dry parts sit

# Servo: Hitec HS-5086WP, digital, metal gear, IP67 (Hitec product page):
# 29 x 13 x 30 mm, 21.9 g; 3.6 kg.cm (0.35 N m) and 0.17 s/60 deg at 6.0 V,
# 3.0 kg.cm and 0.20 s/60 deg at 4.8 V. Laid on its side along the plate's
# edge, its output shaft on the hinge line: 13 mm tall, centroid 6.5 mm up.
SERVO_MASS = 0.0219             # kg, part
SERVO_VOLUME = 0.029 * 0.013 * 0.030  # m^3, part: its box (the horn and cable gland add <1 cm^3)
SERVO_HEIGHT = 0.0065           # m, part: half of its 13 mm width, lying flat
# Hinge moment it must hold (check, not an input): a wing's normal force at
# 0.3 m/s, 0.5 rho cd v^2 A = 0.73 N, at a third of its height (60 mm) is
# 0.044 N m, an eighth of the stall torque at 6 V.

# --------------------------------------------------------------- dry parts
# Everything inside the dome, as (name, part, mass kg, centroid (x, y, z) m,
# box (dx, dy, dz) m or None, source). Inside the dome they displace nothing
# of their own (the dome's outer volume does), so only their mass and place
# enter the model. Heights are above the plate's top face (z = TOP - h); the
# layout is chosen so that every box fits under the dome's inner surface
# (47 mm radius; a test checks it) and the dry parts' CG lies on the axis,
# where the model puts it: the ballast bars are shifted to balance the rest.
_MM = 0.001


def _at(x_mm, y_mm, h_mm):
    return (x_mm * _MM, y_mm * _MM, TOP - h_mm * _MM)


# m, chosen: 45 mm cuts of 12 mm square steel bar, two of them (60 mm
# before the logic supply, penetrators, switch and leak probe were listed:
# the bars were shortened by their mass, so the vehicle weighs the same)
BALLAST_BAR = (0.045, 0.012, 0.012)
BALLAST_BAR_MASS = RHO_STEEL * BALLAST_BAR[0] * BALLAST_BAR[1] * BALLAST_BAR[2]  # part: geometry x density

_PENETRATOR = "M10 potted cable penetrator with nut and O-ring"
_REST = (
    ("battery cell 1", "Samsung INR18650-35E", 0.050, _at(-1.0, -9.3, 9.3), (0.06525, 0.01855, 0.01855),
     "part: Samsung SDI datasheet, 50.0 g max, 18.55 x 65.25 mm; lying on the plate"),
    ("battery cell 2", "Samsung INR18650-35E", 0.050, _at(-1.0, 9.3, 9.3), (0.06525, 0.01855, 0.01855),
     "part: as cell 1; the two in series (2S, 7.2 V nominal, 3.5 Ah)"),
    ("depth sensor", "Blue Robotics Bar30 (MS5837-30BA)", 0.011, _at(37.0, 0.0, 10.0), (0.010, 0.010, 0.020),
     "assumed: M10 penetrator, nut and board, about 11 g (weigh yours); through the plate, its face flush below"),
    ("microcontroller", "Raspberry Pi Pico 2 (RP2350)", 0.003, _at(0.0, -11.5, 23.0), (0.051, 0.021, 0.004),
     "assumed: the datasheet gives 51 x 21 x 1 mm and no mass; a bare Pico weighs about 3 g"),
    ("IMU", "Adafruit 4517 (LSM6DSOX + LIS3MDL)", 0.002, _at(-12.0, 11.0, 23.3), (0.0256, 0.0178, 0.0046),
     "assumed: a 25.6 x 17.8 mm STEMMA QT breakout, about 2 g"),
    ("servo regulator", "Pololu D36V28F6 (6 V, 3.2 A step-down)", 0.0035, _at(12.0, 11.0, 25.0), (0.018, 0.020, 0.008),
     "assumed: an 18 x 20 mm board with headers, about 3.5 g; feeds the servos 6 V from the 2S pack"),
    ("radio", "HC-12 433 MHz serial transceiver (Si4463)", 0.003, _at(0.0, 0.0, 32.0), (0.0278, 0.0144, 0.004),
     "assumed: 27.8 x 14.4 mm module with its spring antenna, about 3 g; transparent UART at 57,600 baud, "
     "the ground's twin on a CP2102 USB adapter; above the water only (acrylic passes RF, water does not)"),
    ("deck and wiring", "1.6 mm perfboard 60 x 40 mm, leads, M3 screws, standoffs", 0.015, _at(0.0, 0.0, 16.0), None,
     "assumed: weigh yours"),
    ("logic regulator", "Pololu D36V28F5 (5 V, 3.2 A step-down) and a Schottky diode", 0.0035,
     _at(-14.0, -11.5, 29.0), (0.018, 0.020, 0.008),
     "assumed: as the servo regulator, about 3.5 g; the Pico 2's VSYS takes 1.8-5.5 V (Raspberry Pi, Pico 2 "
     "datasheet, 'Powering Pico'), so neither the pack nor the 6 V servo rail can feed it; the diode lets USB "
     "and the pack be connected together, the datasheet's own arrangement"),
    ("power switch", "Blue Robotics Switch (M10 penetrator, 10 A)", 0.010, _at(-37.0, 0.0, 10.0),
     (0.010, 0.010, 0.020),
     "assumed: about 10 g (weigh yours); through the plate opposite the Bar30, so the vehicle is switched on "
     "sealed"),
    ("leak probe", "Blue Robotics SOS Leak Sensor (board and one probe)", 0.005, _at(37.0, -11.0, 2.0),
     (0.012, 0.008, 0.004),
     "assumed: about 5 g; its probe on the plate, the lowest point inside the dome, where water collects; "
     "read on GP15 (firmware/boards/pico2.py)"),
    ("servo lead penetrator 1", _PENETRATOR, 0.004, _at(28.0, 24.0, 5.0), (0.012, 0.012, 0.010),
     "assumed: about 4 g (weigh yours); one a servo lead, through the plate in a corner the cells and the "
     "ballast bars leave free, just inside the dome's rim"),
    ("servo lead penetrator 2", _PENETRATOR, 0.004, _at(-28.0, 24.0, 5.0), (0.012, 0.012, 0.010), "assumed: as 1"),
    ("servo lead penetrator 3", _PENETRATOR, 0.004, _at(-28.0, -24.0, 5.0), (0.012, 0.012, 0.010), "assumed: as 1"),
    ("servo lead penetrator 4", _PENETRATOR, 0.004, _at(28.0, -24.0, 5.0), (0.012, 0.012, 0.010), "assumed: as 1"),
    ("dome lip", "the dome's flange, 6 mm wide, 3 mm thick, with its O-ring and M3 screws",
     RHO_ACRYLIC * math.pi * (0.056 ** 2 - 0.050 ** 2) * 0.003 + 0.004, _at(0.0, 0.0, 1.5), None,
     "part: ring geometry x acrylic density, plus 4 g of screws (assumed); the model's dome is a bare hemisphere, "
     "so the lip's 6 cm^3 outside it is left out of the displaced volume (1.2 %: the vehicle is 0.06 N lighter "
     "in water than modelled)"),
)
# Ballast bars either side of the cells, shifted so the dry parts' CG is on the axis.
_SHIFT = tuple(-sum(p[2] * p[3][k] for p in _REST) / (2 * BALLAST_BAR_MASS) for k in (0, 1))
PARTS = (
    ("ballast bar 1", "steel S235, 12 mm square bar, 45 mm long", BALLAST_BAR_MASS,
     (_SHIFT[0], -0.0246 + _SHIFT[1], TOP - 0.006), BALLAST_BAR,
     "part: geometry x density; chosen count (trim with washers in the water)"),
    ("ballast bar 2", "steel S235, 12 mm square bar, 45 mm long", BALLAST_BAR_MASS,
     (_SHIFT[0], 0.0246 + _SHIFT[1], TOP - 0.006), BALLAST_BAR, "part: as bar 1"),
) + _REST
#: m, the IMU board's and the pressure port's positions from the parts table
IMU_POSITION = next(p[3] for p in PARTS if p[0] == "IMU")
PRESSURE_PORT = next((p[3][0], p[3][1], 0.5 * THICKNESS) for p in PARTS if p[0] == "depth sensor")


def _sheet_mass():
    """Plate, wings, dome shell and servos: everything ``Vehicle`` builds itself."""
    plate = RHO_AL5052 * PLATE_SIDE ** 2 * THICKNESS
    wings = 4 * RHO_PVC * 0.5 * PLATE_SIDE * WING_HEIGHT * THICKNESS
    r_in = 0.5 * DOME_OD - DOME_WALL
    dome = RHO_ACRYLIC * (2.0 / 3.0) * math.pi * ((0.5 * DOME_OD) ** 3 - r_in ** 3)
    return plate + wings + dome + 4 * SERVO_MASS


def payload():
    """The dry parts as the model's flat cylinder: mass, centroid height above
    the mid-plane, and the radius and thickness whose second moments are the
    parts' (I_z = m r^2 / 2 and the vertical spread m h^2 / 12)."""
    m = sum(p[2] for p in PARTS)
    cx = sum(p[2] * p[3][0] for p in PARTS) / m
    cy = sum(p[2] * p[3][1] for p in PARTS) / m
    cz = sum(p[2] * p[3][2] for p in PARTS) / m
    radial = sum(p[2] * ((p[3][0] - cx) ** 2 + (p[3][1] - cy) ** 2) for p in PARTS)
    vertical = sum(p[2] * (p[3][2] - cz) ** 2 for p in PARTS)
    return {"mass": m, "centroid": (cx, cy, cz), "height": -cz,
            "radius": math.sqrt(2.0 * radial / m), "thickness": math.sqrt(12.0 * vertical / m)}


PAYLOAD = payload()

VEHICLE = VehicleParams(
    rho=1000.0,                 # kg/m^3, fresh water (sea water: --water sea, 1025)
    g=9.80665,                  # m/s^2
    cd=1.28,                    # flat plate normal to the flow, thesis sec. 2.2.1 (as the reference)
    cf=0.0,                     # skin friction off, as the reference
    plate_side=PLATE_SIDE,      # chosen, above
    wing_height=WING_HEIGHT,    # chosen, above
    thickness=THICKNESS,        # part: 3 mm sheet
    plate_density=RHO_AL5052,   # part: 5052 aluminium plate (stiff, and its weight sits low)
    wing_density=RHO_PVC,       # part: rigid PVC wings
    k_center=math.sqrt(2.0) / 2.0,  # thesis Table 2.1, as the reference: a square plate
    dlambda_center=1.0,
    kx_center=0.41,
    ky_center=0.41,
    k_wing=0.91,                # thesis Table 2.1's triangle, as the reference
    dlambda_wing=0.6,
    kx_wing=0.75,
    ky_wing=0.15,
    dome_radius=0.5 * DOME_OD,  # part
    dome_shell_thickness=DOME_WALL,  # part
    dome_density=RHO_ACRYLIC,   # part
    servo_mass=SERVO_MASS,      # part
    servo_volume=SERVO_VOLUME,  # part
    servo_height=SERVO_HEIGHT,  # part
    total_mass=_sheet_mass() + PAYLOAD["mass"],  # sum of the parts
    payload_radius=PAYLOAD["radius"],        # from the parts' spread
    payload_thickness=PAYLOAD["thickness"],  # from the parts' spread
    payload_height=PAYLOAD["height"],        # from the parts' centroid
    servo_tau=0.05,             # s, assumed as the reference: the servo's position loop
    # rad/s, part: 0.17 s/60 deg unloaded at the regulator's 6 V; 0.20 s (its 4.8 V figure) for the load and oil
    servo_rate=math.radians(60.0) / 0.20,
    servo_min=0.0,              # rad, flat
    servo_max=math.pi / 2,      # rad, folded up beside the dome
    imu_position=IMU_POSITION,  # m, from the parts table
    pressure_port=PRESSURE_PORT,  # m, the Bar30's face, flush with the plate's underside
)
