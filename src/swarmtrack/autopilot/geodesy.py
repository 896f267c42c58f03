"""Local NED ↔ latitude/longitude about a geodetic origin, as PX4 converts them.

PX4's estimator keeps its local frame about a reference point and converts with an azimuthal equidistant projection
on a sphere of radius :data:`EARTH_RADIUS` (``MapProjection::project`` / ``reproject`` in PX4-Autopilot
``src/lib/geo/geo.cpp``, ``CONSTANTS_RADIUS_OF_EARTH``); altitudes are the origin's altitude minus ``z`` (down).
The functions below are those formulas, in double precision, so a simulated vehicle reports the latitude and longitude
PX4 SITL would for the same local position. The projection is exact at the origin and its distances from it are true;
over a swarm's few kilometres it departs from the WGS-84 ellipsoid by a fraction of a percent, as PX4's does.

:data:`PX4_SITL` is where PX4 SITL starts by default (``PX4_HOME_LAT``, ``PX4_HOME_LON``, ``PX4_HOME_ALT`` of its
simulation scripts: Zürich, 47.397742° N, 8.545594° E, 488 m AMSL).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The sphere's radius PX4 projects on (m): ``CONSTANTS_RADIUS_OF_EARTH`` (``src/lib/geo/geo.h``).
EARTH_RADIUS = 6371000.0


@dataclass(frozen=True)
class Origin:
    """The geodetic point at the local frame's origin: latitude and longitude (degrees), altitude (m AMSL)."""

    lat: float
    lon: float
    alt: float

    def to_global(self, north: float, east: float, down: float) -> tuple[float, float, float]:
        """(latitude°, longitude°, altitude m AMSL) of the local NED point ``(north, east, down)`` (m):
        PX4's ``MapProjection::reproject``."""
        x, y = north / EARTH_RADIUS, east / EARTH_RADIUS
        c = math.hypot(x, y)
        lat0, lon0 = math.radians(self.lat), math.radians(self.lon)
        if c > 0.0:
            sin_c, cos_c = math.sin(c), math.cos(c)
            lat = math.asin(cos_c * math.sin(lat0) + x * sin_c * math.cos(lat0) / c)
            lon = lon0 + math.atan2(y * sin_c, c * math.cos(lat0) * cos_c - x * math.sin(lat0) * sin_c)
        else:
            lat, lon = lat0, lon0
        return math.degrees(lat), math.degrees(lon), self.alt - down

    def to_local(self, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
        """The local NED point (m) of ``(lat°, lon°, alt m AMSL)``: PX4's ``MapProjection::project``."""
        lat_r, lon_r = math.radians(lat), math.radians(lon)
        lat0, lon0 = math.radians(self.lat), math.radians(self.lon)
        cos_d_lon = math.cos(lon_r - lon0)
        arg = min(1.0, max(-1.0, math.sin(lat0) * math.sin(lat_r) + math.cos(lat0) * math.cos(lat_r) * cos_d_lon))
        c = math.acos(arg)
        k = c / math.sin(c) if c > 0.0 else 1.0
        north = k * (math.cos(lat0) * math.sin(lat_r) - math.sin(lat0) * math.cos(lat_r) * cos_d_lon) * EARTH_RADIUS
        east = k * math.cos(lat_r) * math.sin(lon_r - lon0) * EARTH_RADIUS
        return north, east, self.alt - alt


#: PX4 SITL's default start (``PX4_HOME_LAT/LON/ALT``).
PX4_SITL = Origin(47.397742, 8.545594, 488.0)
