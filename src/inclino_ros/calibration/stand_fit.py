"""
The stand stage from stand positions or free readings: one rule for the node and the command.

``~/solve_stand_calibration`` (positions captured one by one,
``stand_capture``) and ``inclino fit-stand`` (a recorded run) both end here:

- consecutive readings of one attitude, without a pause, are one position (``group_positions``),
  each still (``position_noise_deg``); a later visit of an attitude is a
  position of its own (a repeat);
- without a temperature stage, positions whose readings stood for
  temperatures more than a limit apart are refused (the drift would be taken
  for K: ``check_temperature_span``);
- seed 001 Eq. 10 with a bias (``stand.fit_stand``) over the positions,
  repeats of one accelerometer attitude weighed like any position and their
  scatter reported (``repeatability_note``), refused when the fit does not
  reproduce its own positions (``solve_stand``); or, without attitudes,
  ``|G| = g`` over every reading (``solve_sphere``);
- the stage records the temperature its readings stood for, and a new stand
  drops the installation and tool-axis stages (``with_stand``): K holds the
  mounting misalignment, and after a sphere fit the level bench must be
  measured again on the stand-corrected readings.
"""

from dataclasses import dataclass, replace

from inclino_ros.calibration.invalidation import replace_stages
from inclino_ros.calibration.provenance import readings_temperature_c, utc_now_iso
from inclino_ros.calibration.stages import Stand
from inclino_ros.calibration.still_capture import CaptureRefused, require_still_vectors
from inclino_ros.core.stand import (
    attitude_numbers, fit_sphere, fit_stand, fit_stand_plateaus, MIN_POSITIONS, plateau_numbers,
    plateau_stand_fit, stand_specific_force, StandFitRefused)
from inclino_ros.core.stillness import MIN_SAMPLES, SegmentLimits
import numpy as np


@dataclass(frozen=True)
class StandSolution:
    """A stand or sphere fit, its stage, and why it must not be applied (None: it may)."""

    stage: Stand
    fit: object              # core.stand.StandFit or SphereFit
    readings: np.ndarray     # the positions' means (stand) or the readings (sphere)
    attitudes_deg: np.ndarray  # (P, 2) inclination, toolface of the positions; None: sphere
    refusal: str
    plateaus: object = None  # core.stand.TemperatureStandFit of a multi-temperature stand


def stand_readings(model, readings, temperature_c=None):
    """
    Return (readings, stood_c) a stand fit takes: the file's stages before the stand applied.

    As ``~/capture_position`` takes them: the temperature stage of ``model``
    corrects the readings at their temperatures ``temperature_c`` (None: at
    its reference); ``stood_c`` (N,) the temperature each reading stood for
    (``provenance.readings_temperature_c``: the stage's reference, else its
    own), None when neither is known.
    """
    readings = np.asarray(readings, dtype=float)
    stood_c = (None if model.temperature is None and temperature_c is None else
               np.broadcast_to(readings_temperature_c(model.temperature, temperature_c),
                               readings.shape[:1]).astype(float))
    return model.apply(readings, temperature_c, before='stand'), stood_c


def position_stood_c(stage, temperature_c, position, counts):
    """
    Return the temperature each position's readings stood for [C], or None when unknown.

    The reference of their temperature ``stage`` (a stage compensates to it),
    else the mean of their own ``temperature_c`` (N,) over each position's
    readings (``position`` (N,) numbers, ``counts`` (P,) readings a position;
    ``provenance.readings_temperature_c``).
    """
    if stage is None and temperature_c is None:
        return None
    return np.bincount(position, weights=np.broadcast_to(
        readings_temperature_c(stage, temperature_c), np.shape(position))) / counts


def group_positions(readings, attitude_deg, times_s=None):
    """
    Return the positions: (attitudes (P, k), mean readings (P, 3), samples, position (N,)).

    Consecutive samples of equal attitude (rows of ``attitude_deg`` (N, k))
    form one position (one visit of the stand: a later visit of the same
    attitude is a position of its own, a repeat ``stand.fit_stand`` weighs
    and reports); ``position`` is the number of each sample's position.
    With ``times_s`` (N,), a pause between two samples longer than the still
    test's window (``SegmentLimits.window_s``) and than ten of the stream's
    median intervals (a slow sensor's own pace is no pause) begins a new
    visit as well: the tool was taken away and set down again (a log's still
    segments with the motion between them cut out; the time the samples
    stood tells what their order alone does not).
    """
    attitude_deg = np.asarray(attitude_deg, dtype=float)
    changed = np.any(attitude_deg[1:] != attitude_deg[:-1], axis=1)
    if times_s is not None and len(times_s) > 1:
        step = np.diff(np.asarray(times_s, dtype=float))
        changed |= step > max(SegmentLimits.window_s, 10.0 * float(np.median(step)))
    position = np.concatenate([[0], np.cumsum(changed)]).astype(int)
    counts = np.bincount(position)
    means = np.stack([np.bincount(position, weights=readings[:, axis]) for axis in range(3)],
                     axis=1) / counts[:, None]
    return attitude_deg[np.flatnonzero(np.concatenate([[True], changed]))], means, counts, \
        position


