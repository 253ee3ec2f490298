"""The hardware pages say what the code says (issue 19): the wiring table of
docs/user/hardware.md gives the pins ``firmware/boards/pico2.py`` uses, at
the Pico 2's physical pin numbers; its sensor table the drivers' I2C
addresses; its bill of materials the masses of
``sim/vehicles/buildable.py``, adding up to the file's total; its figures
what the model computes from that file; and docs/figures/wiring.svg labels
the same pins and addresses. A change to the board profile, a driver or the
parts table that the page does not follow fails here."""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from roboray.firmware.boards import pico2
from roboray.firmware.drivers import lis3mdl, lsm6dsox, ms5837
from roboray.sim.vehicle import Vehicle, load_params

ROOT = Path(__file__).resolve().parent.parent
HARDWARE = ROOT / "docs" / "user" / "hardware.md"
WIRING_SVG = ROOT / "docs" / "figures" / "wiring.svg"
BUILDABLE = ROOT / "sim" / "vehicles" / "buildable.py"

#: The Pico 2's physical pin of each GPIO on its edge (Raspberry Pi's pinout:
#: 1 to 20 down the GP0 side from the USB end, 21 to 40 back up the other).
PICO2_PIN = {0: 1, 1: 2, 2: 4, 3: 5, 4: 6, 5: 7, 6: 9, 7: 10, 8: 11, 9: 12, 10: 14, 11: 15, 12: 16, 13: 17,
             14: 19, 15: 20, 16: 21, 17: 22, 18: 24, 19: 25, 20: 26, 21: 27, 22: 29, 26: 31, 27: 32, 28: 34}

#: The wiring table's signals and the board profile's GPIO for each.
SIGNALS = {
    "UART0 TX, radio in": pico2.UART_TX, "UART0 RX, radio out": pico2.UART_RX,
    "I2C0 SDA": pico2.I2C_SDA, "I2C0 SCL": pico2.I2C_SCL,
    "wing 1 servo": pico2.SERVO_PINS[0], "wing 2 servo": pico2.SERVO_PINS[1],
    "wing 3 servo": pico2.SERVO_PINS[2], "wing 4 servo": pico2.SERVO_PINS[3],
    "leak probe": pico2.LEAK_PIN, "battery sense, ADC0": pico2.BATTERY_ADC_PIN,
}


def _section(title: str) -> str:
    """The text of hardware.md's ``## title`` section."""
    text = HARDWARE.read_text(encoding="utf-8")
    m = re.search(r"^## %s\n(.*?)(?=^## |\Z)" % re.escape(title), text, re.M | re.S)
    assert m, "hardware.md has no section %r" % title
    return m.group(1)


def _table(section: str) -> list[list[str]]:
    """The rows (cells stripped) of the first Markdown table in ``section``, header and rule left out."""
    rows = [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in section.splitlines() if line.lstrip().startswith("|")]
    assert len(rows) > 2
    return rows[2:]


def _grams(cell: str) -> float:
    m = re.fullmatch(r"\**([0-9.]+) g\**", cell)
    assert m, "not a mass: %r" % cell
    return float(m.group(1))


def _buildable():
    namespace: dict = {}
    exec(compile(BUILDABLE.read_text(encoding="utf-8"), str(BUILDABLE), "exec"), namespace)
    return namespace


def test_the_pico2_pin_map_is_the_boards():
    # the map's GPIOs are the Pico 2's edge pins: 26 of them, none twice, no
    # power pin among them (3, 8, ... 38 ground, 30 RUN, 33 AGND, 35-40 power)
    assert len(set(PICO2_PIN.values())) == len(PICO2_PIN) == 26
    assert not set(PICO2_PIN.values()) & {3, 8, 13, 18, 23, 28, 30, 33, 35, 36, 37, 38, 39, 40}


def test_the_wiring_table_gives_the_board_profiles_pins():
    assert pico2.UART_ID == 0 and pico2.I2C_ID == 0   # the table says UART0 and I2C0
    found = {}
    for row in _table(_section("Wiring")):
        m = re.fullmatch(r"(\d+) \(GP(\d+)\)", row[1])
        if m:
            found[row[0]] = (int(m.group(1)), int(m.group(2)))
    assert set(found) == set(SIGNALS)
    for signal, gpio in SIGNALS.items():
        pin, gp = found[signal]
        assert gp == gpio, "%s: the page says GP%d, the board profile GP%d" % (signal, gp, gpio)
        assert pin == PICO2_PIN[gpio], "%s: GP%d is pin %d, not %d" % (signal, gpio, PICO2_PIN[gpio], pin)
    # the servo note's rule and the profile's frequency
    assert "Wing *i* is on GP(9+*i*), 50 Hz" in _section("Wiring")
    assert pico2.SERVO_PINS == tuple(9 + i for i in (1, 2, 3, 4)) and pico2.SERVO_FREQ == 50


