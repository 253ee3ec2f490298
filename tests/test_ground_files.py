"""Parameter files and tlogs: the formats other tools write, and damaged input."""

from __future__ import annotations

import struct

import pytest
from pymavlink.dialects.v20 import common as pm

from roboray.ground import paramfile, tlog


def test_param_file_reads_ardupilot_and_mission_planner_forms():
    text = "# saved by MAVProxy\nFS_GCS_ENABLE 1\nFS_GCS_TIMEOUT\t7.5  # seconds\n\nSR_ATTITUDE,10\n"
    assert paramfile.parse(text) == {"FS_GCS_ENABLE": 1.0, "FS_GCS_TIMEOUT": 7.5, "SR_ATTITUDE": 10.0}


@pytest.mark.parametrize("line,message", [
    ("FS_GCS_ENABLE", "expected NAME VALUE"),
    ("FS_GCS_ENABLE one", "has value 'one', not a number"),
    ("FS_GCS_ENABLE nan", "not a finite number"),
    ("BAD-NAME 1", "is not a parameter name"),
    ("A 1 2", "expected NAME VALUE"),
])
def test_param_file_errors_name_file_and_line(line, message):
    with pytest.raises(paramfile.ParamFileError) as info:
        paramfile.parse("X 1\n" + line + "\n", "vehicle.parm")
    assert str(info.value).startswith("vehicle.parm:2: ") and message in str(info.value)


def test_param_file_save_is_atomic_and_round_trips(tmp_path):
    f = tmp_path / "p.parm"
    paramfile.save(str(f), [("A_PARAM", "1"), ("B", "2.5")])
    assert f.read_text() == "A_PARAM          1\nB                2.5\n"
    assert paramfile.load(str(f)) == {"A_PARAM": 1.0, "B": 2.5}
    assert not list(tmp_path.glob("*.tmp"))


def _f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def test_values_are_written_so_that_they_read_back_to_the_same_float32(tmp_path):
    from roboray.ground.link import fmt_value

    # the shortest text that is the same float32, as Python writes it; integers without a point
    assert [fmt_value(_f32(x), 9) for x in (0.1, 6.6, -0.0029, 4.0, 101325.0, 1e-7)] == [
        "0.1", "6.6", "-0.0029", "4.0", "101325.0", "1e-07"]
    assert (fmt_value(57600.0, 6), fmt_value(-3.0, 4), fmt_value(1.5, 1)) == ("57600", "-3", "1.5")
    # the issue's case: 7 significant digits lose these two float32s' difference
    a, b = _f32(0.1), _f32(0.100000009)
    assert a != b and "%.7g" % a == "%.7g" % b and fmt_value(a, 9) != fmt_value(b, 9)
    # every float32 of a sweep across the exponents survives a save and a load
    values = [struct.unpack("<f", struct.pack("<I", bits))[0] for bits in range(0x00800001, 0x7F000000, 0x7F3A1)]
    values += [-v for v in values[::7]]
    named = {"P%d" % i: v for i, v in enumerate(values)}
    f = tmp_path / "sweep.parm"
    paramfile.save(str(f), ((k, fmt_value(v, 9)) for k, v in named.items()))
    back = paramfile.load(str(f))
    assert {k: _f32(v) for k, v in back.items()} == named
    # and a file written from what was read is the same file, byte for byte
    g = tmp_path / "again.parm"
    paramfile.save(str(g), ((k, fmt_value(_f32(v), 9)) for k, v in back.items()))
    assert g.read_bytes() == f.read_bytes()


