"""The report of a level-bench fit (``inclino fit-level``): the capture, its blocks, figure."""

import math

from inclino_ros.calibration.level_capture import angles_sigma_text
from inclino_ros.core.installation import level_axis_angles
from inclino_ros.io.report import Residual
from inclino_ros.report.common import finish_figure, new_figure
import numpy as np

#: Blocks the capture is cut into for the residual table.
BLOCKS = 5


def capture_lines(model, applied):
    """Return the summary lines of ``model``'s level capture; ``applied``: stages used first."""
    installation = model.installation
    return [
        f'level capture: {installation.sample_count} samples'
        + (f' after the {" and ".join(applied)} stage of the file' if applied else ''),
        f'gamma_deg={installation.gamma_deg:.4f} beta_deg={installation.beta_deg:.4f} '
        f'theta_deg={installation.theta_deg:.4f} (noise {installation.std_deg:.4f} deg per '
        f'sample, {angles_sigma_text(model)}, '
        f'G-total {installation.g_total_mps2:.4f} m/s^2)']


def axis_tilts_deg(level, two_axis_g):
    """Return the tilts theta'_x1, theta'_y1 (N, 2) [deg] of each sample (seed 000 Eqs. 11-12)."""
    g = np.full(level.shape[0], two_axis_g) if two_axis_g else np.linalg.norm(level, axis=1)
    return np.degrees(np.stack(level_axis_angles(level, g), axis=1))


def block_residuals(level, installation, two_axis_g):
    """
    Return the Residual rows of the capture cut in BLOCKS: each axis tilt's mean minus the whole's.

    The stated noise of a block's mean is the stage's per-sample noise
    ``std_deg`` over the square root of the block's samples: a block far
    above it is a drift or a knock the stillness check let through.
    """
    tilts_deg = axis_tilts_deg(level, two_axis_g)
    rows = []
    for number, block in enumerate(np.array_split(np.arange(level.shape[0]), BLOCKS)):
        if block.size == 0:
            continue
        noise_deg = installation.std_deg / math.sqrt(block.size)
        for column, name in enumerate(("theta'_x1", "theta'_y1")):
            rows.append(Residual(
                f'block {number + 1}/{BLOCKS} ({block.size} samples) {name}',
                float(tilts_deg[block, column].mean() - tilts_deg[:, column].mean()),
                noise_deg, 'deg'))
    return rows


def plot_level(path, level, installation, two_axis_g):
    """Plot the axis tilts of every sample and their mean (seed 000 Eqs. 11-12)."""
    tilts_deg = axis_tilts_deg(level, two_axis_g)
    pyplot, fig, axes = new_figure(2, f'inclino fit-level: gamma {installation.gamma_deg:.4f} '
                                      f'deg, beta {installation.beta_deg:.4f} deg')
    sample = np.arange(level.shape[0])
    for ax, column, name in zip(axes, tilts_deg.T, ("theta'_x1", "theta'_y1")):
        ax.plot(sample, column, '.', markersize=3, label=f'{name} per sample')
        ax.axhline(column.mean(), color='black',
                   label=f'mean {column.mean():.4f} deg (spread {column.std():.4f} deg)')
        ax.set_ylabel(f'{name} [deg]')
    for ax in axes:
        ax.set_xlabel('sample of the level capture [number]')
    finish_figure(pyplot, fig, axes, path)
