"""The fix relay: a positioning system's fixes to the vehicle as ATT_POS_MOCAP.

Each line from the source (``fixes_sources``) is decoded
(``fixes_formats``), dated, checked, brought into the vehicle's frame
(``fixes_geo``) and sent as MAVLink ATT_POS_MOCAP: ``x`` metres north and
``y`` east of the release point, ``z`` the depth when the source gives one
(NaN otherwise), ``q`` the identity (a position system measures no
attitude; the firmware reads only ``x`` and ``y``), the covariance unknown
(NaN first, as MAVLink says), and ``time_usec`` the measurement time on the
vehicle's boot clock (``fixes_clock``).

**The measurement time.** The source's own timestamp when it gives one (a
GGA's UTC time, the JSON or CSV ``t``), else the arrival here; either minus
``latency_s`` (``--latency-ms``: what passed before that time was taken).
The source's Unix time is brought onto our monotonic clock at arrival (the
difference of ``time.time()`` and ``time.monotonic()`` then), so a wall
clock stepped by NTP in the middle of a run moves no fix.

**Exactly as the firmware dates a fix.** The firmware does not read
``time_usec``: ``firmware/navigation.py`` dates a fix ``VISO_DELAY_MS``
before it arrives (ArduPilot's rule for external navigation), and the
estimator fuses it against where it was then. So that this is the
measurement time, the relay *holds* each fix until it will reach the
vehicle ``VISO_DELAY_MS`` after its measurement (read from the vehicle at
the start; the radio's one-way time is half the best TIMESYNC round trip,
plus the longer frame's bytes on a serial link). A fix already older goes
at once and counts as *late*: the vehicle then takes it for younger than it
is by the difference (``dating_error``), which the summary reports with the
value ``VISO_DELAY_MS`` should have. ``hold=False`` sends every fix as it
comes (the error is then its age short of ``VISO_DELAY_MS``).

**What is not sent**, counted by reason: lines that are no fix
(``rejected``: a bad checksum, a GGA without a fix, bad JSON, ...) and
good fixes dropped (``dropped``): ``stale`` (older than ``max_age_s`` when
it came, or when it could be sent: fixes that came while the relay was
starting; held fixes are let through up to ``VISO_DELAY_MS``), ``future`` (dated more than ``FUTURE_S`` after it came: the
source's clock is ahead of ours), ``repeat`` (the same position as the
source's previous fix: Water Linked's example ``nmeaoutput.py`` re-sends
the last position five times a second, stamped anew), ``rate`` (over
``rate_hz``; a fix may come up to a tenth of a period early, so that a
source at exactly that rate is not halved by its jitter, and the long-run
rate still never exceeds it) and ``unsent`` (still held when the relay
stopped).
"""

from __future__ import annotations

import heapq
import math
import time
from collections import Counter, deque
from typing import Any, Optional

from roboray.ground.fixes_clock import VehicleClock
from roboray.ground.fixes_formats import Decoder, Reading, Reject
from roboray.ground.fixes_geo import Origin
from roboray.ground.fixes_sources import MAX_LINE, Line

#: A fix dated up to this far after its arrival is taken as arriving at
#: once (two clocks synchronised by NTP agree to a few ms; a source that
#: stamps when it sends is a little ahead of our arrival); beyond, refused.
FUTURE_S = 0.2
#: A fix reaching the vehicle within this of ``VISO_DELAY_MS`` is on time:
#: the relay wakes every 5 ms and the vehicle reads its radio every 10 ms.
LATE_S = 0.02
#: Ages kept for the median.
_AGES = 1000
#: MAVLink 2 frame bytes (header 10, CRC 2, the payload as sent: trailing
#: zeros cut): ATT_POS_MOCAP with its covariance's first element NaN, and
#: the TIMESYNC whose round trip measures the radio.
_MOCAP_FRAME = 12 + 40
_TIMESYNC_FRAME = 12 + 16
_IDENTITY = (1.0, 0.0, 0.0, 0.0)
_COVARIANCE_UNKNOWN = [math.nan] + [0.0] * 20