def test_pdef_is_ardupilots_apm_pdef_xml_for_every_firmware_parameter():
    import xml.etree.ElementTree as ET

    from roboray.firmware.app import PARAMS
    from roboray.shared.param_meta import META, UNITS

    text = paramfile.pdef_xml(PARAMS, META, UNITS)
    assert text.startswith('<?xml version="1.0" encoding="utf-8"?>\n<!-- ')
    root = ET.fromstring(text)
    assert root.tag == "paramfile" and [c.tag for c in root] == ["vehicles", "libraries"]
    group = root.find("vehicles/parameters")
    assert group is not None and group.get("name") == "RoboRay"
    params = {p.get("name"): p for p in group.findall("param")}
    assert list(params) == ["RoboRay:" + d[0] for d in PARAMS]
    for p in params.values():
        assert p.get("humanName") and p.get("documentation") and p.get("user") in ("Standard", "Advanced")
    fields = {f.get("name"): f.text for f in params["RoboRay:FS_GCS_TIMEOUT"].findall("field")}
    assert fields == {"Range": "1.0 120.0", "Units": "s", "UnitText": "seconds"}
    act = params["RoboRay:FS_LEAK_ENABLE"]
    assert [(v.get("code"), v.text) for v in act.findall("values/value")] == [
        ("0", "Off"), ("1", "Warn"), ("2", "Disarm"), ("3", "FAILSAFE mode")]
    assert {f.get("name"): f.text for f in act.findall("field")} == {"Range": "0 3"}
    baud = {f.get("name"): f.text for f in params["RoboRay:SERIAL_BAUD"].findall("field")}
    assert baud == {"Range": "1200 921600", "ReadOnly": "True"}


def _tlog(n: int) -> tuple[bytes, list[bytes]]:
    mav = pm.MAVLink(None, 1, 1)
    frames = [pm.MAVLink_attitude_message(i, 0.1 * i, 0.0, 0.0, 0.0, 0.0, 0.0).pack(mav) for i in range(n)]
    t0 = 1_700_000_000_000_000
    data = b"".join(struct.pack(">Q", t0 + 10_000 * i) + f for i, f in enumerate(frames))
    return data, frames


def test_tlog_records_resynchronise_over_damage():
    data, frames = _tlog(30)
    start = [sum(8 + len(f) for f in frames[:i]) for i in range(len(frames) + 1)]
    # record 5 cut short, then garbage, then record 6 on; the last record cut at the end
    damaged = data[:start[5] + 11] + b"\x00\x13garbage" + data[start[6]:-7]
    got = [f for _, f in tlog.records(damaged)]
    assert frames[:5] + frames[6:29] == got


def test_tlog_decoder_reports_crc_and_fields():
    data, frames = _tlog(2)
    dec = tlog.Decoder()
    m = dec.decode(frames[1])
    assert m["mavpackettype"] == "ATTITUDE" and m["roll"] == pytest.approx(0.1) and m["crc_ok"] is True
    bad = bytearray(frames[1])
    bad[12] ^= 0x40
    m = dec.decode(bytes(bad))
    assert m["mavpackettype"] == "ATTITUDE" and m["crc_ok"] is False
    assert dec.decode(b"\xfd\x01\x00\x00\x00\x01\x01\x99\x99\x99\x00\x00\x00")["mavpackettype"].startswith("UNKNOWN_")


def test_param_file_lists_every_problem_at_once(tmp_path):
    with pytest.raises(paramfile.ParamFileError) as info:
        paramfile.parse("A 1\nB x\nA 2\nC\n", "f.parm")
    assert info.value.problems == ["f.parm:2: B has value 'x', not a number",
                                   "f.parm:3: A is given twice (first on line 1)",
                                   "f.parm:4: expected NAME VALUE, got 'C'"]
    assert str(info.value).startswith("3 problems:")


@pytest.mark.parametrize("data,message", [
    (b"A 1\n\x00\x01", "a NUL byte at offset 4: a binary file"),
    (b"A 1\nB \xff\n", "f.parm:2: byte 0xff at offset 6 is not UTF-8 text"),
    (b"A 1\n" * 70000, "280000 bytes; a parameter file is at most 262144"),
])
def test_param_file_that_is_not_text_or_too_large_is_refused(tmp_path, data, message):
    f = tmp_path / "f.parm"
    f.write_bytes(data)
    with pytest.raises(paramfile.ParamFileError) as info:
        paramfile.load(str(f))
    assert message in str(info.value)


def test_tlog_records_count_the_damage_they_skip():
    data, frames = _tlog(10)
    start = [sum(8 + len(f) for f in frames[:i]) for i in range(len(frames) + 1)]
    damage = tlog.Damage()
    got = [f for _, f in tlog.records(data[:start[3] + 5] + data[start[4]:-3], damage)]
    assert got == frames[:3] + frames[4:9]
    assert (damage.stretches, damage.cut_at, damage.skipped_bytes) == (2, start[9] - (8 + len(frames[3])) + 5, 5 + 8 + len(frames[9]) - 3)
    clean = tlog.Damage()
    assert len(list(tlog.records(data, clean))) == 10 and clean.describe("x", 10) == ""
