"""
The processing chain shared by the node and the command line.

raw specific force -> screening -> sensor axes to tool axes -> (two-axis
completion) -> calibration model -> screening of what cannot be gravity ->
inclination, gravity toolface, orientation, each with its 1 sigma (and, with
magnetometer readings turned into the tool axes too, the azimuth, its 1 sigma
and its QC).  A toolface or azimuth whose 1 sigma exceeds its limit is NaN.
One batch of N samples at a time: the node passes what one executor wake-up
finds queued, the command line 10 000.
"""

from dataclasses import dataclass
from functools import cached_property
import math

from inclino_ros.calibration.plausibility import FIELD_NT
from inclino_ros.core.attitude import (
    complete_two_axis, inclination, orientation_quaternion, TOOLFACE_CONVENTIONS)
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.core.magnetics import (
    azimuth_deg, b_total_nT, dip_deg, gravity_from_specific_force, iscwsa_from_tool, QcLimits,
    survey_qc, SurveyQc, true_azimuth_deg)
from inclino_ros.core.mounting import axes_map_matrix, IDENTITY, keeps_axial, to_tool_axes
from inclino_ros.core.screening import ACCEPTED, screen, screen_corrected
from inclino_ros.core.stillness import floored_count, own_noise
from inclino_ros.core.uncertainty import (
    azimuth_std_rad, dip_std_rad, inclination_std_rad, parameter_covariance,
    roll_pitch_covariance, specific_force_covariance, toolface_std_rad)
import numpy as np

#: Smallest field [nT] taken for the Earth's (which is 22000-67000 nT at the surface): below,
#: a dead magnetometer (``plausibility.FIELD_NT``; a raw reading beyond its upper end is
#: dropped before it is paired, ``plausibility.field_reading_ok``).
MIN_FIELD_NT = FIELD_NT[0]
#: An averaged window whose readings scatter more than this many times the per-sample
#: noise (largest per-axis sample std) held a moving tool (``average``).
MOVING_SIGMA = 3.0
#: Variance of a yaw that nothing observes: uniform on [-pi, pi).
UNOBSERVED_YAW_VARIANCE = math.pi ** 2 / 3.0
#: Per-sample QC limits are the station limits widened by this many sigma of the
#: sample's own noise (the station limits are themselves 3 sigma, formulas.md).
QC_SIGMA = 3.0


@dataclass(frozen=True)
class Settings:
    """
    Sensor and output settings of the chain (the node's parameters).

    ``noise_std_mps2``: the accelerometer's per-sample noise, 1 sigma per
    axis; ``bias_instability_mps2``: its configured bias instability B (a
    datasheet figure, ``stillness.floored_count``: the floor of a mean's
    1 sigma; 0: none); ``toolface_max_std_deg``: a toolface of larger 1 sigma is NaN;
    ``g_total_tolerance_mps2``: a three-axis sample whose corrected G-total is
    further from g is not gravity (dropped, ``dynamic``);
    ``two_axis_max_inclination_deg``: a two-axis sample steeper than this is
    dropped (``two_axis_range``): it may be a tool past 90 deg folded back.
    """

    accelerometer_axes: int = 3
    gravity_mps2: float = STANDARD_GRAVITY_MPS2
    accelerometer_range_mps2: float = 2.0 * STANDARD_GRAVITY_MPS2
    toolface_convention: str = 'seed000'
    noise_std_mps2: float = 0.01
    toolface_max_std_deg: float = 5.0
    g_total_tolerance_mps2: float = 3.0
    two_axis_max_inclination_deg: float = 60.0
    accelerometer_axes_map: str = IDENTITY  # core.mounting: sensor axes -> tool axes
    magnetometer_axes_map: str = IDENTITY
    allow_left_handed_axes: bool = False
    bias_instability_mps2: float = 0.0   # IEEE Std 952 B of the accelerometer (0: none)

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
    """
    The reference field and limits of the azimuth (the node's magnetic.* parameters).

    ``limits`` are the station QC limits (a per-sample QC widens them by the
    sample's own noise, ``QC_SIGMA``); ``noise_std_nT`` the magnetometer's
    per-sample noise per axis; ``azimuth_max_std_deg``: an azimuth of larger
    1 sigma is NaN (near vertical it is undefined and its sigma unbounded).
    """

    reference_total_nT: float = 0.0   # 0: no reference known, QC not checked
    reference_dip_deg: float = 0.0
    declination_deg: float = 0.0
    limits: QcLimits = QcLimits()
    noise_std_nT: float = 100.0
    azimuth_max_std_deg: float = 1.0
    bias_instability_nT: float = 0.0   # IEEE Std 952 B of the magnetometer (0: none)


