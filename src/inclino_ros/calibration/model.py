"""
The calibration model: what is applied to every sample, and its file.

A model is an ordered set of correction stages applied to raw specific force
(three-axis sensors; a two-axis sensor has the installation stage only):

1. ``temperature``: seed 001 Eqs. 5-7, each axis divided by its scale factor
   K_T(T), with T clamped to the fitted range;
2. ``stand``: seed 001 Eqs. 10-11, ``K^-1 (A - b)`` from a multi-position
   stand (or the reference-free sphere fit);
3. ``installation``: seed 000 Eqs. 8-9, the level-bench angles gamma, beta.

The file is JSON, versioned, written atomically (temporary file, fsync,
rename, ``io.files``) and validated on load and before every write: its
structure here, what each stage can physically be in ``plausibility``; any
defect raises ``CalibrationFileError`` naming the file, never a silent zero
correction.
"""

from dataclasses import asdict, dataclass, fields
from datetime import datetime, timezone
from functools import cached_property
import math
import os

from inclino_ros.calibration import plausibility
from inclino_ros.core.cross_axial import apply_cross_axial
from inclino_ros.core.installation import (
    inverse_installation_matrix, pseudo_inclination, to_tool_frame)
from inclino_ros.core.stand import correct_stand
from inclino_ros.core.temperature import compensate_temperature, TemperatureFit
from inclino_ros.io.files import read_json, write_json
import numpy as np

FORMAT = 'inclino_ros.calibration'
SCHEMA_VERSION = 2
#: Versions load_model reads: version 1 files hold the installation stage only.
READABLE_VERSIONS = (1, 2)
STAGES = ('temperature', 'stand', 'installation')


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

    @cached_property
    def inverse_matrix(self):
        """Return C^-1 of seed 000 Eq. 8 for these angles (computed once)."""
        return inverse_installation_matrix(
            math.radians(self.gamma_deg), math.radians(self.beta_deg))

    def apply(self, f, temperature_c=None):
        """Return ``f`` (N x 3) in the ideal tool frame (seed 000 Eq. 9)."""
        return to_tool_frame(f, self.inverse_matrix)


@dataclass(frozen=True)
class Stand:
    """Seed 001 scale/misalignment matrix K and bias b: ``G = K^-1 (A - b)``."""

    scale_matrix: tuple        # K, 3 rows of 3, dimensionless
    bias_mps2: tuple           # b, 3 values
    method: str                # 'stand' (known attitudes) or 'sphere' (|G| = g only)
    condition_number: float    # of the fit's design matrix
    rms_inclination_deg: float  # residual at the stand positions; None for 'sphere'
    positions: int             # positions (stand) or readings (sphere) fitted
    fitted_at: str

    def apply(self, f, temperature_c=None):
        """Return ``K^-1 (f - b)`` (seed 001 Eq. 11) for ``f`` of shape (N, 3)."""
        return correct_stand(f, self.arrays[0], self.arrays[1])

    @cached_property
    def arrays(self):
        """Return K and b as numpy arrays, built once."""
        return np.array(self.scale_matrix), np.array(self.bias_mps2)


@dataclass(frozen=True)
class Temperature:
    """Seed 001 per-axis scale factor K_T(T), 1 at the reference temperature."""

    coefficients: tuple          # 3 rows of a0..an, T in deg C (Eq. 7)
    t_min_c: float               # fitted range; T is clamped to it
    t_max_c: float
    reference_temperature_c: float
    rms_residual_mps2: tuple     # per axis
    samples: int
    fitted_at: str

    @cached_property
    def fit(self):
        """Return the TemperatureFit of this stage (built once)."""
        return TemperatureFit(
            coefficients=np.array(self.coefficients), t_min_c=self.t_min_c,
            t_max_c=self.t_max_c, reference_temperature_c=self.reference_temperature_c,
            rms_residual_mps2=np.array(self.rms_residual_mps2))

    def clamp(self, temperature_c):
        """Return the temperatures clamped to the fitted range; NaN is the reference one."""
        temperature_c = np.asarray(temperature_c, dtype=float)
        return np.clip(np.where(np.isnan(temperature_c), self.reference_temperature_c,
                                temperature_c), self.t_min_c, self.t_max_c)

    def apply(self, f, temperature_c=None):
        """
        Return ``A_T / K_T(T)`` per axis (seed 001 Eq. 6), T clamped to the fitted range.

        Without a temperature (None, or NaN for a sample), the reference
        temperature is used (K_T = 1).
        """
        f = np.asarray(f, dtype=float)
        if temperature_c is None:
            temperature_c = self.reference_temperature_c
        temperature_c = np.broadcast_to(self.clamp(temperature_c), f.shape[:1])
        return compensate_temperature(f, temperature_c, self.fit)


