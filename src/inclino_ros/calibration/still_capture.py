"""
Every capture's still test: the tool must not move, and the mean must be precise enough.

One rule for the level bench, the stand positions, the survey stations and
the rotation (``core.stillness``): motion is a mean that moves (drift or
unsteady block means against the noise the capture itself shows), precision
the standard error of the mean.  A capture that fails is refused
(``CaptureRefused``) with the reason: "tool is moving (drift X deg/s ...)"
or "too noisy for the target: N samples needed ...".
"""

from inclino_ros.core.attitude import inclination, toolface_seed000
from inclino_ros.core.refusal import Refused
from inclino_ros.core.stillness import (
    assess, judge, motion, tangent_angles, without_once_per_turn)
import numpy as np


class CaptureRefused(Refused):
    """A capture whose samples cannot give a trustworthy calibration."""


def require_still(angles_rad, times_s, limits, precision=True):
    """
    Return the Stillness of a capture; CaptureRefused when it moves or is too noisy.

    ``angles_rad`` (N,) or (N, k), ``times_s`` (N,) or None; ``precision``
    False checks motion only (a rotation, whose mean is not used).
    """
    try:
        stillness = assess(angles_rad, times_s)
    except ValueError as err:
        raise CaptureRefused(str(err)) from None
    reason = judge(stillness, limits) if precision else motion(stillness, limits, steady=False)
    if reason is not None:
        raise CaptureRefused(reason)
    return stillness


def require_axis_still(vectors, times_s, limits):
    """
    Return the Stillness of the tool axis of a rotation about it; CaptureRefused if it drifts.

    ``vectors`` (N, 3) corrected specific force while the tool turns: the
    inclination must not drift (``stillness.motion`` without the steadiness
    test), once its once-per-turn wobble (``stillness.without_once_per_turn``)
    is removed.
    """
    vectors = np.asarray(vectors, dtype=float)
    axis = without_once_per_turn(inclination(vectors), toolface_seed000(vectors))
    try:
        return require_still(axis, times_s, limits, precision=False)
    except CaptureRefused as err:
        raise CaptureRefused(f'the tool axis moves while it turns: {err}') from None


def require_still_vectors(vectors, times_s, limits):
    """Return the Stillness of the directions of ``vectors`` (N, 3) (``require_still``)."""
    if len(vectors) < 1:
        raise CaptureRefused('no samples captured')
    return require_still(tangent_angles(vectors), times_s, limits)