@dataclass(frozen=True)
class AzimuthSurvey:
    """Azimuth of the accepted samples that came with a magnetometer reading."""

    uncorrected_nT: np.ndarray    # (M, 3) field in the tool axes before correction, NaN unpaired
    azimuth_deg: np.ndarray       # (M,) magnetic azimuth, NaN where not trusted
    true_azimuth_deg: np.ndarray  # (M,) azimuth_deg + declination
    b_total_nT: np.ndarray        # (M,) of the corrected field
    dip_deg: np.ndarray           # (M,)
    qc: SurveyQc                  # None without a reference field
    trusted: np.ndarray           # (M,) paired, finite, precise enough and passing QC
    azimuth_std_deg: np.ndarray   # (M,) 1 sigma of the azimuth (NaN where undefined)
    precise: np.ndarray           # (M,) azimuth_std_deg within the limit
    defined_azimuth_deg: np.ndarray = None  # (M,) wherever defined, QC or not
    b_total_std_nT: np.ndarray = None    # (M,) 1 sigma of b_total_nT (the QC widening's)
    dip_std_deg: np.ndarray = None       # (M,) 1 sigma of dip_deg
    g_total_std_mps2: np.ndarray = None  # (M,) 1 sigma of the G-total

    @property
    def imprecise(self):
        """Return where a usable field gave an azimuth whose 1 sigma exceeds the limit."""
        return (self.b_total_nT >= MIN_FIELD_NT) & ~self.precise


@dataclass(frozen=True)
class Survey:
    """Results for the accepted samples of a batch, in input order."""

    codes: np.ndarray            # (N,) screening code per input sample
    uncorrected_mps2: np.ndarray  # (M, 3) in the tool axes, before any correction (captures)
    corrected_mps2: np.ndarray   # (M, 3) corrected specific force, tool frame
    inclination_deg: np.ndarray  # (M,)
    toolface_deg: np.ndarray     # (M,), NaN where its 1 sigma exceeds the limit
    orientation_wxyz: np.ndarray  # (M, 4)
    g_total_mps2: np.ndarray     # (M,)
    covariance_mps2: np.ndarray  # (M, 3, 3) of corrected_mps2 (sensor noise, temperature fit)
    tilt_var_rad2: float         # variance of the tilt from the calibration itself
    toolface_std_deg: np.ndarray     # (M,) 1 sigma (inf for a vertical tool)
    magnetic: AzimuthSurvey = None  # when magnetometer readings were given
    # (acceleration (M, 9), orientation (M, 9)) of ``imu_covariances`` when the float
    # chain (``scalar_chain``) computed them with the rest; None: computed when asked.
    imu_covariance_rows: tuple = None

    @property
    def inclination_std_deg(self):
        """Return the 1 sigma of each inclination [deg] (``uncertainty.inclination_std_rad``)."""
        return np.degrees(inclination_std_rad(self.corrected_mps2, self.covariance_mps2,
                                              self.tilt_var_rad2))

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


