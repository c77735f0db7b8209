"""
What a calibration stage, and a reading a fit takes, can physically be: one place.

The stage checks run when a file is loaded (``model.load_model``) and when a
fit's result is written (``model.save_model`` validates what it writes, and
every fit of the node and of the command line is written through it), so a
stage that could not come from a real sensor is refused either way.  The
reading checks run before a fit, on what it is given: there a unit mistake
shows, and is named (tesla or gauss instead of nT, g instead of m/s^2).
Every refusal is an ``Implausible`` (a ValueError) with the reason.

The bounds, and why:

- accelerometer (m/s^2): a still tool reads |A| = g within the scale and bias
  errors, so the readings of a fit have a median |A| within
  ``STILL_G_FRACTION`` of g and none beyond ``MAX_STILL_G`` g; a stand stage
  has K near a rotation (the mount) times identity: K itself has a positive
  determinant and its rotation tilts the tool axis by at most
  ``MAX_STAND_TILT_DEG``, the symmetric part of its polar decomposition has
  each scale within ``MAX_SCALE_ERROR`` of 1 and each cross-coupling term at
  most ``MAX_CROSS_COUPLING``, a bias
  of at most ``MAX_BIAS_G`` g on each axis and, against the sensor's range
  when it is known, ``|K_i| g + |b_i|`` below the range on every axis (else
  the axis could not have read both +g and -g unsaturated);
- installation: |gamma|, |beta| below ``MAX_INSTALLATION_DEG``, the G-total
  of the capture within ``STILL_G_FRACTION`` of g;
- temperature: a fitted range within ``TEMPERATURE_C`` and K_T(T) within
  ``MAX_TEMPERATURE_SCALE_ERROR`` of 1 over it;
- magnetometer (nT): the Earth's field is 22 000-67 000 nT at the surface
  (``EARTH_FIELD_NT`` with a margin); a drill string's interference stays
  below ``MAX_INTERFERENCE_NT`` per axis (seed 002 §3.2), hard iron included;
  so a raw reading's magnitude lies within ``FIELD_NT`` (below: a dead sensor
  or another unit; beyond: not a reading, and ``field_reading_ok`` drops it);
  the soft-iron correction is near identity with an axis ratio of at most
  that of the rotation fit (``RotationLimits.max_axis_ratio``); an MSA
  reference is an Earth field; its 1 sigma is at most the interference bound;
- magnetometer stage (K_m, b_m, seed 001 Eq. 12): K_m invertible
  (condition at most ``MAX_CONDITION_NUMBER``) with each scale within
  ``MAX_MAGNETOMETER_SCALE_ERROR`` of 1 (soft iron included), each bias
  within ``FIELD_NT``'s upper bound, the field it is scaled to an Earth
  field (else the readings were not in nT: the unit is named);
- magnetometer alignment: a proper rotation (orthonormal within 1e-6,
  determinant +1), its dip within +-90 deg;
- tool axis: |gamma|, |beta| below ``MAX_INSTALLATION_DEG`` (a mount, as the
  installation), its axial RMS an angle;
- every stage's time (``captured_at``, ``fitted_at``): not more than
  ``MAX_FUTURE_S`` ahead of this clock;
- temperature stages of both triads: the fitted range within
  ``TEMPERATURE_C``, K_T(T) within ``MAX_TEMPERATURE_SCALE_ERROR`` of 1 over
  it and 1 at the reference; a bias drift B_T(T) 0 at the reference and at
  most ``MAX_BIAS_G`` g (accelerometer) or ``MAX_INTERFERENCE_NT``
  (magnetometer) over the range; a captured stage's temperature within
  ``TEMPERATURE_C``.
"""

from datetime import datetime, timezone

from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.core.cross_axial import RotationLimits
from inclino_ros.core.msa import MAX_INTERFERENCE_NT
from inclino_ros.core.refusal import Refused
from inclino_ros.core.stand import MAX_CONDITION_NUMBER, rotation_part
import numpy as np

