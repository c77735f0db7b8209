"""
Survey stations for the multi-station analysis (seed 002 §2.2), and their file.

A station is one still survey: the mean corrected specific force and the mean
RAW magnetometer reading, both in the z-up tool frame.  Keeping the field
raw lets a later rotation fit (cross-axial correction) apply to stations
taken before it.  ``msa_inputs`` turns stations into the ISCWSA G and B the
MSA solvers take.  The file is JSON, written atomically and validated on
load like the calibration file.
"""

from dataclasses import asdict, dataclass, replace
import math
import os

from inclino_ros.calibration.provenance import utc_now_iso
from inclino_ros.calibration.stages import NO_MAGNETIC_CORRECTION
from inclino_ros.core.cross_axial import apply_cross_axial
from inclino_ros.core.magnetics import gravity_from_specific_force, iscwsa_from_tool
from inclino_ros.core.msa import (
    improved_cross_axial, MsaLimits, short_collar, solve_msa_axial, solve_msa_classic,
    solve_msa_improved)
from inclino_ros.io.files import read_json, write_json
import numpy as np

FORMAT = 'inclino_ros.calibration.stations'
#: The MSA solvers of a method name (``improved`` and ``short-collar``: ``solve_interference``).
SOLVERS = {'classic': solve_msa_classic, 'axial': solve_msa_axial}
SCHEMA_VERSION = 1


class StationsFileError(Exception):
    """A stations file that exists but cannot be trusted."""

    def __init__(self, path, reason):
        super().__init__(f'stations file {path}: {reason}')
        self.path = path
        self.reason = reason


@dataclass(frozen=True)
class Station:
    """One still survey, averaged."""

    specific_force_mps2: tuple  # corrected accelerometer, tool frame before the toolface mark
    field_nT: tuple             # raw magnetometer, tool frame
    samples: int
    captured_at: str
    temperature_c: float = None  # mean sensor temperature of the station; None: unknown


def corrected_field_nT(model, field_nT, temperatures_c=None):
    """
    Return raw tool-frame field readings (N, 3) as the MSA takes them [nT, tool frame].

    Through the ``model``'s magnetometer stages before seed 002's (its
    temperature stage at ``temperatures_c``, its reference where None; its
    own; the shared mount) and the cross-axial correction of its magnetic
    stage (W and c of a rotation fit; identity without one), but keeping its
    interference: that is what MSA solves.
    """
    field = model.apply_magnetic(np.asarray(field_nT, dtype=float).reshape(-1, 3),
                                 temperatures_c, before='magnetic')
    if model.magnetic is not None:
        field = apply_cross_axial(field, model.magnetic)
    return field


def msa_inputs(stations, model):
    """
    Return (G, B) of ``stations`` in the ISCWSA frame for the MSA solvers.

    B as ``corrected_field_nT`` gives it, each station at its temperature
    (the magnetometer temperature stage's reference where unknown).
    """
    force = np.array([s.specific_force_mps2 for s in stations], dtype=float).reshape(-1, 3)
    temperatures_c = None
    if model.magnetometer_temperature is not None:
        reference_c = model.magnetometer_temperature.reference_temperature_c
        temperatures_c = [reference_c if s.temperature_c is None else s.temperature_c
                          for s in stations]
    field = corrected_field_nT(model, [s.field_nT for s in stations], temperatures_c)
    return gravity_from_specific_force(force), iscwsa_from_tool(field)


def raw_survey_inputs(model, gravity, field_nT, gravity_mps2):
    """
    Return (G, B) of raw ISCWSA survey readings corrected by ``model`` for the MSA solvers.

    Both triads sit on one board (the shared mount): G (in any unit, here
    scaled by ``gravity_mps2`` to the accelerometer's m/s^2) goes through the
    accelerometer stages as B through ``corrected_field_nT``, or the two
    would be in frames the mount turns apart.  ISCWSA and tool axes differ
    by a turn about x (``magnetics.iscwsa_from_tool``, its own inverse); the
    tool's specific force is -G.
    """
    gravity = np.asarray(gravity, dtype=float)
    if model.stages:
        force = -iscwsa_from_tool(gravity) * gravity_mps2
        gravity = -iscwsa_from_tool(model.apply(force, before='toolface_mark')) / gravity_mps2
    return gravity, iscwsa_from_tool(corrected_field_nT(model, iscwsa_from_tool(field_nT)))