def resolve_azimuth(corrected_mps2, field_nT, model, settings, magnetic_settings,
                    covariance_mps2, tilt_var_rad2, temperature_c=None, averaged=1,
                    field_averaged=None, parameter_blocks=()):
    """
    Return the AzimuthSurvey of corrected accelerometer and uncorrected magnetometer readings.

    Both in the z-up tool axes, (M, 3); a NaN field row (no paired reading)
    gives a NaN azimuth.  The field is corrected by the model's magnetometer
    stages (at ``temperature_c``: its temperature stage, its own, the shared
    mount, seed 002's) and turned into the ISCWSA frame with the gravity
    vector (``magnetics.gravity_from_specific_force``) for the azimuth of seed
    001 Eq. 4.  Its 1 sigma (``uncertainty.azimuth_std_rad``) takes the
    accelerometer's covariance and calibration tilt, the magnetometer's noise
    (over ``field_averaged`` readings, default ``averaged``) and the MSA
    interference's own 1 sigma (which holds the reference field's uncertainty) and the
    magnetometer temperature fit's own (``CalibrationModel.temperature_covariance``) and
    every other fit's own (``parameter_blocks``, ``CalibrationModel.parameter_blocks`` in
    the tool frame: the accelerometer's of them are not in ``covariance_mps2``).
    Defined (``defined_azimuth_deg``): a finite azimuth of a field above
    MIN_FIELD_NT whose sigma is within ``azimuth_max_std_deg`` (near vertical
    the azimuth is undefined).  Trusted:
    defined and passing QC against the reference (limits widened by QC_SIGMA of
    the sample's own noise).
    """
    gravity = gravity_from_specific_force(corrected_mps2)
    field = iscwsa_from_tool(model.apply_magnetic(field_nT, temperature_c))
    azimuth = azimuth_deg(gravity, field)
    field_total_nT = b_total_nT(field)
    flip = np.diag([-1.0, 1.0, 1.0])          # G = (-f_x, f_y, f_z)
    field_averaged = averaged if field_averaged is None else np.maximum(field_averaged, 1)
    noise_nT = magnetic_settings.noise_std_nT / np.sqrt(field_averaged)
    field_covariance = np.square(noise_nT)[..., None, None] * np.eye(3)
    stage = model.magnetic
    if stage is not None and stage.interference_std_nT is not None:
        field_covariance = field_covariance + np.diag(np.square(stage.interference_std_nT))
    to_iscwsa = np.diag([1.0, -1.0, -1.0])
    if model.magnetometer_temperature is not None:   # its fit's own error, tool -> ISCWSA axes
        field_covariance = field_covariance + to_iscwsa @ model.temperature_covariance(
            field_nT, temperature_c, 'magnetometer') @ to_iscwsa
    blocks = [(c, None if j_f is None else flip @ j_f, None if j_b is None else to_iscwsa @ j_b)
              for c, j_f, j_b in parameter_blocks]
    std_deg = np.degrees(azimuth_std_rad(gravity, field, flip @ covariance_mps2 @ flip,
                                         field_covariance, tilt_var_rad2, blocks))
    precise = std_deg <= magnetic_settings.azimuth_max_std_deg   # NaN: False
    # Below MIN_FIELD_NT there is no Earth field in the reading (a dead magnetometer).
    defined = np.isfinite(azimuth) & (field_total_nT >= MIN_FIELD_NT) & precise
    trusted = defined.copy()
    qc = None
    # The QC figures' own 1 sigma: |B| and |G| move by the per-axis noise along their
    # direction, the dip by ``uncertainty.dip_std_rad``.
    count = gravity.shape[0]
    g_std = np.broadcast_to(settings.noise_std_mps2 / np.sqrt(averaged), (count,))
    b_std = np.broadcast_to(noise_nT, (count,))
    dip_std = np.degrees(dip_std_rad(gravity, field, g_std, b_std))
    if magnetic_settings.reference_total_nT > 0:
        limits = magnetic_settings.limits
        widened = QcLimits(
            b_total_tolerance_nT=np.hypot(limits.b_total_tolerance_nT, QC_SIGMA * noise_nT),
            dip_tolerance_deg=np.hypot(limits.dip_tolerance_deg, QC_SIGMA * dip_std),
            g_total_tolerance=np.hypot(limits.g_total_tolerance, QC_SIGMA * g_std))
        qc = survey_qc(gravity, field, magnetic_settings.reference_total_nT,
                       magnetic_settings.reference_dip_deg, settings.gravity_mps2, widened)
        trusted &= qc.ok
    defined_azimuth = np.where(defined, azimuth, math.nan)
    azimuth = np.where(trusted, azimuth, math.nan)
    return AzimuthSurvey(
        uncorrected_nT=field_nT, azimuth_deg=azimuth, defined_azimuth_deg=defined_azimuth,
        true_azimuth_deg=true_azimuth_deg(azimuth, magnetic_settings.declination_deg),
        b_total_nT=field_total_nT, dip_deg=dip_deg(gravity, field), qc=qc,
        trusted=trusted, azimuth_std_deg=std_deg, precise=precise, b_total_std_nT=b_std,
        dip_std_deg=dip_std, g_total_std_mps2=g_std)


