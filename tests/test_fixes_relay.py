"""The relay's rules, with the ground station's real ``Link`` sending over
UDP to pymavlink listening as the vehicle: the measurement time on the
vehicle's clock (from a TIMESYNC exchange), the hold to ``VISO_DELAY_MS``,
rate, staleness, repeats, the origin. Arrival times are given, not waited
for, so every figure is exact."""

from __future__ import annotations

import os
import socket
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from roboray.ground import nmea  # noqa: E402
from roboray.ground.fixes import Relay  # noqa: E402
from roboray.ground.fixes_clock import VehicleClock  # noqa: E402
from roboray.ground.fixes_formats import Decoder  # noqa: E402
from roboray.ground.fixes_geo import Origin  # noqa: E402
from roboray.ground.fixes_sources import Line  # noqa: E402
from roboray.ground.link import Link  # noqa: E402

#: The vehicle's boot clock when our monotonic clock reads 0, in the TIMESYNC answer below.
VEHICLE_AHEAD_S = 1234.5
HALF_TRIP_S = 0.01


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def pair():
    """(ground Link, pymavlink listening as the vehicle, the vehicle clock timed by one exchange)."""
    port = _free_port()
    vehicle = mavutil.mavlink_connection("udpin:127.0.0.1:%d" % port, source_system=1, source_component=1)
    link = Link("udpout:127.0.0.1:%d" % port)
    clock = VehicleClock()
    clock.request(link, time.monotonic())
    request = vehicle.recv_match(type="TIMESYNC", blocking=True, timeout=5)
    assert request is not None and request.tc1 == 0
    sent = request.ts1 / 1e9
    answer = mavlink.MAVLink_timesync_message(int(round((sent + HALF_TRIP_S + VEHICLE_AHEAD_S) * 1e9)), request.ts1)
    clock.note(answer, sent + 2 * HALF_TRIP_S)
    assert clock.via == "TIMESYNC" and clock.uncertainty_s() == pytest.approx(HALF_TRIP_S, abs=1e-6)
    yield link, vehicle, clock
    link.close()
    vehicle.close()


def _fixes(vehicle, n: int, timeout: float = 5.0) -> list:
    out = []
    end = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < end:
        m = vehicle.recv_match(type="ATT_POS_MOCAP", blocking=True, timeout=0.2)
        if m is not None:
            out.append(m)
    return out


def _silent(vehicle) -> bool:
    return vehicle.recv_match(type="ATT_POS_MOCAP", blocking=True, timeout=0.3) is None


def _json(t: float, north: float, east: float) -> str:
    return '{"t": %.6f, "north": %r, "east": %r}' % (t, north, east)


def test_the_measurement_time_reaches_the_vehicle_on_its_own_clock(pair):
    link, vehicle, clock = pair
    relay = Relay(link, clock, Decoder(), Origin(), None, latency_s=0.05, rate_hz=100)
    mono, unix = time.monotonic(), time.time()
    # stamped 0.3 s before it arrived, 50 ms after its measurement
    relay.take(Line(mono, unix, _json(unix - 0.3, 1.25, -0.5)))
    [m] = _fixes(vehicle, 1)
    assert m.time_usec == pytest.approx((mono - 0.35 + VEHICLE_AHEAD_S) * 1e6, abs=2)
    assert (m.x, m.y) == (1.25, -0.5) and m.z != m.z and list(m.q) == [1.0, 0.0, 0.0, 0.0]
    assert m.covariance[0] != m.covariance[0]     # unknown, as MAVLink marks it
    # without a source time (and with --time arrival) the arrival minus the latency
    relay.take(Line(mono + 1.0, unix + 1.0, '{"north": 2.0, "east": 0.0}'))
    arrival = Relay(link, clock, Decoder(), Origin(), None, use_source_time=False, latency_s=0.2)
    arrival.take(Line(mono + 2.0, unix + 2.0, _json(unix, 3.0, 0.0)))
    a, b = _fixes(vehicle, 2)
    assert a.time_usec == pytest.approx((mono + 1.0 - 0.05 + VEHICLE_AHEAD_S) * 1e6, abs=2)
    assert b.time_usec == pytest.approx((mono + 2.0 - 0.2 + VEHICLE_AHEAD_S) * 1e6, abs=2)
    assert relay.summary()["vehicle_clock"]["via"] == "TIMESYNC"


