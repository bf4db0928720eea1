"""lat/lon ⇄ local north/east: the autopilot's EKF map and the true WGS-84 geodesic."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.base.geometry import NonFiniteError
from helixd.mission.geodesy import geodesic_latlon, geodesic_ne_m

# AP_Common/Location.h: LOCATION_SCALING_FACTOR, metres per 1e-7 degree (written out here,
# not derived, so the test does not share the module's arithmetic)
LSF = 0.011131884502145034
LAT0, LON0 = 49.2606, -123.2460  # a pond near Vancouver


def ardupilot_ne(lat: float, lon: float, lat0: float, lon0: float) -> tuple[float, float]:
    """Location::get_distance_NE_ftype on 1e-7-degree integers, as the EKF places a GPS fix."""
    ilat, ilon, ilat0, ilon0 = (round(v * 1e7) for v in (lat, lon, lat0, lon0))
    scale = min(max(math.cos((ilat + ilat0) / 2 * 1e-7 * math.pi / 180), 0.01), 1.0)
    return (ilat - ilat0) * LSF, (ilon - ilon0) * LSF * scale


@pytest.mark.parametrize(
    ("dlat", "dlon"), [(0.009, 0.0), (0.0, 0.0137), (0.0064, 0.0097), (-0.0064, -0.0097)]
)
def test_ekf_map_matches_ardupilot_to_the_millimetre_at_1_km(dlat: float, dlon: float) -> None:
    lat, lon = LAT0 + dlat, LON0 + dlon
    n, e = latlon_to_ne(lat, lon, LAT0, LON0)
    n_ap, e_ap = ardupilot_ne(lat, lon, LAT0, LON0)
    assert 990.0 < math.hypot(n, e) < 1010.0
    assert n == pytest.approx(n_ap, abs=1e-3)
    assert e == pytest.approx(e_ap, abs=1e-3)


def test_ekf_map_is_what_a_waypoint_needs_not_the_geodesic() -> None:
    """The documented difference: the EKF map is 0.1–0.2 % off the WGS-84 geodesic at 49° N.
    Converting waypoints with the geodesic would put that offset into every global mission."""
    lat, lon = LAT0 + 0.009, LON0 + 0.0137
    n_map, e_map = latlon_to_ne(lat, lon, LAT0, LON0)
    n_geo, e_geo = geodesic_ne_m(lat, lon, LAT0, LON0)
    assert 0.0005 < (n_map - n_geo) / n_geo < 0.002
    assert -0.003 < (e_map - e_geo) / e_geo < -0.001


def meridian_arc_m(lat_deg: float) -> float:
    """Helmert's series for the WGS-84 meridian arc from the equator (sub-millimetre)."""
    a, f = 6378137.0, 1 / 298.257223563
    n = f / (2 - f)
    phi = math.radians(lat_deg)
    return (
        a
        / (1 + n)
        * (1 + n**2 / 4 + n**4 / 64)
        * (
            phi
            - (3 / 2 * n - 9 / 16 * n**3) * math.sin(2 * phi)
            + (15 / 16 * n**2 - 15 / 32 * n**4) * math.sin(4 * phi)
            - 35 / 48 * n**3 * math.sin(6 * phi)
            + 315 / 512 * n**4 * math.sin(8 * phi)
        )
    )


@pytest.mark.parametrize("lat0", [0.0, 30.0, 49.2606, 60.0, -45.0])
def test_geodesic_north_is_the_meridian_arc(lat0: float) -> None:
    n, e = geodesic_ne_m(lat0 + 0.009, 10.0, lat0, 10.0)
    assert n == pytest.approx(meridian_arc_m(lat0 + 0.009) - meridian_arc_m(lat0), abs=1e-3)
    assert abs(e) < 1e-6


def test_geodesic_known_pair_degree_of_latitude_at_the_equator() -> None:
    n, _ = geodesic_ne_m(1.0, 0.0, 0.0, 0.0)
    assert n == pytest.approx(110_574.389, abs=0.01)  # textbook WGS-84 value


coord = st.floats(-2000, 2000, allow_nan=False)


def assert_round_trip(
    to_latlon: Callable[..., tuple[float, float]],
    to_ne: Callable[..., tuple[float, float]],
    origin: tuple[float, float],
    ne: tuple[float, float],
) -> None:
    """``ne`` (m from ``origin``) to latitude/longitude and back within a micrometre."""
    lat, lon = to_latlon(*ne, *origin)
    n2, e2 = to_ne(lat, lon, *origin)
    assert n2 == pytest.approx(ne[0], abs=1e-6)
    assert e2 == pytest.approx(ne[1], abs=1e-6)


@given(st.floats(-80, 80), st.floats(-180, 180), coord, coord)
def test_ekf_map_round_trip(lat0: float, lon0: float, n: float, e: float) -> None:
    assert_round_trip(ne_to_latlon, latlon_to_ne, (lat0, lon0), (n, e))


@given(st.floats(-80, 80), st.floats(-180, 180), coord, coord)
def test_geodesic_round_trip(lat0: float, lon0: float, n: float, e: float) -> None:
    assert_round_trip(geodesic_latlon, geodesic_ne_m, (lat0, lon0), (n, e))


def test_across_the_antimeridian() -> None:
    n, e = latlon_to_ne(0.0, -179.999, 0.0, 179.999)
    assert n == 0.0
    assert e == pytest.approx(0.002 * 111_318.845, abs=1e-3)
    _, lon = ne_to_latlon(0.0, 300.0, 0.0, 179.999)
    assert -180.0 <= lon < -179.99


@pytest.mark.parametrize(("lat", "lon"), [(91.0, 0.0), (0.0, 180.5), (-90.1, 0.0), (0.0, -181.0)])
def test_off_the_earth_is_an_error(lat: float, lon: float) -> None:
    with pytest.raises(ValueError, match="not on the Earth"):
        latlon_to_ne(lat, lon, 0.0, 0.0)
    with pytest.raises(ValueError, match="not on the Earth"):
        ne_to_latlon(0.0, 0.0, lat, lon)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_is_an_error(bad: float) -> None:
    with pytest.raises(NonFiniteError):
        latlon_to_ne(bad, 0.0, 0.0, 0.0)
    with pytest.raises(NonFiniteError):
        ne_to_latlon(0.0, bad, 0.0, 0.0)
    with pytest.raises(NonFiniteError):
        geodesic_ne_m(0.0, bad, 0.0, 0.0)
