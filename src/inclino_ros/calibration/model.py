"""
The calibration model: what is applied to every sample, and its file.

A model is an ordered set of correction stages.  Each triad has its own, and
both share the mount.  Raw specific force (three-axis sensors; a two-axis
sensor has the mount stages only) goes through:

1. ``temperature``: seed 001 Eqs. 5-7 with a bias drift, each axis
   ``(A - B_T(T)) / K_T(T)``, with T clamped to the fitted range;
2. ``stand``: seed 001 Eqs. 10-11, ``K^-1 (A - b)`` from a multi-position
   stand (or the reference-free sphere fit); its output is the
   accelerometer frame;
3. ``installation`` (shared mount): seed 000 Eqs. 8-9, the level-bench
   angles gamma, beta;
4. ``tool_axis`` (shared mount): the same rotation found from roll groups
   (``inclino fit-magnetometer``), measured after the installation stage.

Raw magnetometer readings [nT] go through their own stages into the
accelerometer frame, then the same mount, then seed 002's corrections:

1. ``magnetometer``: seed 001 Eq. 12, ``K_m^-1 (m - b_m)`` (scale,
   non-orthogonality, hard and soft iron) from the stand or the ellipsoid;
2. ``magnetometer_alignment``: the rotation of the magnetometer's axes into
   the accelerometer's sensing axes (identity without the stage: the
   magnetometer sits on the accelerometer's axes), then the rotation the
   accelerometer's own ``stand`` correction gives those axes
   (``Stand.rotation``), so that a new accelerometer calibration carries
   the magnetometer along;
3. ``installation``, ``tool_axis``: the shared mount, as above;
4. ``magnetic``: seed 002's cross-axial correction and interference.

The magnetometer has its own: ``magnetometer_temperature`` (the same
temperature model in nT) and ``magnetic`` (seed 002).  Every stage records
the temperature its readings stood for (``temperature_c``; None: unknown);
the file names the sensor it belongs to (``sensor_id``).

The file is JSON, versioned, written atomically (temporary file, fsync,
rename, ``io.files``) and validated on load and before every write: its
structure here, what each stage can physically be in ``plausibility``; any
defect raises ``CalibrationFileError`` naming the file, never a silent zero
correction.  ``save_model`` is the one door of every write (node services,
``inclino fit-*``, ``msa``, ``calibration restore``): it keeps every version
in the file's history (``calibration.history``) and refuses to write over a
file that changed since the writer read it (``CalibrationChanged``).
"""

from dataclasses import asdict, dataclass, fields
from datetime import datetime, timezone
from functools import cached_property
import json
import math
import os

from inclino_ros.calibration import history, plausibility
from inclino_ros.core.cross_axial import apply_cross_axial
from inclino_ros.core.installation import (
    inverse_installation_matrix, pseudo_inclination, to_tool_frame)
from inclino_ros.core.stand import correct_stand, rotation_part
from inclino_ros.core.temperature import compensate_temperature, TemperatureFit
from inclino_ros.io.files import loads_strict, Outputs, read_json, write_text
import numpy as np

#: Gravity [m/s^2] against which a temperature residual becomes an angle.
STANDARD_GRAVITY_MPS2 = 9.80665

FORMAT = 'inclino_ros.calibration'
SCHEMA_VERSION = 3
#: Versions load_model reads: version 1 files hold the installation stage only,
#: version 2 files no magnetometer, tool-axis or magnetometer temperature stage and lack
#: the fields version 3 added to theirs (``VERSION_3_FIELDS``).
READABLE_VERSIONS = (1, 2, 3)
#: The accelerometer's stages, in the order they are applied.
STAGES = ('temperature', 'stand', 'installation', 'tool_axis')
#: The stages both triads share: the mount.
MOUNT_STAGES = ('installation', 'tool_axis')
#: The magnetometer's stages, in the order they are applied (the mount included).
MAGNETOMETER_STAGES = ('magnetometer_temperature', 'magnetometer',
                       'magnetometer_alignment') + MOUNT_STAGES + ('magnetic',)