@dataclass(frozen=True)
class Magnetic:
    """
    Seed 002 magnetometer corrections, all in the z-up tool frame, nT.

    ``B = W (m_xy - c)`` on the cross-axial axes (the per-rotation ellipse
    fit, seed 002 §2.1), then ``B - interference`` (the multi-station
    analysis, §2.2; solved in the ISCWSA frame and stored here turned into
    the tool frame).
    """

    hard_iron_nT: tuple        # c, tool x and y
    soft_iron: tuple           # W, 2 rows of 2 (identity without a rotation fit)
    interference_nT: tuple     # MSA eps in tool axes x, y, z
    rotation_fitted_at: str    # None until ~/capture_rotation
    msa_method: str            # None until ~/solve_msa, else improved/classic/axial
    msa_stations: int
    msa_reference_total_nT: float
    msa_reference_dip_deg: float
    msa_fitted_at: str

    @property
    def offset_nT(self):
        """Return c as an array (``cross_axial.apply_cross_axial`` reads it)."""
        return np.array(self.hard_iron_nT)

    @property
    def correction(self):
        """Return W as an array (``cross_axial.apply_cross_axial`` reads it)."""
        return np.array(self.soft_iron)

    def apply(self, b_nT):
        """Return corrected tool-frame field readings (..., 3) [nT]."""
        return apply_cross_axial(b_nT, self) - np.asarray(self.interference_nT)


@dataclass(frozen=True)
class CalibrationModel:
    """All corrections for one tool; a stage that is None is not applied."""

    accelerometer_axes: int
    installation: Installation = None
    stand: Stand = None
    temperature: Temperature = None
    magnetic: Magnetic = None

    @property
    def stages(self):
        """Return the names of the accelerometer stages present, in their order."""
        return tuple(name for name in STAGES if getattr(self, name) is not None)

    @property
    def calibrated(self):
        """Whether any accelerometer correction stage is present."""
        return bool(self.stages)

    def apply(self, f, temperature_c=None, before=None):
        """
        Return corrected specific force for raw ``f`` of shape (N, 3).

        Stages run in the order of STAGES; ``before`` names a stage to stop
        at (e.g. ``before='installation'`` gives the input of a level capture).
        """
        f = np.asarray(f, dtype=float)
        for name in STAGES:
            if name == before:
                break
            stage = getattr(self, name)
            if stage is not None:
                f = stage.apply(f, temperature_c)
        return f

    def apply_magnetic(self, b_nT):
        """Return corrected magnetometer readings (N, 3) [nT, tool frame]."""
        b_nT = np.asarray(b_nT, dtype=float)
        return b_nT if self.magnetic is None else self.magnetic.apply(b_nT)

    def to_dict(self):
        """Return the JSON-ready document of this model."""
        doc = {'format': FORMAT, 'schema_version': SCHEMA_VERSION,
               'accelerometer_axes': self.accelerometer_axes}
        for name in STAGES + ('magnetic',):
            stage = getattr(self, name)
            if stage is not None:
                doc[name] = asdict(stage)
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
    model_from_dict(model.to_dict())  # never write what load_model would refuse
    write_json(os.path.expanduser(path), model.to_dict())


def load_model(path):
    """
    Read and validate a calibration file.

    Raises FileNotFoundError when there is no file, CalibrationFileError when
    there is one that cannot be trusted.
    """
    path = os.path.expanduser(path)
    try:
        doc = read_json(path)
    except ValueError as err:
        raise CalibrationFileError(path, str(err)) from None
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
    version = doc.get('schema_version')
    if not is_int(version) or version not in READABLE_VERSIONS:
        raise ValueError(f'schema_version {version!r} is not one of {READABLE_VERSIONS}')
    axes = doc['accelerometer_axes']
    if not is_int(axes) or axes not in (2, 3):
        raise ValueError(f'accelerometer_axes {axes!r} is not 2 or 3')
    stages = STAGES + ('magnetic',) if version == SCHEMA_VERSION else ('installation',)
    unknown = set(doc) - {'format', 'schema_version', 'accelerometer_axes', *stages}
    if unknown:
        raise ValueError(f'unknown sections {sorted(unknown)} in a version {version} file')
    readers = {'installation': installation_from_dict, 'stand': stand_from_dict,
               'temperature': temperature_from_dict, 'magnetic': magnetic_from_dict}
    model = CalibrationModel(accelerometer_axes=axes, **{
        name: readers[name](doc[name]) for name in stages if doc.get(name) is not None})
    if axes == 2 and (model.stand or model.temperature):
        raise ValueError('stand and temperature stages need a three-axis accelerometer')
    return model


def _check_fields(section, kind, name):
    """Raise ValueError unless ``section`` has exactly the fields of dataclass ``kind``."""
    expected = {f.name for f in fields(kind)}
    if not isinstance(section, dict) or set(section) != expected:
        got = sorted(section) if isinstance(section, dict) else section
        raise ValueError(f'{name} needs exactly the fields {sorted(expected)}, got {got}')


def _finite(section, name, *keys, shape=()):
    """Return ``section[key]`` as finite float arrays of ``shape``; ValueError if not."""
    values = []
    for key in keys:
        value = section[key]
        array = np.asarray(value, dtype=object)
        if array.shape != shape or any(
                isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                for v in array.flat):
            what = 'a finite number' if shape == () else f'finite numbers of shape {shape}'
            raise ValueError(f'{name}.{key} = {value!r} is not {what}')
        values.append(np.asarray(value, dtype=float))
    return values


