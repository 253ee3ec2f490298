"""ArduPilot's parameter file format, so files move between tools.

One parameter a line: ``NAME VALUE`` (spaces or tabs) or ``NAME,VALUE``
(Mission Planner); ``#`` starts a comment; blank lines are ignored. We
write ``NAME VALUE`` padded to a column, as MAVProxy's ``param save`` does.

A file is read whole and checked whole before anything uses it: its size,
its encoding, every line, names given twice. Every problem is reported at
once (``ParamFileError.problems``), each with its file and line, so one
edit fixes them all; a caller applies nothing unless the file is good.
"""

from __future__ import annotations

import math
import os
import re
from typing import Iterable, Optional

_NAME = re.compile(r"^[A-Za-z0-9_]{1,16}$")

#: The largest file read. ArduPilot's full list (~1,200 parameters) is
#: ~40 kB as text and ours ~2 kB: anything past this is not a parameter
#: file, and reading it whole would cost memory for nothing.
MAX_BYTES = 256 * 1024

#: Problems listed before the rest are only counted.
MAX_LISTED = 20


class ParamFileError(ValueError):
    """A file that cannot be used; ``problems`` lists each bad line (file:line: why)."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        shown = self.problems[:MAX_LISTED]
        more = len(self.problems) - len(shown)
        text = shown[0] if len(shown) == 1 else "%d problems:\n  %s" % (len(self.problems), "\n  ".join(shown))
        if more > 0:
            text += "\n  ... and %d more" % more
        super().__init__(text)


def parse_lines(text: str, source: str = "<text>") -> tuple[dict[str, float], dict[str, int], list[str]]:
    """``(values, line of each name, problems)``: the good lines and what is wrong with the others.

    Names are upper-cased, as the vehicle's are (``param set`` does the
    same). A name given twice is a problem on its second line, whether or
    not the values agree: which one was meant cannot be known.
    """
    values: dict[str, float] = {}
    where: dict[str, int] = {}
    problems: list[str] = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        at = "%s:%d: " % (source, lineno)
        parts = [p for p in re.split(r"[,\s]+", line) if p]
        if len(parts) != 2:
            problems.append(at + "expected NAME VALUE, got %r" % raw.strip()[:60])
            continue
        name, text_value = parts
        if not _NAME.match(name):
            problems.append(at + "%r is not a parameter name" % name[:40])
            continue
        name = name.upper()
        try:
            value = float(text_value)
        except ValueError:
            problems.append(at + "%s has value %r, not a number" % (name, text_value[:40]))
            continue
        if not math.isfinite(value):
            problems.append(at + "%s has value %r, not a finite number" % (name, text_value))
            continue
        if name in where:
            problems.append(at + "%s is given twice (first on line %d)" % (name, where[name]))
            continue
        values[name] = value
        where[name] = lineno
    return values, where, problems


def parse(text: str, source: str = "<text>") -> dict[str, float]:
    """The file's parameters; ``ParamFileError`` listing every bad line if any."""
    values, _, problems = parse_lines(text, source)
    if problems:
        raise ParamFileError(problems)
    return values


def read_text(path: str) -> str:
    """The file's text, refused whole when too large or not UTF-8 text."""
    try:
        size = os.stat(path).st_size
    except OSError as exc:
        raise ParamFileError(["%s: %s" % (path, exc.strerror or exc)])
    if size > MAX_BYTES:
        raise ParamFileError(["%s: %d bytes; a parameter file is at most %d (is this the right file?)"
                              % (path, size, MAX_BYTES)])
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ParamFileError(["%s: %s" % (path, exc.strerror or exc)])
    if len(data) > MAX_BYTES:   # grew since the stat
        raise ParamFileError(["%s: more than %d bytes; not a parameter file" % (path, MAX_BYTES)])
    nul = data.find(b"\x00")
    if nul >= 0:
        raise ParamFileError(["%s: a NUL byte at offset %d: a binary file, not a parameter file" % (path, nul)])
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ParamFileError(["%s:%d: byte 0x%02x at offset %d is not UTF-8 text: not a parameter file"
                              % (path, data.count(b"\n", 0, exc.start) + 1, data[exc.start], exc.start)])