#: Sections of each readable schema version.
SECTIONS = {1: ('installation',),
            2: ('temperature', 'stand', 'installation', 'magnetic'),
            3: STAGES + ('magnetometer_temperature', 'magnetometer', 'magnetometer_alignment',
                         'magnetic')}
#: Fields version 3 added, with the value an older file's section gets.
VERSION_3_FIELDS = {
    'installation': {'temperature_c': None},
    'stand': {'temperature_c': None},
    'temperature': {'bias_coefficients_mps2': None, 'attitudes': 1},
    'magnetic': {'interference_std_nT': None, 'rotation_temperature_c': None},
}


class CalibrationFileError(Exception):
    """A calibration file that exists but cannot be trusted."""

    def __init__(self, path, reason):
        super().__init__(f'calibration file {path}: {reason}')
        self.path = path
        self.reason = reason


class CalibrationChanged(Exception):
    """The file changed on disk since its writer read it: nothing written, the file kept."""

    def __init__(self, path):
        """Name the file that changed."""
        super().__init__(
            f'{path} changed on disk since it was read (another writer, e.g. an inclino fit-* '
            'command, replaced it): not written over, so the stages it holds are kept; read it '
            'again (restart the node) and redo this calibration on top of it')


#: ``save_model``'s ``based_on`` when the file on disk is not compared.
UNCHECKED = object()


class _SeedZeroRotation:
    """A rotation of seed 000's form (gamma about Y, beta about X', Eq. 1) from sensor to tool."""

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
class Installation(_SeedZeroRotation):
    """Seed 000 installation angles with the provenance of their capture."""

    gamma_deg: float
    beta_deg: float
    captured_at: str
    sample_count: int
    std_deg: float             # per-sample noise of one axis tilt; std / sqrt(N): 1 sigma
    g_total_mps2: float
    temperature_c: float = None  # what the captured readings stood for; None: unknown

    @property
    def tilt_std_rad(self):
        """Return the 1 sigma of the captured tilt: the standard error of its mean [rad]."""
        return math.radians(self.std_deg) / math.sqrt(self.sample_count)


@dataclass(frozen=True)
class ToolAxis(_SeedZeroRotation):
    """
    The tool axis found from roll groups, as seed 000's gamma, beta (shared mount).

    Shots taken with the tool axis held in one direction and the tool turned
    about it keep the components of gravity and field along that axis
    constant (``core.shots``): the axis, in the frame after the installation
    stage, is the level-bench reading of a vertical tool (``u = C e_z``,
    seed 000 Eqs. 11-14), without a level bench.
    """

    gamma_deg: float
    beta_deg: float
    roll_groups: int
    shots: int
    axial_rms_deg: float       # what the fit leaves of the within-group axial spread
    fitted_at: str


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
    temperature_c: float = None  # what the captured readings stood for; None: unknown

    @property
    def tilt_std_rad(self):
        """Return the fit's own inclination residual as the stage's tilt 1 sigma [rad]."""
        return math.radians(self.rms_inclination_deg or 0.0)

    def apply(self, f, temperature_c=None):
        """Return ``K^-1 (f - b)`` (seed 001 Eq. 11) for ``f`` of shape (N, 3)."""
        return correct_stand(f, self.arrays[0], self.arrays[1])

    @cached_property
    def arrays(self):
        """Return K and b as numpy arrays, built once."""
        return np.array(self.scale_matrix), np.array(self.bias_mps2)

    @cached_property
    def rotation(self):
        """
        Return the rotation ``K^-1`` gives the sensing axes (``stand.rotation_part``).

        The magnetometer, sitting on the accelerometer's axes, is turned by it
        too: for a stand fit it holds the mount, for a sphere fit the turn of
        its upper-triangular convention.
        """
        return rotation_part(np.linalg.inv(self.arrays[0]))


