"""
The expected geomagnetic field at a site, from the World Magnetic Model, offline.

Survey QC and multi-station analysis compare the measured field with a
reference: total intensity, dip and declination (formulas.md, "Survey QC" and
"Multi-station analysis").  The reference comes from the World Magnetic Model
through ``pygeomag`` (MIT, pure Python, the WMM coefficient files bundled, so
no network call is ever made).  The package is optional: it is imported when a
reference is asked for, and its absence raises ImportError naming it.

WMM2025 uncertainty (1 sigma, formulas.md): F 138 nT, dip 0.20 deg; the model
holds the core field only (no crustal anomaly, no storm): in-field referencing
(IFR) is what narrows it.
"""

from dataclasses import dataclass
import datetime
import math

#: Bundled coefficient file of each WMM epoch; each model holds for five years.
WMM_FILES = {
    2015: 'wmm/WMM_2015v2.COF',
    2020: 'wmm/WMM_2020.COF',
    2025: 'wmm/WMM_2025.COF',
}
WMM_LIFE_SPAN_YEARS = 5
REQUIREMENT = 'pygeomag>=1.1,<2'


@dataclass(frozen=True)
class ReferenceField:
    """
    The expected geomagnetic field at one place and time.

    ``total_nT`` is F, ``dip_deg`` the inclination I (positive downward),
    ``declination_deg`` D (positive east of true north); ``source`` says which
    model, where and when.
    """

    total_nT: float
    dip_deg: float
    declination_deg: float
    source: str


def decimal_year(date):
    """
    Return ``date`` as a decimal year: ``year + elapsed / length of the year``.

    Accepts a ``datetime.datetime`` (naive taken as UTC), a ``datetime.date``
    (midnight) or a number, already a decimal year.
    """
    if isinstance(date, (int, float)):
        return float(date)
    if not isinstance(date, datetime.datetime):
        date = datetime.datetime(date.year, date.month, date.day)
    if date.tzinfo is not None:
        date = date.astimezone(datetime.timezone.utc).replace(tzinfo=None)
    start = datetime.datetime(date.year, 1, 1)
    length = datetime.datetime(date.year + 1, 1, 1) - start
    return date.year + (date - start) / length


def reference_from_model(latitude_deg, longitude_deg, altitude_m, date):
    """
    Return the ReferenceField of the WMM at a site and date.

    ``latitude_deg``/``longitude_deg`` are WGS 84 geodetic (north, east
    positive), ``altitude_m`` the height above the ellipsoid (the WMM is
    specified from -1 km to 850 km), ``date`` a date, datetime or decimal year.
    The model is chosen by epoch (WMM2015v2, WMM2020, WMM2025); a date outside
    every model's five-year life span raises ValueError rather than
    extrapolating, and so does a site off the Earth (latitude beyond +-90 deg,
    longitude beyond -180..360 deg, a height outside the model's) or a
    non-finite number.  Raises ImportError when pygeomag is not installed.
    """
    if not (-90.0 <= latitude_deg <= 90.0 and -180.0 <= longitude_deg <= 360.0
            and -1000.0 <= altitude_m <= 850_000.0):
        raise ValueError(f'{latitude_deg} N, {longitude_deg} E, {altitude_m} m is no site of '
                         'the model (latitude -90..90, longitude -180..360 deg, height '
                         '-1000..850000 m)')
    year = decimal_year(date)
    if not math.isfinite(year):
        raise ValueError(f'{date} is not a date')
    epoch = WMM_LIFE_SPAN_YEARS * math.floor(year / WMM_LIFE_SPAN_YEARS)
    if epoch not in WMM_FILES:
        last = max(WMM_FILES) + WMM_LIFE_SPAN_YEARS
        raise ValueError(f'no bundled World Magnetic Model covers {year:.3f}; '
                         f'the models span {min(WMM_FILES)}-{last}')
    try:
        from pygeomag import GeoMag
    except ImportError as err:
        raise ImportError(f'the reference field needs the pygeomag package '
                          f'(pip install "{REQUIREMENT}")') from err
    model = GeoMag(coefficients_file=WMM_FILES[epoch])
    result = model.calculate(glat=latitude_deg, glon=longitude_deg,
                             alt=altitude_m / 1000.0, time=year)
    return ReferenceField(
        total_nT=result.f, dip_deg=result.i, declination_deg=result.d,
        source=(f'{model.model} (pygeomag) at {latitude_deg:.6f} N, {longitude_deg:.6f} E, '
                f'{altitude_m:.1f} m, {year:.4f}'))