def test_a_fix_is_held_until_it_reaches_the_vehicle_viso_delay_after_its_measurement(pair):
    link, vehicle, clock = pair
    relay = Relay(link, clock, Decoder(), Origin(), 0.21, rate_hz=100)
    mono, unix = time.monotonic(), time.time()
    relay.take(Line(mono, unix, _json(unix - 0.05, 1.0, 1.0)))   # 50 ms old: held
    release = mono - 0.05 + 0.21 - HALF_TRIP_S
    assert relay.held == 1 and relay.sent == 0 and relay.next_release() == pytest.approx(release, abs=2e-6)
    relay.service(release - 0.001)
    assert relay.sent == 0 and _silent(vehicle)
    relay.service(release + 0.001)
    [m] = _fixes(vehicle, 1)
    assert relay.sent == 1 and m.x == 1.0 and relay.late == 0
    # 0.5 s old when it came: sent at once, late by about 0.3 s
    relay.take(Line(time.monotonic(), time.time(), _json(time.time() - 0.5, 2.0, 2.0)))
    assert relay.sent == 2 and relay.late == 1 and len(_fixes(vehicle, 1)) == 1
    s = relay.summary()
    assert s["held"] == 1 and s["viso_delay_ms"] == 210 and s["hold"] is True
    assert s["dating_error_ms"]["max"] == pytest.approx(300, abs=30)
    # most fixes late: the summary says what VISO_DELAY_MS should be
    mono, unix = time.monotonic(), time.time()
    for k in range(3):
        relay.take(Line(mono + 0.02 * (k + 1), unix + 0.02 * (k + 1), _json(unix - 0.6, 3.0 + k, 0.0)))
    s = relay.summary()
    assert s["late"] == 4 and 600 <= s["suggested_viso_delay_ms"] <= 700


def test_without_hold_fixes_go_as_they_come(pair):
    link, vehicle, clock = pair
    relay = Relay(link, clock, Decoder(), Origin(), 0.21, hold=False)
    relay.take(Line(time.monotonic(), time.time(), _json(time.time() - 0.05, 1.0, 1.0)))
    assert relay.sent == 1 and relay.held == 0 and len(_fixes(vehicle, 1)) == 1
    assert relay.summary()["dating_error_ms"]["median"] == pytest.approx(-150, abs=30)


def test_rate_limit_lets_a_source_at_the_rate_through_and_thins_a_faster_one(pair):
    link, vehicle, clock = pair
    relay = Relay(link, clock, Decoder(), Origin(), None, use_source_time=False, rate_hz=2.0)
    mono, unix = time.monotonic(), time.time()
    for k in range(10):     # 10 Hz for one second
        relay.take(Line(mono + 0.1 * k, unix + 0.1 * k, '{"north": %d, "east": 0}' % k))
    assert relay.sent == 2 and relay.dropped["rate"] == 8
    # a source at 2 Hz whose fixes come up to a tenth of a period early is not halved
    for k, jitter in enumerate((0.0, -0.04, 0.03, -0.045, 0.0)):
        relay.take(Line(mono + 2.0 + 0.5 * k + jitter, unix, '{"north": %d, "east": 1}' % k))
    assert relay.sent == 7 and relay.dropped["rate"] == 8
    assert [m.x for m in _fixes(vehicle, 7)] == [0, 5, 0, 1, 2, 3, 4]


