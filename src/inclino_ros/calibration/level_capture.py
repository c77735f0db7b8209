"""
Level-bench capture: installation angles from still samples (seed 000 §3).

The tool lies on a bench levelled with an electronic level (true inclination
zero); the mean sensor reading then gives the axis tilts of Eqs. 11-12 and the
installation angles of Eqs. 13-14.  A capture is refused, with a reason, when
its samples cannot give a trustworthy answer.
"""

from dataclasses import dataclass
import math

from inclino_ros.calibration.model import Installation, utc_now_iso
from inclino_ros.calibration.still_capture import CaptureRefused, require_still
from inclino_ros.core.installation import (
    installation_angles, level_axis_angles, pseudo_inclination)
from inclino_ros.core.stillness import StillLimits
import numpy as np

__all__ = ('CaptureRefused', 'LevelLimits', 'solve_level_capture')


@dataclass(frozen=True)
class LevelLimits:
    """Acceptance limits of a level capture (``still``: motion and precision)."""

    max_tilt_deg: float
    gravity_mps2: float
    g_total_tolerance_mps2: float
    still: StillLimits = StillLimits(drift_name='still.max_drift_deg_per_s',
                                     motion_name='still.max_motion_deg',
                                     sem_name='level_capture.max_sem_deg')


def solve_level_capture(samples, axes, limits, times_s=None, temperature_c=None):
    """
    Return the Installation of a level capture, or raise CaptureRefused.

    ``samples`` are accepted raw readings, shape (N, 3), m/s^2 (for a
    two-axis sensor the z column is ignored and ``v_g`` is the configured
    gravity); ``times_s`` their times (None: in sample order);
    ``temperature_c`` the temperature their readings stand for (None:
    unknown), recorded in the stage.  Checks, in order: the tool is still and
    the mean precise enough (``still_capture.require_still`` of the
    per-sample axis tilts of Eqs. 11-12); G-total within tolerance (three
    axes); the bench level (false tilt theta of Eq. 4 at most
    ``max_tilt_deg``).  ``std_deg`` of the stage is the per-sample noise of
    one tilt (of correlated noise the white one of the same mean's standard
    error, ``Stillness.white_noise_deg``), so ``std_deg / sqrt(sample_count)``
    is the angles' 1 sigma.
    """
    samples = np.asarray(samples, dtype=float)
    if not np.isfinite(samples[:, :axes]).all():
        raise CaptureRefused('the capture holds non-finite readings')
    if axes == 3:
        g_per_sample = np.linalg.norm(samples, axis=1)
    else:
        g_per_sample = np.full(samples.shape[0], limits.gravity_mps2)
    tilt_x, tilt_y = level_axis_angles(samples, g_per_sample)
    stillness = require_still(np.column_stack([tilt_x, tilt_y]), times_s, limits.still)
    mean = samples.mean(axis=0)
    g_total = float(np.linalg.norm(mean)) if axes == 3 else limits.gravity_mps2
    if not abs(g_total - limits.gravity_mps2) <= limits.g_total_tolerance_mps2:
        raise CaptureRefused(
            f'implausible G-total {g_total:.4f} m/s^2: expected {limits.gravity_mps2} '
            f'+/- {limits.g_total_tolerance_mps2} m/s^2 (sensor scale or units wrong?)')
    gamma, beta = installation_angles(*level_axis_angles(mean, g_total))
    theta_deg = math.degrees(float(pseudo_inclination(gamma, beta)))
    if not theta_deg <= limits.max_tilt_deg:
        raise CaptureRefused(
            f'bench is not level: tilt {theta_deg:.3f} deg exceeds '
            f'level_capture.max_tilt_deg {limits.max_tilt_deg} deg')
    return Installation(
        gamma_deg=math.degrees(float(gamma)), beta_deg=math.degrees(float(beta)),
        captured_at=utc_now_iso(), sample_count=int(samples.shape[0]),
        std_deg=stillness.white_noise_deg, g_total_mps2=g_total, temperature_c=temperature_c)


def angles_sigma_text(model):
    """
    Return how a fit states the 1 sigma of ``model``'s installation angles (node and command).

    ``CalibrationModel.installation_std_deg``: the capture's noise alone
    ("1 sigma of the angles X deg"), or with a stand's fit read through the
    bench, gamma's and beta's each, the noise's share said.
    """
    noise_deg = math.degrees(model.installation.tilt_std_rad)
    gamma_deg, beta_deg = model.installation_std_deg()
    if max(gamma_deg, beta_deg) <= noise_deg * (1.0 + 1e-9):
        return f'1 sigma of the angles {noise_deg:.4f} deg'
    return (f'1 sigma of the angles {gamma_deg:.4f} / {beta_deg:.4f} deg (gamma / beta: the '
            f"capture's noise {noise_deg:.4f} deg and the stand's fit)")
