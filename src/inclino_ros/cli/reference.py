"""
The reference field options of ``inclino msa`` and ``inclino process``.

The expected field (total intensity, dip, declination) comes from the
command line (``--reference-total-nT``, ``--reference-dip-deg``,
``--declination-deg``) or from the World Magnetic Model at a site
(``--site LAT LON ALT_M DATE``, ``reference_field.reference_from_model``,
offline through pygeomag); values given explicitly win over the site's.
Unusable values raise ValueError (the commands report it, exit code 2), and
so does ``--site`` without the optional pygeomag.
"""

import datetime

from inclino_ros.cli.options import dip_deg, node_parameter, reference_total_nT
from inclino_ros.core.reference_field import reference_from_model, REQUIREMENT


def add_reference_arguments(parser):
    """Add --reference-total-nT, --reference-dip-deg, --declination-deg and --site."""
    parser.add_argument('--reference-total-nT', type=reference_total_nT, metavar='F',
                        help='reference total field [nT] (e.g. WMM/IFR at the well)')
    parser.add_argument('--reference-dip-deg', type=dip_deg, metavar='D',
                        help='reference dip [deg], positive downward')
    parser.add_argument('--declination-deg', type=node_parameter('magnetic.declination_deg'),
                        metavar='X',
                        help='declination [deg], east positive: true azimuth = magnetic + X')
    parser.add_argument('--site', nargs=4, metavar=('LAT', 'LON', 'ALT_M', 'DATE'),
                        help='take F, D and the declination from the World Magnetic Model at '
                             'latitude, longitude [deg, WGS 84], height [m] and date '
                             '(YYYY-MM-DD or a decimal year); explicit values win')


def site_reference(site):
    """Return the ReferenceField of ``--site`` values (strings); ValueError if unusable."""
    try:
        latitude_deg, longitude_deg, altitude_m = (float(v) for v in site[:3])
        date = _date(site[3])
        return reference_from_model(latitude_deg, longitude_deg, altitude_m, date)
    except ImportError:  # pygeomag is optional (no rosdep key): only --site needs it
        raise ValueError(f'--site needs the Python package pygeomag: '
                         f'pip install "{REQUIREMENT}"') from None
    except ValueError as err:
        raise ValueError(f'--site {" ".join(site)}: {err}') from None


def _date(text):
    """Return ``YYYY-MM-DD`` as a date, a number as a decimal year; ValueError if neither."""
    if '-' in text.strip().lstrip('-+'):
        try:
            return datetime.date.fromisoformat(text)
        except ValueError as err:
            raise ValueError(f'the date {text!r} is no day of the calendar ({err})') from None
    try:
        return float(text)
    except ValueError:
        raise ValueError(f'the date {text!r} is neither YYYY-MM-DD nor a decimal year') from None


def resolve_reference(args, model=None):
    """
    Return (total_nT, dip_deg, declination_deg, source) of the options.

    Each of F and D comes from its option, else ``--site``, else the
    reference the calibration ``model``'s MSA was solved against
    (``Magnetic.msa_reference``, when neither option is given); None where
    none gives it, the declination too.  ValueError for an impossible value.
    """
    stage = None if model is None else model.magnetic
    fallback = (stage.msa_reference if stage is not None and stage.msa_reference is not None
                else (None, None))
    site = None if args.site is None else site_reference(args.site)
    total_nT, dip_deg, declination_deg = (
        args.reference_total_nT, args.reference_dip_deg, args.declination_deg)
    source = 'given'
    if site is not None:
        total_nT = site.total_nT if total_nT is None else total_nT
        dip_deg = site.dip_deg if dip_deg is None else dip_deg
        declination_deg = site.declination_deg if declination_deg is None else declination_deg
        source = site.source
    elif total_nT is None and dip_deg is None and fallback[0] is not None:
        total_nT, dip_deg = fallback
        source = 'the calibration file (MSA reference)'
    if total_nT is not None and not total_nT > 0.0:
        raise ValueError('--reference-total-nT must be positive')
    if dip_deg is not None and not -90.0 < dip_deg < 90.0:
        raise ValueError('--reference-dip-deg must lie strictly between -90 and 90')
    return total_nT, dip_deg, declination_deg, source