@dataclass(frozen=True)
class Magnetometer:
    """
    The magnetometer's own correction ``B = K_m^-1 (m - b_m)`` (seed 001 Eq. 12) [nT].

    K_m holds the axis scales, their non-orthogonality and the soft iron,
    b_m the bias and hard iron (and any field fixed to the tool when it was
    fitted).  ``method``: ``stand`` (Eq. 12 against the field expected at
    known stand attitudes) or ``ellipsoid`` (``inclino fit-magnetometer``,
    no reference: K_m symmetric, scaled to ``field_nT``).
    """

    scale_matrix: tuple        # K_m, 3 rows of 3
    bias_nT: tuple             # b_m
    method: str
    condition_number: float
    rms_residual_nT: float     # stand: |corrected - expected|; ellipsoid: |B| - field_nT
    field_nT: float            # the total field the scale refers to
    positions: int             # stand positions or shots
    fitted_at: str

    @cached_property
    def arrays(self):
        """Return K_m and b_m as numpy arrays, built once."""
        return np.array(self.scale_matrix), np.array(self.bias_nT)

    def apply(self, b_nT):
        """Return ``K_m^-1 (m - b_m)`` for readings (N, 3)."""
        return correct_stand(b_nT, *self.arrays)


@dataclass(frozen=True)
class MagnetometerAlignment:
    """
    The rotation R of the magnetometer's axes into the accelerometer's sensing axes.

    ``v_accelerometer = R v_magnetometer``.  ``method``: ``dip`` (from the
    constancy of the dip, ``inclino fit-magnetometer``), ``stand`` (the turn
    of the magnetometer's stand K_m, seed 001 Eq. 12) or ``given`` (a known
    mounting).  ``dip_deg`` and ``dip_rms_deg``: the constant dip the fit
    found and what it leaves (None otherwise).
    """

    rotation: tuple            # R, 3 rows of 3
    method: str
    dip_deg: float
    dip_rms_deg: float
    shots: int
    fitted_at: str

    @cached_property
    def matrix(self):
        """Return R as a numpy array, built once."""
        return np.array(self.rotation)

    @property
    def angle_deg(self):
        """Return the angle of the rotation [deg]."""
        return math.degrees(math.acos(float(np.clip((np.trace(self.matrix) - 1.0) / 2.0,
                                                    -1.0, 1.0))))


class _TemperatureStage:
    """
    What the temperature stages of both triads do (seed 001 Eqs. 5-7 with a bias drift).

    ``A = (A_T - B_T(T)) / K_T(T)`` per axis, T clamped to the fitted range;
    readings then stand for ``reference_temperature_c``.
    """

    @cached_property
    def fit(self):
        """Return the TemperatureFit of this stage (built once)."""
        bias = self._bias_coefficients
        return TemperatureFit(
            coefficients=np.array(self.coefficients), t_min_c=self.t_min_c,
            t_max_c=self.t_max_c, reference_temperature_c=self.reference_temperature_c,
            rms_residual=np.array(self._rms_residual),
            bias_coefficients=None if bias is None else np.array(bias),
            attitudes=self.attitudes)

    def clamp(self, temperature_c):
        """Return the temperatures clamped to the fitted range; NaN is the reference one."""
        temperature_c = np.asarray(temperature_c, dtype=float)
        return np.clip(np.where(np.isnan(temperature_c), self.reference_temperature_c,
                                temperature_c), self.t_min_c, self.t_max_c)

    def apply(self, f, temperature_c=None):
        """
        Return ``(A_T - B_T(T)) / K_T(T)`` per axis (seed 001 Eq. 6), T clamped to the range.

        Without a temperature (None, or NaN for a sample), the reference
        temperature is used (no change).
        """
        f = np.asarray(f, dtype=float)
        if temperature_c is None:
            temperature_c = self.reference_temperature_c
        temperature_c = np.broadcast_to(self.clamp(temperature_c), f.shape[:1])
        return compensate_temperature(f, temperature_c, self.fit)

    def residual_angle_rad(self, magnitude):
        """Return the fit's RMS residual as an angle against a vector of ``magnitude``."""
        return float(np.sqrt(np.mean(np.square(self._rms_residual)))) / magnitude