# The sensor limits below come from datasheets of the parts this package meets, each with
# the margin named beside it; a quartz-flex MWD accelerometer is far inside every one.
# Figures checked against the datasheets' tables (issue 21): ADXL345 rev. E Table 1
# (sensitivity 230 .. 256 .. 282 LSB/g at +-2 g 10-bit; 0 g output X, Y -150 .. +150 mg,
# Z -250 .. +250 mg; sensitivity change +-0.01 %/C; -40 .. +85 C) and its siblings ADXL313
# (cross-axis +-1 %) and ADXL350 (cross-axis +-3 %, inter-axis alignment +-0.1 deg); the
# InvenSense accelerometer of the MPU-9150 as specified for the MPU-6050 (PS-MPU-6000A-00
# rev 3.4 Table 6.2: initial tolerance +-3 %, +-0.02 %/C, cross-axis +-2 %, zero-G X, Y
# +-50 mg, Z +-80 mg) and the MPU-9250 (PS-MPU-9250A-01 rev 1.0 Table 2: +-3 %,
# +-0.026 %/C, cross-axis +-2 %, zero-G X, Y +-60 mg, Z +-80 mg, +-1.5 mg/C over
# -40 .. +85 C); the MPU-9150's own table (PS-MPU-9150A-00 rev 4.3 Table 6.2) was not at
# hand, its zero-G figures below (X, Y +-80 mg, Z +-150 mg) are the larger, kept.
# Magnetometer: AKM AK8975 of the MPU-9150.  The real MPU-9150 units of
# /work/shared/data/real (their authors' fit: scale 0.25-0.93 %, misalignment <= 0.32 deg,
# bias <= 0.35 m/s^2) lie inside with room to spare
# (test_plausibility.test_real_mpu9150_units_are_plausible).