def run(raw, model, settings, temperature_c=None, field_nT=None,
        magnetic_settings=MagneticSettings(), averaged=1, field_averaged=None):
    """
    Screen, correct and resolve a batch of raw readings (N x 3, m/s^2, sensor axes).

    ``temperature_c`` (scalar or (N,)) feeds the model's temperature stages;
    None (or NaN for a row) compensates at the reference temperature and
    widens every 1 sigma by the drift over the fitted range
    (``_TemperatureStage.compensation_covariance``; whether that is allowed:
    ``provenance.missing_temperature``).  ``field_nT`` (N x 3,
    magnetometer axes, NaN rows where no reading is paired) adds the azimuth.
    ``averaged``: each row is the mean of that many samples (a station), one
    count or one per row (N,): its noise is the per-sample noise /
    sqrt(averaged); ``field_averaged`` the magnetometer's (default
    ``averaged``, ``station_counts``).  Screening looks at the
    sensor's own axes (its range is per axis, ``screening.screen``); the axes
    maps of ``settings`` then turn both sensors into the tool axes, and
    ``correct`` drops what cannot be gravity after the correction.
    """
    raw = np.asarray(raw, dtype=float).reshape(-1, 3)
    codes = screen(raw, settings.accelerometer_axes,
                   settings.accelerometer_range_mps2, settings.gravity_mps2)
    kept = codes == ACCEPTED
    if np.ndim(temperature_c) == 1:
        temperature_c = np.asarray(temperature_c)[kept]
    if np.ndim(averaged) == 1:
        averaged = np.asarray(averaged)[kept]
    if np.ndim(field_averaged) == 1:
        field_averaged = np.asarray(field_averaged)[kept]
    if field_nT is not None:
        field_nT = to_tool_axes(np.asarray(field_nT, dtype=float).reshape(-1, 3)[kept],
                                settings.magnetometer_matrix)
    return correct(to_tool_axes(raw[kept], settings.accelerometer_matrix), model, settings,
                   temperature_c, field_nT, magnetic_settings, codes, averaged, field_averaged)