@dataclass(frozen=True)
class Temperature(_TemperatureStage):
    """Accelerometer temperature drift: K_T(T) per axis (1 at the reference) and B_T(T)."""

    coefficients: tuple          # 3 rows of a0..an, T in deg C (Eq. 7)
    t_min_c: float               # fitted range; T is clamped to it
    t_max_c: float
    reference_temperature_c: float
    rms_residual_mps2: tuple     # per axis
    samples: int
    fitted_at: str
    bias_coefficients_mps2: tuple = None  # 3 rows of b0..bn, 0 at the reference; None: none
    attitudes: int = 1           # 1: scale only (seed 001); >= 2: bias and scale

    @property
    def _bias_coefficients(self):
        return self.bias_coefficients_mps2

    @property
    def _rms_residual(self):
        return self.rms_residual_mps2


@dataclass(frozen=True)
class MagnetometerTemperature(_TemperatureStage):
    """Magnetometer temperature drift, the same model in nT (seed 001 §3.2)."""

    coefficients: tuple
    t_min_c: float
    t_max_c: float
    reference_temperature_c: float
    rms_residual_nT: tuple
    samples: int
    fitted_at: str
    bias_coefficients_nT: tuple = None
    attitudes: int = 1

    @property
    def _bias_coefficients(self):
        return self.bias_coefficients_nT

    @property
    def _rms_residual(self):
        return self.rms_residual_nT


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
    interference_std_nT: tuple = None  # 1 sigma of the MSA interference (tool axes), None
    rotation_temperature_c: float = None  # what the rotation's readings stood for

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
    tool_axis: ToolAxis = None
    magnetometer: Magnetometer = None
    magnetometer_alignment: MagnetometerAlignment = None
    magnetometer_temperature: MagnetometerTemperature = None
    sensor_id: str = None     # the sensor this calibration belongs to; None: not named

    @property
    def stages(self):
        """Return the names of the accelerometer stages present, in their order."""
        return tuple(name for name in STAGES if getattr(self, name) is not None)

    @property
    def magnetometer_stages(self):
        """Return the names of the magnetometer stages present (the mount included), in order."""
        return tuple(name for name in MAGNETOMETER_STAGES if getattr(self, name) is not None)

    @cached_property
    def magnetometer_rotation(self):
        """
        Return the rotation taking the magnetometer's corrected axes into the accelerometer frame.

        ``Stand.rotation`` (the turn of the accelerometer's own correction,
        identity without a stand stage) after the alignment's R (identity
        without one): the magnetometer follows the accelerometer's axes.
        """
        rotation = np.eye(3) if self.stand is None else self.stand.rotation
        if self.magnetometer_alignment is not None:
            rotation = rotation @ self.magnetometer_alignment.matrix
        return rotation

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

    def apply_magnetic(self, b_nT, temperature_c=None, before=None):
        """
        Return corrected magnetometer readings (N, 3) [nT, tool frame].

        Stages run in the order of MAGNETOMETER_STAGES, the temperature stage
        at ``temperature_c`` (None: its reference); ``before`` names one to
        stop at (``before='magnetic'``: the input of seed 002's fits).  The
        alignment's rotation is applied with the accelerometer's
        (``magnetometer_rotation``) even without an alignment stage.
        """
        b_nT = np.asarray(b_nT, dtype=float)
        for name in MAGNETOMETER_STAGES:
            if name == before:
                break
            if name == 'magnetometer_alignment':
                if self.magnetometer_alignment is not None or self.stand is not None:
                    b_nT = to_tool_frame(b_nT, self.magnetometer_rotation)
                continue
            stage = getattr(self, name)
            if stage is None:
                continue
            if name == 'magnetometer_temperature':
                b_nT = stage.apply(b_nT.reshape(-1, 3), temperature_c).reshape(b_nT.shape)
            else:
                b_nT = stage.apply(b_nT)
        return b_nT

    @cached_property
    def linear_map(self):
        """
        Return the 3x3 matrix the stand and mount stages apply (C^-1 K^-1), built once.

        What turns the sensor's noise into the corrected reading's (the
        temperature stage's scale, within a few percent of 1, is left out).
        """
        matrix = np.eye(3)
        if self.stand is not None:
            matrix = np.linalg.inv(self.stand.arrays[0]) @ matrix
        for stage in (self.installation, self.tool_axis):
            if stage is not None:
                matrix = stage.inverse_matrix @ matrix
        return matrix

    @property
    def tilt_std_rad(self):
        """
        Return the 1 sigma of the corrected tilt from the calibration itself [rad].

        The stages' own uncertainties, independent, added in quadrature: the
        installation capture's standard error, the stand fit's inclination
        residual, the temperature fit's residual as an angle against g.
        """
        variance = sum(stage.tilt_std_rad ** 2 for stage in (self.installation, self.stand)
                       if stage is not None)
        if self.temperature is not None:
            variance += self.temperature.residual_angle_rad(STANDARD_GRAVITY_MPS2) ** 2
        return math.sqrt(variance)

    def to_dict(self):
        """Return the JSON-ready document of this model."""
        doc = {'format': FORMAT, 'schema_version': SCHEMA_VERSION,
               'accelerometer_axes': self.accelerometer_axes, 'sensor_id': self.sensor_id}
        for name in SECTIONS[SCHEMA_VERSION]:
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