def test_stale_future_and_repeated_fixes_are_dropped_and_counted(pair):
    link, vehicle, clock = pair
    relay = Relay(link, clock, Decoder(), Origin(), None, max_age_s=1.0, rate_hz=100)
    mono, unix = time.monotonic(), time.time()
    relay.take(Line(mono, unix, _json(unix - 1.5, 1.0, 1.0)))      # stale
    relay.take(Line(mono, unix, _json(unix + 0.5, 1.0, 1.0)))      # from the future: clocks disagree
    relay.take(Line(mono, unix, _json(unix + 0.1, 1.0, 1.0)))      # a little ahead: taken as just measured
    relay.take(Line(mono + 1, unix + 1, _json(unix + 0.9, 1.0, 1.0)))    # the same position again
    relay.take(Line(mono + 2, unix + 2, "$GPGGA,bad*00"))           # bad checksum
    relay.take(Line(mono + 2, unix + 2, "", too_long=True))
    assert relay.sent == 1
    assert dict(relay.dropped) == {"stale": 1, "future": 1, "repeat": 1}
    assert dict(relay.rejected) == {"checksum": 1, "too_long": 1}
    assert relay.received == 6
    [m] = _fixes(vehicle, 1)
    assert m.time_usec == pytest.approx((mono + VEHICLE_AHEAD_S) * 1e6, abs=2)
    # each kind of trouble is told once, in words
    assert any("clock is ahead" in n for n in relay.notes) and any("--max-age" in n for n in relay.notes)
    kept = Relay(link, clock, Decoder(), Origin(), None, keep_repeats=True, rate_hz=100)
    for k in range(3):
        kept.take(Line(mono + k, unix + k, _json(unix + k, 1.0, 1.0)))
    assert kept.sent == 3


def test_gga_fixes_are_metres_from_the_first_fix_or_the_given_origin(pair):
    link, vehicle, clock = pair
    now = time.time()
    tod = (now - 0.1) % 86400.0

    def gga(lat_min: float, lon_min: float, t: float = tod) -> str:
        hh, mm, ss = int(t // 3600), int(t % 3600 // 60), t % 60
        return nmea.sentence("GPGGA,%02d%02d%05.2f,63%07.4f,N,010%07.4f,E,1,08,0.9,0.0,M,39.5,M,," % (
            hh, mm, ss, lat_min, lon_min))

    relay = Relay(link, clock, Decoder(), Origin(), None, rate_hz=10)
    mono = time.monotonic()
    relay.take(Line(mono, now, gga(25.8, 23.7)))
    relay.take(Line(mono + 0.1, now + 0.1, gga(25.8 + 0.001, 23.7 + 0.002, tod + 0.1)))
    first, second = _fixes(vehicle, 2)
    assert (first.x, first.y) == (0.0, 0.0)
    north, east = Origin(63 + 25.8 / 60, 10 + 23.7 / 60).north_east(63 + 25.801 / 60, 10 + 23.702 / 60)
    assert (second.x, second.y) == pytest.approx((north, east), abs=1e-4)
    assert 1.8 < second.x < 1.9 and 1.6 < second.y < 1.7     # a thousandth of a minute: 1.85 m north
    assert relay.summary()["origin"]["from"] == "the first fix"
    given = Relay(link, clock, Decoder(), Origin(63 + 25.8 / 60, 10 + 23.6 / 60), None)
    given.take(Line(time.monotonic(), now, gga(25.8, 23.7)))
    [m] = _fixes(vehicle, 1)
    assert m.y == pytest.approx(Origin(63 + 25.8 / 60, 10 + 23.6 / 60).north_east(63 + 25.8 / 60,
                                                                                10 + 23.7 / 60)[1], abs=1e-4)
    # kilometres away: a wrong origin, refused
    given.take(Line(time.monotonic() + 0.6, now + 0.6, gga(45.0, 23.7, tod + 0.5)))
    assert given.rejected["far"] == 1 and given.sent == 1


def test_held_fixes_still_waiting_at_the_end_are_counted_unsent(pair):
    link, vehicle, clock = pair
    relay = Relay(link, clock, Decoder(), Origin(), 0.5)
    relay.take(Line(time.monotonic(), time.time(), _json(time.time(), 1.0, 1.0)))
    relay.finish()
    assert relay.sent == 0 and relay.dropped["unsent"] == 1 and relay.next_release() is None