def solve_interference(method, gravity, field_nT, reference, reference_std,
                       rotation_fitted_at=None, given_nT=None, exclude_failing_qc=False,
                       azimuth_max_std_deg=MsaLimits.max_azimuth_std_deg):
    """
    Return (MsaResult, cross-axial source or None) of ``method`` over ISCWSA stations.

    ``improved`` (seed 002) takes the cross-axial part given, else zero
    after a rotation fit, else the classic solve's (``msa.improved_cross_axial``;
    MsaRefused otherwise); ``classic`` and ``axial`` solve as named;
    ``short-collar`` corrects each station alone.  ``reference``: (total nT,
    dip deg), ``reference_std`` their 1 sigma; ``azimuth_max_std_deg`` the
    outputs' limit on an azimuth's 1 sigma, which refuses a solution whose
    interference alone gives more (``MsaLimits.max_azimuth_std_deg``).
    """
    if method == 'short-collar':
        return short_collar(gravity, field_nT, *reference), None
    options = {'exclude_failing_qc': exclude_failing_qc, 'reference_std': reference_std,
               'limits': MsaLimits(max_azimuth_std_deg=azimuth_max_std_deg)}
    if method != 'improved':
        return SOLVERS[method](gravity, field_nT, *reference, **options), None
    cross_axial, source, covariance = improved_cross_axial(
        gravity, field_nT, *reference, given_nT=given_nT, rotation_fitted_at=rotation_fitted_at,
        **options)
    source = (f'cross-axial {cross_axial[0]:.1f}, {cross_axial[1]:.1f} nT: {source}'
              + ('' if covariance is not None else ' (its uncertainty not included)'))
    return solve_msa_improved(gravity, field_nT, *reference, cross_axial_nT=cross_axial,
                              cross_axial_covariance_nT2=covariance, **options), source


def with_interference(model, result, reference):
    """
    Return ``model`` whose magnetic stage holds the interference of the MsaResult ``result``.

    Solved in the ISCWSA frame, stored turned into the tool frame, with its
    1 sigma, the method, the stations used and the ``reference`` field
    (total nT, dip deg) it was solved against.
    """
    stage = replace(model.magnetic or NO_MAGNETIC_CORRECTION,
                    interference_nT=tuple(iscwsa_from_tool(result.eps_nT).tolist()),
                    interference_std_nT=tuple(result.eps_std_nT.tolist()),
                    msa_method=result.method,
                    msa_stations=int(result.diagnostics.stations_used),
                    msa_reference_total_nT=float(reference[0]),
                    msa_reference_dip_deg=float(reference[1]), msa_fitted_at=utc_now_iso())
    return replace(model, magnetic=stage)


def save_stations(path, stations):
    """Write the station list to ``path`` atomically."""
    write_json(os.path.expanduser(path), {'format': FORMAT, 'schema_version': SCHEMA_VERSION,
                                          'stations': [asdict(s) for s in stations]})


def load_stations(path):
    """Return the stations of ``path``: [] if there is no file, StationsFileError if invalid."""
    path = os.path.expanduser(path)
    try:
        doc = read_json(path)
    except FileNotFoundError:
        return []
    except ValueError as err:
        raise StationsFileError(path, str(err)) from None
    try:
        return _stations_from_dict(doc)
    except (KeyError, TypeError, ValueError) as err:
        raise StationsFileError(path, str(err)) from None


def _stations_from_dict(doc):
    if not isinstance(doc, dict) or doc.get('format') != FORMAT \
            or doc.get('schema_version') != SCHEMA_VERSION:
        raise ValueError(f'not an {FORMAT} version {SCHEMA_VERSION} document')
    stations = []
    for number, entry in enumerate(doc['stations'], start=1):
        station = Station(**entry)
        values = list(station.specific_force_mps2) + list(station.field_nT)
        if len(values) != 6 or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                       and math.isfinite(v) for v in values):
            raise ValueError(f'station {number} needs 3 + 3 finite numbers')
        if not isinstance(station.samples, int) or station.samples < 1:
            raise ValueError(f'station {number} has no samples')
        if station.temperature_c is not None and not (
                isinstance(station.temperature_c, (int, float))
                and math.isfinite(station.temperature_c)):
            raise ValueError(f'station {number} has a temperature that is not a number')
        stations.append(Station(tuple(station.specific_force_mps2), tuple(station.field_nT),
                                station.samples, station.captured_at, station.temperature_c))
    return stations
