"""
The WMM reference field against NOAA's official WMM2025 test values.

The rows are NOAA's published WMM2025 test values (WMM2025COF.zip ->
WMM2025_TestValues.txt, also https://www.ncei.noaa.gov/sites/default/files/2025-02/
WMM2025testvalues.pdf): X, Y, Z printed to 0.1 nT and D to 0.01 deg.  F and the dip are
derived here from X, Y, Z, so their tolerance follows from that rounding: each component is
off by at most 0.05 nT, hence F by at most 0.05 sqrt(3) < 0.1 nT and the dip by at most
0.05 sqrt(2) / F rad < 1e-4 deg; D by at most 0.005 deg, plus 0.001 of margin.
"""

import datetime
import math
import sys

from inclino_ros.core.reference_field import decimal_year, reference_from_model
import pytest

# decimal year, height above the ellipsoid [km], latitude, longitude, X, Y, Z [nT], D [deg]
NOAA_WMM2025 = [
    (2025.0, 0.0, 80.0, 0.0, 6521.6, 145.9, 54791.5, 1.28),
    (2025.0, 0.0, 0.0, 120.0, 39677.8, -109.6, -10580.2, -0.16),
    (2025.0, 0.0, -80.0, 240.0, 6117.5, 15751.9, -52022.5, 68.78),
    (2025.0, 100.0, 80.0, 0.0, 6216.0, 92.4, 52598.8, 0.85),
    (2025.0, 100.0, 0.0, 120.0, 37688.6, -96.2, -10152.1, -0.15),
    (2025.0, 100.0, -80.0, 240.0, 5907.6, 14780.3, -49540.7, 68.21),
    (2027.5, 0.0, 80.0, 0.0, 6500.8, 294.5, 54869.4, 2.59),
    (2027.5, 0.0, 0.0, 120.0, 39701.6, -167.4, -10381.8, -0.24),
    (2027.5, 0.0, -80.0, 240.0, 6200.7, 15730.3, -51783.7, 68.49),
    (2027.5, 100.0, 80.0, 0.0, 6196.7, 233.8, 52670.5, 2.16),
    (2027.5, 100.0, 0.0, 120.0, 37711.5, -148.7, -9969.8, -0.23),
    (2027.5, 100.0, -80.0, 240.0, 5984.0, 14760.1, -49317.7, 67.93),
]
F_TOL_NT = 0.1
DIP_TOL_DEG = 1e-4
DECLINATION_TOL_DEG = 0.006


@pytest.fixture
def pygeomag():
    """Skip where the optional pygeomag is not installed."""
    return pytest.importorskip('pygeomag')


@pytest.mark.parametrize('year, height_km, lat, lon, x, y, z, declination', NOAA_WMM2025)
def test_matches_the_official_wmm2025_test_values(
        pygeomag, year, height_km, lat, lon, x, y, z, declination):
    ref = reference_from_model(lat, lon, height_km * 1000.0, year)
    assert ref.total_nT == pytest.approx(math.sqrt(x * x + y * y + z * z), abs=F_TOL_NT)
    assert ref.dip_deg == pytest.approx(math.degrees(math.atan2(z, math.hypot(x, y))),
                                        abs=DIP_TOL_DEG)
    assert ref.declination_deg == pytest.approx(declination, abs=DECLINATION_TOL_DEG)
    assert 'WMM-2025' in ref.source


def test_a_date_selects_the_model_of_its_epoch(pygeomag):
    ref_2027 = reference_from_model(0.0, 120.0, 0.0, datetime.date(2027, 7, 2))
    assert ref_2027.declination_deg == pytest.approx(-0.24, abs=DECLINATION_TOL_DEG)
    assert 'WMM-2020' in reference_from_model(52.0, -1.0, 100.0, 2022.3).source


def test_dates_outside_every_model_are_refused():
    with pytest.raises(ValueError, match='no bundled World Magnetic Model covers 2031'):
        reference_from_model(0.0, 0.0, 0.0, datetime.date(2031, 1, 1))
    with pytest.raises(ValueError, match='2014'):
        reference_from_model(0.0, 0.0, 0.0, 2014.99)


def test_missing_pygeomag_names_the_package(monkeypatch):
    monkeypatch.setitem(sys.modules, 'pygeomag', None)
    with pytest.raises(ImportError, match='pygeomag>=1.1,<2'):
        reference_from_model(0.0, 0.0, 0.0, 2026.0)


def test_decimal_year():
    assert decimal_year(datetime.datetime(2027, 7, 2, 12)) == 2027.5
    assert decimal_year(datetime.date(2028, 1, 1)) == 2028.0
    assert decimal_year(2025.25) == 2025.25
    plus_two_hours = datetime.timezone(datetime.timedelta(hours=2))
    aware = datetime.datetime(2027, 7, 2, 14, tzinfo=plus_two_hours)
    assert decimal_year(aware) == 2027.5
