"""
Survey stations for the multi-station analysis (seed 002 §2.2), and their file.

A station is one still survey: the mean corrected specific force and the mean
RAW magnetometer reading, both in the z-up tool frame.  Keeping the field
raw lets a later rotation fit (cross-axial correction) apply to stations
taken before it.  ``msa_inputs`` turns stations into the ISCWSA G and B the
MSA solvers take.  The file is JSON, written atomically and validated on
load like the calibration file.
"""

from dataclasses import asdict, dataclass
import math
import os

from inclino_ros.core.cross_axial import apply_cross_axial
from inclino_ros.core.magnetics import gravity_from_specific_force, iscwsa_from_tool
from inclino_ros.io.files import read_json, write_json
import numpy as np

FORMAT = 'inclino_ros.calibration.stations'
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

    specific_force_mps2: tuple  # corrected accelerometer, tool frame
    field_nT: tuple             # raw magnetometer, tool frame
    samples: int
    captured_at: str
    temperature_c: float = None  # mean sensor temperature of the station; None: unknown


def msa_inputs(stations, model):
    """
    Return (G, B) of ``stations`` in the ISCWSA frame for the MSA solvers.

    B goes through the ``model``'s magnetometer stages before seed 002's (its
    temperature stage at each station's temperature, its reference where
    unknown; its own; the shared mount) and the cross-axial correction of its
    magnetic stage (W and c of a rotation fit), but keeps its interference:
    that is what MSA solves.
    """
    force = np.array([s.specific_force_mps2 for s in stations], dtype=float).reshape(-1, 3)
    temperatures_c = None
    if model.magnetometer_temperature is not None:
        reference_c = model.magnetometer_temperature.reference_temperature_c
        temperatures_c = [reference_c if s.temperature_c is None else s.temperature_c
                          for s in stations]
    field = model.apply_magnetic(
        np.array([s.field_nT for s in stations], dtype=float).reshape(-1, 3), temperatures_c,
        before='magnetic')
    if model.magnetic is not None:
        field = apply_cross_axial(field, model.magnetic)
    return gravity_from_specific_force(force), iscwsa_from_tool(field)


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