#: A still tool's |A| (and a level capture's G-total) lies within this fraction of g:
#: scale (ADXL345 sensitivity 230 .. 282 LSB/g, +-10 %) plus bias (0.25 g, below) is
#: 0.35 g at worst, with a margin for local gravity and noise.
STILL_G_FRACTION = 0.5
#: No reading of a still tool reaches this many g: 1 g times the worst scale (1.1)
#: plus the worst bias (0.25 g) is 1.35 g; 2 g leaves a margin for noise spikes.
MAX_STILL_G = 2.0
#: Largest bias of an accelerometer axis [g]: ADXL345 0 g output Z -250 .. +250 mg
#: (X, Y +-150 mg), MPU-9150 zero-G Z +-150 mg (X, Y +-80 mg), MPU-9250 Z 80 mg plus
#: 1.5 mg/C over the 60 C from 25 C to 85 C, 170 mg; 0.3 g is the largest with a 20 %
#: margin.
MAX_BIAS_G = 0.3
#: Largest |K_ii - 1| of a stand stage: ADXL345 sensitivity +-10 % (MPU-9150 initial
#: tolerance +-3 %), margin x2.
MAX_SCALE_ERROR = 0.2
#: Largest |P_ij| (i != j) of the symmetric part of a stand K: cross-axis sensitivity
#: (MPU-6050/9250 +-2 %, ADXL313 +-1 %, ADXL350 +-3 %), margin x2.5 on the +-2 % of the
#: parts met (x1.7 on the ADXL350's).  The package's misalignment (about
#: 1 deg, 0.017) is a rotation: it is in K's rotation part, bounded by MAX_STAND_TILT_DEG.
MAX_CROSS_COUPLING = 0.05
#: Largest |gamma|, |beta| [deg] of an installation stage: a package sits within about
#: 1 deg of its board, a board within a few degrees of the housing; a sensor turned
#: further is mounted by an axes map (core.mounting), and seed 000's closed form is
#: only exercised up to here.
MAX_INSTALLATION_DEG = 45.0
#: Largest tilt [deg] of a stand K's rotation part away from the tool axis (its roll
#: about the axis is the mount, any angle): as an installation's.
MAX_STAND_TILT_DEG = MAX_INSTALLATION_DEG
#: Largest |K_T - 1| of a temperature stage over its fitted range: MEMS scale drift is
#: 100 .. 260 ppm/C (ADXL345 +-0.01 %/C, MPU-6050 +-0.02 %/C, MPU-9250 +-0.026 %/C),
#: 8.3 % over the whole TEMPERATURE_C span (320 C) at 260 ppm/C; 0.2 is that with a
#: margin x2.4.
MAX_TEMPERATURE_SCALE_ERROR = 0.2
#: Temperatures [deg C] a sensor reads: MEMS parts are rated -40 .. 85 C (MPU-9150,
#: ADXL345 operating range), downhole sensors to 175 .. 200 C (high-temperature MWD
#: tools); with a margin on both sides.
TEMPERATURE_C = (-60.0, 260.0)
#: The Earth's field at the surface [nT], with a margin (WMM: 22 000 - 67 000 nT).
EARTH_FIELD_NT = (20_000.0, 70_000.0)
#: Magnitude [nT] a raw magnetometer reading may have: an Earth field plus interference
#: (and the sensor's own hard iron: a real hand-held instrument, circuitpython-mag-cal's
#: cal_data/ab, reads 113000 nT median, 80 uT of hard iron on a 55 uT field).
FIELD_NT = (1_000.0, 200_000.0)
#: Largest axis ratio of a soft-iron correction: that of the rotation fit.
MAX_SOFT_IRON_AXIS_RATIO = RotationLimits().max_axis_ratio
#: Largest |K_ii - 1| of a magnetometer stage (its soft iron is in K_m): AK8975
#: sensitivity 0.285 .. 0.315 uT/LSB (+-5 %) and per-axis adjustment values of up to
#: +-50 % (its ASA registers scale by 0.5 .. 1.5): the worst part uncorrected.
MAX_MAGNETOMETER_SCALE_ERROR = 0.5
#: Largest sample count of a stage (a day at 10 kHz is 8.6e8).
MAX_COUNT = 10 ** 9

#: How far [s] a stage's time may lie ahead of this clock: two hosts' clocks (NTP keeps
#: them within a second; a laptop without it drifts ~1 min/month); beyond, the time was
#: typed or the writer's clock is wrong, and the stage's age means nothing.
MAX_FUTURE_S = 600.0

#: Units a magnetometer may wrongly be read in, and their nT.
_FIELD_UNITS = (('tesla', 1e9), ('gauss', 1e5), ('microtesla (uT)', 1e3),
                ('milligauss (mG)', 1e2))
#: Units an accelerometer may wrongly be read in, and their m/s^2.
_ACCELERATION_UNITS = (('g', STANDARD_GRAVITY_MPS2), ('mg', STANDARD_GRAVITY_MPS2 / 1000.0))


class Implausible(Refused, ValueError):
    """A stage or readings no real sensor gives; ``reason`` says why."""


def magnitude(vectors):
    """Return |v| of each row of (N, k) vectors without overflow or underflow."""
    vectors = np.asarray(vectors, dtype=float)
    vectors = vectors[None] if vectors.ndim == 1 else vectors
    largest = np.max(np.abs(vectors), axis=1, initial=0.0)
    with np.errstate(invalid='ignore', divide='ignore'):
        scaled = vectors / largest[:, None]
        result = largest * np.sqrt(np.sum(scaled * scaled, axis=1))
    return np.where(largest == 0.0, 0.0, np.where(np.isinf(largest), np.inf, result))


def _unit_hint(value, units, expected, unit):
    """Return '; in <unit>? ...' when ``value`` in one of ``units`` is ``expected``."""
    for name, factor in units:
        if expected[0] <= value * factor <= expected[1]:
            return f'; is it in {name}? x{factor:g} gives {value * factor:.4g} {unit}'
    return ''


