"""What a positioning system sends, line by line, as readings.

Three formats, told apart line by line with ``--format auto`` (the default)
by the first character: ``$`` NMEA 0183, ``{`` a JSON object, anything else
CSV.

- **NMEA 0183 GGA** (``ground/nmea.py``): latitude and longitude, the UTC
  time of the fix (a time of day: the date is the arrival's, the one that
  puts it nearest the arrival). Other sentences (RMC, HDT, ...) are ignored
  and counted by type. The altitude field becomes the depth (``down`` =
  minus the altitude) only with ``depth_from_altitude``: Water Linked's
  NMEA bridge writes 0.00 there whatever the locator's depth.
- **JSON lines**: one object a line, ``{"t": 1767225600.25, "north": 1.20,
  "east": -0.35, "down": 4.1}``; ``t`` (Unix time, seconds, UTC: what
  Python's ``time.time()`` gives) and ``down`` may be absent or null.
- **CSV**: a header line naming the columns (``t,north,east,down``, any
  order, ``t`` and ``down`` optional), then one fix a line; ``columns``
  gives the names when the source sends no header (UDP, one fix a
  datagram). A line that is not all numbers is a header.

``fields`` maps our names (``t``, ``north``, ``east``, ``down``) to the
source's: a JSON key, or a dotted path into nested objects (``pose.x``), or
a CSV column name; a leading ``-`` negates the value (a camera's image
``y`` grows southwards: ``north=-y``).

Every bad line raises :class:`Reject` with a short ``reason`` (the relay
counts them by it) and a sentence saying what was wrong.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from typing import NamedTuple, Optional

from roboray.ground import nmea

FORMATS = ("auto", "nmea", "json", "csv")
NAMES = ("t", "north", "east", "down")
#: Unix times before this (2001-09-09) are not Unix times: a tracker's own
#: clock from its start, which cannot be compared with ours.
UNIX_MIN_S = 1e9


class Reject(ValueError):
    """A line that gives no fix; ``reason`` is its short name."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason


class Reading(NamedTuple):
    """One fix as the source gave it."""

    #: The source's time of the fix, Unix seconds; None: it gave none.
    t_unix: Optional[float]
    #: How finely the source gives that time, s (1.0: whole seconds; 0: finer than we can tell).
    t_step_s: float
    #: Latitude and longitude in degrees (a GGA), else None.
    lat_deg: Optional[float]
    lon_deg: Optional[float]
    #: Metres north and east of the release point (a local tracker), else None.
    north_m: Optional[float]
    east_m: Optional[float]
    #: Metres below the surface, or None.
    down_m: Optional[float]


def parse_fields(text: str) -> dict:
    """``"north=y,east=-x,t=stamp"`` -> {our name: (path, sign)}; ValueError says what is wrong."""
    out: dict = {}
    for part in (p.strip() for p in text.split(",")):
        name, eq, source = part.partition("=")
        name, source = name.strip(), source.strip()
        if not eq or not source:
            raise ValueError("%r: expected NAME=FIELD pairs, e.g. north=y,east=-x,t=stamp" % text)
        if name not in NAMES:
            raise ValueError("%r: %r is not one of %s" % (text, name, ", ".join(NAMES)))
        if name in out:
            raise ValueError("%r: %s given twice" % (text, name))
        sign = 1.0
        if source.startswith("-"):
            sign, source = -1.0, source[1:].strip()
        if not source or any(not p for p in source.split(".")):
            raise ValueError("%r: an empty field name for %s" % (text, name))
        out[name] = (tuple(source.split(".")), sign)
    return out


def parse_columns(text: str) -> list:
    """``"t,north,east"`` -> the CSV column names; ValueError says what is wrong."""
    cols = [c.strip() for c in text.split(",")]
    if any(not c for c in cols):
        raise ValueError("%r: an empty column name" % text)
    if len(set(cols)) != len(cols):
        raise ValueError("%r: a column named twice" % text)
    return cols


def unix_from_time_of_day(tod_s: float, near_unix: float) -> float:
    """The Unix time of a UTC time of day, on the date that puts it nearest ``near_unix``."""
    t = math.floor(near_unix / 86400.0) * 86400.0 + tod_s
    if t - near_unix > 43200.0:
        t -= 86400.0
    elif near_unix - t > 43200.0:
        t += 86400.0
    return t


