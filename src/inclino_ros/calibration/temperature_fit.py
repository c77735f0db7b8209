"""
A triad's temperature stage from a heating run (seed 001 Eqs. 5-7, with a bias drift).

Heated at two or more attitudes (where every axis reads differently), each
axis gets a bias AND a scale drift, ``A_T = K_T(T) A + B_T(T)``
(``temperature.fit_temperature_drift``).  At one attitude (or with given
references) only seed 001's scale factor K_T is fitted
(``temperature.fit_temperature``): a bias drift is absorbed into K_T at that
attitude and wrong at every other.  The reference of a one-attitude fit is
the given one, else the mean reading within a window of 25 deg C.

The stage compensates the readings to the temperature the later stages'
readings stood for (stand and installation; for the magnetometer the stage it
feeds: its own ``magnetometer`` stage, else the rotation fit), when they
record one: a stand captured at 35 deg C keeps working.
"""

from inclino_ros.calibration.provenance import common_stage_temperature, utc_now_iso
from inclino_ros.calibration.stages import MagnetometerTemperature, Temperature
from inclino_ros.core.attitude import angle_between, inclination
from inclino_ros.core.temperature import (
    fit_temperature, fit_temperature_drift, REFERENCE_TEMPERATURE_C, TemperatureFitRefused)
import numpy as np

#: Per triad: the calibration section of its temperature stage, and its later stages.
TRIAD_STAGES = {
    'accelerometer': ('temperature', ('stand', 'installation')),
    'magnetometer': ('magnetometer_temperature', ('magnetometer', 'magnetic')),
}
#: Triads whose temperature stage targets only the first of its later stages present
#: (the one it feeds: the magnetometer's K_m, fitted on its readings; the rotation fit
#: came after K_m and stood for whatever K_m's readings did).
FEEDS_FIRST = ('magnetometer',)

#: What a one-attitude fit cannot see (said in every report of one).
ONE_ATTITUDE_NOTE = (
    'ONE attitude (or given references): scale factor K_T(T) only (seed 001). A bias drift '
    'cannot be seen here: it is absorbed into K_T, exactly at this attitude (the residual '
    'stays at the noise) and wrongly at every other; heat the tool at a second attitude '
    'where each axis reads differently to fit it')


def heated_attitudes(temperature_c, attitude, order):
    """Return how many attitudes were heated through ``order + 1`` distinct temperatures."""
    return sum(np.unique(np.round(temperature_c[attitude == a], 1)).size >= order + 1
               for a in np.unique(attitude))


def one_attitude_fit(temperature_c, readings, reference, order, window_c, notes):
    """
    Return seed 001's scale-only fit (reference: given, else the 25 deg C reading).

    TemperatureFitRefused when no reading lies within ``window_c`` of 25 deg C
    to take the reference from; ``notes`` (a list) gets what the fit says.
    """
    if reference is None:
        near = np.abs(temperature_c - REFERENCE_TEMPERATURE_C) <= window_c
        if not near.any():
            raise TemperatureFitRefused(
                f'no reading within {window_c} deg C of {REFERENCE_TEMPERATURE_C} deg C (data '
                f'{temperature_c.min():.2f} .. {temperature_c.max():.2f} deg C) to take the '
                'reference from; heat through 25 deg C or give the ref columns')
        reference = readings[near].mean(axis=0)
        notes.append(f'reference: mean of {near.sum()} readings within {window_c} deg C of '
                     f'{REFERENCE_TEMPERATURE_C} deg C: '
                     + ' '.join(f'{v:.6f}' for v in reference))
    notes.append(ONE_ATTITUDE_NOTE)
    return fit_temperature(temperature_c, readings, reference, order)


def later_stages_temperature(model, later, result, max_difference_c):
    """
    Return the temperature the stage must compensate to, None for its reference.

    The later stages' common temperature (``provenance.common_stage_temperature``)
    when they record one; TemperatureFitRefused when they disagree by more
    than ``max_difference_c`` or it lies outside the heated range.
    """
    try:
        target_c = common_stage_temperature(model, max_difference_c, later)
    except ValueError as err:
        raise TemperatureFitRefused(str(err)) from None
    if target_c is not None and not result.t_min_c <= target_c <= result.t_max_c:
        raise TemperatureFitRefused(
            f'the later stages stand for {target_c:.1f} C, outside the heated range '
            f'{result.t_min_c:.1f} .. {result.t_max_c:.1f} C: heat through it')
    return target_c