def _finite_magnitudes(vectors, what):
    """Return the finite |v| of (N, 3) vectors; Implausible if there is none."""
    size = magnitude(np.asarray(vectors, dtype=float).reshape(-1, 3))
    size = size[np.isfinite(size)]
    if size.size == 0:
        raise Implausible(f'{what} hold no finite value')
    return size


def check_field_unit(field_nT, what='the magnetometer readings'):
    """
    Raise Implausible unless the median |B| of the readings (N, 3) is an Earth field in nT.

    Only the median: single readings beyond (a tool passing iron) are the
    caller's to screen.  Returns the finite magnitudes.
    """
    size = _finite_magnitudes(field_nT, what)
    median = float(np.median(size))
    if not FIELD_NT[0] <= median <= FIELD_NT[1]:
        raise Implausible(
            f'{what} have |B| = {median:.4g} nT (median), not an Earth field plus '
            f'interference ({FIELD_NT[0]:g} .. {FIELD_NT[1]:g} nT): a dead magnetometer, '
            'or readings not in nT' + _unit_hint(median, _FIELD_UNITS, EARTH_FIELD_NT, 'nT'))
    return size


def check_field_readings(field_nT, what='the magnetometer readings'):
    """Raise Implausible unless the finite readings (N, 3) [nT] are Earth fields, in nT."""
    size = check_field_unit(field_nT, what)
    beyond = np.flatnonzero(size > FIELD_NT[1])
    if beyond.size:
        raise Implausible(f'{what}: {beyond.size} reading(s) beyond {FIELD_NT[1]:g} nT '
                          f'(largest |B| {size.max():.4g} nT): not Earth fields')


def field_reading_ok(field_nT):
    """Return whether each raw reading (N, 3) [nT] may be used: finite, |B| within FIELD_NT."""
    field_nT = np.asarray(field_nT, dtype=float).reshape(-1, 3)
    return np.isfinite(field_nT).all(axis=1) & (magnitude(field_nT) <= FIELD_NT[1])


def check_acceleration_unit(readings, gravity_mps2, what='the readings'):
    """
    Raise Implausible unless the median |A| of the readings (N, 3) is gravity in m/s^2.

    Only the median (g or mg instead of m/s^2 is named): single readings of
    a moving tool are the caller's to screen.  Returns the finite magnitudes.
    """
    size = _finite_magnitudes(readings, what)
    median = float(np.median(size))
    still = (gravity_mps2 * (1.0 - STILL_G_FRACTION), gravity_mps2 * (1.0 + STILL_G_FRACTION))
    if not still[0] <= median <= still[1]:
        raise Implausible(
            f'{what} have |A| = {median:.4g} m/s^2 (median), not gravity ({gravity_mps2:g} '
            f'm/s^2 within {STILL_G_FRACTION:.0%})'
            + _unit_hint(median, _ACCELERATION_UNITS, still, 'm/s^2'))
    return size


def check_accelerometer_readings(readings, gravity_mps2, what='the readings'):
    """Raise Implausible unless the finite readings (N, 3) are of a still tool, in m/s^2."""
    size = check_acceleration_unit(readings, gravity_mps2, what)
    beyond = np.flatnonzero(size > MAX_STILL_G * gravity_mps2)
    if beyond.size:
        raise Implausible(f'{what}: {beyond.size} reading(s) beyond {MAX_STILL_G:g} g (largest '
                          f'|A| {size.max():.4g} m/s^2): not a still tool')


def temperature_ok(temperature_c):
    """Return whether each temperature [deg C] is finite and within TEMPERATURE_C."""
    temperature_c = np.asarray(temperature_c, dtype=float)
    with np.errstate(invalid='ignore'):
        return (temperature_c >= TEMPERATURE_C[0]) & (temperature_c <= TEMPERATURE_C[1])