class Relay:
    """Turns source lines into ATT_POS_MOCAP on ``link``.

    Parameters
    ----------
    link:
        A connected ``ground.link.Link`` (or anything with ``mav``,
        ``may_send()``, ``baud`` and ``master``).
    clock:
        The vehicle's clock, fed by the caller with the link's messages.
    decoder, origin:
        How lines become readings, and latitude and longitude metres.
    viso_delay_s:
        The vehicle's ``VISO_DELAY_MS`` in seconds, None when unknown (no hold).
    use_source_time:
        Date fixes by the source's timestamp when it has one (else by arrival).
    """

    def __init__(self, link: Any, clock: VehicleClock, decoder: Decoder, origin: Origin,
                 viso_delay_s: Optional[float], use_source_time: bool = True, latency_s: float = 0.0,
                 rate_hz: float = 2.0, max_age_s: float = 1.0, hold: bool = True,
                 keep_repeats: bool = False) -> None:
        if not rate_hz > 0 or not max_age_s > 0 or latency_s < 0:
            raise ValueError("rate_hz and max_age_s must be > 0, latency_s >= 0")
        self.link = link
        self.clock = clock
        self.decoder = decoder
        self.origin = origin
        self.viso_delay_s = viso_delay_s
        self.use_source_time = use_source_time
        self.latency_s = latency_s
        self.period_s = 1.0 / rate_hz
        self.max_age_s = max_age_s
        self.hold = hold and viso_delay_s is not None
        #: Older than this when it comes or when it could go, a fix is dropped;
        #: never under the age a held fix is sent at.
        self._stale_s = max_age_s
        if self.hold and max_age_s < viso_delay_s + LATE_S:    # type: ignore[operator]
            self._stale_s = viso_delay_s + LATE_S    # type: ignore[operator]
        self.keep_repeats = keep_repeats
        master = str(getattr(link, "master", ""))
        serial = ":" not in master.split(",")[0] and not master.endswith(".tlog")
        #: The fix's frame takes longer on a serial line than the TIMESYNC that timed it.
        self._extra_s = (_MOCAP_FRAME - _TIMESYNC_FRAME) * 10.0 / link.baud if serial else 0.0
        self.received = 0               # lines that were fixes or bad ones (not blank, not ignored)
        self.sent = 0
        self.held = 0
        self.late = 0
        self.rejected: Counter = Counter()
        self.dropped: Counter = Counter()
        self.notes: list = []           # what the user should read once, for the caller to print
        self._said: set = set()
        self._pending: list = []        # heap of (release, seq, fix)
        self._seq = 0
        self._next_slot = -math.inf
        self._previous: Optional[tuple] = None
        self._ages: deque = deque(maxlen=_AGES)
        self._errors: deque = deque(maxlen=_AGES)
        self._lags: deque = deque(maxlen=_AGES)
        self.last: Optional[dict] = None
        self._coarse_time = False

    # ------------------------------------------------------------ taking
    def take(self, line: Line) -> None:
        """Decode one source line and send, hold or drop its fix."""
        if line.too_long:
            self.received += 1
            self._reject("too_long", "a line of over %d bytes without an end: not NMEA, JSON or CSV" % MAX_LINE)
            return
        try:
            reading = self.decoder.decode(line.text, line.unix)
        except Reject as exc:
            self.received += 1
            self._reject(exc.reason, str(exc))
            return
        if reading is None:
            return
        self.received += 1
        self._accept(reading, line)

    def _reject(self, reason: str, detail: str) -> None:
        self.rejected[reason] += 1
        self._note(reason, "rejected (%s): %s" % (reason.replace("_", " "), detail))

    def _drop(self, reason: str, detail: str) -> None:
        self.dropped[reason] += 1
        self._note("drop " + reason, "dropped (%s): %s" % (reason, detail))

    def _note(self, key: str, text: str) -> None:
        """Tell the user once per kind of trouble; the counts say how often."""
        if key not in self._said:
            self._said.add(key)
            self.notes.append(text)

    def _accept(self, r: Reading, line: Line) -> None:
        # when it was measured, on our monotonic clock
        if self.use_source_time and r.t_unix is not None:
            self._lags.append(line.unix - r.t_unix)
            t = line.mono - (line.unix - r.t_unix) - self.latency_s
            if r.t_step_s >= 1.0 and not self._coarse_time:
                self._coarse_time = True
                self._note("coarse", "the source's times are whole seconds: a fix's age is known only to a "
                                     "second (--time arrival with --latency-ms may date it better)")
        else:
            t = line.mono - self.latency_s
        age = line.mono - t
        if age < -FUTURE_S:
            self._drop("future", "dated %.3f s after it arrived: the source's clock is ahead of this "
                                 "computer's (synchronise both, or use --time arrival)" % -age)
            return
        t = min(t, line.mono)
        if age > self._stale_s:
            self._drop("stale", "%.3f s old when it arrived, over --max-age %g s%s" % (
                age, self._stale_s, " (is the source's clock behind this computer's? or use --time arrival)"
                if age > 10.0 else ""))
            return
        # where, in the vehicle's frame
        if r.lat_deg is not None:
            self.origin.set_from(r.lat_deg, r.lon_deg)    # type: ignore[arg-type]
            north, east = self.origin.north_east(r.lat_deg, r.lon_deg)   # type: ignore[arg-type]
            key: tuple = (r.lat_deg, r.lon_deg, r.down_m)
        else:
            north, east = r.north_m, r.east_m    # type: ignore[assignment]
            key = (north, east, r.down_m)
        distance = math.hypot(north, east)
        if distance > Origin.FAR_M:
            self._reject("far", "a fix %.0f m from the %s: %s" % (
                distance, "origin" if r.lat_deg is not None else "release point",
                "a wrong --origin?" if r.lat_deg is not None else "metres expected (pixels? millimetres?)"))
            return
        if not self.keep_repeats and key == self._previous:
            self._drop("repeat", "the same position as the source's previous fix (a source re-sending its "
                                 "last one; --keep-repeats sends them)")
            return
        self._previous = key
        if line.mono < self._next_slot - 0.1 * self.period_s:
            self._drop("rate", "the source sends faster than --rate-hz %g: the fixes between go unsent"
                               % (1.0 / self.period_s))
            return
        # the next slot a period on from this one's; early by up to the
        # tolerance counts as on it, so the schedule does not drift later
        # (the first fix starts the schedule where it came)
        if self._next_slot == -math.inf:
            self._next_slot = line.mono + self.period_s
        else:
            self._next_slot = max(self._next_slot, line.mono - 0.1 * self.period_s) + self.period_s
        fix = {"t": t, "north": north, "east": east, "down": r.down_m, "arrival": line.mono}
        release = line.mono
        if self.hold:
            release = t + self.viso_delay_s - self.clock.one_way_s() - self._extra_s    # type: ignore[operator]
        if release > line.mono:
            self.held += 1
            self._seq += 1
            heapq.heappush(self._pending, (release, self._seq, fix))
        else:
            self._send(fix, time.monotonic())

    # ----------------------------------------------------------- sending
    def next_release(self) -> Optional[float]:
        return self._pending[0][0] if self._pending else None

    def service(self, now: Optional[float] = None) -> None:
        """Send the held fixes whose time has come."""
        if now is None:
            now = time.monotonic()
        while self._pending and self._pending[0][0] <= now and self.link.may_send():
            _, _, fix = heapq.heappop(self._pending)
            self._send(fix, now)

    def _send(self, fix: dict, now: float) -> None:
        if not self.link.may_send():      # signing: not before our clock follows the vehicle's
            self._seq += 1
            heapq.heappush(self._pending, (now, self._seq, fix))
            return
        if now - fix["t"] > self._stale_s:  # it waited (the relay starting, signing's first listen)
            self._drop("stale", "%.3f s old when it could be sent, over --max-age %g s" % (
                now - fix["t"], self._stale_s))
            return
        time_usec = self.clock.vehicle_us(fix["t"])
        down = fix["down"]
        self.link.mav.att_pos_mocap_send(0 if time_usec is None else time_usec, _IDENTITY, fix["north"],
                                         fix["east"], math.nan if down is None else down,
                                         covariance=_COVARIANCE_UNKNOWN)
        self.sent += 1
        age = now + self.clock.one_way_s() + self._extra_s - fix["t"]
        self._ages.append(age)
        if self.viso_delay_s is not None:
            error = age - self.viso_delay_s
            self._errors.append(error)
            if error > LATE_S:
                self.late += 1
        self.last = {"north_m": fix["north"], "east_m": fix["east"], "down_m": down,
                     "time_usec": time_usec, "age_s": age, "sent_mono": now}

    def finish(self) -> None:
        """Stop: what is still held is not sent."""
        if self._pending:
            self.dropped["unsent"] += len(self._pending)
            self._pending.clear()

    # ---------------------------------------------------------- reporting
    def status(self, now: float, source_state: str) -> str:
        """One line: in, out, rejected, dropped, the last fix's age, the clock, the source."""
        parts = ["fixes in %d out %d rejected %d dropped %d" % (
            self.received, self.sent, sum(self.rejected.values()), sum(self.dropped.values()))]
        if self.last is not None:
            parts.append("last: age %.3f s, %.1f s ago" % (self.last["age_s"], now - self.last["sent_mono"]))
        via, u = self.clock.via, self.clock.uncertainty_s()
        parts.append("clock %s" % ("unknown" if via is None else via if u is None else "%s +-%.1f ms" % (
            via, u * 1e3)))
        if source_state != "ok":
            parts.append("source " + source_state)
        return " | ".join(parts)

    def summary(self) -> dict:
        ages = sorted(self._ages)
        errors = sorted(self._errors)
        lags = sorted(self._lags)
        u = self.clock.uncertainty_s()
        out: dict = {
            "in": self.received, "out": self.sent,
            "rejected": dict(sorted(self.rejected.items())), "dropped": dict(sorted(self.dropped.items())),
            "ignored": dict(sorted(self.decoder.ignored.items())),
            "held": self.held, "late": self.late,
            "age_s": None if not ages else {"last": _r(self._ages[-1], 4), "median": _r(_median(ages), 4),
                                            "max": _r(ages[-1], 4)},
            "viso_delay_ms": None if self.viso_delay_s is None else int(round(self.viso_delay_s * 1000)),
            "hold": self.hold,
            "dating_error_ms": None if not errors else {
                "median": _r(_median(errors) * 1e3, 1), "max": _r(max(errors, key=abs) * 1e3, 1)},
            "source_lag_s": None if not lags else _r(_median(lags), 4),
            "vehicle_clock": {"via": self.clock.via, "uncertainty_ms": None if u is None else _r(u * 1e3, 2),
                              "one_way_ms": _r((self.clock.one_way_s() + self._extra_s) * 1e3, 2),
                              "answers": self.clock.answers, "restarts": self.clock.restarts},
            "origin": None if not self.origin.known else {
                "lat_deg": self.origin.lat_deg, "lon_deg": self.origin.lon_deg,
                "from": "--origin" if self.origin.given else "the first fix"},
            "last_fix": None if self.last is None else {k: (_r(v, 4) if isinstance(v, float) else v)
                                                        for k, v in self.last.items() if k != "sent_mono"},
        }
        if ages and self.viso_delay_s is not None and self.late * 10 > self.sent:
            # most fixes should reach the vehicle within VISO_DELAY_MS: the 90th percentile
            out["suggested_viso_delay_ms"] = int(math.ceil(ages[min(len(ages) - 1, int(0.9 * len(ages)))] * 1e3))
        return out


def _median(sorted_values: list) -> float:
    n = len(sorted_values)
    mid = n // 2
    return sorted_values[mid] if n % 2 else 0.5 * (sorted_values[mid - 1] + sorted_values[mid])


def _r(v: Optional[float], digits: int) -> Optional[float]:
    return None if v is None else round(v, digits)
