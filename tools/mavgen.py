"""Generate the board's MAVLink message table from pymavlink's ``common.xml``
(and its ``development.xml``, for the few messages only it defines yet).

The board has no XML parser and no room for pymavlink's 17,000-line dialect,
so this tool writes ``shared/mavlink/messages.py``: for each message the
vehicle uses, its id, CRC_EXTRA, wire lengths, ``struct`` format (fields in
wire order) and field names, plus the enum values the endpoint needs. The
generated file is committed; ``tests/test_mavlink_codec.py`` regenerates it and
compares, so a pymavlink upgrade that changes a message cannot slip by.

Wire order and CRC_EXTRA follow the MAVLink specification
(mavlink.io, "Serialization" and "CRC_EXTRA calculation"): base fields sorted
by element size, largest first, stable; extension fields appended in XML
order; CRC_EXTRA is the X.25 CRC of the message name and each base field's
type, name and array length, folded to one byte.

Message ids 0-255 have three bytes each in ``WIRE``, indexed by id; the
few above 255 (``WIRE_HIGH`` lists them, three bytes an id) follow, in
that order, then three zeros, and ``wire_high(msgid)`` finds an id's place
without allocating (the zeros' for an id it lacks, so the callers test one
byte, as for an id below 256).

Run: ``python -m roboray.tools.mavgen [--check] [--out PATH]``.
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Optional, Sequence

#: Messages the vehicle sends or understands (issue 8), in id order after generation.
MESSAGES = (
    "HEARTBEAT", "SYS_STATUS", "SYSTEM_TIME", "ATTITUDE", "ATTITUDE_QUATERNION",
    "LOCAL_POSITION_NED", "LOCAL_POSITION_NED_COV", "SCALED_PRESSURE", "SCALED_IMU", "SERVO_OUTPUT_RAW",
    "BATTERY_STATUS", "STATUSTEXT", "NAMED_VALUE_FLOAT", "NAMED_VALUE_INT", "PARAM_REQUEST_LIST",
    "PARAM_REQUEST_READ", "PARAM_SET", "PARAM_VALUE", "COMMAND_LONG", "COMMAND_ACK",
    "SET_POSITION_TARGET_LOCAL_NED", "POSITION_TARGET_LOCAL_NED", "ATT_POS_MOCAP",
    "TIMESYNC", "RADIO_STATUS", "SETUP_SIGNING",
    # the handshake a ground station opens with (issue 17)
    "SET_MODE", "REQUEST_DATA_STREAM", "COMMAND_INT", "AUTOPILOT_VERSION", "HOME_POSITION",
    # the landing target as a one-item mission (issue 17)
    "MISSION_REQUEST_LIST", "MISSION_COUNT", "MISSION_REQUEST_INT", "MISSION_REQUEST",
    "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_ACK", "MISSION_CLEAR_ALL", "MISSION_CURRENT",
    "MISSION_SET_CURRENT", "MISSION_ITEM_REACHED",
    # the on-board flight log's download (issue 18)
    "LOG_REQUEST_LIST", "LOG_ENTRY", "LOG_REQUEST_DATA", "LOG_DATA", "LOG_ERASE", "LOG_REQUEST_END",
    # the standard modes protocol (issue 17), in development.xml only
    "AVAILABLE_MODES", "CURRENT_MODE",
    # MAVLink FTP, answered with a refusal: no files served (shared/mavlink/ftp.py)
    "FILE_TRANSFER_PROTOCOL",
)

#: Messages taken from ``development.xml`` (which includes common.xml): not
#: in common.xml yet. Every other message comes from common.xml, so a
#: development change to a common message cannot slip in.
DEVELOPMENT = ("AVAILABLE_MODES", "CURRENT_MODE")

#: Message ids indexed directly in ``WIRE`` (0-255); higher ones are listed
#: in ``WIRE_HIGH``.
WIRE_DENSE = 256

#: Enum entries the endpoint and the ground station use, by enum name.
ENUMS = {
    "MAV_TYPE": ("MAV_TYPE_SUBMARINE", "MAV_TYPE_GCS"),
    "MAV_AUTOPILOT": ("MAV_AUTOPILOT_GENERIC", "MAV_AUTOPILOT_INVALID"),
    "MAV_COMPONENT": ("MAV_COMP_ID_AUTOPILOT1",),
    "MAV_MODE_FLAG": None,
    "MAV_STATE": None,
    "MAV_RESULT": None,
    "MAV_PARAM_TYPE": None,
    "MAV_SEVERITY": None,
    "MAV_FRAME": ("MAV_FRAME_GLOBAL", "MAV_FRAME_LOCAL_NED", "MAV_FRAME_GLOBAL_RELATIVE_ALT",
                  "MAV_FRAME_GLOBAL_INT", "MAV_FRAME_GLOBAL_RELATIVE_ALT_INT", "MAV_FRAME_LOCAL_OFFSET_NED"),
    "MAV_MISSION_RESULT": None,
    "MAV_MISSION_TYPE": ("MAV_MISSION_TYPE_MISSION", "MAV_MISSION_TYPE_FENCE", "MAV_MISSION_TYPE_RALLY",
                         "MAV_MISSION_TYPE_ALL"),
    "MAV_CMD": (
        "MAV_CMD_COMPONENT_ARM_DISARM", "MAV_CMD_DO_SET_MODE", "MAV_CMD_DO_REPOSITION",
        "MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN", "MAV_CMD_SET_MESSAGE_INTERVAL",
        "MAV_CMD_REQUEST_MESSAGE", "MAV_CMD_GET_HOME_POSITION", "MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES",
        "MAV_CMD_NAV_WAYPOINT", "MAV_CMD_NAV_LAND", "MAV_CMD_DO_SET_MISSION_CURRENT",
        "MAV_CMD_DO_SET_STANDARD_MODE",
    ),
    "MAV_STANDARD_MODE": ("MAV_STANDARD_MODE_NON_STANDARD", "MAV_STANDARD_MODE_MISSION"),
    "MAV_PROTOCOL_CAPABILITY": (
        "MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT", "MAV_PROTOCOL_CAPABILITY_COMMAND_INT",
        "MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED", "MAV_PROTOCOL_CAPABILITY_MAVLINK2",
        "MAV_PROTOCOL_CAPABILITY_MISSION_INT", "MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT",
    ),
    "MAV_SYS_STATUS_SENSOR": ("MAV_SYS_STATUS_GEOFENCE",),
    "MAV_DATA_STREAM": (
        "MAV_DATA_STREAM_ALL", "MAV_DATA_STREAM_RAW_SENSORS", "MAV_DATA_STREAM_EXTENDED_STATUS",
        "MAV_DATA_STREAM_RC_CHANNELS", "MAV_DATA_STREAM_POSITION", "MAV_DATA_STREAM_EXTRA1",
        "MAV_DATA_STREAM_EXTRA3",
    ),
    "MAV_ESTIMATOR_TYPE": ("MAV_ESTIMATOR_TYPE_AUTOPILOT",),
    "FIRMWARE_VERSION_TYPE": ("FIRMWARE_VERSION_TYPE_DEV", "FIRMWARE_VERSION_TYPE_OFFICIAL"),
}

_TYPES = {  # MAVLink type -> (struct code, size in bytes)
    "char": ("s", 1), "uint8_t": ("B", 1), "int8_t": ("b", 1),
    "uint16_t": ("H", 2), "int16_t": ("h", 2), "uint32_t": ("I", 4), "int32_t": ("i", 4),
    "uint64_t": ("Q", 8), "int64_t": ("q", 8), "float": ("f", 4), "double": ("d", 8),
}


def default_xml() -> Path:
    """``common.xml`` inside the installed pymavlink (message_definitions or dialects/v20)."""
    import pymavlink

    root = Path(pymavlink.__file__).parent
    for rel in ("message_definitions/v1.0/common.xml", "dialects/v20/common.xml"):
        if (root / rel).is_file():
            return root / rel
    raise FileNotFoundError("no common.xml under %s" % root)


def development_xml(xml: Path) -> Path:
    """``development.xml`` beside ``xml`` (pymavlink ships both in one folder)."""
    return xml.with_name("development.xml")


def default_out() -> Path:
    return Path(__file__).resolve().parent.parent / "shared" / "mavlink" / "messages.py"


def x25(data: bytes, crc: int = 0xFFFF) -> int:
    for b in data:
        tmp = (b ^ crc) & 0xFF
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


class Field:
    def __init__(self, name: str, xml_type: str, extension: bool) -> None:
        self.name = name
        self.extension = extension
        self.array = 0
        base = xml_type
        if "[" in xml_type:
            base, n = xml_type.rstrip("]").split("[")
            self.array = int(n)
        if base == "uint8_t_mavlink_version":  # HEARTBEAT.mavlink_version, a uint8_t on the wire
            base = "uint8_t"
        if base not in _TYPES:
            raise ValueError("field %s: unknown MAVLink type %r" % (name, xml_type))
        self.type = base
        self.code, self.size = _TYPES[base]

    @property
    def fmt(self) -> str:
        if self.type == "char":
            return "%ds" % max(self.array, 1)
        return ("%d%s" % (self.array, self.code)) if self.array else self.code

    @property
    def wire_len(self) -> int:
        return self.size * max(self.array, 1)


class Message:
    def __init__(self, node: ET.Element) -> None:
        self.name = node.get("name", "")
        self.id = int(node.get("id", "-1"))
        fields = []
        extension = False
        for child in node:
            if child.tag == "extensions":
                extension = True
            elif child.tag == "field":
                fields.append(Field(child.get("name", ""), child.get("type", ""), extension))
        base = [f for f in fields if not f.extension]
        # Stable sort by element size: the wire order (mavlink.io serialization).
        self.wire = sorted(base, key=lambda f: f.size, reverse=True) + [f for f in fields if f.extension]
        self.min_len = sum(f.wire_len for f in base)
        self.max_len = sum(f.wire_len for f in self.wire)
        crc = x25((self.name + " ").encode())
        for f in sorted(base, key=lambda f: f.size, reverse=True):
            crc = x25((f.type + " ").encode(), crc)
            crc = x25((f.name + " ").encode(), crc)
            if f.array:
                crc = x25(bytes([f.array]), crc)
        self.crc_extra = (crc & 0xFF) ^ (crc >> 8)

    @property
    def fmt(self) -> str:
        return "<" + "".join(f.fmt for f in self.wire)


def load(path: Path, seen: Optional[set] = None) -> tuple[dict, dict]:
    """Messages and enums of ``path`` and the files it includes."""
    seen = set() if seen is None else seen
    path = path.resolve()
    if path in seen:
        return {}, {}
    seen.add(path)
    root = ET.parse(path).getroot()
    messages: dict = {}
    enums: dict = {}
    for inc in root.findall("include"):
        m, e = load(path.parent / (inc.text or "").strip(), seen)
        messages.update(m)
        for k, v in e.items():
            enums.setdefault(k, {}).update(v)
    for node in root.iter("message"):
        msg = Message(node)
        messages[msg.name] = msg
    for node in root.iter("enum"):
        entries = enums.setdefault(node.get("name", ""), {})
        value = -1
        for entry in node.findall("entry"):
            v = entry.get("value")
            value = int(v, 0) if v is not None else value + 1
            entries[entry.get("name", "")] = value
    return messages, enums


def load_chosen(xml: Path) -> tuple[list, dict]:
    """The messages of ``MESSAGES`` (``DEVELOPMENT``'s from development.xml,
    the rest from ``xml``) in id order, and the enums of both."""
    messages, enums = load(xml)
    dev_messages, dev_enums = load(development_xml(xml)) if DEVELOPMENT else ({}, {})
    for k, v in dev_enums.items():
        for name, value in v.items():
            enums.setdefault(k, {}).setdefault(name, value)
    pick = {}
    for n in MESSAGES:
        source = dev_messages if n in DEVELOPMENT else messages
        if n in source:
            pick[n] = source[n]
    missing = [n for n in MESSAGES if n not in pick]
    if missing:
        raise ValueError("%s lacks messages %s" % (xml.name, ", ".join(missing)))
    return sorted(pick.values(), key=lambda m: m.id), enums


def generate(xml: Path) -> str:
    chosen, enums = load_chosen(xml)
    high = [m for m in chosen if m.id >= WIRE_DENSE]
    out = [
        '"""MAVLink message table: GENERATED by tools/mavgen.py from pymavlink\'s',
        "common.xml (%s) and development.xml (%s)." % (xml.name, ", ".join(DEVELOPMENT)),
        "Do not edit; regenerate with ``python -m roboray.tools.mavgen``.",
        "",
        "The board's table is ``WIRE``, one bytes constant, three bytes a message:",
        "``WIRE[w + WIRE_CRC_EXTRA]`` its CRC_EXTRA, ``WIRE[w + WIRE_MIN_LEN]`` its",
        "MAVLink 1 payload (base fields), ``WIRE[w + WIRE_MAX_LEN]`` its MAVLink 2",
        "payload (with extensions), 0 for an unknown id. ``w`` is ``3 * m`` for an",
        "id ``m`` below ``WIRE_DENSE``, ``wire_high(m)`` above: the few ids above",
        "255 are listed in ``WIRE_HIGH`` (three bytes each, little-endian), their",
        "three bytes follow the dense part in that order, then three zeros, where",
        "``wire_high`` points for an id it lacks; so a high id costs six bytes, not",
        "three times its value, and every caller tests one byte. A bytes constant is",
        "one object with no children for the collector, and from the ROMFS",
        "partition its data stays in flash (the tuples of names and formats it",
        "replaces were 140 objects on the heap and overflowed the collector's",
        "64-entry mark stack). ``<NAME>_FMT`` and ``<NAME>_LEN`` serve the encoders.",
        "",
        "The host's ``TABLE`` (names, formats, fields) is in ``table.py`` (not",
        "imported on the board); ``messages.TABLE`` reaches it on CPython.",
        '"""',
        "",
        "try:",
        "    from micropython import const",
        "except ImportError:  # CPython",
        "    def const(x):",
        "        return x",
        "",
        "# Indices into a TABLE entry (host side, table.py)",
        "NAME = const(0)",
        "CRC_EXTRA = const(1)",
        "MIN_LEN = const(2)",
        "MAX_LEN = const(3)",
        "FMT = const(4)",
        "FIELDS = const(5)",
        "ARRAYS = const(6)",
        "",
        "# Offsets into a message id's three WIRE bytes",
        "WIRE_CRC_EXTRA = const(0)",
        "WIRE_MIN_LEN = const(1)",
        "WIRE_MAX_LEN = const(2)",
        "#: Message ids WIRE indexes directly (0 to WIRE_DENSE - 1)",
        "WIRE_DENSE = const(%d)" % WIRE_DENSE,
        "",
        "# Message ids",
    ]
    for m in chosen:
        out.append("MSG_%s = const(%d)" % (m.name, m.id))
    out += ["", "# Wire formats (little-endian, wire order) and full payload lengths"]
    for m in chosen:
        out.append('%s_FMT = "%s"' % (m.name, m.fmt))
        out.append("%s_LEN = const(%d)" % (m.name, m.max_len))
    wire = bytearray(3 * (WIRE_DENSE + len(high) + 1))   # (the last three: an unknown id's)
    ids = bytearray()
    for m in chosen:
        if not 0 <= m.id < 1 << 24 or not 0 < m.max_len < 256:
            raise ValueError("%s: id %d / length %d do not fit WIRE" % (m.name, m.id, m.max_len))
        w = 3 * m.id if m.id < WIRE_DENSE else 3 * (WIRE_DENSE + len(ids) // 3)
        if m.id >= WIRE_DENSE:
            ids += m.id.to_bytes(3, "little")
        wire[w:w + 3] = bytes((m.crc_extra, m.min_len, m.max_len))
    out += ["", "# CRC_EXTRA, MAVLink 1 and MAVLink 2 payload lengths of message ids 0-%d" % (WIRE_DENSE - 1),
            "# (three zeros: unknown), then of WIRE_HIGH's ids (%s), then three zeros"
            % ", ".join(str(m.id) for m in high),
            "WIRE = ("]
    for k in range(0, len(wire), 48):
        out.append('    b"%s"' % "".join("\\x%02x" % b for b in wire[k:k + 48]))
    out += [")", "#: The ids above 255 WIRE holds, three bytes each (little-endian)",
            'WIRE_HIGH = b"%s"' % "".join("\\x%02x" % b for b in ids), "", "",
            "def wire_high(msgid):",
            '    """Where an id above 255 has its three bytes in ``WIRE``; the last',
            '    three, zeros, for an id it lacks (or a negative one)."""',
            "    h = WIRE_HIGH",
            "    k = 0",
            "    n = len(h)",
            "    while k < n:",
            "        if h[k] | (h[k + 1] << 8) | (h[k + 2] << 16) == msgid:",
            "            break",
            "        k += 3",
            "    return %d + k" % (3 * WIRE_DENSE),
            "", "",
            "def __getattr__(name):",
            '    """``TABLE`` (host side): the full table, from ``table.py``."""',
            '    if name == "TABLE":',
            "        from roboray.shared.mavlink.table import TABLE",
            "        return TABLE",
            "    raise AttributeError(name)",
            ""]
    for enum, names in ENUMS.items():
        entries = enums[enum]
        wanted = names if names is not None else tuple(k for k in entries if not k.endswith("_ENUM_END"))
        out.append("# %s" % enum)
        for n in wanted:
            out.append("%s = const(%d)" % (n, entries[n]))
        out.append("")
    return "\n".join(out)


def generate_table(xml: Path) -> str:
    """``table.py``: the host's full table (names, formats, fields)."""
    chosen, _ = load_chosen(xml)
    out = [
        '"""MAVLink message table for host tools: GENERATED by tools/mavgen.py from',
        "pymavlink's common.xml (%s) and development.xml (%s)." % (xml.name, ", ".join(DEVELOPMENT)),
        "Do not edit; regenerate with ``python -m roboray.tools.mavgen``.",
        "",
        "``TABLE[msgid]`` is ``(name, crc_extra, min_len, max_len, fmt, fields, arrays)``:",
        "``min_len`` is the MAVLink 1 payload (base fields), ``max_len`` MAVLink 2's",
        "(with extensions); ``fmt`` unpacks a ``max_len`` payload in wire order into",
        "the values of ``fields`` (an array of N numbers is N values, a char array",
        "one bytes value); ``arrays[i]`` is field i's array length, 0 for a scalar or",
        "a char array. The board does not import this module (its table is",
        "``messages.WIRE``); ``messages.TABLE`` is this one.",
        '"""',
        "",
        "from roboray.shared.mavlink import messages as _m",
        "",
        "TABLE = {",
    ]
    for m in chosen:
        names = ", ".join('"%s"' % f.name for f in m.wire)
        arrays = ", ".join(str(f.array if f.type != "char" else 0) for f in m.wire)
        out.append('    %d: ("%s", %d, %d, %d, _m.%s_FMT, (%s,), (%s,)),' % (
            m.id, m.name, m.crc_extra, m.min_len, m.max_len, m.name, names, arrays))
    out += ["}", ""]
    return "\n".join(out)


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="mavgen", description=__doc__.splitlines()[0])
    p.add_argument("--xml", type=Path, default=None, help="common.xml (default: pymavlink's)")
    p.add_argument("--out", type=Path, default=None, help="output (default shared/mavlink/messages.py)")
    p.add_argument("--check", action="store_true", help="exit 1 if the committed file differs")
    args = p.parse_args(argv)
    xml = args.xml or default_xml()
    out = args.out or default_out()
    outputs = [(out, generate(xml)), (out.with_name("table.py"), generate_table(xml))]
    if args.check:
        status = 0
        for path, text in outputs:
            same = path.is_file() and path.read_text() == text
            sys.stdout.write("%s: %s\n" % (path, "up to date" if same else "differs from the generator"))
            status = status or (0 if same else 1)
        return status
    for path, text in outputs:
        tmp = path.with_suffix(".py.tmp")
        tmp.write_text(text)
        tmp.replace(path)
        sys.stdout.write("wrote %s (%d messages)\n" % (path, len(MESSAGES)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
