"""``roboray-ground fixes SOURCE``: the fix relay's command line.

Opens the source first (a source that cannot be opened is said before the
vehicle is waited for), then the link (``_connect``, MAVProxy's link
options), reads the vehicle's ``VISO_DELAY_MS``, times its clock with
TIMESYNC, and relays (``ground/fixes.py``) until Ctrl-C, ``--duration`` or
``--count``. On a terminal a status line is redrawn in place; the first
line of each kind of trouble goes to stderr; at the end the summary, one
JSON document with ``--json``. Ctrl-C ends the relay as a normal stop
(exit 0, the summary printed).

``cli.py`` registers it with ``register(sub, _link_options, _connect)``.
"""

from __future__ import annotations

import argparse
import math
import queue
import sys
import time
from typing import Any, Callable

from roboray.tools.cli import UsageError, add_json, command, emit, positive

#: Seconds to wait for the vehicle's first TIMESYNC answer before relaying.
SYNC_WAIT_S = 2.0
#: The status line's redraw period, s.
STATUS_S = 0.5


def _source(text: str):
    from roboray.ground.fixes_sources import parse_source

    try:
        return parse_source(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


def _origin(text: str) -> tuple:
    from roboray.ground.fixes_geo import parse_lat_lon

    try:
        return parse_lat_lon(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


def _fields(text: str) -> dict:
    from roboray.ground.fixes_formats import parse_fields

    try:
        return parse_fields(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


def _columns(text: str) -> list:
    from roboray.ground.fixes_formats import parse_columns

    try:
        return parse_columns(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


def _milliseconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("%r is not a number of milliseconds" % text)
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError("%r must be 0 or more milliseconds" % text)
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value <= 0:
        raise argparse.ArgumentTypeError("%r is not a whole number > 0" % text)
    return value


def register(sub: Any, link_options: Callable[[argparse.ArgumentParser], None],
             connect: Callable[[argparse.Namespace], Any]) -> None:
    """Add ``fixes`` to ``roboray-ground``'s subcommands."""

    def do_fixes(args: argparse.Namespace) -> None:
        relay_fixes(args, connect)

    p = command(sub, "fixes", do_fixes,
                "relay a positioning system's fixes (NMEA GGA, JSON lines, CSV) to the vehicle as "
                "ATT_POS_MOCAP, dated by their measurement (docs/user/fixes.md)")
    p.add_argument("source", metavar="SOURCE", type=_source,
                   help="where fixes come from: a serial port (PATH or PATH,BAUD; default 4800 baud), "
                        "tcp:HOST:PORT (we connect), tcpin:[HOST:]PORT (the tracker connects to us) or "
                        "udpin:[HOST:]PORT (datagrams)")
    p.add_argument("--format", choices=("auto", "nmea", "json", "csv"), default="auto",
                   help="the lines' format; auto (default) tells each line by its first character: "
                        "$ NMEA, { JSON, else CSV")
    p.add_argument("--origin", type=_origin, default=None, metavar="LAT,LON",
                   help="NMEA: the release point in decimal degrees (south, west negative); default: the "
                        "first fix")
    p.add_argument("--depth-from-altitude", action="store_true",
                   help="NMEA: take the depth as minus GGA's altitude (default: ignored; Water Linked "
                        "writes 0.00 there)")
    p.add_argument("--fields", type=_fields, default=None, metavar="MAP",
                   help="JSON and CSV: our names t, north, east, down as the source's fields, e.g. "
                        "t=stamp,north=-y,east=x (dotted paths into JSON objects, - negates)")
    p.add_argument("--columns", type=_columns, default=None, metavar="NAMES",
                   help="CSV without a header line: the columns' names in order, e.g. t,north,east")
    p.add_argument("--time", choices=("source", "arrival"), default="source",
                   help="date a fix by the source's timestamp when it has one (default), or by its arrival "
                        "here")
    p.add_argument("--latency-ms", type=_milliseconds, default=0.0, metavar="MS",
                   help="milliseconds from the measurement to the time used (the source's stamp, or the "
                        "arrival); default 0")
    p.add_argument("--rate-hz", type=positive, default=2.0, metavar="HZ",
                   help="send at most this many fixes a second (default 2: about 2%% of a 57,600 baud radio)")
    p.add_argument("--max-age", type=positive, default=1.0, metavar="S",
                   help="drop a fix older than this when it arrives (default 1 s)")
    p.add_argument("--no-hold", dest="hold", action="store_false",
                   help="send each fix as it comes, instead of holding it until it will reach the vehicle "
                        "VISO_DELAY_MS after its measurement (the age the firmware gives it)")
    p.add_argument("--keep-repeats", action="store_true",
                   help="send a fix at the same position as the source's previous one (default: dropped, "
                        "a source re-sending its last fix)")
    p.add_argument("--duration", type=positive, default=None, metavar="S", help="stop after this many seconds")
    p.add_argument("--count", type=_count, default=None, metavar="N", help="stop after sending N fixes")
    link_options(p)
    add_json(p)


class _Screen:
    """The status line on a terminal (stdout), notes on stderr around it."""

    def __init__(self, live: bool) -> None:
        self.live = live
        self._shown = False

    def status(self, text: str) -> None:
        if self.live:
            sys.stdout.write("\r" + text[:200] + "\x1b[K")
            sys.stdout.flush()
            self._shown = True

    def note(self, text: str) -> None:
        self.clear()
        sys.stderr.write("roboray-ground fixes: %s\n" % text)
        sys.stderr.flush()

    def clear(self) -> None:
        if self._shown:
            sys.stdout.write("\r\x1b[K")
            sys.stdout.flush()
            self._shown = False


def relay_fixes(args: argparse.Namespace, connect: Callable[[argparse.Namespace], Any]) -> None:
    from roboray.ground.fixes import Relay
    from roboray.ground.fixes_clock import VehicleClock
    from roboray.ground.fixes_formats import Decoder, Reject
    from roboray.ground.fixes_geo import Origin
    from roboray.ground.fixes_sources import Source
    from roboray.ground.link import LinkError
    from roboray.tools.cli import CliError

    try:
        decoder = Decoder(args.format, args.fields, args.columns, args.depth_from_altitude)
    except Reject as exc:
        raise UsageError("--columns: %s" % exc)
    origin = Origin(*args.origin) if args.origin else Origin()
    screen = _Screen(sys.stdout.isatty() and not args.json)
    lines: queue.Queue = queue.Queue()
    source = Source(args.source, lines)
    source.open()
    source.start()
    try:
        link = connect(args)
    except BaseException:
        source.close()
        raise
    clock = VehicleClock()
    link.on_message = clock.note
    relay = None
    started = time.monotonic()
    try:
        viso = None
        if args.hold:
            try:
                value, _ = link.param_get("VISO_DELAY_MS", timeout=3.0)
                viso = float(value) / 1000.0
            except LinkError:
                screen.note("the vehicle did not say its VISO_DELAY_MS: fixes go as they come (no hold)")
        # the first TIMESYNC answers, before any fix needs the vehicle's clock
        end_sync = time.monotonic() + SYNC_WAIT_S
        while clock.via != "TIMESYNC" and time.monotonic() < end_sync:
            if link.may_send():
                clock.request(link, time.monotonic())
            link.wait(lambda m: m.get_type() == "TIMESYNC", 0.25)
        if clock.via != "TIMESYNC":
            screen.note("no TIMESYNC answer from the vehicle: fixes are dated by its SYSTEM_TIME (later than "
                        "they should be by the radio's latency) or, until one comes, with time_usec 0")
        relay = Relay(link, clock, decoder, origin, viso, use_source_time=args.time == "source",
                      latency_s=args.latency_ms / 1000.0, rate_hz=args.rate_hz, max_age_s=args.max_age,
                      hold=args.hold, keep_repeats=args.keep_repeats)
        _loop(args, link, clock, relay, source, lines, screen, started)
    except KeyboardInterrupt:
        if relay is None:
            raise   # before the relay began: an interrupted start
        # Ctrl-C is how a relay is stopped: the summary follows
    except CliError as exc:     # the link failed or closed under the relay
        screen.clear()
        if relay is not None:
            relay.finish()
            _report(args, relay, source, link, started, stopped="the link to the vehicle failed")
        raise exc
    finally:
        screen.clear()
        source.close()
        link.close()
    relay.finish()
    _report(args, relay, source, link, started)


def _loop(args: argparse.Namespace, link: Any, clock: Any, relay: Any, source: Any, lines: queue.Queue,
          screen: _Screen, started: float) -> None:
    end = math.inf if args.duration is None else started + args.duration
    next_status = 0.0
    state = source.state
    while True:
        now = time.monotonic()
        if now >= end or (args.count is not None and relay.sent >= args.count):
            return
        if clock.due(now) and link.may_send():
            clock.request(link, now)
        release = relay.next_release()
        wait = 0.005 if release is None else min(0.005, max(0.0, release - now))
        link.recv(wait)
        while True:
            try:
                relay.take(lines.get_nowait())
            except queue.Empty:
                break
            if args.count is not None and relay.sent >= args.count:
                break
        relay.service()
        for text in relay.notes:
            screen.note(text)
        relay.notes.clear()
        if source.state != state:
            state = source.state
            screen.note("source %s: %s" % (source.describe(), state))
        now = time.monotonic()
        if now >= next_status:
            next_status = now + STATUS_S
            screen.status(relay.status(now, source.state))


def _report(args: argparse.Namespace, relay: Any, source: Any, link: Any, started: float,
            stopped: str = "") -> None:
    result = relay.summary()
    result.update(source=source.describe(), vehicle=link.describe(), source_losses=source.losses,
                  duration_s=round(time.monotonic() - started, 2))
    if stopped:
        result["stopped"] = stopped

    def text(r: dict) -> str:
        lines = ["relayed %d fixes of the %d lines received from %s to %s in %.1f s" % (
            r["out"], r["in"], r["source"], r["vehicle"], r["duration_s"])]
        for what in ("rejected", "dropped", "ignored"):
            counts = r[what]
            if counts:
                lines.append("%s %d: %s" % (what, sum(counts.values()),
                                            ", ".join("%s %d" % (k.replace("_", " "), n) for k, n in counts.items())))
        a = r["age_s"]
        if a is not None:
            line = "age at the vehicle: last %.3f s, median %.3f s, max %.3f s" % (a["last"], a["median"], a["max"])
            if r["viso_delay_ms"] is not None:
                line += "; VISO_DELAY_MS %d (%s), %d late" % (
                    r["viso_delay_ms"], "held to it" if r["hold"] else "not held", r["late"])
            lines.append(line)
        if r.get("suggested_viso_delay_ms") is not None:
            lines.append("most fixes reach the vehicle older than VISO_DELAY_MS: set it to %d "
                         "(roboray-ground param set VISO_DELAY_MS %d)" % (r["suggested_viso_delay_ms"],
                                                                           r["suggested_viso_delay_ms"]))
        c = r["vehicle_clock"]
        lines.append("vehicle clock: %s" % ("unknown (time_usec 0)" if c["via"] is None else c["via"] if
                                            c["uncertainty_ms"] is None else "%s, +-%.1f ms, radio %.1f ms one way"
                                            % (c["via"], c["uncertainty_ms"], c["one_way_ms"])))
        o = r["origin"]
        if o is not None:
            lines.append("origin %.7f,%.7f (%s)%s" % (o["lat_deg"], o["lon_deg"], o["from"],
                                                      "" if o["from"] == "--origin" else
                                                      ": give --origin %.7f,%.7f to keep it" % (o["lat_deg"],
                                                                                                o["lon_deg"])))
        f = r["last_fix"]
        if f is not None:
            lines.append("last fix %.2f m north, %.2f m east%s" % (
                f["north_m"], f["east_m"], "" if f["down_m"] is None else ", %.2f m down" % f["down_m"]))
        if stopped:
            lines.append("stopped: " + stopped)
        return "\n".join(lines)

    emit(args, result, text)