def check_temperatures(temperature_c, what='the temperatures'):
    """Raise Implausible unless every temperature [deg C] is one a sensor reads."""
    bad = np.flatnonzero(~temperature_ok(temperature_c))
    if bad.size:
        raise Implausible(f'{what}: {bad.size} value(s) outside {TEMPERATURE_C[0]:g} .. '
                          f'{TEMPERATURE_C[1]:g} C (first: '
                          f'{np.asarray(temperature_c, dtype=float)[bad[0]]:.4g} C)')


def check_time(moment, name, now=None):
    """Raise Implausible when ``moment`` (an aware datetime) lies in the future (MAX_FUTURE_S)."""
    now = now or datetime.now(timezone.utc)
    ahead_s = (moment - now).total_seconds()
    if ahead_s > MAX_FUTURE_S:
        raise Implausible(f'{name} = {moment.isoformat()} lies {ahead_s:.0f} s in the future '
                          f'(at most {MAX_FUTURE_S:g} s of clock difference): a time not yet '
                          'come cannot be a capture')


def _within(value, low, high, name, unit=''):
    """Raise Implausible unless low <= value <= high."""
    if not low <= value <= high:
        raise Implausible(f'{name} = {value:.6g}{unit} is outside {low:g} .. {high:g}{unit}')


def check_installation(stage):
    """Raise Implausible for an Installation no level bench gives."""
    for name in ('gamma_deg', 'beta_deg'):
        if abs(getattr(stage, name)) >= MAX_INSTALLATION_DEG:
            raise Implausible(f'installation.{name} = {getattr(stage, name)} is not an '
                              f'installation error (|angle| must be < {MAX_INSTALLATION_DEG:g} '
                              'deg)')
    _within(stage.std_deg, 0.0, 90.0, 'installation.std_deg', ' deg')
    _within(stage.g_total_mps2, STANDARD_GRAVITY_MPS2 * (1.0 - STILL_G_FRACTION),
            STANDARD_GRAVITY_MPS2 * (1.0 + STILL_G_FRACTION), 'installation.g_total_mps2',
            ' m/s^2')
    _within(stage.sample_count, 1, MAX_COUNT, 'installation.sample_count')


def check_stand(stage, range_mps2=None):
    """Raise Implausible for a Stand no accelerometer has (K near I, bias, range)."""
    k, bias = (np.asarray(a, dtype=float) for a in stage.arrays)
    if not np.linalg.cond(k) <= MAX_CONDITION_NUMBER:
        raise Implausible(f'stand.scale_matrix {np.round(k, 6).tolist()} is not a sensor: '
                          'singular')
    # A stand K also holds the mount (any roll of the board about the tool axis, issue 8):
    # the sensor is its symmetric part P of K = R P (polar decomposition).
    # K itself, then: a proper rotation (det K > 0, a mirror is no mount) tilted from the
    # tool axis no more than a mount is, times a P near identity.
    try:
        rotation = rotation_part(k)
    except ValueError as err:
        raise Implausible(f'stand.scale_matrix {np.round(k, 6).tolist()} is not a sensor: '
                          f'{err}') from None
    tilt_deg = float(np.degrees(np.arccos(np.clip(rotation[2, 2], -1.0, 1.0))))
    if tilt_deg > MAX_STAND_TILT_DEG:
        raise Implausible(f'stand.scale_matrix {np.round(k, 6).tolist()} is not a sensor: it '
                          f'turns the tool axis by {tilt_deg:.3g} deg (at most '
                          f'{MAX_STAND_TILT_DEG:g}; a sensor turned further needs an axes map)')
    p = rotation.T @ k
    off = p - np.diag(np.diag(p))
    if np.any(np.abs(np.diag(p) - 1.0) > MAX_SCALE_ERROR) \
            or np.any(np.abs(off) > MAX_CROSS_COUPLING):
        raise Implausible(
            f'stand.scale_matrix {np.round(k, 6).tolist()} is not a sensor: K must be near '
            f'identity (scales within {MAX_SCALE_ERROR:g} of 1, cross terms at most '
            f'{MAX_CROSS_COUPLING:g})')
    limit = MAX_BIAS_G * STANDARD_GRAVITY_MPS2
    if np.any(np.abs(bias) > limit):
        raise Implausible(f'stand.bias_mps2 {bias.tolist()} exceeds {MAX_BIAS_G:g} g '
                          f'({limit:.4g} m/s^2) on an axis')
    if range_mps2 is not None:
        reach = np.linalg.norm(k, axis=1) * STANDARD_GRAVITY_MPS2 + np.abs(bias)
        if np.any(reach >= range_mps2):
            raise Implausible(
                f'stand stage: an axis reads up to {reach.max():.4g} m/s^2 at +-g, beyond the '
                f'sensor range {range_mps2:g} m/s^2 (it could not have been fitted unsaturated)')
    _within(stage.condition_number, 1.0 - 1e-9, MAX_CONDITION_NUMBER, 'stand.condition_number')
    if stage.rms_inclination_deg is not None:
        _within(stage.rms_inclination_deg, 0.0, 90.0, 'stand.rms_inclination_deg', ' deg')
    _within(stage.positions, 1, MAX_COUNT, 'stand.positions')


