"""NMEA 0183 sentences: framing, checksum, and GGA (GPS fix data).

A sentence is ``$`` + address (talker and type, ``GPGGA``) + ``,``-separated
fields + ``*`` + two hexadecimal digits, the XOR of every character between
``$`` and ``*``. GGA's fields (NMEA 0183 v4.11, as gpsd documents them)::

    $--GGA,hhmmss.ss,ddmm.mmmm,N,dddmm.mmmm,E,q,ss,h.h,a.a,M,g.g,M,age,ref*hh
            time      latitude    longitude  | |  |   |      geoid   DGPS
                                  quality ---+ |  |   +--- altitude above mean sea level, metres
                                satellites ----+  +--- horizontal dilution of precision

The time is the UTC time of the fix, without a date. Quality 0 is "no
fix"; 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float, 6 dead reckoning, 7 manual,
8 simulation. Any talker is taken (GP, GN, GA, ...).

Every way a line can be wrong raises :class:`NmeaError` with a short
``reason`` (the relay counts them by it) and a sentence saying what.
"""

from __future__ import annotations

import re
from typing import NamedTuple, Optional

#: Degrees (up to three digits), then the minutes: two digits and a fraction.
_ANGLE = re.compile(r"^(\d{0,3})(\d\d(?:\.\d*)?)$")


class NmeaError(ValueError):
    """A line that is not a usable sentence; ``reason`` is its short name."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason


class Sentence(NamedTuple):
    talker: str          #: "GP", "GN", ...; "P" for a proprietary sentence
    kind: str            #: "GGA", "RMC", ...; a proprietary one's maker and type
    fields: list         #: the fields after the address, as text


class Gga(NamedTuple):
    #: Seconds since 00:00 UTC of the fix; None when the field is empty.
    time_of_day_s: Optional[float]
    #: Digits after the seconds' decimal point (0: the time is whole seconds).
    time_decimals: int
    lat_deg: float
    lon_deg: float
    quality: int
    satellites: Optional[int]
    hdop: Optional[float]
    #: Metres above mean sea level; None when the field is empty.
    altitude_m: Optional[float]


def checksum(body: str) -> int:
    """The XOR of the characters of ``body`` (the text between ``$`` and ``*``)."""
    c = 0
    for ch in body.encode("ascii", "replace"):
        c ^= ch
    return c


def sentence(body: str) -> str:
    """``body`` framed as a sentence with its checksum (no line ending)."""
    return "$%s*%02X" % (body, checksum(body))


def parse(line: str) -> Sentence:
    """One sentence, its checksum checked; NmeaError when it is not one."""
    text = line.strip()
    if not text.startswith("$"):
        raise NmeaError("malformed", "not an NMEA sentence (no leading $): %s" % show(text))
    star = text.rfind("*")
    if star < 0:
        raise NmeaError("no_checksum", "no checksum (*hh) at the end: %s" % show(text))
    body, given = text[1:star], text[star + 1:]
    try:
        want = int(given, 16)
        if len(given) != 2:
            raise ValueError
    except ValueError:
        raise NmeaError("malformed", "checksum %r is not two hexadecimal digits: %s" % (given, show(text)))
    got = checksum(body)
    if got != want:
        raise NmeaError("checksum", "checksum %02X, the sentence says %02X: %s" % (got, want, show(text)))
    fields = body.split(",")
    address = fields[0]
    if not (5 <= len(address) <= 6 and address.isalnum() and address.isupper()):
        raise NmeaError("malformed", "address %r is not a talker and a sentence type: %s" % (address, show(text)))
    if address.startswith("P"):     # proprietary: P, a maker's code, its own type
        return Sentence("P", address[1:], fields[1:])
    return Sentence(address[:2], address[2:], fields[1:])


def gga(s: Sentence) -> Gga:
    """The fix of a GGA sentence; NmeaError when it has none or a field is bad."""
    f = s.fields
    if s.kind != "GGA":
        raise NmeaError("malformed", "a %s sentence, not GGA" % s.kind)
    if len(f) < 9:
        raise NmeaError("malformed", "GGA with %d fields, at least 9 expected" % len(f))
    quality = _int(f[5], "quality", 0) or 0
    if quality == 0 or not f[1] or not f[3]:
        raise NmeaError("no_fix", "GGA without a fix (quality %d%s)" % (
            quality, "" if f[1] and f[3] else ", no position"))
    time_s, decimals = _time(f[0])
    lat = _angle(f[1], f[2], 90, "NS", "latitude")
    lon = _angle(f[3], f[4], 180, "EW", "longitude")
    altitude = None
    if len(f) > 8 and f[8]:
        altitude = _float(f[8], "altitude")
    return Gga(time_s, decimals, lat, lon, quality,
               _int(f[6], "satellites", None), _float(f[7], "HDOP") if f[7] else None, altitude)


def _time(text: str) -> tuple:
    if not text:
        return None, 0
    whole, _, frac = text.partition(".")
    if len(whole) != 6 or not whole.isdigit() or (frac and not frac.isdigit()):
        raise NmeaError("malformed", "time %r is not hhmmss.ss" % text)
    h, m, s = int(whole[:2]), int(whole[2:4]), int(whole[4:6])
    if h > 23 or m > 59 or s > 60:    # 60: a leap second
        raise NmeaError("malformed", "time %r is not a time of day" % text)
    return h * 3600 + m * 60 + s + (float("0." + frac) if frac else 0.0), len(frac)


def _angle(text: str, hemisphere: str, most: int, signs: str, name: str) -> float:
    """``ddmm.mmmm`` (``dddmm.mmmm`` for longitude) and N/S (E/W) as degrees.

    The two digits before the point are the whole minutes, the digits before
    them the degrees, however many (pynmea2's reading): a sender that drops
    the degrees' leading zeros (Water Linked's NMEA bridge writes 10 deg
    23.7 min east as ``1023.7``) is still read right."""
    m = _ANGLE.match(text)
    if m is None:
        raise NmeaError("malformed", "%s %r is not %smm.mmmm" % (name, text, "d" * (2 if most == 90 else 3)))
    degrees = int(m.group(1) or "0")
    minutes = float(m.group(2))
    if minutes >= 60.0:
        raise NmeaError("malformed", "%s %r has %g minutes" % (name, text, minutes))
    value = degrees + minutes / 60.0
    if value > most:
        raise NmeaError("malformed", "%s %r is beyond %d degrees" % (name, text, most))
    if hemisphere not in signs:
        raise NmeaError("malformed", "%s hemisphere %r is not %s or %s" % (name, hemisphere, signs[0], signs[1]))
    return -value if hemisphere == signs[1] else value


def _int(text: str, name: str, empty: Optional[int]) -> Optional[int]:
    if not text:
        return empty
    try:
        return int(text)
    except ValueError:
        raise NmeaError("malformed", "%s %r is not a whole number" % (name, text))


def _float(text: str, name: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise NmeaError("malformed", "%s %r is not a number" % (name, text))
    if value != value or value in (float("inf"), float("-inf")):
        raise NmeaError("malformed", "%s %r is not a finite number" % (name, text))
    return value


def show(text: str) -> str:
    """A line as it may be printed: at most 90 characters, control characters escaped."""
    shown = text.encode("ascii", "backslashreplace").decode("ascii")
    shown = "".join(ch if ch.isprintable() else "\\x%02x" % ord(ch) for ch in shown)
    return shown if len(shown) <= 90 else shown[:87] + "..."