def load(path: str) -> dict[str, float]:
    return parse(read_text(path), path)


def load_lines(path: str) -> tuple[dict[str, float], dict[str, int], list[str]]:
    """``parse_lines`` of a file (size and encoding problems still raise)."""
    return parse_lines(read_text(path), path)


def format_lines(values: Iterable[tuple[str, str]]) -> str:
    return "".join("%-16s %s\n" % (name, value) for name, value in values)


def save(path: str, values: Iterable[tuple[str, str]]) -> None:
    """Write atomically: a temporary file, flushed to the disk, renamed over the target."""
    text = format_lines(values)
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def pdef_xml(decls: Iterable[tuple], meta: dict, units: dict, vehicle: str = "RoboRay") -> str:
    """The parameters' documentation in ArduPilot's ``apm.pdef.xml`` form.

    As ``Tools/autotest/param_metadata/param_parse.py`` writes it, so
    ground stations that read ArduPilot's (Mission Planner, QGroundControl,
    MAVProxy) read ours: ``<paramfile><vehicles><parameters name=VEHICLE>``,
    one ``<param humanName name="VEHICLE:NAME" documentation user>`` a
    parameter with ``<field>`` children (``Range``, ``Units``, ``UnitText``,
    ``ReadOnly``) and ``<values><value code>``; ``<libraries/>`` stays
    empty. ``decls``: the firmware's declarations (range, read-only);
    ``meta``: ``shared/param_meta.py``'s ``META``; ``units``: its ``UNITS``."""
    import xml.etree.ElementTree as ET

    from roboray.ground.link import fmt_value

    root = ET.Element("paramfile")
    vehicles = ET.SubElement(root, "vehicles")
    group = ET.SubElement(vehicles, "parameters", name=vehicle)
    for d in decls:
        name, ptype, lo, hi = d[0], d[1], d[3], d[4]
        display, unit, description, values, user = meta[name]
        p = ET.SubElement(group, "param", humanName=display, name="%s:%s" % (vehicle, name),
                          documentation=description, user=user)
        ET.SubElement(p, "field", name="Range").text = "%s %s" % (fmt_value(lo, ptype), fmt_value(hi, ptype))
        if values:
            vs = ET.SubElement(p, "values")
            for code, label in values:
                ET.SubElement(vs, "value", code=str(code)).text = label
        if unit:
            ET.SubElement(p, "field", name="Units").text = unit
            ET.SubElement(p, "field", name="UnitText").text = units[unit]
        if len(d) > 5 and d[5] & 1:   # READ_ONLY (shared/params.py)
            ET.SubElement(p, "field", name="ReadOnly").text = "True"
    ET.SubElement(root, "libraries")
    ET.indent(root)
    return ('<?xml version="1.0" encoding="utf-8"?>\n'
            "<!-- Dynamically generated list of documented parameters (roboray-ground param pdef) -->\n"
            + ET.tostring(root, encoding="unicode") + "\n")


def check_value(name: str, value: float, ptype: int, decl: Optional[tuple]) -> Optional[str]:
    """Why ``value`` cannot be set on the vehicle's ``name`` (MAV_PARAM_TYPE ``ptype``), or None.

    ``decl``: the firmware's declaration ``(name, type, default, min, max[, flags])``
    when this ground station knows it (ranges and read-only live there;
    the vehicle checks again and refuses what it must)."""
    if ptype != 9 and not float(value).is_integer():   # 9: MAV_PARAM_TYPE_REAL32
        return "%s is an integer parameter; %r is not an integer" % (name, value)
    if decl is not None:
        lo, hi = decl[3], decl[4]
        if not lo <= value <= hi:
            return "%s = %g is out of range [%g, %g]" % (name, value, lo, hi)
        if len(decl) > 5 and decl[5] & 1:   # READ_ONLY (shared/params.py)
            return "%s is read-only on the vehicle" % name
    return None
