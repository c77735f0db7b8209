"""
The processing chain shared by the node and the command line.

raw specific force -> screening -> sensor axes to tool axes -> (two-axis
completion) -> calibration model -> inclination, gravity toolface,
orientation (and, with magnetometer readings turned into the tool axes too,
the azimuth and its QC).  One batch of N samples at a time: the node passes
what one executor wake-up finds queued, the command line 10 000.
"""

from dataclasses import dataclass
from functools import cached_property
import math

from inclino_ros.core.attitude import (
    complete_two_axis, inclination, orientation_quaternion, TOOLFACE_CONVENTIONS)
from inclino_ros.core.magnetics import (
    azimuth_deg, b_total_nT, dip_deg, gravity_from_specific_force, iscwsa_from_tool, QcLimits,
    survey_qc, SurveyQc, true_azimuth_deg)
from inclino_ros.core.mounting import axes_map_matrix, IDENTITY, keeps_axial, to_tool_axes
from inclino_ros.core.screening import ACCEPTED, screen
import numpy as np

#: Smallest field [nT] taken for the Earth's (which is 22000-67000 nT at the surface).
MIN_FIELD_NT = 1000.0
#: Variance of a yaw that nothing observes: uniform on [-pi, pi).
UNOBSERVED_YAW_VARIANCE = math.pi ** 2 / 3.0


@dataclass(frozen=True)
class Settings:
    """Sensor and output settings of the chain (the node's parameters)."""

    accelerometer_axes: int = 3
    gravity_mps2: float = 9.80665
    accelerometer_range_mps2: float = 2.0 * 9.80665
    toolface_convention: str = 'seed000'
    toolface_min_inclination_deg: float = 0.01
    accelerometer_axes_map: str = IDENTITY  # core.mounting: sensor axes -> tool axes
    magnetometer_axes_map: str = IDENTITY
    allow_left_handed_axes: bool = False

    def __post_init__(self):
        """Refuse settings the chain cannot honour."""
        if self.accelerometer_axes not in (2, 3):
            raise ValueError(f'accelerometer_axes must be 2 or 3, not {self.accelerometer_axes}')
        if self.toolface_convention not in TOOLFACE_CONVENTIONS:
            raise ValueError(f'toolface_convention must be one of '
                             f'{sorted(TOOLFACE_CONVENTIONS)}, not {self.toolface_convention!r}')
        # Both maps are checked now, not at the first sample (ValueError naming the map).
        accelerometer, _ = self.accelerometer_matrix, self.magnetometer_matrix
        if self.accelerometer_axes == 2 and not keeps_axial(accelerometer):
            raise ValueError(f'accelerometer_axes_map {self.accelerometer_axes_map!r}: a '
                             'two-axis sensor has to have its unmeasured z along the tool axis')

    @cached_property
    def accelerometer_matrix(self):
        """Return M of ``v_tool = M v_sensor`` for the accelerometer (ValueError if invalid)."""
        return self._axes_matrix('accelerometer_axes_map')

    @cached_property
    def magnetometer_matrix(self):
        """Return M of ``v_tool = M v_sensor`` for the magnetometer (ValueError if invalid)."""
        return self._axes_matrix('magnetometer_axes_map')

    def _axes_matrix(self, name):
        try:
            return axes_map_matrix(getattr(self, name), self.allow_left_handed_axes)
        except ValueError as err:
            raise ValueError(f'{name}: {err}') from None


@dataclass(frozen=True)
class MagneticSettings:
    """The reference field and QC limits of the azimuth (the node's magnetic.* parameters)."""

    reference_total_nT: float = 0.0   # 0: no reference known, QC not checked
    reference_dip_deg: float = 0.0
    declination_deg: float = 0.0
    limits: QcLimits = QcLimits()
    min_inclination_deg: float = 0.5  # the azimuth of a vertical tool is undefined