def position_noise_deg(readings, times_s, position, count, limits, what=''):
    """
    Return each position's per-sample noise [deg] (NaN: too few samples to test).

    ``Stillness.noise_deg`` (within blocks), what a node's captured position
    keeps too (``stand_capture.Position.noise_deg``): both weigh a mean alike
    (``mean_noise_mps2``).

    CaptureRefused at the first position that moved or misses the precision
    of ``limits`` (``still_capture.require_still_vectors``); ``what`` names
    the triad in the reason.
    """
    noise_deg = np.full(count, np.nan)
    for number in range(count):
        mine = position == number
        if mine.sum() < MIN_SAMPLES:
            continue
        try:
            noise_deg[number] = require_still_vectors(
                readings[mine], None if times_s is None else times_s[mine],
                limits).noise_deg
        except CaptureRefused as err:
            raise CaptureRefused(f'position {number + 1}{what}: {err}') from None
    return noise_deg


def check_temperature_span(temperatures_c, max_difference_c, limit_name):
    """
    Raise StandFitRefused when the readings stood for temperatures too far apart.

    Beyond ``max_difference_c`` (``limit_name`` in the reason).
    ``temperatures_c``: what each position's (or sample's) readings stood
    for, None when unknown (nothing to compare); through a temperature stage
    they all stand for its reference.  Without one, the drift between them
    would be taken for K.
    """
    if temperatures_c is None or len(temperatures_c) == 0 or None in list(temperatures_c):
        return
    temperatures_c = np.asarray(temperatures_c, dtype=float)
    if np.ptp(temperatures_c) > max_difference_c:
        raise StandFitRefused(
            f'the readings stand for {np.min(temperatures_c):.1f} .. '
            f'{np.max(temperatures_c):.1f} C (more than {limit_name} {max_difference_c:g} C '
            'apart) and there is no temperature stage: the drift would be taken for K; fit the '
            'temperature stage first or capture at one temperature')


def stood_for_c(temperatures_c):
    """Return the mean temperature [deg C] the readings stood for, None when any is unknown."""
    if temperatures_c is None or len(temperatures_c) == 0 or None in list(temperatures_c):
        return None
    return float(np.mean(np.asarray(temperatures_c, dtype=float)))


def stand_stage(result, method, rms_inclination_deg, positions, temperature_c):
    """Return the Stand stage of a stand or sphere fit (``core.stand``)."""
    return Stand(scale_matrix=tuple(map(tuple, result.scale_matrix.tolist())),
                 bias_mps2=tuple(result.bias_mps2.tolist()), method=method,
                 condition_number=float(result.condition_number),
                 rms_inclination_deg=(None if rms_inclination_deg is None
                                      else float(rms_inclination_deg)),
                 positions=int(positions), fitted_at=utc_now_iso(),
                 temperature_c=temperature_c,
                 parameter_covariance=(None if getattr(result, 'parameter_covariance', None)
                                       is None else tuple(map(tuple, result.parameter_covariance
                                                              .tolist()))))


def mean_noise_mps2(noise_deg, samples, gravity_mps2):
    """
    Return the 1 sigma [m/s^2] of each position's mean reading, per axis.

    ``noise_deg`` (P,): each position's per-sample noise
    (``Stillness.noise_deg``, NaN: unknown), ``samples`` (P,) its
    count: ``g noise / sqrt(samples)``, the ``mean_noise_mps2`` that
    ``stand.fit_stand`` weighs the positions by; one rule for the node's
    captured positions and the command's.
    """
    return (gravity_mps2 * np.radians(np.asarray(noise_deg, dtype=float))
            / np.sqrt(np.asarray(samples, dtype=float)))


