"""
Stand positions captured one by one, then solved into a stand stage (seed 001 §4).

The tool sits on a calibration stand at a known attitude (inclination,
toolface, and the magnetic azimuth of the hole direction); a still capture is
averaged into one Position.  Six or more well-spread positions give K and b
(``stand.fit_stand``, Eq. 10 with a bias); the fit must also reproduce its
own positions within a residual limit before it becomes the model's
``stand`` stage.  With a reference field and the magnetometer captured at
every position, the same fit against the field expected there gives the
magnetometer's K_m and bias (Eq. 12, ``magnetometer.fit_field_stand``).
"""

from dataclasses import dataclass
import math

from inclino_ros.calibration.magnetometer import fit_field_stand
from inclino_ros.calibration.plausibility import check_accelerometer_readings
from inclino_ros.calibration.stand_fit import mean_noise_mps2, repeatability_note, solve_stand
from inclino_ros.calibration.still_capture import (
    CaptureRefused, require_still, require_still_vectors)
from inclino_ros.core.attitude import angle_between
from inclino_ros.core.magnetics import expected_field_tool_nT
from inclino_ros.core.stand import MIN_SEPARATION_DEG, stand_specific_force, StandFitRefused
from inclino_ros.core.stillness import tangent_angles
import numpy as np


@dataclass(frozen=True)
class Position:
    """One averaged still capture at a known stand attitude."""

    inclination_deg: float
    toolface_deg: float
    reading_mps2: tuple  # mean of the temperature-compensated readings
    std_deg: float       # per-sample noise of the direction, one component (still test;
    #                      correlated: the white one of the same standard error)
    samples: int
    azimuth_deg: float = 0.0   # magnetic azimuth of the hole direction (as survey.z)
    field_nT: tuple = None     # mean raw magnetometer reading, None when not captured
    field_std_deg: float = None  # per-sample noise of the field's direction
    temperature_c: float = None  # what the readings stood for; None: unknown
    field_temperature_c: float = None  # what the field stood for (its own temperature stage)
    noise_deg: float = math.nan  # per-sample noise within blocks (Stillness.noise_deg): what
    #                              the mean is weighed by (stand_fit.mean_noise_mps2), as fit-stand


def repeated_position(positions, inclination_deg, toolface_deg, azimuth_deg=0.0,
                      reference=None):
    """
    Return the number (1-based) of the first captured position this attitude repeats, or None.

    A repeat is welcome (``stand.fit_stand`` weighs every visit and reports
    the stand's repeatability); the number lets the caller say so.  With
    ``reference`` (total nT, dip deg) a position that differs only in azimuth
    is new (the magnetometer sees it); without, only the gravity direction
    counts.
    """
    for number, position in enumerate(positions, start=1):
        old = stand_specific_force(position.inclination_deg, position.toolface_deg, 1.0)
        new = stand_specific_force(inclination_deg, toolface_deg, 1.0)
        apart_deg = math.degrees(float(angle_between(new, old)))
        if reference is not None:
            fields = expected_field_tool_nT(
                [inclination_deg, position.inclination_deg],
                [toolface_deg, position.toolface_deg],
                [azimuth_deg, position.azimuth_deg], *reference)
            apart_deg = max(apart_deg, math.degrees(float(angle_between(*fields))))
        if apart_deg < MIN_SEPARATION_DEG:
            return number
    return None


