"""The report of a stand fit (``inclino fit-stand``): K, b, per-position table and figures."""

from functools import partial

from inclino_ros.core.attitude import inclination
from inclino_ros.io.report import Residual, residual_lines
from inclino_ros.report.common import finish_figure, matrix_lines, new_figure
import numpy as np

#: The title of a known-attitude stand fit's residual table.
POSITIONS_TITLE = ("inclination residual of each position against its mean's noise "
                   '(spread / sqrt(n))')


def position_report(solution, attitudes, counts, spread_deg, repeatability):
    """
    Return (lines, residual rows, draw) of a known-attitude stand fit (``stand_fit.solve_stand``).

    ``attitudes`` (P, 3) [deg], ``counts`` (P,) samples and ``spread_deg``
    (P,) per-sample noise of each position; ``repeatability`` the line on
    the repeated attitudes (``stand_fit.repeatability_note``).  The lines
    hold K, b, the geometry, the position table, the plateaus of a
    multi-temperature stand, the RMS and the residual table; ``draw(path)``
    plots the inclination error per position before and after.
    """
    result, means = solution.fit, solution.readings
    raw_deg = np.degrees(inclination(means)) - attitudes[:, 0]
    after_deg = result.inclination_residual_deg
    lines = geometry_lines(result)
    lines.append(f'{"pos":>3} {"att":>3} {"incl_deg":>9} {"tf_deg":>8} {"az_deg":>7} '
                 f'{"samples":>7} {"noise_deg":>10} {"raw_err_deg":>11} {"residual_deg":>12}')
    lines += [f'{k + 1:>3} {a + 1:>3} {incl:9.3f} {tf:8.3f} {az:7.2f} {n:>7} {s:10.4f} '
              f'{before:11.4f} {after:12.6f}'
              for k, ((incl, tf, az), a, n, s, before, after) in enumerate(
                  zip(attitudes, result.attitude, counts, spread_deg, raw_deg, after_deg))]
    lines.append(repeatability)
    if solution.plateaus is not None:
        lines += plateau_lines(solution.plateaus)
    lines.append(f'RMS inclination residual: {result.rms_inclination_deg:.6f} deg (raw '
                 f'{np.sqrt(np.mean(raw_deg ** 2)):.4f} deg); RMS residual '
                 f'{result.rms_residual_mps2:.3g} m/s^2')
    rows = [Residual(f'position {k + 1} (I {attitude[0]:.1f}, TF {attitude[1]:.1f} deg, {n} '
                     'samples)', float(after), float(spread / np.sqrt(n)), 'deg')
            for k, (attitude, n, spread, after) in enumerate(
                zip(attitudes, counts, spread_deg, after_deg))]
    lines += residual_lines(rows, POSITIONS_TITLE)
    return lines, rows, partial(plot_positions, raw_deg=raw_deg, after_deg=after_deg,
                                rms_deg=result.rms_inclination_deg)


def sphere_report(solution, readings, gravity_mps2):
    """Return (lines, draw) of a sphere fit of ``readings`` (``stand_fit.solve_sphere``)."""
    result = solution.fit
    rms_deg = np.degrees(result.rms_residual_mps2 / gravity_mps2)
    lines = geometry_lines(result) + [
        f'RMS |G| - g: {result.rms_residual_mps2:.3g} m/s^2 ({rms_deg:.6f} deg as an '
        f'angle) over {readings.shape[0]} readings']
    return lines, partial(plot_readings,
                          raw_mps2=np.linalg.norm(readings, axis=1) - gravity_mps2,
                          after_mps2=result.residual_mps2)


def field_lines(fit, total_nT, dip_deg, source, positions):
    """Return the lines of a stand's magnetometer fit (``magnetometer.fit_field_stand``)."""
    lines = [f'magnetometer (seed 001 Eq. 12) against {total_nT:.1f} nT, dip '
             f'{dip_deg:.3f} deg ({source}): {positions} positions, field residual '
             f'{fit.rms_residual_deg:.4f} deg RMS (worst {fit.residual_deg.max():.4f})']
    if fit.plateaus is not None:
        lines += plateau_lines(fit.plateaus, 'nT', ('RMS field residual', fit.plateau_rms_deg))
    lines += matrix_lines('K_m (m = K_m B + b_m, symmetric part)',
                          fit.magnetometer.scale_matrix, '10.6f')
    lines.append('bias_nT: ' + ' '.join(f'{v:.1f}' for v in fit.magnetometer.bias_nT)
                 + f"; axes turned {fit.alignment.angle_deg:.4f} deg into the accelerometer's")
    return lines