def model_text(model):
    """Return the text of the calibration file of ``model``."""
    return json.dumps(model.to_dict(), indent=2) + '\n'


#: Writer recorded for a version written from Python (scripts, tests) rather than a command.
PYTHON_WRITER = 'python (inclino_ros.calibration.model.save_model)'


def save_model(path, model, writer=PYTHON_WRITER, outputs=None, based_on=UNCHECKED):
    """
    Write ``model`` to ``path`` atomically, its new version kept in the history; return its digest.

    The one door of every calibration write: a reader sees old or new,
    whole; the file's history (``calibration.history``) receives the new
    version, and the one on disk first if it lacks it, in the same commit,
    as written by ``writer`` (e.g. ``'node ~/calibrate_level'``).  With
    ``outputs`` (an open ``io.files.Outputs``) the file is one output of that
    command, renamed into place with its others.  ``based_on``: the digest of
    the file the writer read (``history.file_digest``; None: there was none);
    when the file on disk is another one at the commit, CalibrationChanged and
    nothing is written.  ValueError for a model load_model would refuse.
    """
    path = os.path.abspath(os.path.expanduser(path))
    model_from_dict(model.to_dict())  # never write what load_model would refuse
    if outputs is None:
        with Outputs(force=True) as own:
            return save_model(path, model, writer, own, based_on)
    text = model_text(model)

    def unchanged():
        if based_on is not UNCHECKED and history.file_digest(path) != based_on:
            raise CalibrationChanged(path)

    unchanged()
    outputs.require(unchanged)
    history.record(path, text, writer, model.sensor_id, utc_now_iso(), outputs)
    write_text(path, text, outputs=outputs, update=True)
    return history.digest(text)


def load_model(path, with_digest=False):
    """
    Read and validate a calibration file.

    Raises FileNotFoundError when there is no file, CalibrationFileError when
    there is one that cannot be trusted (a FIFO or a device too, never
    waited on).  ``with_digest``: return (model, the digest of the bytes it
    was read from), the ``based_on`` of a later ``save_model``.
    """
    path = os.path.expanduser(path)
    try:
        doc, sha256 = read_json(path, with_digest=True)
    except ValueError as err:
        raise CalibrationFileError(path, str(err)) from None
    try:
        model = model_from_dict(doc)
    except (KeyError, TypeError, ValueError, OverflowError) as err:
        raise CalibrationFileError(path, str(err)) from None
    return (model, sha256) if with_digest else model


def _check_text(text):
    """Raise ValueError unless ``text`` is a valid calibration file's text."""
    try:
        model_from_dict(loads_strict(text))
    except (KeyError, TypeError, ValueError, OverflowError, RecursionError) as err:
        raise ValueError(f'not a valid calibration ({err})') from None


