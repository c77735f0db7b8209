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

from inclino_ros.calibration.level_capture import CaptureRefused
from inclino_ros.calibration.magnetometer import fit_field_stand, merge_repeated_attitudes
from inclino_ros.calibration.model import Stand, utc_now_iso
from inclino_ros.core.attitude import angle_between
from inclino_ros.core.magnetics import expected_field_tool_nT
from inclino_ros.core.stand import (
    fit_stand, MIN_SEPARATION_DEG, stand_specific_force, StandFitRefused)
import numpy as np


@dataclass(frozen=True)
class Position:
    """One averaged still capture at a known stand attitude."""

    inclination_deg: float
    toolface_deg: float
    reading_mps2: tuple  # mean of the temperature-compensated readings
    std_deg: float       # RMS angle of the samples about their mean direction
    samples: int
    azimuth_deg: float = 0.0   # magnetic azimuth of the hole direction (as survey.z)
    field_nT: tuple = None     # mean raw magnetometer reading, None when not captured
    field_std_deg: float = None


def direction_spread_deg(samples):
    """Return the RMS angle [deg] of the sample directions about their mean direction."""
    samples = np.asarray(samples, dtype=float)
    return math.degrees(math.sqrt(np.mean(angle_between(samples, samples.mean(axis=0)) ** 2)))


def check_new_attitude(positions, inclination_deg, toolface_deg, azimuth_deg=0.0,
                       reference=None):
    """
    Raise CaptureRefused when the attitude repeats one already captured.

    With ``reference`` (total nT, dip deg) a position that differs only in
    azimuth is new (the magnetometer sees it); without, only the gravity
    direction counts.
    """
    new = stand_specific_force(inclination_deg, toolface_deg, 1.0)
    for number, position in enumerate(positions, start=1):
        old = stand_specific_force(position.inclination_deg, position.toolface_deg, 1.0)
        apart_deg = math.degrees(float(angle_between(new, old)))
        if reference is not None:
            fields = expected_field_tool_nT(
                [inclination_deg, position.inclination_deg],
                [toolface_deg, position.toolface_deg],
                [azimuth_deg, position.azimuth_deg], *reference)
            apart_deg = max(apart_deg, math.degrees(float(angle_between(*fields))))
        if apart_deg < MIN_SEPARATION_DEG:
            raise CaptureRefused(
                f'duplicate position: inclination {inclination_deg} deg, toolface '
                f'{toolface_deg} deg, azimuth {azimuth_deg} deg is {apart_deg:.3f} deg from '
                f'position {number}; set stand.inclination_deg / stand.toolface_deg / '
                'stand.azimuth_deg to the next stand attitude')


def average_position(samples, inclination_deg, toolface_deg, max_std_deg, fields_nT=None,
                     azimuth_deg=0.0):
    """
    Return the Position of a still capture, or raise CaptureRefused if it moved.

    ``fields_nT``: the paired magnetometer readings (NaN rows unpaired) when
    the magnetometer is captured; fewer than two paired leave the position
    without a field.  The field must be as still as the accelerometer: a turn
    about the vertical (the azimuth axis of a stand) shows in it alone.
    """
    samples = np.asarray(samples, dtype=float)
    if samples.shape[0] < 2:
        raise CaptureRefused(f'only {samples.shape[0]} sample(s) captured, need at least 2')
    std_deg = direction_spread_deg(samples)
    if std_deg > max_std_deg:
        raise CaptureRefused(f'tool is moving: spread {std_deg:.4f} deg exceeds '
                             f'stand.max_std_deg {max_std_deg} deg')
    field, field_std_deg = None, None
    if fields_nT is not None:
        fields_nT = np.asarray(fields_nT, dtype=float).reshape(-1, 3)
        fields_nT = fields_nT[np.isfinite(fields_nT).all(axis=1)]
        if fields_nT.shape[0] >= 2:
            field_std_deg = direction_spread_deg(fields_nT)
            if field_std_deg > max_std_deg:
                raise CaptureRefused(f'tool is moving: magnetometer spread {field_std_deg:.4f} '
                                     f'deg exceeds stand.max_std_deg {max_std_deg} deg')
            field = tuple(fields_nT.mean(axis=0).tolist())
    return Position(inclination_deg=float(inclination_deg), toolface_deg=float(toolface_deg),
                    reading_mps2=tuple(samples.mean(axis=0).tolist()), std_deg=std_deg,
                    samples=int(samples.shape[0]), azimuth_deg=float(azimuth_deg),
                    field_nT=field, field_std_deg=field_std_deg)


def solve_positions(positions, gravity_mps2, max_rms_deg, reference=None,
                    max_field_rms_deg=None):
    """
    Return (Stand stage, FieldStandFit or None, note) of ``positions``, or raise StandFitRefused.

    Refused as ``stand.fit_stand`` refuses (too few, repeated or ill-posed
    positions), and when the fit's inclination residual RMS over its own
    positions exceeds ``max_rms_deg`` (inconsistent captures: a position
    mislabelled, or the tool not seated the same way).  Positions that differ
    only in azimuth are one attitude for the accelerometer (averaged).  With
    ``reference`` (total nT, dip deg) and a field at every position the
    magnetometer is fitted too (``magnetometer.fit_field_stand``, refused
    beyond ``max_field_rms_deg``); the note says why it was not otherwise.
    """
    readings = np.array([p.reading_mps2 for p in positions]).reshape(-1, 3)
    attitudes = np.array([(p.inclination_deg, p.toolface_deg, p.azimuth_deg)
                          for p in positions]).reshape(-1, 3)
    readings, accel_attitudes = merge_repeated_attitudes(readings, attitudes, MIN_SEPARATION_DEG)
    truth = stand_specific_force(accel_attitudes[:, 0], accel_attitudes[:, 1], gravity_mps2)
    fit = fit_stand(readings, np.reshape(truth, (-1, 3)))
    if fit.rms_inclination_deg > max_rms_deg:
        worst = int(np.argmax(np.abs(fit.inclination_residual_deg)))
        raise StandFitRefused(
            f'the fit does not reproduce its positions: residual RMS '
            f'{fit.rms_inclination_deg:.4f} deg exceeds stand.max_rms_deg {max_rms_deg} deg '
            f'(worst: position {worst + 1}, {fit.inclination_residual_deg[worst]:+.4f} deg)')
    stand = Stand(
        scale_matrix=tuple(map(tuple, fit.scale_matrix.tolist())),
        bias_mps2=tuple(fit.bias_mps2.tolist()), method='stand',
        condition_number=float(fit.condition_number),
        rms_inclination_deg=float(fit.rms_inclination_deg), positions=len(readings),
        fitted_at=utc_now_iso())
    without = [number for number, p in enumerate(positions, start=1) if p.field_nT is None]
    if reference is None:
        return stand, None, 'magnetometer not fitted: no reference field'
    if without:
        return stand, None, f'magnetometer not fitted: no field at position(s) {without}'
    fields = np.array([p.field_nT for p in positions])
    return stand, fit_field_stand(fields, attitudes, *reference, stand, max_field_rms_deg), None