def plateau_lines(plateaus, unit='m/s^2', residual=None):
    """
    Return a multi-temperature stand's plateaus, order, residual and 1 sigma as text lines.

    ``residual``: (name, values [deg] per plateau) of the residual to show; None: each
    plateau fit's RMS inclination residual (the accelerometer's).  ``unit``: of b.
    """
    name, values = residual or ('RMS inclination residual',
                                [fit.rms_inclination_deg for fit in plateaus.fits])
    return [f'positions at {len(plateaus.fits)} temperature plateaus: K(T) and b(T), every '
            f'element a polynomial of T of order {plateaus.order} (chi-square per order tried: '
            + ', '.join(f'{order}: {chi:.3g} for {dof} dof' for order, chi, dof
                        in plateaus.chi_square)
            + f'), valid over {plateaus.range_c[0]:.1f} .. {plateaus.range_c[1]:.1f} C'] + [
        f'  plateau {t:6.2f} C: {fit.attitude.size} positions, {name} {value:.5f} deg, '
        f'1 sigma of K elements <= {sigma[:9].max():.2g}, of b <= {sigma[9:].max():.2g} {unit}'
        for t, fit, sigma, value in zip(plateaus.plateaus_c, plateaus.fits,
                                        plateaus.element_sigma, values)] + [
        "  the fit's own 1 sigma of K(T), b(T) (in every 1 sigma of the angles) at "
        + '; '.join(f'{t:.1f} C: K <= {sigma[:9].max():.2g}, b <= {sigma[9:].max():.2g} {unit}'
                    for t, sigma in ((t, plateaus.sigma_at(t)) for t in _plateaus_and_between(
                        plateaus.plateaus_c)))]


def _plateaus_and_between(plateaus_c):
    """Return the plateaus' temperatures and the midpoints between them, in order."""
    plateaus_c = np.sort(np.asarray(plateaus_c, dtype=float))
    return np.insert(plateaus_c, np.arange(1, plateaus_c.size),
                     0.5 * (plateaus_c[1:] + plateaus_c[:-1]))


def geometry_lines(result):
    """Return K, b and the sensing-axis geometry of a fit as text lines."""
    return matrix_lines('K (A = K G + b)', result.scale_matrix, '10.6f') + [
        'bias_mps2: ' + ' '.join(f'{v:.6f}' for v in result.bias_mps2),
        'axis scales: ' + ' '.join(f'{v:.6f}' for v in result.axis_scales),
        'non-orthogonality_deg (xy xz yz): '
        + ' '.join(f'{v:.4f}' for v in result.non_orthogonality_deg),
        f'condition number: {result.condition_number:.3f}']


def plot_positions(path, raw_deg, after_deg, rms_deg):
    """Plot the inclination error per position before and after the fit."""
    pyplot, fig, axes = new_figure(2, 'inclino fit-stand: inclination error per stand position')
    position = np.arange(1, raw_deg.size + 1)
    axes[0].bar(position, raw_deg, color='tab:red', label='raw readings')
    axes[0].set_ylabel('raw inclination error [deg]')
    axes[1].bar(position, after_deg, color='tab:green',
                label=f'after K^-1 (A - b), RMS {rms_deg:.2g} deg')
    axes[1].set_ylabel('residual [deg]')
    for ax in axes:
        ax.set_xlabel('stand position [number]')
        ax.set_xticks(position)
        ax.axhline(0.0, color='black', linewidth=0.8)
    finish_figure(pyplot, fig, axes, path)


def plot_readings(path, raw_mps2, after_mps2):
    """Plot |G| - g per reading before and after a sphere fit."""
    pyplot, fig, axes = new_figure(2, 'inclino fit-stand --method sphere: |G| - g per reading')
    index = np.arange(raw_mps2.size)
    axes[0].plot(index, raw_mps2, '.', color='tab:red', markersize=4, label='raw readings')
    axes[1].plot(index, after_mps2, '.', color='tab:green', markersize=4,
                 label='after K^-1 (A - b)')
    for ax in axes:
        ax.set_ylabel('|G| - g [m/s^2]')
    for ax in axes:
        ax.set_xlabel('reading [number]')
    finish_figure(pyplot, fig, axes, path)