def correct(tool_mps2, model, settings, temperature_c=None, field_nT=None,
            magnetic_settings=MagneticSettings(), codes=None, averaged=1, field_averaged=None,
            floor_averaged=None):
    """
    Correct and resolve accepted readings already in the tool axes (M x 3).

    What ``run`` does after screening and the axes maps; a capture that
    averages the Survey's ``uncorrected_mps2`` (and ``uncorrected_nT``)
    corrects its mean here (``averaged`` samples; ``field_averaged`` distinct
    magnetometer readings, default ``averaged``).  ``codes`` (N,): the
    screening codes of the batch, its M accepted ones in order (default: all
    accepted); samples that cannot be gravity after the correction
    (``screening.screen_corrected``) are dropped and their codes set.

    ``floor_averaged`` (default ``averaged``): the count the configured noise
    alone gives the row (``station_counts``), which decides whether its
    toolface is defined (``toolface_defined``); ``averaged`` (the row's own
    noise, ``floored_count``) gives its published 1 sigma.
    """
    tool_mps2 = np.asarray(tool_mps2, dtype=float).reshape(-1, 3)
    codes = (np.full(tool_mps2.shape[0], ACCEPTED, dtype=np.int8) if codes is None
             else np.array(codes))
    kept = np.flatnonzero(codes == ACCEPTED)
    sensor = sensor_vectors(tool_mps2, settings)
    corrected = model.apply(sensor, temperature_c)
    late = screen_corrected(corrected, settings.accelerometer_axes, settings.gravity_mps2,
                            settings.g_total_tolerance_mps2,
                            settings.two_axis_max_inclination_deg)
    codes[kept] = late
    good = late == ACCEPTED
    if not good.all():   # (all kept, the usual case: no copies)
        tool_mps2, sensor, corrected = tool_mps2[good], sensor[good], corrected[good]
        if np.ndim(temperature_c) == 1:
            temperature_c = np.asarray(temperature_c)[good]
        if field_nT is not None:
            field_nT = np.asarray(field_nT, dtype=float).reshape(-1, 3)[good]
        if np.ndim(averaged):   # one count per row (averaged windows)
            averaged = np.asarray(averaged)[good]
            floor_averaged = (None if floor_averaged is None
                              else np.asarray(floor_averaged)[good])
            field_averaged = (None if field_averaged is None
                              else np.asarray(field_averaged)[good])
    elif field_nT is not None:
        field_nT = np.asarray(field_nT, dtype=float).reshape(-1, 3)

    def noise_covariance_of(count):
        noise_mps2 = settings.noise_std_mps2 / np.sqrt(count)
        return specific_force_covariance(sensor, np.reshape(noise_mps2, (-1, 1, 1)),
                                         settings.accelerometer_axes, model.linear_map)

    covariance = noise_covariance_of(averaged)
    others = 0.0   # the temperature stage's and the fits' own: not the row's noise
    if model.temperature is not None:
        others = model.temperature_covariance(sensor, temperature_c)
        covariance = covariance + others
    blocks = model.parameter_blocks(sensor, field_nT, temperature_c)
    fits_covariance = parameter_covariance(blocks, 1)
    noise_covariance = covariance
    if fits_covariance is not None:   # the fits' own error of f (for the azimuth: blocks)
        covariance = covariance + fits_covariance
        others = others + fits_covariance
    tilt_var = model.tilt_std_rad ** 2
    incl_deg = np.degrees(inclination(corrected))
    toolface_deg = np.degrees(TOOLFACE_CONVENTIONS[settings.toolface_convention](corrected))
    toolface_std_deg = np.degrees(toolface_std_rad(corrected, covariance, tilt_var))
    floor_std_deg = toolface_std_deg if floor_averaged is None else np.degrees(
        toolface_std_rad(corrected, noise_covariance_of(floor_averaged) + others, tilt_var))
    toolface_deg[~toolface_defined(floor_std_deg, settings)] = math.nan
    return Survey(codes=codes, uncorrected_mps2=tool_mps2, corrected_mps2=corrected,
                  inclination_deg=incl_deg, toolface_deg=toolface_deg,
                  orientation_wxyz=orientation_quaternion(corrected),
                  g_total_mps2=np.sqrt(np.einsum('ij,ij->i', corrected, corrected)),
                  covariance_mps2=covariance, tilt_var_rad2=tilt_var,
                  toolface_std_deg=toolface_std_deg,
                  magnetic=None if field_nT is None else resolve_azimuth(
                      corrected, field_nT, model, settings, magnetic_settings,
                      noise_covariance, tilt_var, temperature_c, averaged, field_averaged,
                      blocks))