def _count(section, name, key):
    """Raise ValueError unless ``section[key]`` is a positive integer."""
    if not is_int(section[key]) or section[key] < 1:
        raise ValueError(f'{name}.{key} = {section[key]!r} is not a positive integer')


def _time(section, name, key):
    """Raise ValueError unless ``section[key]`` is an ISO 8601 time with a zone."""
    try:
        moment = datetime.fromisoformat(section[key])
    except (TypeError, ValueError):
        raise ValueError(f'{name}.{key} = {section[key]!r} is not an ISO 8601 time') from None
    if moment.tzinfo is None:
        raise ValueError(f'{name}.{key} has no time zone')


def installation_from_dict(section):
    """Return a validated Installation from its file section."""
    _check_fields(section, Installation, 'installation')
    _finite(section, 'installation', 'gamma_deg', 'beta_deg', 'std_deg', 'g_total_mps2')
    _count(section, 'installation', 'sample_count')
    _time(section, 'installation', 'captured_at')
    stage = Installation(**section)
    plausibility.check_installation(stage)
    return stage


def stand_from_dict(section):
    """Return a validated Stand from its file section."""
    _check_fields(section, Stand, 'stand')
    (k,) = _finite(section, 'stand', 'scale_matrix', shape=(3, 3))
    _finite(section, 'stand', 'bias_mps2', shape=(3,))
    _finite(section, 'stand', 'condition_number')
    if section['method'] not in ('stand', 'sphere'):
        raise ValueError(f'stand.method = {section["method"]!r} is not stand or sphere')
    if section['rms_inclination_deg'] is not None:
        _finite(section, 'stand', 'rms_inclination_deg')
    _count(section, 'stand', 'positions')
    _time(section, 'stand', 'fitted_at')
    stage = Stand(**dict(section, scale_matrix=tuple(map(tuple, k.tolist())),
                         bias_mps2=tuple(section['bias_mps2'])))
    plausibility.check_stand(stage)
    return stage


def temperature_from_dict(section):
    """Return a validated Temperature from its file section."""
    _check_fields(section, Temperature, 'temperature')
    coefficients = np.asarray(section['coefficients'], dtype=object)
    if coefficients.ndim != 2 or coefficients.shape[0] != 3 or coefficients.shape[1] < 1:
        raise ValueError('temperature.coefficients must be 3 rows of a0..an')
    _finite(section, 'temperature', 'coefficients', shape=coefficients.shape)
    t_min, t_max, t_ref = _finite(section, 'temperature', 't_min_c', 't_max_c',
                                  'reference_temperature_c')
    _finite(section, 'temperature', 'rms_residual_mps2', shape=(3,))
    if not t_min <= t_ref <= t_max or t_min == t_max:
        raise ValueError(f'temperature range [{t_min}, {t_max}] C is empty or does not '
                         f'contain the reference {t_ref} C')
    _count(section, 'temperature', 'samples')
    _time(section, 'temperature', 'fitted_at')
    stage = Temperature(**dict(section, coefficients=tuple(map(tuple, section['coefficients'])),
                               rms_residual_mps2=tuple(section['rms_residual_mps2'])))
    plausibility.check_temperature(stage)
    return stage


def magnetic_from_dict(section):
    """Return a validated Magnetic from its file section."""
    _check_fields(section, Magnetic, 'magnetic')
    _finite(section, 'magnetic', 'soft_iron', shape=(2, 2))
    _finite(section, 'magnetic', 'hard_iron_nT', shape=(2,))
    _finite(section, 'magnetic', 'interference_nT', shape=(3,))
    for key in ('rotation_fitted_at', 'msa_fitted_at'):
        if section[key] is not None:
            _time(section, 'magnetic', key)
    if section['msa_method'] is not None:
        if section['msa_method'] not in ('improved', 'classic', 'axial'):
            raise ValueError(f'magnetic.msa_method = {section["msa_method"]!r} is unknown')
        _count(section, 'magnetic', 'msa_stations')
        _finite(section, 'magnetic', 'msa_reference_total_nT', 'msa_reference_dip_deg')
    stage = Magnetic(**dict(section, hard_iron_nT=tuple(section['hard_iron_nT']),
                            soft_iron=tuple(map(tuple, section['soft_iron'])),
                            interference_nT=tuple(section['interference_nT'])))
    plausibility.check_magnetic(stage)
    return stage


#: A magnetic stage that changes nothing, to build the first correction on.
NO_MAGNETIC_CORRECTION = Magnetic(
    hard_iron_nT=(0.0, 0.0), soft_iron=((1.0, 0.0), (0.0, 1.0)),
    interference_nT=(0.0, 0.0, 0.0), rotation_fitted_at=None, msa_method=None,
    msa_stations=0, msa_reference_total_nT=0.0, msa_reference_dip_deg=0.0, msa_fitted_at=None)