@dataclass(frozen=True)
class AzimuthSurvey:
    """Azimuth of the accepted samples that came with a magnetometer reading."""

    uncorrected_nT: np.ndarray    # (M, 3) field in the tool axes before correction, NaN unpaired
    azimuth_deg: np.ndarray       # (M,) magnetic azimuth, NaN where not trusted
    true_azimuth_deg: np.ndarray  # (M,) azimuth_deg + declination
    b_total_nT: np.ndarray        # (M,) of the corrected field
    dip_deg: np.ndarray           # (M,)
    qc: SurveyQc                  # None without a reference field
    trusted: np.ndarray           # (M,) paired, finite and passing QC


@dataclass(frozen=True)
class Survey:
    """Results for the accepted samples of a batch, in input order."""

    codes: np.ndarray            # (N,) screening code per input sample
    uncorrected_mps2: np.ndarray  # (M, 3) in the tool axes, before any correction (captures)
    corrected_mps2: np.ndarray   # (M, 3) corrected specific force, tool frame
    inclination_deg: np.ndarray  # (M,)
    toolface_deg: np.ndarray     # (M,), NaN below the minimum inclination
    orientation_wxyz: np.ndarray  # (M, 4)
    g_total_mps2: np.ndarray     # (M,)
    magnetic: AzimuthSurvey = None  # when magnetometer readings were given

    @property
    def accepted(self):
        """Boolean mask of the input samples that produced a result."""
        return self.codes == ACCEPTED


def sensor_vectors(tool_mps2, settings):
    """Return full 3-vectors of readings in the tool axes (two-axis: z completed)."""
    tool_mps2 = np.asarray(tool_mps2, dtype=float)
    if settings.accelerometer_axes == 2:
        return complete_two_axis(tool_mps2[:, 0], tool_mps2[:, 1], settings.gravity_mps2)
    return tool_mps2


def resolve_azimuth(corrected_mps2, field_nT, model, settings, magnetic_settings):
    """
    Return the AzimuthSurvey of corrected accelerometer and uncorrected magnetometer readings.

    Both in the z-up tool axes, (M, 3); a NaN field row (no paired reading)
    gives a NaN azimuth.  The field is corrected by the model's magnetic stage
    and turned into the ISCWSA frame with the gravity vector
    (``magnetics.gravity_from_specific_force``) for the azimuth of seed 001
    Eq. 4; a sample failing QC against the reference, or below the minimum
    inclination (where the azimuth is undefined), is not trusted.
    """
    gravity = gravity_from_specific_force(corrected_mps2)
    field = iscwsa_from_tool(model.apply_magnetic(field_nT))
    azimuth = azimuth_deg(gravity, field)
    field_total_nT = b_total_nT(field)
    # Below MIN_FIELD_NT there is no Earth field in the reading (a dead magnetometer).
    steep_enough = (inclination(corrected_mps2)
                    >= math.radians(magnetic_settings.min_inclination_deg))
    trusted = np.isfinite(azimuth) & (field_total_nT >= MIN_FIELD_NT) & steep_enough
    qc = None
    if magnetic_settings.reference_total_nT > 0:
        qc = survey_qc(gravity, field, magnetic_settings.reference_total_nT,
                       magnetic_settings.reference_dip_deg, settings.gravity_mps2,
                       magnetic_settings.limits)
        trusted &= qc.ok
    azimuth = np.where(trusted, azimuth, math.nan)
    return AzimuthSurvey(
        uncorrected_nT=field_nT, azimuth_deg=azimuth,
        true_azimuth_deg=true_azimuth_deg(azimuth, magnetic_settings.declination_deg),
        b_total_nT=field_total_nT, dip_deg=dip_deg(gravity, field), qc=qc,
        trusted=trusted)