def read_model_history(path):
    """Return (versions, problems) of the history of ``path``, each version validated."""
    return history.read_history(path, _check_text)


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
    stages = SECTIONS[version]
    top = {'format', 'schema_version', 'accelerometer_axes'} | (
        {'sensor_id'} if version >= 3 else set())
    unknown = set(doc) - top - set(stages)
    if unknown:
        raise ValueError(f'unknown sections {sorted(unknown)} in a version {version} file')
    sensor_id = doc.get('sensor_id') if version >= 3 else None
    if sensor_id is not None and not isinstance(sensor_id, str):
        raise ValueError(f'sensor_id {sensor_id!r} is not a string')
    readers = {'installation': installation_from_dict, 'stand': stand_from_dict,
               'temperature': temperature_from_dict, 'magnetic': magnetic_from_dict,
               'tool_axis': tool_axis_from_dict, 'magnetometer': magnetometer_from_dict,
               'magnetometer_alignment': alignment_from_dict,
               'magnetometer_temperature': magnetometer_temperature_from_dict}
    sections = {name: _upgraded(doc[name], name, version)
                for name in stages if doc.get(name) is not None}
    model = CalibrationModel(accelerometer_axes=axes, sensor_id=sensor_id, **{
        name: readers[name](section) for name, section in sections.items()})
    if axes == 2 and (model.stand or model.temperature):
        raise ValueError('stand and temperature stages need a three-axis accelerometer')
    return model


def _upgraded(section, name, version):
    """Return a section of an older file with the fields version 3 added (``VERSION_3_FIELDS``)."""
    if version >= 3 or not isinstance(section, dict):
        return section
    return {**VERSION_3_FIELDS.get(name, {}), **section}


def check_sensor(model, sensor_id, path):
    """
    Raise CalibrationFileError when ``model`` belongs to another sensor than ``sensor_id``.

    A file that names no sensor (older files) matches any; a node or command
    that names none matches only such a file.
    """
    if model.sensor_id is not None and model.sensor_id != (sensor_id or None):
        wanted = repr(sensor_id) if sensor_id else 'an unnamed one (no sensor_id given)'
        raise CalibrationFileError(
            path, f'belongs to sensor {model.sensor_id!r}, not to {wanted}: the calibration '
            'of another tool (set sensor_id / --sensor-id, or use the file of this tool)')


#: Stages with a time, the field holding it, and which age limit applies: the drill
#: string's interference (MSA) has its own, shorter one.
STAGE_TIMES = (('temperature', 'fitted_at', 'calibration'),
               ('stand', 'fitted_at', 'calibration'),
               ('installation', 'captured_at', 'calibration'),
               ('tool_axis', 'fitted_at', 'calibration'),
               ('magnetometer_temperature', 'fitted_at', 'calibration'),
               ('magnetometer', 'fitted_at', 'calibration'),
               ('magnetometer_alignment', 'fitted_at', 'calibration'),
               ('magnetic', 'rotation_fitted_at', 'calibration'),
               ('magnetic', 'msa_fitted_at', 'interference'))


def stage_ages_s(model, now=None):
    """Return ``[(stage name, age [s], limit kind)]`` of every dated stage of ``model``."""
    ages = []
    for name, field, kind in STAGE_TIMES:
        stage = getattr(model, name)
        when = None if stage is None else getattr(stage, field)
        if when is not None:
            label = 'msa' if field == 'msa_fitted_at' else (
                'rotation' if field == 'rotation_fitted_at' else name)
            ages.append((label, age_seconds(when, now), kind))
    return ages


def stale_stages(model, max_age_s, interference_max_age_s, now=None):
    """Return ``[(stage, age [s], limit [s])]`` of the stages older than their limit."""
    limits = {'calibration': max_age_s, 'interference': interference_max_age_s}
    return [(name, age, limits[kind]) for name, age, kind in stage_ages_s(model, now)
            if age > limits[kind]]


def readings_temperature_c(temperature_stage, measured_c):
    """
    Return the temperature [deg C] corrected readings stand for.

    Through a temperature stage: its reference; without: the temperature they
    were measured at (``measured_c``, None when unknown).
    """
    return measured_c if temperature_stage is None else temperature_stage.reference_temperature_c


