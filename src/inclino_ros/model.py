"""
The calibration model: what is applied to every sample, and its file.

A model is an ordered set of correction stages applied to raw specific force.
Seed 000's installation correction (gamma, beta) is the one stage so far;
later stages (seed 001's scale matrix and temperature drift) go before it,
as new optional sections of the same versioned file.

The file is JSON, written atomically (temporary file, fsync, rename) and
validated on load; any defect raises ``CalibrationFileError`` naming the file,
never a silent zero correction.
"""

from dataclasses import asdict, dataclass
from datetime import datetime, timezone
import json
import math
import os
import tempfile

from inclino_ros.installation import correct_installation, pseudo_inclination
import numpy as np

FORMAT = 'inclino_ros.calibration'
SCHEMA_VERSION = 1


class CalibrationFileError(Exception):
    """A calibration file that exists but cannot be trusted."""

    def __init__(self, path, reason):
        super().__init__(f'calibration file {path}: {reason}')
        self.path = path
        self.reason = reason


@dataclass(frozen=True)
class Installation:
    """Seed 000 installation angles with the provenance of their capture."""

    gamma_deg: float
    beta_deg: float
    captured_at: str
    sample_count: int
    std_deg: float
    g_total_mps2: float

    @property
    def theta_deg(self):
        """Return the false tilt of the sensor on a level bench (seed 000 Eq. 4)."""
        return math.degrees(float(pseudo_inclination(
            math.radians(self.gamma_deg), math.radians(self.beta_deg))))

    def apply(self, f):
        """Return ``f`` (N x 3) in the ideal tool frame (seed 000 Eq. 9)."""
        return correct_installation(
            f, math.radians(self.gamma_deg), math.radians(self.beta_deg))


@dataclass(frozen=True)
class CalibrationModel:
    """All corrections for one tool; ``installation`` None means uncalibrated."""

    accelerometer_axes: int
    installation: Installation = None

    @property
    def calibrated(self):
        """Whether any correction stage is present."""
        return self.installation is not None

    def apply(self, f):
        """Return corrected specific force for raw ``f`` of shape (N, 3)."""
        if self.installation is None:
            return np.asarray(f, dtype=float)
        return self.installation.apply(f)

    def to_dict(self):
        """Return the JSON-ready document of this model."""
        doc = {'format': FORMAT, 'schema_version': SCHEMA_VERSION,
               'accelerometer_axes': self.accelerometer_axes}
        if self.installation is not None:
            doc['installation'] = asdict(self.installation)
        return doc


def utc_now_iso():
    """Return the current UTC time as an ISO 8601 string."""
    return datetime.now(timezone.utc).isoformat(timespec='seconds')


def age_seconds(iso_time, now=None):
    """Return the seconds elapsed since ``iso_time`` (an ISO 8601 string)."""
    now = now or datetime.now(timezone.utc)
    return (now - datetime.fromisoformat(iso_time)).total_seconds()


def save_model(path, model):
    """Write ``model`` to ``path`` atomically: a reader sees old or new, whole."""
    path = os.path.abspath(os.path.expanduser(path))
    model_from_dict(model.to_dict())  # never write what load_model would refuse
    folder = os.path.dirname(path)
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix='.calibration-', suffix='.tmp', dir=folder)
    try:
        with os.fdopen(fd, 'w') as out:
            json.dump(model.to_dict(), out, indent=2)
            out.write('\n')
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    dir_fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def load_model(path):
    """
    Read and validate a calibration file.

    Raises FileNotFoundError when there is no file, CalibrationFileError when
    there is one that cannot be trusted.
    """
    path = os.path.expanduser(path)
    with open(path, 'rb') as stream:
        data = stream.read()
    try:
        # From bytes, so undecodable garbage is a ValueError (UnicodeDecodeError) here too.
        doc = json.loads(data)
    except (ValueError, RecursionError) as err:
        raise CalibrationFileError(path, f'not valid JSON ({err})') from None
    try:
        return model_from_dict(doc)
    except (KeyError, TypeError, ValueError, OverflowError) as err:
        raise CalibrationFileError(path, str(err)) from None


def is_int(value):
    """Return whether ``value`` is a JSON integer (not a bool, not a float)."""
    return isinstance(value, int) and not isinstance(value, bool)


def model_from_dict(doc):
    """Return the model of a parsed document; ValueError/KeyError if invalid."""
    if not isinstance(doc, dict) or doc.get('format') != FORMAT:
        raise ValueError(f'not an {FORMAT} document')
    if not is_int(doc.get('schema_version')) or doc['schema_version'] != SCHEMA_VERSION:
        raise ValueError(f'schema_version {doc.get("schema_version")!r} is not '
                         f'{SCHEMA_VERSION}')
    axes = doc['accelerometer_axes']
    if not is_int(axes) or axes not in (2, 3):
        raise ValueError(f'accelerometer_axes {axes!r} is not 2 or 3')
    known = {'format', 'schema_version', 'accelerometer_axes', 'installation'}
    unknown = set(doc) - known
    if unknown:
        raise ValueError(f'unknown sections {sorted(unknown)}')
    section = doc.get('installation')
    return CalibrationModel(
        accelerometer_axes=axes,
        installation=None if section is None else installation_from_dict(section))


def installation_from_dict(section):
    """Return a validated Installation from its file section."""
    fields = set(Installation.__dataclass_fields__)
    if set(section) != fields:
        raise ValueError(f'installation needs exactly the fields {sorted(fields)}, '
                         f'got {sorted(section)}')
    for name in ('gamma_deg', 'beta_deg', 'std_deg', 'g_total_mps2'):
        value = section[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            raise ValueError(f'installation.{name} = {value!r} is not a finite number')
    for name in ('gamma_deg', 'beta_deg'):
        if abs(section[name]) >= 45.0:
            raise ValueError(f'installation.{name} = {section[name]} is not an '
                             'installation error (|angle| must be < 45 deg)')
    count = section['sample_count']
    if not is_int(count) or count < 1:
        raise ValueError(f'installation.sample_count = {count!r} is not a positive integer')
    if section['std_deg'] < 0 or section['g_total_mps2'] <= 0:
        raise ValueError('installation.std_deg must be >= 0 and g_total_mps2 > 0')
    try:
        captured = datetime.fromisoformat(section['captured_at'])
    except (TypeError, ValueError):
        raise ValueError(f'installation.captured_at = {section["captured_at"]!r} is not '
                         'an ISO 8601 time') from None
    if captured.tzinfo is None:
        raise ValueError('installation.captured_at has no time zone')
    return Installation(**section)