def toolface_defined(floor_std_deg, settings):
    """
    Return where a toolface is defined: its 1 sigma at the configured noise within the limit.

    ``floor_std_deg``: the toolface's 1 sigma with the configured per-sample
    noise over the row's samples (``station_counts``: no own noise), the
    calibration's and temperature stage's own error included;
    ``settings.toolface_max_std_deg`` the limit (NaN: not defined).  Not the
    published 1 sigma of a mean (the capture's own noise, ``floored_count``):
    a short correlated capture estimates its noise with a few degrees of
    freedom, and publishing only where that estimate is small would publish
    its under-estimates (MEMS at 0.1 deg under AR(1) rho 0.73: 1 / 2 sigma
    coverage 0.65 / 0.90 of the 30 % published, issue 19).  Decided from a
    figure independent of that estimate's error, a defined toolface's
    published 1 sigma covers, and may exceed the limit where the capture's
    own noise exceeds the configured.
    """
    return np.asarray(floor_std_deg) <= settings.toolface_max_std_deg


def effective_count(vectors, times_s, noise_floor, bias_instability=0.0):
    """
    Return the count of white samples of noise ``noise_floor`` a capture's mean is worth.

    ``vectors`` (M, 3) of one still capture (readings of one sensor), ``times_s``
    (M,) or None: ``stillness.floored_count`` of its ``stillness.own_noise`` and
    the configured ``bias_instability``.
    """
    vectors = np.asarray(vectors, dtype=float)
    sigma, effective = own_noise(vectors, times_s)
    return float(floored_count(sigma, effective, vectors.shape[0], noise_floor,
                               bias_instability))


def station_counts(samples, settings, magnetic_settings):
    """
    Return (accelerometer, magnetometer) counts of white samples rows of ``samples`` are worth.

    A row the mean of ``samples`` readings (scalar or (N,)) whose own noise is
    not known (``inclino survey``'s stations): ``stillness.floored_count``
    with no own noise, i.e. ``samples`` white samples of the configured
    noise with the configured bias instability's flicker added (B = 0:
    ``samples`` unchanged), for ``run``'s ``averaged`` and ``field_averaged``.
    """
    nan = np.full(np.shape(samples), math.nan)
    return (floored_count(nan, samples, samples, settings.noise_std_mps2,
                          settings.bias_instability_mps2),
            floored_count(nan, samples, samples, magnetic_settings.noise_std_nT,
                          magnetic_settings.bias_instability_nT))


def capture_mean(tool_mps2, times_s, model, settings, temperature_c=None, field_nT=None,
                 magnetic_settings=MagneticSettings()):
    """
    Return the Survey (one row) of the mean of a still capture, its 1 sigma from the capture.

    ``tool_mps2`` (M, 3) accepted readings in the tool axes, ``times_s`` (M,)
    or None, ``field_nT`` (M, 3) paired magnetometer readings (NaN rows
    unpaired) or None.  Each sensor's mean counts as ``effective_count``
    samples of its configured noise (``settings.noise_std_mps2``,
    ``magnetic_settings.noise_std_nT``): correlated noise (a low-pass filter
    below the output rate) widens every 1 sigma by sqrt(F), a noise above the
    configured one by its ratio (issue 19 item 4), a configured bias instability
    by its flicker (``stillness.floored_count``).
    """
    tool_mps2 = np.asarray(tool_mps2, dtype=float).reshape(-1, 3)
    count = effective_count(tool_mps2, times_s, settings.noise_std_mps2,
                            settings.bias_instability_mps2)
    floor = station_counts(tool_mps2.shape[0], settings, magnetic_settings)[0]
    mean_field, field_count = None, None
    if field_nT is not None:
        field_nT = np.asarray(field_nT, dtype=float).reshape(-1, 3)
        paired = np.isfinite(field_nT).all(axis=1)
        times = None if times_s is None else np.asarray(times_s, dtype=float)[paired]
        mean_field = field_nT[paired].mean(axis=0)[None]
        field_count = [effective_count(field_nT[paired], times, magnetic_settings.noise_std_nT,
                                       magnetic_settings.bias_instability_nT)]
    return correct(tool_mps2.mean(axis=0)[None], model, settings, temperature_c, mean_field,
                   magnetic_settings, averaged=np.array([count]), field_averaged=field_count,
                   floor_averaged=np.array([floor]))