def stage_of(triad, result, samples, axes_map=None):
    """Return the Temperature or MagnetometerTemperature stage of a fit (sensor ``axes_map``)."""
    bias = (None if result.bias_coefficients is None
            else tuple(map(tuple, result.bias_coefficients.tolist())))
    common = {'coefficients': tuple(map(tuple, result.coefficients.tolist())),
              't_min_c': float(result.t_min_c), 't_max_c': float(result.t_max_c),
              'reference_temperature_c': float(result.reference_temperature_c),
              'samples': int(samples), 'fitted_at': utc_now_iso(),
              'attitudes': int(result.attitudes), 'axes_map': axes_map,
              'parameter_covariance': tuple(tuple(map(tuple, axis))
                                            for axis in result.parameter_covariance.tolist())}
    rms = tuple(result.rms_residual.tolist())
    if triad == 'accelerometer':
        return Temperature(**common, rms_residual_mps2=rms, bias_coefficients_mps2=bias)
    return MagnetometerTemperature(**common, rms_residual_nT=rms, bias_coefficients_nT=bias)


def solve_temperature(model, triad, temperature_c, readings, attitude, order, reference=None,
                      window_c=1.0, max_difference_c=2.0, axes_map=None):
    """
    Return (stage, TemperatureFit, notes) of a heating run of ``triad`` for ``model``.

    ``attitude`` (N,): a label per reading (readings of one label share one
    attitude, ``stillness.label_attitudes``); ``reference`` (N, 3) or None:
    the reading each stood for at 25 deg C (a one-attitude fit).  ``readings``
    and ``reference`` in the sensor's own axes, ``axes_map`` the map that
    turns them into the tool axes (``core.mounting``; None: they are the tool
    axes): a drift is per sensor axis (issue 19 item 7).  The fit is
    referenced to the later stages' temperature (``later_stages_temperature``);
    TemperatureFitRefused as the fit or that rule refuses.  ``notes``: what
    the report must say.
    """
    notes = []
    later = TRIAD_STAGES[triad][1]
    if triad in FEEDS_FIRST:
        later = next(((name,) for name in later if getattr(model, name) is not None), later)
    if reference is None and heated_attitudes(temperature_c, attitude, order) >= 2:
        result = fit_temperature_drift(temperature_c, readings, attitude, order)
        notes.append(f'{result.attitudes} attitudes heated: bias and scale drift per axis '
                     '(A_T = K_T(T) A + B_T(T))')
    else:
        result = one_attitude_fit(temperature_c, readings, reference, order, window_c, notes)
    target_c = later_stages_temperature(model, later, result, max_difference_c)
    if target_c is not None:
        result = result.referenced_to(target_c)
    elif any(getattr(model, name) is not None for name in later):
        notes.append(f'WARNING: the {" and ".join(n for n in later if getattr(model, n))} '
                     'stage(s) record no temperature: compensating to '
                     f'{result.reference_temperature_c:g} C assumes they were captured there')
    return stage_of(triad, result, temperature_c.size, axes_map), result, notes


def _per_attitude_reference(values, attitude, temperature_c, reference_c):
    """Return each sample's attitude value nearest ``reference_c`` (the run's own baseline)."""
    baseline = np.empty_like(values)
    for label in np.unique(attitude):
        mine = attitude == label
        nearest = np.argmin(np.abs(temperature_c[mine] - reference_c))
        baseline[mine] = values[mine][nearest]
    return baseline


def inclination_errors(previous, model, readings, temperature_c, attitude):
    """Return (before, after, name): inclination change over the run per attitude [deg]."""
    reference_c = model.temperature.reference_temperature_c
    before = np.degrees(inclination(previous.apply(readings)))
    after = np.degrees(inclination(model.apply(readings, temperature_c)))
    baseline = _per_attitude_reference(after, attitude, temperature_c, reference_c)
    return before - baseline, after - baseline, 'inclination error'


def direction_errors(previous, model, readings, temperature_c, attitude):
    """Return (before, after, name): field direction change over the run per attitude [deg]."""
    reference_c = model.magnetometer_temperature.reference_temperature_c
    before = previous.apply_magnetic(readings)
    after = model.apply_magnetic(readings, temperature_c)
    baseline = _per_attitude_reference(after, attitude, temperature_c, reference_c)
    return (np.degrees(angle_between(before, baseline)),
            np.degrees(angle_between(after, baseline)), 'field direction error')


def run_errors(triad, previous, model, readings, temperature_c, attitude):
    """
    Return (before, after, name) of a heating run: its error over the run [deg], per attitude.

    ``previous`` the model without the new temperature stage of ``triad``,
    ``model`` with it: the accelerometer's inclination, the magnetometer's
    field direction, against each attitude's value at the stage's reference
    temperature (``inclination_errors``, ``direction_errors``).
    """
    errors = inclination_errors if triad == 'accelerometer' else direction_errors
    return errors(previous, model, readings, temperature_c, attitude)