def test_the_sensor_table_gives_the_drivers_addresses():
    rows = {row[1]: row[2] for row in _table(_section("The board and the sensors"))}
    expected = {
        "ST LSM6DSOX (on Adafruit 4517)": (lsm6dsox.ADDRESS, pico2.LSM6DSOX_ADDR),
        "ST LIS3MDL (on Adafruit 4517)": (lis3mdl.ADDRESS, pico2.LIS3MDL_ADDR),
        "TE MS5837-30BA (Blue Robotics Bar30)": (ms5837.ADDRESS, pico2.MS5837_ADDR),
    }
    assert set(rows) == set(expected)
    for part, (driver, profile) in expected.items():
        assert driver == profile
        assert rows[part] == "I2C%d, 0x%02X" % (pico2.I2C_ID, driver), part
    assert "The bus runs at %d kHz on GP%d (SDA) and GP%d (SCL)" % (
        pico2.I2C_FREQ // 1000, pico2.I2C_SDA, pico2.I2C_SCL) in _section("The board and the sensors")


def test_the_bill_of_materials_has_the_parts_tables_masses_and_total():
    b = _buildable()
    rows = _table(_section("Bill of materials"))
    total = rows.pop()
    assert total[0] == "**total**"
    assert _grams(total[3]) == round(b["VEHICLE"].total_mass * 1000, 1)
    # every entry of PARTS is a row, by its part (or its name) and its mass
    for name, part, mass, *_ in b["PARTS"]:
        hits = [r for r in rows if (part in r[1] or name == r[0]) and _grams(r[3]) == round(mass * 1000, 1)]
        assert hits, "PARTS' %s (%s, %.1f g) is not in the bill of materials" % (name, part, mass * 1000)
    # what Vehicle builds itself from the file's sheet sizes and densities
    plate = b["RHO_AL5052"] * b["PLATE_SIDE"] ** 2 * b["THICKNESS"]
    wing = b["RHO_PVC"] * 0.5 * b["PLATE_SIDE"] * b["WING_HEIGHT"] * b["THICKNESS"]
    r_out, r_in = 0.5 * b["DOME_OD"], 0.5 * b["DOME_OD"] - b["DOME_WALL"]
    dome = b["RHO_ACRYLIC"] * (2.0 / 3.0) * math.pi * (r_out ** 3 - r_in ** 3)
    by_name = {r[0]: r for r in rows}
    for name, mass in (("plate", plate), ("wings", wing), ("dome", dome), ("wing servos", b["SERVO_MASS"])):
        assert _grams(by_name[name][3]) == round(mass * 1000, 1), name
    # and the rows add up to the total: count x mass each
    summed = sum(int(r[2].split()[0]) * _grams(r[3]) for r in rows)
    assert summed == pytest.approx(b["VEHICLE"].total_mass * 1000, abs=0.3)


def test_the_pages_figures_are_what_the_model_computes():
    params = load_params(BUILDABLE)
    vehicle = Vehicle(params)
    p = vehicle.properties(np.zeros(4))
    text = " ".join(HARDWARE.read_text(encoding="utf-8").split())
    in_water_g = p["net_weight"] / params.g * 1000
    for figure in ("mass %.1f g" % (p["mass"] * 1000),
                   "displaced volume %.1f cm^3" % (p["displaced_volume"] * 1e6),
                   "weighs %.3f N (%.0f g) in fresh water" % (p["net_weight"], in_water_g),
                   "falls flat at %.3f m/s" % p["terminal_speed"],
                   "the CG %.1f mm below the centre of buoyancy" % (p["ell"] * 1000),
                   "%.0f g in fresh water (%.3f N" % (in_water_g, p["net_weight"])):
        assert figure in text, figure
    # the sensor positions the page prints for the buildable vehicle
    cb = vehicle.centre_of_buoyancy([0.0, 0.0, 0.0, 0.0])
    ins = ", ".join("%.4f" % (round(a - c, 4) + 0.0) for a, c in zip(params.imu_position, cb))
    baro = ", ".join("%.4f" % (round(a - c, 4) + 0.0) for a, c in zip(params.pressure_port, cb))
    assert "`INS_POS1` %s and `BARO_POS` %s (m)" % (ins, baro) in text


def test_the_wiring_diagram_labels_the_same_pins_and_addresses():
    texts = [" ".join("".join(t.itertext()).split()) for t in ET.parse(WIRING_SVG).getroot().iter()
             if t.tag.endswith("}text")]
    for signal, gpio in SIGNALS.items():
        pin = str(PICO2_PIN[gpio])
        assert any("GP%d" % gpio in t.split() and pin in t.split() for t in texts), \
            "wiring.svg has no label for %s (pin %s, GP%d)" % (signal, pin, gpio)
    labels = " ".join(texts)
    for address in (lsm6dsox.ADDRESS, lis3mdl.ADDRESS, ms5837.ADDRESS):
        assert "0x%02X" % address in labels
    assert "VSYS 39" in labels and "3V3 OUT 36" in labels and "AGND 33" in labels


def test_the_user_guide_index_lists_every_user_page():
    index = ROOT / "docs" / "user" / "README.md"
    linked = set(re.findall(r"\]\(([\w-]+\.md)(?:#[\w-]+)?\)", index.read_text(encoding="utf-8")))
    pages = {p.name for p in index.parent.glob("*.md")} - {"README.md"}
    assert {"hardware.md", "calibration.md", "first-dive.md"} <= pages
    assert pages - linked == set(), "docs/user/README.md does not list %s" % sorted(pages - linked)


def test_the_pack_reaches_the_vehicle_through_a_fuse_and_the_switch():
    rows = [r[0] for r in _table(_section("Wiring"))]
    assert rows.index("fuse") < rows.index("power switch") < rows.index("pack")
    wiring = {r[0]: r for r in _table(_section("Wiring"))}
    assert "5 A" in wiring["fuse"][2] and "PACK+" in wiring["power switch"][2]
    texts = " ".join(" ".join("".join(t.itertext()).split()) for t in ET.parse(WIRING_SVG).getroot().iter()
                     if t.tag.endswith("}text"))
    assert "fuse 5 A" in texts and "power switch" in texts and "BMS" in texts
    # the switch is the parts table's, and the fuse's rating sits between what the vehicle draws and the cells'
    assert any(p[0] == "power switch" for p in _buildable()["PARTS"])
    safety = " ".join(_section("Electrical safety").split())
    assert "6 V x 3.2 A / (7.2 V x 0.9) = 3.0 A" in safety and 6 * 3.2 / (7.2 * 0.9) < 5 < 8


def test_the_low_battery_behaviour_the_page_gives_is_the_firmwares():
    from roboray.firmware import failsafe
    from roboray.shared.param_defs import PARAMS as DEFS

    declared = {p[0]: p for p in tuple(DEFS) + tuple(failsafe.PARAMS)}
    safety = " ".join(_section("Electrical safety").split())
    assert "`BATT_LOW_VOLT` (default %g V" % declared["BATT_LOW_VOLT"][2] in safety
    assert "`BATT_PARK` 1, the default" in safety and declared["BATT_PARK"][2] == 1
    assert failsafe._PARKED in safety


def test_the_endurance_sum_adds_up():
    section = _section("Endurance, resting on the bottom and recovery")
    rows = _table(section)
    volts = {"5 V": 5.0, "3.3 V": 5.0, "6 V": 6.0}     # the 3.3 V loads come off the 5 V rail
    logic = servo = 0.0
    divider = None
    for consumer, rail, current, _ in rows:
        ma = float(current.split()[0])
        if rail == "pack":
            divider = ma
        elif rail == "6 V":
            servo += ma
        else:
            logic += ma * volts[rail] / 5.0
    assert divider == pytest.approx(8.4 / 30.0, abs=0.005)
    watts = (5.0 * logic + 6.0 * servo) / 1000.0 / 0.8 + 7.2 * divider / 1000.0
    text = " ".join(section.split())
    assert "5 V x (40 + 19 + 0.55 + 1 + 1.25 + 1) mA = %.3f W" % (5.0 * logic / 1000.0) in text
    assert "**%.3f W, %.0f mA from the pack at 7.2 V**" % (watts, 1000 * watts / 7.2) in text
    amps = watts / 7.2
    assert "**%.0f h** to empty" % (3.5 / amps) in text and "**%.0f h** to `BATT_LOW_VOLT`" % (0.85 * 3.5 / amps) in text


def test_the_dome_seal_the_page_gives_is_the_drawings():
    from roboray.sim import drawing

    text = " ".join(_section("Mechanics").split())
    inner, outer = drawing.groove()
    assert "**AS568-041** (ID %.2f mm, cross-section %.2f mm" % (drawing.ORING_ID_MM, drawing.ORING_CS_MM) in text
    assert "the drawing: %.2f mm, so %.0f %% squeeze" % (
        drawing.GROOVE_DEPTH_MM, 100 * (drawing.ORING_CS_MM - drawing.GROOVE_DEPTH_MM) / drawing.ORING_CS_MM) in text
    assert "its outside %.2f mm" % outer in text and "the ring's, %.2f mm" % inner in text
    fill = math.pi * (drawing.ORING_CS_MM / 2) ** 2 / (drawing.GROOVE_DEPTH_MM * drawing.GROOVE_WIDTH_MM)
    assert "the ring fills %.0f %% of the groove" % (100 * fill) in text
    assert "on a %g mm circle" % (2 * (50 + drawing.FLANGE_MM + drawing.CLAMP_SCREW_GAP_MM)) in text