def check_temperature(stage, name='temperature'):
    """
    Raise Implausible for a temperature stage no sensor drifts by.

    ``name``: ``temperature`` (accelerometer, m/s^2) or
    ``magnetometer_temperature`` (nT): the unit of its residuals and bias drift.
    """
    magnetometer = name == 'magnetometer_temperature'
    unit, bias_limit, rms_limit = ((' nT', MAX_INTERFERENCE_NT, FIELD_NT[1]) if magnetometer
                                   else (' m/s^2', MAX_BIAS_G * STANDARD_GRAVITY_MPS2,
                                         STANDARD_GRAVITY_MPS2))
    _within(stage.t_min_c, *TEMPERATURE_C, f'{name}.t_min_c', ' C')
    _within(stage.t_max_c, *TEMPERATURE_C, f'{name}.t_max_c', ' C')
    grid_c = np.linspace(stage.t_min_c, stage.t_max_c, 101)
    with np.errstate(all='ignore'):
        scale = stage.fit.scale_factor(grid_c)
        bias = stage.fit.bias(grid_c)
    if not np.all(np.abs(scale - 1.0) <= MAX_TEMPERATURE_SCALE_ERROR):
        raise Implausible(f'{name}.coefficients give a scale factor outside '
                          f'{1 - MAX_TEMPERATURE_SCALE_ERROR:g} .. '
                          f'{1 + MAX_TEMPERATURE_SCALE_ERROR:g} in the fitted range')
    if np.max(np.abs(stage.fit.scale_factor([stage.reference_temperature_c]) - 1.0)) > 1e-6:
        raise Implausible(f'{name}.coefficients are not 1 at the reference temperature')
    if stage.fit.bias_coefficients is not None:
        if not np.all(np.abs(bias) <= bias_limit):
            raise Implausible(f'{name}: the bias drift reaches {np.max(np.abs(bias)):.4g}'
                              f'{unit} in the fitted range, beyond {bias_limit:.4g}{unit}')
        size = max(1.0, float(np.max(np.abs(stage.fit.bias_coefficients))))
        if np.max(np.abs(stage.fit.bias([stage.reference_temperature_c]))) > 1e-6 * size:
            raise Implausible(f'{name}: the bias drift is not 0 at the reference temperature')
    for value in stage.fit.rms_residual:
        _within(value, 0.0, rms_limit, f'{name}.rms_residual', unit)
    _within(stage.samples, 1, MAX_COUNT, f'{name}.samples')