def average(windows, model, settings, magnetic_settings=None):
    """
    Return (kept (W,), [(rows, Survey)]): the angles of the averaged readings of ``windows``.

    ``windows`` (``averaging.Windows``): mean readings in the tool axes, each
    corrected by ``correct`` as a station worth ``stillness.floored_count``
    samples of the configured noise: the window's own noise with its
    effective sample size, the configured noise its floor (the rule of a
    capture's mean, ``capture_mean``; the field's over its distinct
    readings), at its mean temperature.  A window whose readings scatter more than MOVING_SIGMA
    times the per-sample noise held a moving tool: not kept (its mean is no
    attitude and its standard error would be false).  The kept windows come
    in one Survey, or two when only some had a temperature (those without it
    compensate at the reference temperature): ``rows`` are their indices.
    With ``magnetic_settings`` the mean fields give the azimuth.
    """
    # The per-sample noise: the window's own (within its blocks, a steady turn taken out),
    # the configured one its floor: a noise above the configured is no motion.
    noise = settings.noise_std_mps2 if windows.noise is None else np.fmax(
        settings.noise_std_mps2, windows.noise)
    kept = ~(windows.scatter_mps2 > MOVING_SIGMA * noise)
    known = np.isfinite(windows.temperature_c)
    parts = []
    for rows in (np.flatnonzero(kept & ~known), np.flatnonzero(kept & known)):
        if rows.size:
            parts.append((rows, correct(
                windows.raw_mps2[rows], model, settings,
                windows.temperature_c[rows] if known[rows[0]] else None,
                None if magnetic_settings is None else windows.field_nT[rows],
                magnetic_settings or MagneticSettings(), averaged=floored_count(
                    windows.noise[rows], windows.effective_samples[rows],
                    windows.samples[rows], settings.noise_std_mps2,
                    settings.bias_instability_mps2),
                field_averaged=floored_count(
                    windows.field_noise[rows], windows.field_effective_samples[rows],
                    windows.field_samples[rows], (magnetic_settings or MagneticSettings())
                    .noise_std_nT, (magnetic_settings or MagneticSettings())
                    .bias_instability_nT),
                floor_averaged=station_counts(windows.samples[rows], settings,
                                              magnetic_settings or MagneticSettings())[0])))
    return kept, parts


def imu_covariances(survey):
    """
    Return the covariances of the corrected Imu: (linear_acceleration, orientation).

    Both are (M, 9) row-major 3x3 per accepted sample.  Acceleration: the
    propagated sensor noise (two-axis completion and calibration matrices
    included, ``uncertainty.specific_force_covariance``).  Roll and pitch:
    the same through ``uncertainty.roll_pitch_covariance``, plus the
    calibration's own tilt variance; yaw is unobserved.
    """
    if survey.imu_covariance_rows is not None:
        return survey.imu_covariance_rows
    count = survey.corrected_mps2.shape[0]
    orientation = np.zeros((count, 3, 3))
    orientation[:, :2, :2] = roll_pitch_covariance(survey.corrected_mps2,
                                                   survey.covariance_mps2, survey.tilt_var_rad2)
    orientation[:, 2, 2] = UNOBSERVED_YAW_VARIANCE
    return np.reshape(survey.covariance_mps2, (count, 9)), orientation.reshape(count, 9)