def solve_stand(readings, attitudes_deg, gravity_mps2, max_rms_deg, temperatures_c=None,
                max_temperature_difference_c=None,
                names=('stand.max_rms_deg', 'temperature.max_stage_difference_c',
                       'stand.attitude_sigma_deg'),
                attitude_sigma_deg=0.0, mean_noise_mps2=None):
    """
    Return the StandSolution of stand positions (seed 001 Eq. 10 with a bias).

    ``readings`` (P, 3): each position's mean reading (through the temperature
    stage, if any); ``attitudes_deg`` (P, 3): inclination, toolface, azimuth;
    ``temperatures_c`` (P,): what each stood for (None entries: unknown).
    Positions that differ only in azimuth are one attitude for the
    accelerometer (repeats, weighed and reported by ``stand.fit_stand``).
    StandFitRefused as ``stand.fit_stand`` refuses (fewer than six distinct
    attitudes, an ill-posed set) and on a temperature span
    beyond ``max_temperature_difference_c`` (``check_temperature_span``); a
    fit whose inclination residual RMS over its own positions exceeds
    ``max_rms_deg`` (a position mislabelled, the tool moved or not seated the
    same way) comes back with its ``refusal``.  ``names``: how the reasons
    name the two limits and the attitude sigma.  ``attitude_sigma_deg``,
    ``mean_noise_mps2``: the positions' attitudes known only to that, the
    noise of each mean (``stand.fit_stand``: a tool set on its faces by
    hand); refused (StandFitRefused) with positions at two or more
    temperature plateaus, whose K(T) fit weighs every position alike.
    """
    rms_name, temperature_name, sigma_name = names
    readings = np.asarray(readings, dtype=float).reshape(-1, 3)
    attitudes = np.asarray(attitudes_deg, dtype=float).reshape(-1, 3)[:, :2]
    truth = np.reshape(stand_specific_force(attitudes[:, 0], attitudes[:, 1], gravity_mps2),
                       (-1, 3))
    plateaus = temperature_plateaus(readings, truth, temperatures_c)
    if plateaus is not None and attitude_sigma_deg > 0.0:
        raise StandFitRefused(
            f'{sigma_name} {attitude_sigma_deg:g} deg with positions at '
            f'{len(plateaus.plateaus_c)} temperature plateaus: the K(T), b(T) fit weighs '
            f'every position alike; set {sigma_name} to 0, or fit one plateau at a time')
    if plateaus is not None:
        fit = plateau_stand_fit(plateaus, readings, truth, temperatures_c)
    else:
        if max_temperature_difference_c is not None:
            check_temperature_span(temperatures_c, max_temperature_difference_c,
                                   temperature_name)
        fit = fit_stand(readings, truth, attitude_sigma_deg=attitude_sigma_deg,
                        mean_noise_mps2=mean_noise_mps2)
    refusal = None
    if fit.rms_inclination_deg > max_rms_deg:
        worst = int(np.argmax(np.abs(fit.inclination_residual_deg)))
        refusal = (f'the fit does not reproduce its positions: residual RMS '
                   f'{fit.rms_inclination_deg:.4f} deg exceeds {rms_name} {max_rms_deg} deg '
                   f'(worst: position {worst + 1}, {fit.inclination_residual_deg[worst]:+.4f} '
                   'deg: a wrong attitude, or the tool moved)')
    stage = stand_stage(fit, 'stand', fit.rms_inclination_deg, len(readings),
                        stood_for_c(temperatures_c))
    if plateaus is not None:
        stage = replace(
            stage, temperature_c=plateaus.centre_c,
            parameter_covariance=tuple(map(tuple, plateaus.parameter_covariance.tolist())),
            scale_coefficients=tuple(tuple(map(tuple, term))
                                     for term in plateaus.scale_coefficients.tolist()),
            bias_coefficients_mps2=tuple(map(tuple, plateaus.bias_coefficients.tolist())),
            t_min_c=plateaus.range_c[0], t_max_c=plateaus.range_c[1])
    return StandSolution(stage=stage, fit=fit, readings=readings, attitudes_deg=attitudes,
                         refusal=refusal, plateaus=plateaus)