def check_tool_axis(stage):
    """Raise Implausible for a ToolAxis no mount has (angles as an installation's)."""
    for name in ('gamma_deg', 'beta_deg'):
        if abs(getattr(stage, name)) >= MAX_INSTALLATION_DEG:
            raise Implausible(f'tool_axis.{name} = {getattr(stage, name)} is not an installation '
                              f'error (|angle| must be < {MAX_INSTALLATION_DEG:g} deg)')
    _within(stage.axial_rms_deg, 0.0, 90.0, 'tool_axis.axial_rms_deg', ' deg')


#: The largest non-linear correction a magnetometer's axis plausibly needs, over |B|.
MAX_NONLINEAR_FRACTION = 0.2


def check_magnetometer_nonlinear(stage):
    """Raise Implausible for a MagnetometerNonlinear stage larger than a sensor's non-linearity."""
    if not EARTH_FIELD_NT[0] <= stage.scale_nT <= EARTH_FIELD_NT[1]:
        raise Implausible(f'magnetometer_nonlinear.scale_nT = {stage.scale_nT:.6g} nT is not an '
                          f'Earth field ({EARTH_FIELD_NT[0]:g} .. {EARTH_FIELD_NT[1]:g} nT)')
    grid = np.zeros((201, 3))
    grid[:, 0] = grid[:, 1] = stage.scale_nT * np.linspace(-1.0, 1.0, 201)
    largest = float(np.max(np.abs(stage.apply(grid) - grid))) / stage.scale_nT
    if largest > MAX_NONLINEAR_FRACTION:
        raise Implausible(f'magnetometer_nonlinear corrects up to {largest:.3g} of the field '
                          f'(limit {MAX_NONLINEAR_FRACTION:g}): not a smooth non-linearity')
    _within(stage.rms_residual_nT, 0.0, FIELD_NT[1], 'magnetometer_nonlinear.rms_residual_nT',
            ' nT')


#: The least inclination [deg] (from vertical, up or down) a high-side mark is captured at:
#: nearer vertical the toolface is undefined (its 1 sigma grows as 1 / sin I).
MIN_MARK_INCLINATION_DEG = 5.0


def check_toolface_mark(stage):
    """Raise Implausible for a ToolfaceMark no capture gives (off vertical, a finite sigma)."""
    _within(stage.offset_deg, -180.0, 180.0, 'toolface_mark.offset_deg', ' deg')
    _within(stage.std_deg, 0.0, 90.0, 'toolface_mark.std_deg', ' deg')
    _within(stage.inclination_deg, MIN_MARK_INCLINATION_DEG, 180.0 - MIN_MARK_INCLINATION_DEG,
            'toolface_mark.inclination_deg', ' deg')
    _within(stage.sample_count, 1, MAX_COUNT, 'toolface_mark.sample_count')


def check_magnetometer(stage):
    """Raise Implausible for a Magnetometer stage (K_m, b_m) no magnetometer has, in nT."""
    k, bias = (np.asarray(a, dtype=float) for a in stage.arrays)
    if np.any(np.abs(np.diag(k) - 1.0) > MAX_MAGNETOMETER_SCALE_ERROR) \
            or not np.linalg.cond(k) <= MAX_CONDITION_NUMBER:
        raise Implausible(
            f'magnetometer.scale_matrix {np.round(k, 6).tolist()} is not a plausible sensor '
            f'(singular, or an axis scale more than {MAX_MAGNETOMETER_SCALE_ERROR:g} from 1: '
            'readings not in nT?)')
    if np.any(np.abs(bias) > FIELD_NT[1]):
        raise Implausible(f'magnetometer.bias_nT {bias.tolist()} exceeds {FIELD_NT[1]:g} nT')
    if not EARTH_FIELD_NT[0] <= stage.field_nT <= EARTH_FIELD_NT[1]:
        raise Implausible(
            f'magnetometer.field_nT = {stage.field_nT:.6g} nT is not an Earth field '
            f'({EARTH_FIELD_NT[0]:g} .. {EARTH_FIELD_NT[1]:g} nT)'
            + _unit_hint(stage.field_nT, _FIELD_UNITS, EARTH_FIELD_NT, 'nT'))
    _within(stage.rms_residual_nT, 0.0, FIELD_NT[1], 'magnetometer.rms_residual_nT', ' nT')
    _within(stage.condition_number, 1.0 - 1e-9, MAX_CONDITION_NUMBER,
            'magnetometer.condition_number')
    _within(stage.positions, 1, MAX_COUNT, 'magnetometer.positions')


