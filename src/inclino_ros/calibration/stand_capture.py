"""
Stand positions captured one by one, then solved into a stand stage (seed 001 §4).

The tool sits on a calibration stand at a known attitude (inclination,
toolface); a still capture is averaged into one Position.  Six or more
well-spread positions give K and b (``stand.fit_stand``, Eq. 10 with a bias);
the fit must also reproduce its own positions within a residual limit before
it becomes the model's ``stand`` stage.
"""

from dataclasses import dataclass
import math

from inclino_ros.calibration.level_capture import CaptureRefused
from inclino_ros.calibration.model import Stand, utc_now_iso
from inclino_ros.calibration.plausibility import check_accelerometer_readings
from inclino_ros.core.attitude import angle_between
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


def direction_spread_deg(samples):
    """Return the RMS angle [deg] of the sample directions about their mean direction."""
    samples = np.asarray(samples, dtype=float)
    return math.degrees(math.sqrt(np.mean(angle_between(samples, samples.mean(axis=0)) ** 2)))


def check_new_attitude(positions, inclination_deg, toolface_deg):
    """Raise CaptureRefused when the attitude repeats one already captured."""
    new = stand_specific_force(inclination_deg, toolface_deg, 1.0)
    for number, position in enumerate(positions, start=1):
        old = stand_specific_force(position.inclination_deg, position.toolface_deg, 1.0)
        apart_deg = math.degrees(float(angle_between(new, old)))
        if apart_deg < MIN_SEPARATION_DEG:
            raise CaptureRefused(
                f'duplicate position: inclination {inclination_deg} deg, toolface '
                f'{toolface_deg} deg is {apart_deg:.3f} deg from position {number}; set '
                'stand.inclination_deg / stand.toolface_deg to the next stand attitude')


def average_position(samples, inclination_deg, toolface_deg, max_std_deg, gravity_mps2):
    """
    Return the Position of a still capture.

    Raises CaptureRefused if it moved, Implausible for readings that are not
    a still tool's in m/s^2 (``plausibility.check_accelerometer_readings``).
    """
    samples = np.asarray(samples, dtype=float)
    if samples.shape[0] < 2:
        raise CaptureRefused(f'only {samples.shape[0]} sample(s) captured, need at least 2')
    check_accelerometer_readings(samples, gravity_mps2, "the position's samples")
    std_deg = direction_spread_deg(samples)
    if std_deg > max_std_deg:
        raise CaptureRefused(f'tool is moving: spread {std_deg:.4f} deg exceeds '
                             f'stand.max_std_deg {max_std_deg} deg')
    return Position(inclination_deg=float(inclination_deg), toolface_deg=float(toolface_deg),
                    reading_mps2=tuple(samples.mean(axis=0).tolist()), std_deg=std_deg,
                    samples=int(samples.shape[0]))


def solve_positions(positions, gravity_mps2, max_rms_deg):
    """
    Return the Stand stage fitted to ``positions``, or raise StandFitRefused.

    Refused as ``stand.fit_stand`` refuses (too few, repeated or ill-posed
    positions), and when the fit's inclination residual RMS over its own
    positions exceeds ``max_rms_deg`` (inconsistent captures: a position
    mislabelled, or the tool not seated the same way).
    """
    readings = np.array([p.reading_mps2 for p in positions]).reshape(-1, 3)
    truth = stand_specific_force([p.inclination_deg for p in positions],
                                 [p.toolface_deg for p in positions], gravity_mps2)
    fit = fit_stand(readings, np.reshape(truth, (-1, 3)))
    if fit.rms_inclination_deg > max_rms_deg:
        worst = int(np.argmax(np.abs(fit.inclination_residual_deg)))
        raise StandFitRefused(
            f'the fit does not reproduce its positions: residual RMS '
            f'{fit.rms_inclination_deg:.4f} deg exceeds stand.max_rms_deg {max_rms_deg} deg '
            f'(worst: position {worst + 1}, {fit.inclination_residual_deg[worst]:+.4f} deg)')
    return Stand(
        scale_matrix=tuple(map(tuple, fit.scale_matrix.tolist())),
        bias_mps2=tuple(fit.bias_mps2.tolist()), method='stand',
        condition_number=float(fit.condition_number),
        rms_inclination_deg=float(fit.rms_inclination_deg), positions=len(positions),
        fitted_at=utc_now_iso())
