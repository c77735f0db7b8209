"""The report of a temperature fit (``inclino fit-temperature``): coefficients, bins, figure."""

from inclino_ros.core.temperature import AXES
from inclino_ros.io.report import Residual
from inclino_ros.report.common import finish_figure, matrix_lines, new_figure
import numpy as np

#: Width of a temperature bin of the residual table [C].
TEMPERATURE_BIN_C = 5.0


def temperature_residuals(temperature_c, before, after, what):
    """
    Return the Residual rows of each TEMPERATURE_BIN_C of the run: the RMS error compensated.

    The fit states no per-sample noise of the angle, so the noise is NaN
    (no ratio); the uncompensated RMS error of the bin is in the note.
    """
    rows = []
    edges = np.arange(np.floor(temperature_c.min() / TEMPERATURE_BIN_C) * TEMPERATURE_BIN_C,
                      temperature_c.max() + TEMPERATURE_BIN_C, TEMPERATURE_BIN_C)
    for low in edges[:-1]:
        inside = (temperature_c >= low) & (temperature_c < low + TEMPERATURE_BIN_C)
        if inside.any():
            rows.append(Residual(
                f'{low:.0f} .. {low + TEMPERATURE_BIN_C:.0f} C ({int(inside.sum())} samples)',
                float(np.sqrt(np.mean(after[inside] ** 2))), float('nan'), 'deg',
                note=f'RMS {what} {np.sqrt(np.mean(before[inside] ** 2)):.4f} deg '
                     'uncompensated'))
    return rows


def fit_lines(result, unit):
    """Return the report lines of a fit: coefficients, values at the range's ends, residuals."""
    lines = matrix_lines(f'K_T(T) = a0 + a1 T + ... (rows {", ".join(AXES)}; a0 a1 ...)',
                         result.coefficients, '14.6e')
    if result.bias_coefficients is not None:
        lines += matrix_lines(f'B_T(T) = b0 + b1 T + ... [{unit}]', result.bias_coefficients,
                              '14.6e')
    ends_c = (result.t_min_c, result.reference_temperature_c, result.t_max_c)
    lines += [f'K_T and B_T at {", ".join(f"{t:.1f}" for t in ends_c)} deg C:'] + [
        f'  {axis}: ' + ' '.join(f'{v:.6f}' for v in scale) + ' | '
        + ' '.join(f'{v:.6g}' for v in bias)
        for axis, scale, bias in zip(AXES, result.scale_factor(ends_c).T,
                                     result.bias(ends_c).T)]
    return lines + [f'fitted {result.t_min_c:.2f} .. {result.t_max_c:.2f} deg C; RMS '
                    f'residual per axis: ' + ' '.join(f'{v:.3g}' for v in result.rms_residual)
                    + f' {unit}']


def plot(path, temperature_c, result, before, after, what):
    """Plot K_T and B_T per axis, and the error over the run before/after."""
    pyplot, fig, axes = new_figure(3, 'inclino fit-temperature: scale factor and bias drift')
    grid_c = np.linspace(result.t_min_c, result.t_max_c, 200)
    for axis, color in zip(range(3), ('tab:red', 'tab:green', 'tab:blue')):
        axes[0].plot(grid_c, result.scale_factor(grid_c)[:, axis], color=color,
                     label=f'{AXES[axis]}: K_T(T)')
        axes[1].plot(grid_c, result.bias(grid_c)[:, axis], color=color,
                     label=f'{AXES[axis]}: B_T(T)')
    axes[0].set_ylabel('K_T [1]')
    axes[1].set_ylabel('B_T [unit of the readings]')
    axes[2].plot(temperature_c, before, '.', color='tab:red', markersize=2,
                 label=f'uncompensated, largest {np.abs(before).max():.3f} deg')
    axes[2].plot(temperature_c, after, '.', color='tab:green', markersize=2,
                 label=f'compensated, largest {np.abs(after).max():.4f} deg')
    axes[2].set_ylabel(f'{what} [deg]')
    for ax in axes:
        ax.set_xlabel('temperature [deg C]')
    finish_figure(pyplot, fig, axes, path)
