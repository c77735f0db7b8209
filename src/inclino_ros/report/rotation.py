"""The report of a rotation fit (``inclino fit-rotation``): residual against the turn angle."""

from inclino_ros.io.report import Residual
from inclino_ros.report.common import finish_figure, new_figure
import numpy as np

#: Width of a sector of the turn in the residual table [deg].
SECTOR_DEG = 45


def summary_lines(result, readings):
    """Return the text summary of a CrossAxialFit of ``readings``."""
    w = result.correction
    radial_nT = np.linalg.norm(readings[:, :2] - readings[:, :2].mean(axis=0), axis=1)
    return [
        f'rotation: {result.sample_count} readings, coverage {result.coverage_deg:.1f} deg, '
        f'axial field {readings[:, 2].mean():.1f} nT (spread {readings[:, 2].std():.1f} nT)',
        f'hard iron c (tool x, y): {result.offset_nT[0]:.2f}, {result.offset_nT[1]:.2f} nT',
        f'soft iron W: [[{w[0, 0]:.6f}, {w[0, 1]:.6f}], [{w[1, 0]:.6f}, {w[1, 1]:.6f}]]',
        f'axis ratio {result.axis_ratio:.5f}, circle radius {result.radius_nT:.1f} nT',
        f'radial RMSE after {result.rmse_nT:.2f} nT (about the raw mean: '
        f'{np.std(radial_nT):.2f} nT)']


def rotation_angles(readings, corrected, result):
    """
    Return per reading: the rotation angle, radial residual before and after, direction error.

    The angle [deg, 0..360) is the direction of the corrected cross-axial
    field; the radial residuals [nT] are the reading's radius minus the
    circle's, before (about the origin: the raw magnetometer) and after the
    correction (the fit's residual); the direction error [deg] is how far
    the raw reading's cross-axial direction is from the corrected one: what
    the fit removes from the toolface and, through it, from the azimuth.
    """
    angle_deg = np.degrees(np.arctan2(corrected[:, 1], corrected[:, 0])) % 360.0
    before_nT = np.hypot(readings[:, 0], readings[:, 1]) - result.radius_nT
    after_nT = np.hypot(corrected[:, 0], corrected[:, 1]) - result.radius_nT
    raw_deg = np.degrees(np.arctan2(readings[:, 1], readings[:, 0]))
    error_deg = (raw_deg - angle_deg + 180.0) % 360.0 - 180.0
    return angle_deg, before_nT, after_nT, error_deg


def sector_residuals(angle_deg, after_nT, result):
    """
    Return the Residual rows of each 45 deg sector of the turn the readings cover.

    Per sector the RMS radial residual after the correction [nT] against the
    fit's radial RMSE (its stated noise): a sector far above it is a part of
    the turn the ellipse does not describe (a magnetised spot, a jerk).
    """
    rows = []
    for start in range(0, 360, SECTOR_DEG):
        inside = (angle_deg >= start) & (angle_deg < start + SECTOR_DEG)
        if inside.any():
            rows.append(Residual(
                f'{start:3d}-{start + SECTOR_DEG:3d} deg ({int(inside.sum())} readings)',
                float(np.sqrt(np.mean(after_nT[inside] ** 2))), float(result.rmse_nT), 'nT'))
    return rows


def plot_rotation(path, readings, corrected, result):
    """
    Plot what the fit changes against the rotation angle, before and after.

    The readings and the circle are not drawn: a centre of tens of nT and an
    axis ratio near 1 cannot be seen on a circle of tens of thousands.  The
    first panel shows each reading's radial residual (its radius minus the
    circle's), the second the error of its cross-axial direction, which the
    toolface and the azimuth inherit; the band is the fit's noise (radial RMSE,
    and RMSE / r in angle).
    """
    angle_deg, before_nT, after_nT, error_deg = rotation_angles(readings, corrected, result)
    noise_deg = np.degrees(result.rmse_nT / result.radius_nT)
    pyplot, fig, axes = new_figure(
        2, f'inclino fit-rotation: hard iron |c| {np.hypot(*result.offset_nT):.1f} nT, '
           f'axis ratio {result.axis_ratio:.4f}, radius {result.radius_nT:.0f} nT')
    order = np.argsort(angle_deg)
    panels = ((before_nT, after_nT, result.rmse_nT, 'nT',
               'radial residual |B_xy| - r [nT]'),
              (error_deg, np.zeros_like(error_deg), noise_deg, 'deg',
               'cross-axial direction error [deg]'))
    for ax, (before, after, noise, unit, ylabel) in zip(axes, panels):
        ax.axhspan(-noise, noise, color='tab:green', alpha=0.15,
                   label=f'fit noise +-{noise:.3g} {unit} (1 sigma)')
        ax.plot(angle_deg[order], before[order], '.', color='tab:red', markersize=3,
                label=f'before: raw readings (largest {np.max(np.abs(before)):.3g} {unit})')
        ax.axhline(0.0, color='black', linewidth=0.8)
        ax.set_xlim(0.0, 360.0)
        ax.set_xticks(np.arange(0, 361, 45))
        ax.set_xlabel('rotation angle: direction of the corrected cross-axial field [deg]')
        ax.set_ylabel(ylabel)
    axes[0].plot(angle_deg[order], after_nT[order], '.', color='tab:green', markersize=3,
                 label=f'after: W (m - c), RMSE {result.rmse_nT:.2f} nT')
    axes[1].plot([], [], '.', color='tab:green',
                 label=f'after: the corrected direction is the reference; its noise '
                       f'RMSE / r = {noise_deg:.3g} deg')
    finish_figure(pyplot, fig, axes, path)
