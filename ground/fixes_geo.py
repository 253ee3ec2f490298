"""Latitude and longitude to metres north and east of an origin.

The vehicle's frame is metres north and east of its release point (true
north: the estimator turns the compass's heading by ``COMPASS_DEC``). A
positioning system that gives latitude and longitude (an underwater GPS's
GGA) is brought into it here: both points go to Earth-centred, Earth-fixed
coordinates on the WGS-84 ellipsoid, and the difference is turned into the
origin's local east-north-up frame (the standard ECEF to ENU rotation).
Exact for any separation; both points are taken on the ellipsoid (height
0), so the locator's depth does not leak into north and east.

``Origin.FAR_M``: a fix farther than this from the origin is refused. The
vehicle glides at most half its depth sideways; a fix kilometres away is a
wrong origin or a "no position" sentence with zeros in it.
"""

from __future__ import annotations

import math
from typing import Optional

#: WGS-84 semi-major axis (m) and flattening.
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
_E2 = WGS84_F * (2.0 - WGS84_F)    # first eccentricity squared


def ecef(lat_deg: float, lon_deg: float, height_m: float = 0.0) -> tuple:
    """Earth-centred, Earth-fixed x, y, z (m) of a point on WGS-84."""
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    s, c = math.sin(lat), math.cos(lat)
    n = WGS84_A / math.sqrt(1.0 - _E2 * s * s)     # prime vertical radius of curvature
    return ((n + height_m) * c * math.cos(lon), (n + height_m) * c * math.sin(lon),
            (n * (1.0 - _E2) + height_m) * s)


def parse_lat_lon(text: str) -> tuple:
    """``"LAT,LON"`` in decimal degrees (south and west negative); ValueError says what is wrong."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 2:
        raise ValueError("%r: expected LAT,LON in decimal degrees, e.g. 63.4305,10.3951" % text)
    try:
        lat, lon = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError("%r: expected LAT,LON in decimal degrees, e.g. 63.4305,10.3951" % text)
    if not -90.0 <= lat <= 90.0:
        raise ValueError("%r: latitude %g is not between -90 and 90" % (text, lat))
    if not -180.0 <= lon <= 180.0:
        raise ValueError("%r: longitude %g is not between -180 and 180" % (text, lon))
    return lat, lon


class Origin:
    """The point fixes are measured from: given (``--origin``) or, when
    ``lat_deg`` is None, the first fix's (``set_from``)."""

    FAR_M = 10000.0

    def __init__(self, lat_deg: Optional[float] = None, lon_deg: Optional[float] = None) -> None:
        self.lat_deg: Optional[float] = None
        self.lon_deg: Optional[float] = None
        self.given = lat_deg is not None
        if lat_deg is not None:
            self._set(lat_deg, float(lon_deg))    # type: ignore[arg-type]

    @property
    def known(self) -> bool:
        return self.lat_deg is not None

    def set_from(self, lat_deg: float, lon_deg: float) -> None:
        """Take this point as the origin unless one is set already."""
        if self.lat_deg is None:
            self._set(lat_deg, lon_deg)

    def _set(self, lat_deg: float, lon_deg: float) -> None:
        self.lat_deg, self.lon_deg = lat_deg, lon_deg
        lat, lon = math.radians(lat_deg), math.radians(lon_deg)
        self._x0 = ecef(lat_deg, lon_deg)
        sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
        # rows of the ECEF -> local (east, north) rotation
        self._east = (-so, co, 0.0)
        self._north = (-sl * co, -sl * so, cl)

    def north_east(self, lat_deg: float, lon_deg: float) -> tuple:
        """Metres (north, east) of the point from the origin."""
        if self.lat_deg is None:
            raise ValueError("the origin is not known yet")
        x = ecef(lat_deg, lon_deg)
        d = (x[0] - self._x0[0], x[1] - self._x0[1], x[2] - self._x0[2])
        n = self._north[0] * d[0] + self._north[1] * d[1] + self._north[2] * d[2]
        e = self._east[0] * d[0] + self._east[1] * d[1]
        return n, e
