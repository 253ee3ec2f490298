"""The fix relay's reading of its sources: NMEA 0183 GGA (checksum, fields,
Water Linked's forms), latitude and longitude to metres, JSON lines and CSV
with a field map, and the source strings."""

from __future__ import annotations

import math

import pytest

from roboray.ground import nmea
from roboray.ground.fixes_formats import Decoder, Reject, parse_columns, parse_fields, unix_from_time_of_day
from roboray.ground.fixes_geo import Origin, parse_lat_lon
from roboray.ground.fixes_sources import parse_source

#: GGA sentences from a ship's GPS log as recorded (NOAA PSL, ATOMIC 2020
#: cruise, gps02004117_raw.txt): real checksums from a real receiver.
RECORDED = (
    "$GPGGA,170000.00,1420.39092235,N,05515.55719793,W,2,05,2.2,5.6,M,-41.0,M,5.0,0138*70",
    "$GPGGA,170001.00,1420.39085934,N,05515.55733233,W,2,05,2.2,7.2,M,-41.0,M,6.0,0138*7F",
    "$GPGGA,170002.00,1420.39086619,N,05515.55759378,W,2,05,2.2,7.9,M,-41.0,M,7.0,0138*77",
)


def test_recorded_sentences_pass_their_checksums_and_read_as_the_receiver_wrote_them():
    fixes = [nmea.gga(nmea.parse(line)) for line in RECORDED]
    g = fixes[0]
    assert g.time_of_day_s == 17 * 3600 and g.time_decimals == 2
    assert g.lat_deg == pytest.approx(14 + 20.39092235 / 60, abs=1e-12)
    assert g.lon_deg == pytest.approx(-(55 + 15.55719793 / 60), abs=1e-12)
    assert (g.quality, g.satellites, g.hdop, g.altitude_m) == (2, 5, 2.2, 5.6)
    assert [f.time_of_day_s for f in fixes] == [61200.0, 61201.0, 61202.0]


def test_a_damaged_sentence_fails_its_checksum_and_says_which():
    line = RECORDED[0].replace("1420.39092235", "1420.39092236")
    with pytest.raises(nmea.NmeaError) as e:
        nmea.parse(line)
    assert e.value.reason == "checksum" and "the sentence says 70" in str(e.value)
    with pytest.raises(nmea.NmeaError) as e:
        nmea.parse(RECORDED[0].split("*")[0])
    assert e.value.reason == "no_checksum"
    for bad in ("GPGGA,1,2*00", "$GPGGA,1*7", "$gpgga*%02X" % nmea.checksum("gpgga")):
        with pytest.raises(nmea.NmeaError) as e:
            nmea.parse(bad)
        assert e.value.reason == "malformed", bad


def test_water_linked_bridge_sentences():
    # ugps-nmea-go's GAGGA.Serialise: time with milliseconds, minutes
    # without the degrees' padding, 0 satellites, altitude always 0.00
    g = nmea.gga(nmea.parse(nmea.sentence("GPGGA,150405.250,6325.8,N,1023.706,E,1,0,,0.00,M,,M,,")))
    assert g.time_of_day_s == pytest.approx(15 * 3600 + 4 * 60 + 5.25) and g.time_decimals == 3
    assert g.lat_deg == pytest.approx(63.43) and g.lon_deg == pytest.approx(10 + 23.706 / 60)
    assert g.altitude_m == 0.0 and g.hdop is None
    # its "no position" sentence (quality 0, no latitude or longitude)
    with pytest.raises(nmea.NmeaError) as e:
        nmea.gga(nmea.parse(nmea.sentence("GPGGA,150405.000,,,,,0,0,,0.00,M,,M,,")))
    assert e.value.reason == "no_fix"
    # waterlinked/examples nmeaoutput.py: whole seconds, three decimals of minutes
    g = nmea.gga(nmea.parse(nmea.sentence("GPGGA,150405,6325.800,N,01023.706,E,1,00,0.0,0.0,M,0.0,M,,")))
    assert g.time_decimals == 0 and g.lon_deg == pytest.approx(10 + 23.706 / 60)