#: The field of a stage that records the temperature its readings stood for.
TEMPERATURE_FIELDS = {'magnetic': 'rotation_temperature_c'}


def stage_temperatures(model, names=('stand', 'installation')):
    """Return ``{name: temperature_c}`` of the stages ``names`` present that record one."""
    found = {name: getattr(getattr(model, name), TEMPERATURE_FIELDS.get(name, 'temperature_c'),
                           None) for name in names if getattr(model, name) is not None}
    return {name: value for name, value in found.items() if value is not None}


def temperature_conflict(model, temperature_c, tolerance_c, names=('stand', 'installation')):
    """
    Return why a new stage standing for ``temperature_c`` disagrees with ``names``, or None.

    Stages whose readings stood for temperatures more than ``tolerance_c``
    apart do not fit together without a temperature stage to bring their
    readings to one temperature (``temperature_c`` None: nothing to compare).
    """
    if temperature_c is None:
        return None
    for name, other_c in stage_temperatures(model, names).items():
        if abs(other_c - temperature_c) > tolerance_c:
            return (f'this capture stands for {temperature_c:.1f} C but the {name} stage for '
                    f'{other_c:.1f} C (more than {tolerance_c:g} C apart): without a temperature '
                    'stage the drift between them is not corrected; fit the temperature stage '
                    f'(inclino fit-temperature) or capture at {other_c:.1f} C')
    return None


def common_stage_temperature(model, tolerance_c, names=('stand', 'installation')):
    """
    Return the one temperature the stages ``names`` stand for (their mean), None if none is known.

    A new temperature stage must compensate to it.  ValueError (the reason)
    when they lie more than ``tolerance_c`` apart: no one compensation suits
    them all.
    """
    known = stage_temperatures(model, names)
    if not known:
        return None
    values = np.array(list(known.values()))
    if np.ptp(values) > tolerance_c:
        raise ValueError(
            'the stages were captured at different temperatures ('
            + ', '.join(f'{name} {value:.1f} C' for name, value in known.items())
            + f', more than {tolerance_c:g} C apart): no one temperature compensation suits '
            'them; capture them again after the temperature fit')
    return float(values.mean())


def _optional_temperature(section, name):
    """Raise ValueError unless ``section['temperature_c']`` is None or a sensor's deg C."""
    value = section['temperature_c']
    if value is not None:
        (value,) = _finite(section, name, 'temperature_c')
        plausibility.check_temperatures([value], f'{name}.temperature_c')


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
    _optional_temperature(section, 'installation')
    stage = Installation(**section)
    plausibility.check_installation(stage)
    return stage


def tool_axis_from_dict(section):
    """Return a validated ToolAxis from its file section."""
    _check_fields(section, ToolAxis, 'tool_axis')
    _finite(section, 'tool_axis', 'gamma_deg', 'beta_deg', 'axial_rms_deg')
    _count(section, 'tool_axis', 'roll_groups')
    _count(section, 'tool_axis', 'shots')
    _time(section, 'tool_axis', 'fitted_at')
    stage = ToolAxis(**section)
    plausibility.check_tool_axis(stage)
    return stage


def magnetometer_from_dict(section):
    """Return a validated Magnetometer from its file section."""
    _check_fields(section, Magnetometer, 'magnetometer')
    (k,) = _finite(section, 'magnetometer', 'scale_matrix', shape=(3, 3))
    _finite(section, 'magnetometer', 'bias_nT', shape=(3,))
    _finite(section, 'magnetometer', 'condition_number', 'rms_residual_nT', 'field_nT')
    if section['method'] not in ('stand', 'ellipsoid'):
        raise ValueError(f'magnetometer.method = {section["method"]!r} is not stand or ellipsoid')
    _count(section, 'magnetometer', 'positions')
    _time(section, 'magnetometer', 'fitted_at')
    stage = Magnetometer(**dict(section, scale_matrix=tuple(map(tuple, k.tolist())),
                                bias_nT=tuple(section['bias_nT'])))
    plausibility.check_magnetometer(stage)
    return stage


