"""
The high-side mark: the toolface's zero tied to the tool without a stand (issue 19 item 6).

The tool lies still on a bench tilted well off vertical (at least
``plausibility.MIN_MARK_INCLINATION_DEG``) with its high-side mark up: its
toolface is 0 by definition.  The mean corrected reading (every other stage
applied) gives the board's toolface there, the roll of the board about the
tool axis that a level bench, a rotation, a sphere or a magnetometer fit
cannot see; the ``ToolfaceMark`` stage turns it back.  One function for the
node (``~/capture_high_side_mark``) and ``inclino fit-toolface-mark``.
"""

from dataclasses import dataclass
import math

from inclino_ros.calibration.model import ToolfaceMark, utc_now_iso
from inclino_ros.calibration.plausibility import MIN_MARK_INCLINATION_DEG
from inclino_ros.calibration.still_capture import CaptureRefused, require_still_vectors
from inclino_ros.core.attitude import inclination, TOOLFACE_CONVENTIONS
from inclino_ros.core.stillness import StillLimits
import numpy as np

__all__ = ('CaptureRefused', 'MarkLimits', 'solve_toolface_mark')


@dataclass(frozen=True)
class MarkLimits:
    """Acceptance limits of a high-side mark capture (``still``: motion and precision)."""

    gravity_mps2: float
    g_total_tolerance_mps2: float
    still: StillLimits = StillLimits(drift_name='still.max_drift_deg_per_s',
                                     sem_name='level_capture.max_sem_deg')


def solve_toolface_mark(corrected, limits, toolface_convention, times_s=None,
                        temperature_c=None):
    """
    Return the ToolfaceMark of a still capture with the high-side mark up, or raise CaptureRefused.

    ``corrected`` (N, 3): the readings through every stage of the model
    before ``toolface_mark`` (tool frame, m/s^2); ``times_s`` their times
    (None: in sample order); ``temperature_c`` what they stood for.  Checks,
    in order: the tool still and its mean precise enough
    (``still_capture.require_still_vectors``), G-total within tolerance, the
    tool at least MIN_MARK_INCLINATION_DEG off vertical (nearer, the
    toolface is undefined).  The offset is the mean's toolface in
    ``toolface_convention`` (seed 000 Eq. 16 or the ISCWSA high side),
    wrapped to (-180, 180]; its 1 sigma the capture's standard error of the
    tilt across the tool axis over sin I (the toolface's own propagation).
    """
    corrected = np.asarray(corrected, dtype=float)
    if not np.isfinite(corrected).all():
        raise CaptureRefused('the capture holds non-finite readings')
    stillness = require_still_vectors(corrected, times_s, limits.still)
    mean = corrected.mean(axis=0)
    g_total = float(np.linalg.norm(mean))
    if not abs(g_total - limits.gravity_mps2) <= limits.g_total_tolerance_mps2:
        raise CaptureRefused(
            f'implausible G-total {g_total:.4f} m/s^2: expected {limits.gravity_mps2} '
            f'+/- {limits.g_total_tolerance_mps2} m/s^2 (sensor scale or units wrong?)')
    inclination_deg = math.degrees(float(inclination(mean)))
    if not MIN_MARK_INCLINATION_DEG <= inclination_deg <= 180.0 - MIN_MARK_INCLINATION_DEG:
        raise CaptureRefused(
            f'the tool lies {min(inclination_deg, 180.0 - inclination_deg):.2f} deg from '
            f'vertical: near vertical the toolface is undefined (no high side); tilt the bench '
            f'to at least {MIN_MARK_INCLINATION_DEG:g} deg with the high-side mark up')
    toolface_deg = math.degrees(float(TOOLFACE_CONVENTIONS[toolface_convention](mean)))
    offset_deg = -((-toolface_deg + 180.0) % 360.0 - 180.0)   # (-180, 180]
    return ToolfaceMark(
        offset_deg=offset_deg,
        std_deg=stillness.sem_deg / math.sin(math.radians(inclination_deg)),
        inclination_deg=inclination_deg, toolface_convention=toolface_convention,
        sample_count=int(corrected.shape[0]), captured_at=utc_now_iso(),
        temperature_c=temperature_c)