def solve_sample_positions(readings, attitude_deg, times_s, stood_c, still, gravity_mps2,
                           max_rms_deg, max_temperature_difference_c, names,
                           attitude_sigma_deg=0.0):
    """
    Return (StandSolution, attitudes, samples, noise_deg) per position of stand samples.

    ``readings`` (N, 3) at ``attitude_deg`` are grouped into positions
    (``group_positions``), each position's noise judged by the ``still``
    limits (``position_noise_deg``: CaptureRefused) and the temperature it
    stood for is the mean of its samples' ``stood_c`` (None: unknown); then
    ``solve_stand`` (as ``stand_capture.solve_positions`` fits the node's
    positions), StandFitRefused as it refuses.  ``attitude_sigma_deg`` > 0:
    the attitudes are known only to that (``stand.fit_stand``), each mean's
    noise its samples' spread over the square root of their count.
    """
    attitudes, means, counts, position = group_positions(readings, attitude_deg, times_s)
    temperatures_c = (None if stood_c is None else
                      np.bincount(position, weights=stood_c) / counts)
    noise_deg = position_noise_deg(readings, times_s, position, len(means), still)
    return (solve_stand(means, attitudes, gravity_mps2, max_rms_deg, temperatures_c,
                        max_temperature_difference_c, names, attitude_sigma_deg,
                        mean_noise_mps2(noise_deg, counts, gravity_mps2)),
            attitudes, counts, noise_deg)


def temperature_plateaus(readings, truth, temperatures_c):
    """
    Return the TemperatureStandFit of positions at two or more plateaus, else None.

    Positions whose temperatures (each known) fall in two or more plateaus
    (``stand.plateau_numbers``), each with MIN_POSITIONS distinct attitudes,
    are a multi-temperature stand (``stand.fit_stand_plateaus``: K(T), b(T));
    otherwise (one temperature, an unknown one, or a plateau too small to fit
    alone) None: one K and b, the temperature span checked as before.
    """
    if temperatures_c is None or len(temperatures_c) == 0 or None in list(temperatures_c):
        return None
    temperatures_c = np.asarray(temperatures_c, dtype=float)
    plateau = plateau_numbers(temperatures_c)
    if plateau.max() < 1 or any(
            attitude_numbers(truth[plateau == k]).max() + 1 < MIN_POSITIONS
            for k in range(plateau.max() + 1)):
        return None
    return fit_stand_plateaus(readings, truth, temperatures_c)


def repeatability_note(fit):
    """Return what a stand fit's repeats showed, in words (``stand.repeatability``)."""
    repeated = np.flatnonzero(np.isfinite(fit.repeatability_deg))
    if not repeated.size:
        return f'{fit.attitudes} distinct attitudes, none repeated'
    return (f'{fit.attitudes} distinct attitudes, {repeated.size} repeated: repeatability '
            f'{fit.rms_repeatability_deg:.4f} deg RMS (per repeated attitude: '
            + ', '.join(f'{a + 1}: {fit.repeatability_deg[a]:.4f}' for a in repeated) + ')')


def solve_sphere(readings, gravity_mps2, max_rms_deg, temperature_c=None,
                 rms_name='--max-rms-deg'):
    """
    Return the StandSolution of a reference-free sphere fit ``|G| = g`` of every reading.

    StandFitRefused as ``stand.fit_sphere`` refuses; beyond ``max_rms_deg``
    (the RMS of ``|G| - g`` over g, as an angle) the solution carries its
    refusal.  ``temperature_c``: what the readings stood for (None: unknown).
    """
    fit = fit_sphere(readings, gravity_mps2)
    rms_deg = float(np.degrees(fit.rms_residual_mps2 / gravity_mps2))
    refusal = (None if rms_deg <= max_rms_deg else
               f'RMS |G| - g of {rms_deg:.4f} deg (as an angle) exceeds {rms_name} '
               f'{max_rms_deg} deg (the tool moved, or the sensor is not linear)')
    return StandSolution(stage=stand_stage(fit, 'sphere', None, readings.shape[0], temperature_c),
                         fit=fit, readings=readings, attitudes_deg=None, refusal=refusal)


def with_stand(model, stand, field=None):
    """
    Return (``model`` with the new ``stand`` and ``field``'s stages, notes on the stages dropped).

    The installation and tool-axis stages are dropped: a stand K, fitted
    against the tool's attitude, already holds the mounting misalignment (a
    kept gamma/beta would count it twice), and after a sphere fit the level
    bench must be measured again on the stand-corrected readings.  The
    magnetometer's non-linear stage, fitted in the tool frame of the previous
    chain, is dropped too (``inclino fit-magnetometer`` fits it again), and so
    is a high-side mark: it was captured through the old stages (a stand ties
    the toolface itself; after a sphere fit capture the mark again): the one
    rule, ``invalidation.replace_stages``, whose notes (one per stage
    dropped, with what to do) the node's answer and the command's report say.
    ``field``: a ``magnetometer.FieldStandFit`` or None.
    """
    fields = {} if field is None else {'magnetometer': field.magnetometer,
                                       'magnetometer_alignment': field.alignment}
    return replace_stages(model, stand=stand, installation=None, tool_axis=None, **fields)