def test_bad_fields_are_malformed_with_the_field_named():
    for body, word in (("GPGGA,256100.00,6325.8,N,01023.7,E,1,5,1,0,M,,M,,", "time"),
                       ("GPGGA,150405.00,6375.8,N,01023.7,E,1,5,1,0,M,,M,,", "minutes"),
                       ("GPGGA,150405.00,9125.8,N,01023.7,E,1,5,1,0,M,,M,,", "latitude"),
                       ("GPGGA,150405.00,6325.8,X,01023.7,E,1,5,1,0,M,,M,,", "hemisphere"),
                       ("GPGGA,150405.00,6325.8,N,01023.7,E,1,5,1,deep,M,,M,,", "altitude"),
                       ("GPGGA,150405.00,6325.8,N", "fields")):
        with pytest.raises(nmea.NmeaError) as e:
            nmea.gga(nmea.parse(nmea.sentence(body)))
        assert e.value.reason == "malformed" and word in str(e.value), body


def test_utc_time_of_day_takes_the_date_nearest_the_arrival():
    day = 20454 * 86400.0      # 2026-01-01 00:00 UTC
    assert unix_from_time_of_day(3600.5, day + 3601.0) == day + 3600.5
    # a fix at 23:59:59.8 arriving at 00:00:00.1 the next day is from the day before
    assert unix_from_time_of_day(86399.8, day + 0.1) == pytest.approx(day - 0.2)
    assert unix_from_time_of_day(0.1, day - 0.2) == pytest.approx(day + 0.1)


def test_degrees_to_metres_as_the_ellipsoid_gives_them():
    # the meridian arc at the equator is 110,574 m a degree, a degree of
    # longitude there 111,320 m (WGS-84: a (1 - e^2) and a, times pi / 180)
    o = Origin(0.0, 30.0)
    north, east = o.north_east(0.01, 30.0)
    assert north == pytest.approx(1105.743, abs=0.002) and abs(east) < 1e-6
    north, east = o.north_east(0.0, 30.01)
    assert east == pytest.approx(1113.195, abs=0.002) and abs(north) < 1e-3
    # at 60 deg north a degree of longitude is N cos(lat): half the equator's, a little more
    a, e2 = 6378137.0, 0.00669437999014
    n60 = a / math.sqrt(1 - e2 * math.sin(math.radians(60)) ** 2)
    north, east = Origin(60.0, 5.0).north_east(60.0, 5.001)
    assert east == pytest.approx(n60 * 0.5 * math.radians(0.001), abs=1e-4)
    # south and west are negative
    north, east = Origin(-33.9, 18.4).north_east(-33.90001, 18.39999)
    assert north < 0 and east < 0


def test_the_first_fix_is_the_origin_unless_one_is_given():
    o = Origin()
    assert not o.known
    o.set_from(63.43, 10.39)
    o.set_from(64.0, 11.0)
    assert (o.lat_deg, o.lon_deg) == (63.43, 10.39) and o.north_east(63.43, 10.39) == (0.0, 0.0)
    assert parse_lat_lon(" -33.9 , 18.4") == (-33.9, 18.4)
    for bad in ("63.4", "91,0", "0,181", "a,b", "1,2,3"):
        with pytest.raises(ValueError):
            parse_lat_lon(bad)


def test_json_lines_with_the_default_names_and_a_field_map():
    d = Decoder("auto")
    r = d.decode('{"t": 1767225600.25, "north": 1.5, "east": -0.25, "down": 4.0}', 1767225600.4)
    assert (r.t_unix, r.north_m, r.east_m, r.down_m, r.lat_deg) == (1767225600.25, 1.5, -0.25, 4.0, None)
    r = d.decode('{"north": 1, "east": 2, "t": null}', 0.0)
    assert r.t_unix is None and r.down_m is None
    m = Decoder("json", parse_fields("t=stamp,north=-pose.y,east=pose.x,down=pose.z"))
    r = m.decode('{"stamp": 1767225600.0, "pose": {"x": 0.5, "y": 2.0, "z": 3.5}}', 0.0)
    assert (r.t_unix, r.north_m, r.east_m, r.down_m) == (1767225600.0, -2.0, 0.5, 3.5)