class Decoder:
    """Lines to readings.

    Parameters
    ----------
    fmt:
        One of ``FORMATS``.
    fields:
        ``parse_fields``' map (JSON and CSV); missing names map to themselves.
    columns:
        CSV column names when the source sends no header, else None.
    depth_from_altitude:
        GGA: the depth is minus the altitude field.
    """

    def __init__(self, fmt: str = "auto", fields: Optional[dict] = None, columns: Optional[list] = None,
                 depth_from_altitude: bool = False) -> None:
        if fmt not in FORMATS:
            raise ValueError("format %r: one of %s" % (fmt, ", ".join(FORMATS)))
        self.fmt = fmt
        self.fields = {n: ((n,), 1.0) for n in NAMES}
        self.fields.update(fields or {})
        self.fixed_columns = columns is not None
        self.columns: Optional[list] = list(columns) if columns is not None else None
        self.depth_from_altitude = depth_from_altitude
        #: Lines that carry no fix and are no error: other NMEA sentences by type, CSV headers.
        self.ignored: Counter = Counter()
        if columns is not None:
            self._check_columns(columns, "--columns")

    def decode(self, line: str, arrival_unix: float) -> Optional[Reading]:
        """The reading in ``line``, None when it carries none (a blank line,
        another sentence, a header); Reject when it is bad."""
        text = line.strip()
        if not text:
            return None
        fmt = self.fmt
        if fmt == "auto":
            fmt = "nmea" if text[0] in "$!" else "json" if text[0] == "{" else "csv"
        if fmt == "nmea":
            return self._nmea(text, arrival_unix)
        if fmt == "json":
            return self._json(text)
        return self._csv(text)

    # ------------------------------------------------------------- NMEA
    def _nmea(self, text: str, arrival_unix: float) -> Optional[Reading]:
        if text.startswith("!"):    # encapsulated (AIS): never a fix
            self.ignored[text[1:6] or "!"] += 1
            return None
        try:
            s = nmea.parse(text)
            if s.kind != "GGA":
                self.ignored[s.talker + s.kind if s.talker != "P" else "P" + s.kind] += 1
                return None
            g = nmea.gga(s)
        except nmea.NmeaError as exc:
            raise Reject(exc.reason, str(exc))
        t = None if g.time_of_day_s is None else unix_from_time_of_day(g.time_of_day_s, arrival_unix)
        down = -g.altitude_m if self.depth_from_altitude and g.altitude_m is not None else None
        return Reading(t, 10.0 ** -g.time_decimals if t is not None else 0.0, g.lat_deg, g.lon_deg,
                       None, None, down)

    # ------------------------------------------------------------- JSON
    def _json(self, text: str) -> Reading:
        try:
            obj = json.loads(text)
        except ValueError as exc:
            raise Reject("not_json", "not a JSON object (%s): %s" % (exc, nmea.show(text)))
        if not isinstance(obj, dict):
            raise Reject("not_json", "a JSON %s, not an object: %s" % (type(obj).__name__, nmea.show(text)))
        values = {}
        for name in NAMES:
            path, sign = self.fields[name]
            v: object = obj
            for key in path:
                v = v.get(key) if isinstance(v, dict) else None
            if v is None:
                values[name] = None
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise Reject("not_number", "%s (%s) is %s, not a number: %s" % (
                    name, ".".join(path), json.dumps(v), nmea.show(text)))
            values[name] = sign * float(v)
        return self._local(values, text)

    # -------------------------------------------------------------- CSV
    def _csv(self, text: str) -> Optional[Reading]:
        cells = [c.strip() for c in text.split(",")]
        numbers: list = []
        for c in cells:
            try:
                numbers.append(float(c) if c else None)
            except ValueError:
                numbers.append(c)
        words = [c for c in numbers if isinstance(c, str)]
        if words and len(words) == len(cells):
            # a header (with --columns: one the source sends anyway)
            self.ignored["header"] += 1
            if not self.fixed_columns:
                self.columns = None
                self._check_columns(cells, "the header")
                self.columns = cells
            return None
        if words:
            raise Reject("not_number", "%r is not a number: %s" % (words[0], nmea.show(text)))
        if self.columns is None:
            raise Reject("no_header", "a CSV line before any header (give --columns when the source "
                                      "sends none): %s" % nmea.show(text))
        if len(numbers) != len(self.columns):
            raise Reject("malformed", "%d values, the header names %d (%s): %s" % (
                len(numbers), len(self.columns), ",".join(self.columns), nmea.show(text)))
        row = dict(zip(self.columns, numbers))
        values = {}
        for name in NAMES:
            path, sign = self.fields[name]
            v = row.get(".".join(path))
            values[name] = None if v is None else sign * v
        return self._local(values, text)

    def _check_columns(self, columns: list, what: str) -> None:
        for name in ("north", "east"):
            col = ".".join(self.fields[name][0])
            if col not in columns:
                raise Reject("no_header", "%s (%s) has no %s column %r (--fields maps names)" % (
                    what, ",".join(columns), name, col))

    # ----------------------------------------------------------- common
    def _local(self, v: dict, text: str) -> Reading:
        for name in ("north", "east"):
            if v[name] is None:
                raise Reject("missing", "no %s (%s): %s" % (name, ".".join(self.fields[name][0]), nmea.show(text)))
        for name in NAMES:
            if v[name] is not None and not math.isfinite(v[name]):
                raise Reject("not_number", "%s is not finite: %s" % (name, nmea.show(text)))
        t = v["t"]
        if t is not None and t < UNIX_MIN_S:
            raise Reject("t_clock", "t %g is not Unix time (seconds since 1970, UTC): stamp fixes with "
                                    "time.time() or use --time arrival" % t)
        return Reading(t, 0.0, None, None, v["north"], v["east"], v["down"])