def average_position(samples, inclination_deg, toolface_deg, limits, times_s=None,
                     temperature_c=None, fields_nT=None, azimuth_deg=0.0, gravity_mps2=None,
                     field_temperature_c=None):
    """
    Return the Position of a still capture; CaptureRefused if it moved or is too noisy.

    ``limits`` (``stillness.StillLimits``) as ``still_capture.require_still``
    applies them to the directions of the samples; ``times_s`` their times.
    ``fields_nT``: the paired magnetometer readings (NaN rows unpaired) when
    the magnetometer is captured; fewer than two paired leave the position
    without a field.  The field must not move either: a turn about the
    vertical (the azimuth axis of a stand) shows in it alone.  With
    ``gravity_mps2``, raises Implausible for readings that are not a still
    tool's in m/s^2 (``plausibility.check_accelerometer_readings``).
    ``temperature_c``, ``field_temperature_c``: what the readings and the
    fields stood for (``provenance.readings_temperature_c`` of each triad's
    temperature stage).
    """
    samples = np.asarray(samples, dtype=float)
    if gravity_mps2 is not None:
        check_accelerometer_readings(samples, gravity_mps2, "the position's samples")
    stillness = require_still_vectors(samples, times_s, limits)
    field, field_std_deg = None, None
    if fields_nT is not None:
        fields_nT = np.asarray(fields_nT, dtype=float).reshape(-1, 3)
        paired = np.isfinite(fields_nT).all(axis=1)
        if np.count_nonzero(paired) >= 2:
            times = None if times_s is None else np.asarray(times_s, dtype=float)[paired]
            try:
                field_still = require_still(tangent_angles(fields_nT[paired]), times, limits,
                                            precision=False)
            except CaptureRefused as err:
                raise CaptureRefused(f'magnetometer: {err}') from None
            field = tuple(fields_nT[paired].mean(axis=0).tolist())
            field_std_deg = field_still.white_noise_deg
    return Position(inclination_deg=float(inclination_deg), toolface_deg=float(toolface_deg),
                    reading_mps2=tuple(samples.mean(axis=0).tolist()),
                    std_deg=stillness.white_noise_deg, noise_deg=stillness.noise_deg,
                    samples=int(samples.shape[0]),
                    azimuth_deg=float(azimuth_deg), field_nT=field, field_std_deg=field_std_deg,
                    temperature_c=temperature_c, field_temperature_c=field_temperature_c)


def solve_positions(positions, gravity_mps2, max_rms_deg, reference=None,
                    max_field_rms_deg=None, max_temperature_difference_c=None,
                    attitude_sigma_deg=0.0):
    """
    Return (Stand, FieldStandFit or None, note, repeats) of ``positions``; StandFitRefused.

    The stand fit of ``stand_fit.solve_stand`` (its refusals raised, the
    limits named as the node's parameters; repeats weighed, ``repeats`` says
    their repeatability: ``stand_fit.repeatability_note``); with
    ``reference`` (total nT, dip deg) and a field at every position the
    magnetometer is fitted too (``magnetometer.fit_field_stand``, refused
    beyond ``max_field_rms_deg``; positions at two or more temperature
    plateaus give K_m(T), b_m(T) as they give K(T), b(T)); the note says why
    it was not otherwise.  ``attitude_sigma_deg`` > 0: the attitudes are
    known only to that (``stand.fit_stand``), each position's mean of the
    noise it was captured with (``stand_fit.mean_noise_mps2``).
    """
    readings = np.array([p.reading_mps2 for p in positions]).reshape(-1, 3)
    attitudes = np.array([(p.inclination_deg, p.toolface_deg, p.azimuth_deg)
                          for p in positions]).reshape(-1, 3)
    noise_mps2 = mean_noise_mps2([p.noise_deg for p in positions],
                                 [p.samples for p in positions], gravity_mps2)
    solution = solve_stand(readings, attitudes, gravity_mps2, max_rms_deg,
                           [p.temperature_c for p in positions], max_temperature_difference_c,
                           attitude_sigma_deg=attitude_sigma_deg, mean_noise_mps2=noise_mps2)
    if solution.refusal:
        raise StandFitRefused(solution.refusal)
    stand = solution.stage
    repeats = repeatability_note(solution.fit)
    without = [number for number, p in enumerate(positions, start=1) if p.field_nT is None]
    if reference is None:
        return stand, None, 'magnetometer not fitted: no reference field', repeats
    if without:
        return (stand, None, f'magnetometer not fitted: no field at position(s) {without}',
                repeats)
    fields = np.array([p.field_nT for p in positions])
    return (stand, fit_field_stand(fields, attitudes, *reference, stand, max_field_rms_deg,
                                   [p.field_temperature_c for p in positions]),
            None, repeats)