@pytest.mark.parametrize("line, reason", [
    ("{not json", "not_json"),
    ("[1, 2]", "not_json"),
    ('{"north": 1}', "missing"),
    ('{"north": "1", "east": 2}', "not_number"),
    ('{"north": true, "east": 2}', "not_number"),
    ('{"north": 1, "east": 2, "t": 12.5}', "t_clock"),
])
def test_bad_json_lines_are_rejected_by_reason(line, reason):
    with pytest.raises(Reject) as e:
        Decoder("json").decode(line, 0.0)
    assert e.value.reason == reason


def test_csv_with_a_header_columns_given_and_bad_rows():
    d = Decoder("csv")
    with pytest.raises(Reject) as e:
        d.decode("1767225600.0,1.0,2.0", 0.0)
    assert e.value.reason == "no_header"
    assert d.decode("east, t ,north", 0.0) is None and d.ignored["header"] == 1
    r = d.decode("2.0,1767225600.5,1.0", 0.0)
    assert (r.t_unix, r.north_m, r.east_m, r.down_m) == (1767225600.5, 1.0, 2.0, None)
    assert d.decode("2.0,,1.0", 0.0).t_unix is None    # no time: dated by its arrival
    for line, reason in (("1,2", "malformed"), ("1,x,2", "not_number"), (",1767225600.5,1", "missing"),
                         ("nan,1767225600.5,1", "not_number")):
        with pytest.raises(Reject) as e:
            d.decode(line, 0.0)
        assert e.value.reason == reason, line
    # a header without the names the map needs
    with pytest.raises(Reject) as e:
        d.decode("time,x,y", 0.0)
    assert e.value.reason == "no_header" and "no north column" in str(e.value)
    c = Decoder("csv", parse_fields("north=y,east=-x"), parse_columns("t,x,y"))
    r = c.decode("1767225600.0,0.5,1.5", 0.0)
    assert (r.north_m, r.east_m) == (1.5, -0.5)
    assert c.decode("t,x,y", 0.0) is None    # a header sent anyway
    with pytest.raises(Reject):
        Decoder("csv", None, parse_columns("t,x,y"))


def test_auto_format_tells_lines_apart_and_ignores_other_sentences():
    d = Decoder("auto")
    assert d.decode(RECORDED[0], 1580000000.0).lat_deg == pytest.approx(14.33985, abs=1e-5)
    assert d.decode("$GPHDT,68.34,T*3C", 0.0) is None
    assert d.decode("$GPZDA,170000.00,10,02,2020,00,00*63", 0.0) is None
    assert d.decode("!AIVDM,1,1,,A,13aEOK?P00PD2wVMdLDRhgvL289?,0*26", 0.0) is None
    assert d.decode("   ", 0.0) is None
    assert dict(d.ignored) == {"GPHDT": 1, "GPZDA": 1, "AIVDM": 1}
    assert d.decode('{"north": 1, "east": 2}', 0.0).north_m == 1.0
    # altitude as depth only when asked: Water Linked writes 0.00 there
    assert d.decode(RECORDED[0], 1580000000.0).down_m is None
    assert Decoder(depth_from_altitude=True).decode(RECORDED[0], 1580000000.0).down_m == -5.6


def test_field_maps_and_columns_refuse_what_they_cannot_mean():
    for bad in ("north", "north=", "up=z", "north=y,north=x", "north=a..b", "east=-"):
        with pytest.raises(ValueError):
            parse_fields(bad)
    for bad in ("t,,north", "t,t,north"):
        with pytest.raises(ValueError):
            parse_columns(bad)


def test_source_strings():
    assert parse_source("/dev/ttyUSB1") == ("serial", "/dev/ttyUSB1", "/dev/ttyUSB1", 4800, "", 0)
    assert parse_source("/dev/ttyUSB1,115200").baud == 115200
    assert parse_source("tcp:192.168.2.94:7777")[:2] == ("tcp", "tcp:192.168.2.94:7777")
    s = parse_source("udpin:10110")
    assert (s.kind, s.host, s.port) == ("udpin", "0.0.0.0", 10110)
    s = parse_source("udp:127.0.0.1:2947")
    assert (s.kind, s.host, s.port) == ("udpin", "127.0.0.1", 2947)
    assert parse_source("tcpin:5000").host == "0.0.0.0"
    for bad in ("tcp:5000", "udpin:x", "udpin:0", "ftp:a:1", "/dev/ttyUSB1,fast", "/dev/ttyUSB1,0", ""):
        with pytest.raises(ValueError):
            parse_source(bad)