def alignment_from_dict(section):
    """Return a validated MagnetometerAlignment from its file section."""
    _check_fields(section, MagnetometerAlignment, 'magnetometer_alignment')
    (r,) = _finite(section, 'magnetometer_alignment', 'rotation', shape=(3, 3))
    if section['method'] not in ('dip', 'stand', 'given'):
        raise ValueError(f'magnetometer_alignment.method = {section["method"]!r} is not dip, '
                         'stand or given')
    for key in ('dip_deg', 'dip_rms_deg'):
        if section[key] is not None:
            _finite(section, 'magnetometer_alignment', key)
    _count(section, 'magnetometer_alignment', 'shots')
    _time(section, 'magnetometer_alignment', 'fitted_at')
    stage = MagnetometerAlignment(**dict(section, rotation=tuple(map(tuple, r.tolist()))))
    plausibility.check_magnetometer_alignment(stage)
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
    _optional_temperature(section, 'stand')
    stage = Stand(**dict(section, scale_matrix=tuple(map(tuple, k.tolist())),
                         bias_mps2=tuple(section['bias_mps2'])))
    plausibility.check_stand(stage)
    return stage


def temperature_from_dict(section):
    """Return a validated (accelerometer) Temperature from its file section."""
    return _temperature_stage(section, Temperature, 'temperature', 'mps2')


def magnetometer_temperature_from_dict(section):
    """Return a validated MagnetometerTemperature from its file section."""
    return _temperature_stage(section, MagnetometerTemperature, 'magnetometer_temperature', 'nT')


def _temperature_stage(section, kind, name, unit):
    """Return a validated temperature stage ``kind``; its unit-named fields end in ``unit``."""
    _check_fields(section, kind, name)
    coefficients = np.asarray(section['coefficients'], dtype=object)
    if coefficients.ndim != 2 or coefficients.shape[0] != 3 or coefficients.shape[1] < 1:
        raise ValueError(f'{name}.coefficients must be 3 rows of a0..an')
    _finite(section, name, 'coefficients', shape=coefficients.shape)
    bias_key, rms_key = f'bias_coefficients_{unit}', f'rms_residual_{unit}'
    if section[bias_key] is not None:
        _finite(section, name, bias_key, shape=coefficients.shape)
    t_min, t_max, t_ref = _finite(section, name, 't_min_c', 't_max_c',
                                  'reference_temperature_c')
    _finite(section, name, rms_key, shape=(3,))
    if not t_min <= t_ref <= t_max or t_min == t_max:
        raise ValueError(f'{name} range [{t_min}, {t_max}] C is empty or does not '
                         f'contain the reference {t_ref} C')
    _count(section, name, 'samples')
    _count(section, name, 'attitudes')
    _time(section, name, 'fitted_at')
    bias = section[bias_key]
    stage = kind(**dict(section, coefficients=tuple(map(tuple, section['coefficients'])),
                        **{rms_key: tuple(section[rms_key]),
                           bias_key: None if bias is None else tuple(map(tuple, bias))}))
    plausibility.check_temperature(stage, name)
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
    std = section['interference_std_nT']
    if std is not None:
        (std,) = _finite(section, 'magnetic', 'interference_std_nT', shape=(3,))
        std = tuple(std.tolist())
    _optional_temperature({'temperature_c': section['rotation_temperature_c']},
                          'magnetic.rotation')
    stage = Magnetic(**dict(section, hard_iron_nT=tuple(section['hard_iron_nT']),
                            soft_iron=tuple(map(tuple, section['soft_iron'])),
                            interference_nT=tuple(section['interference_nT']),
                            interference_std_nT=std))
    plausibility.check_magnetic(stage)
    return stage


#: A magnetic stage that changes nothing, to build the first correction on.
NO_MAGNETIC_CORRECTION = Magnetic(
    hard_iron_nT=(0.0, 0.0), soft_iron=((1.0, 0.0), (0.0, 1.0)),
    interference_nT=(0.0, 0.0, 0.0), rotation_fitted_at=None, msa_method=None,
    msa_stations=0, msa_reference_total_nT=0.0, msa_reference_dip_deg=0.0, msa_fitted_at=None)