def run(raw, model, settings, temperature_c=None, field_nT=None,
        magnetic_settings=MagneticSettings()):
    """
    Screen, correct and resolve a batch of raw readings (N x 3, m/s^2, sensor axes).

    ``temperature_c`` (scalar or (N,)) feeds the model's temperature stage;
    None compensates at the reference temperature.  ``field_nT`` (N x 3,
    magnetometer axes, NaN rows where no reading is paired) adds the azimuth.
    Screening looks at the sensor's own axes (its range is per axis); the
    axes maps of ``settings`` then turn both sensors into the tool axes.
    """
    raw = np.asarray(raw, dtype=float).reshape(-1, 3)
    codes = screen(raw, settings.accelerometer_axes,
                   settings.accelerometer_range_mps2, settings.gravity_mps2)
    accepted = codes == ACCEPTED
    if field_nT is not None:
        field_nT = np.asarray(field_nT, dtype=float).reshape(-1, 3)
    if not accepted.all():
        raw = raw[accepted]
        if np.ndim(temperature_c) == 1:
            temperature_c = np.asarray(temperature_c)[accepted]
        if field_nT is not None:
            field_nT = field_nT[accepted]
    return correct(to_tool_axes(raw, settings.accelerometer_matrix), model, settings,
                   temperature_c,
                   None if field_nT is None else to_tool_axes(field_nT,
                                                              settings.magnetometer_matrix),
                   magnetic_settings, codes)


def correct(tool_mps2, model, settings, temperature_c=None, field_nT=None,
            magnetic_settings=MagneticSettings(), codes=None):
    """
    Correct and resolve accepted readings already in the tool axes (M x 3).

    What ``run`` does after screening and the axes maps; a capture that
    averages the Survey's ``uncorrected_mps2`` (and ``uncorrected_nT``)
    corrects its mean here.  ``codes`` default to all accepted.
    """
    tool_mps2 = np.asarray(tool_mps2, dtype=float).reshape(-1, 3)
    corrected = model.apply(sensor_vectors(tool_mps2, settings), temperature_c)
    incl_deg = np.degrees(inclination(corrected))
    toolface_deg = np.degrees(TOOLFACE_CONVENTIONS[settings.toolface_convention](corrected))
    toolface_deg[incl_deg < settings.toolface_min_inclination_deg] = math.nan
    return Survey(codes=np.full(tool_mps2.shape[0], ACCEPTED, dtype=np.int8)
                  if codes is None else codes,
                  uncorrected_mps2=tool_mps2, corrected_mps2=corrected,
                  inclination_deg=incl_deg, toolface_deg=toolface_deg,
                  orientation_wxyz=orientation_quaternion(corrected),
                  g_total_mps2=np.sqrt(np.einsum('ij,ij->i', corrected, corrected)),
                  magnetic=None if field_nT is None else resolve_azimuth(
                      corrected, np.asarray(field_nT, dtype=float).reshape(-1, 3), model,
                      settings, magnetic_settings))


def imu_covariances(survey, model, settings, noise_std_mps2):
    """
    Return the covariances of the corrected Imu: (linear_acceleration, orientation).

    Both are (M, 9) row-major 3x3 per accepted sample.  Acceleration: the
    sensor noise variance per axis; for a two-axis sensor z = sqrt(g^2 - x^2 -
    y^2), so first-order propagation gives var_z = var (x^2 + y^2) / z^2.
    Roll and pitch: var / |f|^2 plus the variance of the calibration's mean
    tilt (std_deg^2 / sample_count); yaw is unobserved.
    """
    f = survey.corrected_mps2
    var = noise_std_mps2 ** 2
    acceleration = np.zeros((f.shape[0], 9))
    acceleration[:, 0] = acceleration[:, 4] = acceleration[:, 8] = var
    if settings.accelerometer_axes == 2:
        acceleration[:, 8] = var * (f[:, 0] ** 2 + f[:, 1] ** 2) / np.maximum(f[:, 2] ** 2, 1e-12)
    installation = model.installation
    calibration_var = (0.0 if installation is None else
                       math.radians(installation.std_deg) ** 2 / installation.sample_count)
    orientation = np.zeros((f.shape[0], 9))
    orientation[:, 0] = orientation[:, 4] = var / survey.g_total_mps2 ** 2 + calibration_var
    orientation[:, 8] = UNOBSERVED_YAW_VARIANCE
    return acceleration, orientation