def check_magnetometer_alignment(stage):
    """Raise Implausible for a MagnetometerAlignment that is not a proper rotation."""
    r = np.asarray(stage.rotation, dtype=float)
    if np.max(np.abs(r @ r.T - np.eye(3))) > 1e-6 or np.linalg.det(r) <= 0:
        raise Implausible(f'magnetometer_alignment.rotation {r.tolist()} is not a rotation')
    if stage.dip_deg is not None and not abs(stage.dip_deg) < 90.0:
        raise Implausible(f'magnetometer_alignment.dip_deg = {stage.dip_deg} is not within '
                          '-90 .. 90 deg')
    if stage.dip_rms_deg is not None:
        _within(stage.dip_rms_deg, 0.0, 90.0, 'magnetometer_alignment.dip_rms_deg', ' deg')


def check_magnetic(stage):
    """Raise Implausible for a Magnetic stage no drill string has."""
    hard_iron = np.asarray(stage.hard_iron_nT, dtype=float)
    if np.any(np.abs(hard_iron) > MAX_INTERFERENCE_NT):
        raise Implausible(f'magnetic.hard_iron_nT {hard_iron.tolist()} exceeds '
                          f'{MAX_INTERFERENCE_NT:g} nT')
    w = np.asarray(stage.soft_iron, dtype=float)
    if np.any(np.abs(np.diag(w) - 1.0) > MAX_SCALE_ERROR) \
            or np.any(np.abs(w - np.diag(np.diag(w))) > MAX_CROSS_COUPLING) \
            or not np.linalg.cond(w) <= MAX_SOFT_IRON_AXIS_RATIO * (1.0 + 1e-9):
        raise Implausible(
            f'magnetic.soft_iron {w.tolist()} is not a plausible correction (near identity, '
            f'axis ratio at most {MAX_SOFT_IRON_AXIS_RATIO:g})')
    eps = np.asarray(stage.interference_nT, dtype=float)
    if np.any(np.abs(eps) > MAX_INTERFERENCE_NT):
        raise Implausible(f'magnetic.interference_nT {eps.tolist()} exceeds '
                          f'{MAX_INTERFERENCE_NT:g} nT')
    if stage.interference_std_nT is not None:
        std = np.asarray(stage.interference_std_nT, dtype=float)
        if not np.all((std >= 0.0) & (std <= MAX_INTERFERENCE_NT)):
            raise Implausible(f'magnetic.interference_std_nT {std.tolist()} must lie within '
                              f'0 .. {MAX_INTERFERENCE_NT:g} nT')
    if stage.msa_method is not None:
        _within(stage.msa_reference_total_nT, *EARTH_FIELD_NT,
                'magnetic.msa_reference_total_nT', ' nT')
        if not abs(stage.msa_reference_dip_deg) < 90.0:
            raise Implausible(f'magnetic.msa_reference_dip_deg = '
                              f'{stage.msa_reference_dip_deg} is not within -90 .. 90 deg')
        _within(stage.msa_stations, 1, MAX_COUNT, 'magnetic.msa_stations')


def check_for_sensor(model, range_mps2):
    """Raise Implausible when the model's stand stage does not fit a sensor of ``range_mps2``."""
    if model.stand is not None:
        check_stand(model.stand, range_mps2)
