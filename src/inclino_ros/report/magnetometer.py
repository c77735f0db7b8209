"""The report of a shot calibration (``inclino fit-magnetometer``): shots, groups, figure."""

from inclino_ros.core.shots import circular_mean_deg, group_spreads
from inclino_ros.io.report import REFUSED, Residual, USED
from inclino_ros.report.common import finish_figure, new_figure
import numpy as np


def robust_lines(fit, labels):
    """Return the lines naming the outlier shots left out and the roll groups taken as free."""
    lines = [f'outlier shot {shot + 1}'
             + ('' if labels is None or labels[shot] < 0 else f' (roll group {labels[shot] + 1})')
             + f': {sigma:.1f} robust sigma from the others, left out of the fit (the tool '
             'moved, or iron was near)' for shot, sigma in fit.outliers]
    lines += [f'roll group {group + 1} taken as free shots (no tool axis from it): {why}'
              for group, why in fit.freed_groups]
    lines += [f'roll group {k + 1}: pointing wander {fit.axial_rms_deg[k]:.3f} deg RMS along '
              'the tool axis (its weight in the fit)' for k in fit.groups]
    return lines


def shot_residuals(fit, labels):
    """
    Return the Residual rows of each shot: its |B| after the fit minus the fitted field [nT].

    Against the noise the fit found per shot (``noise_nT``); an outlier shot
    left out of the fit is refused, with how many robust sigma it stood off.
    """
    outliers, rows = dict(fit.outliers), []
    for i, b_total_nT in enumerate(fit.b_total_nT):
        group = '' if labels is None or labels[i] < 0 else f' (roll group {labels[i] + 1})'
        note = '' if fit.used[i] else (f'outlier, {outliers.get(i, float("nan")):.1f} robust '
                                       'sigma from the others: left out')
        rows.append(Residual(f'shot {i + 1}{group}', float(b_total_nT - fit.field_nT),
                             float(fit.noise_nT), 'nT', USED if fit.used[i] else REFUSED, note))
    return rows


def fit_table_lines(fit, labels):
    """Return the per-shot |g|, |B| and dip the fit leaves (a refused fit's figures)."""
    lines = [f'{"shot":>4} {"group":>5} {"|g| [m/s^2]":>12} {"|B| [nT]":>10} {"dip [deg]":>10}']
    for i in range(len(fit.b_total_nT)):
        group = '' if labels is None or labels[i] < 0 else str(labels[i] + 1)
        lines.append(f'{i + 1:>4} {group:>5} {fit.g_total_mps2[i]:12.5f} '
                     f'{fit.b_total_nT[i]:10.1f} {fit.dip_per_shot_deg[i]:10.4f}'
                     + ('' if fit.used[i] else '  outlier, left out'))
    return lines


def summary_lines(result, labels, before, after, total_nT, dip_ref, source):
    """Return the text summary of a shot calibration."""
    fit = result.fit
    model = result.model
    lines = [f'{len(fit.b_total_nT)} shots, {len(fit.groups)} roll group(s); joint fit in '
             f'{fit.evaluations} evaluations; noise found: {fit.noise_mps2:.3g} m/s^2, '
             f'{fit.noise_nT:.3g} nT per shot']
    lines += list(result.notes) + robust_lines(fit, labels)
    lines.append(f'field scaled to {fit.field_nT:.1f} nT '
                 + (f'(reference, {source})' if total_nT is not None
                    else "(the magnetometer's own mean scale: no reference given)"))
    lines.append(f'dip found {fit.dip_deg:.4f} deg, RMS over the shots {fit.dip_rms_deg:.4f} deg'
                 + ('' if dip_ref is None else
                    f'; reference {dip_ref:.4f} deg ({fit.dip_deg - dip_ref:+.4f})'))
    k_m, bias = model.magnetometer.arrays
    lines.append('magnetometer K_m: ' + '; '.join(' '.join(f'{v:.6f}' for v in row)
                                                  for row in k_m)
                 + '  bias/hard iron nT: ' + ' '.join(f'{v:.1f}' for v in bias))
    lines.append(f'magnetometer axes turned {model.magnetometer_alignment.angle_deg:.4f} deg '
                 "into the accelerometer's")
    if model.tool_axis is not None:
        axis = model.tool_axis
        lines.append(f'tool axis from the roll groups: gamma_deg={axis.gamma_deg:.4f} '
                     f'beta_deg={axis.beta_deg:.4f} (axial RMS left {axis.axial_rms_deg:.4f} deg)')
    lines.append(f'{"shot":>4} {"group":>5} {"|g| before":>11} {"after":>9} {"|B| before":>11} '
                 f'{"after":>9} {"dip before":>10} {"after":>8}')
    for i in range(len(fit.b_total_nT)):
        group = '' if labels is None or labels[i] < 0 else str(labels[i] + 1)
        lines.append(f'{i + 1:>4} {group:>5} {before["g_total_mps2"][i]:11.5f} '
                     f'{after["g_total_mps2"][i]:9.5f} {before["b_total_nT"][i]:11.1f} '
                     f'{after["b_total_nT"][i]:9.1f} {before["dip_deg"][i]:10.4f} '
                     f'{after["dip_deg"][i]:8.4f}' + ('' if fit.used[i] else '  outlier'))
    for what, key in (('|g| [m/s^2]', 'g_total_mps2'), ('|B| [nT]', 'b_total_nT'),
                      ('dip [deg]', 'dip_deg')):
        lines.append(f'spread (std) of {what} over the shots used: before '
                     f'{np.std(before[key][fit.used]):.5g}, '
                     f'after {np.std(after[key][fit.used]):.5g}')
    for k, ((az0, inc0), (az1, inc1)) in enumerate(zip(group_spreads(labels, before, fit.used),
                                                       group_spreads(labels, after, fit.used))):
        lines.append(f'roll group {k + 1}: azimuth spread {az0:.4f} -> {az1:.4f} deg RMS, '
                     f'inclination spread {inc0:.4f} -> {inc1:.4f} deg'
                     + (f', turned over {fit.roll_deg[k]:.0f} deg' if k in fit.groups
                        else ' (free shots)'))
    return lines


def plot_report(path, labels, before, after, field_nT, g):
    """Plot |g|, |B|, dip per shot and the azimuth of the roll-group shots, before and after."""
    pyplot, fig, axes = new_figure(4, 'inclino fit-magnetometer: shots before and after')
    shot = np.arange(1, len(after['b_total_nT']) + 1)
    for ax, key, unit, centre in ((axes[0], 'g_total_mps2', 'm/s^2', g),
                                  (axes[1], 'b_total_nT', 'nT', field_nT),
                                  (axes[2], 'dip_deg', 'deg', None)):
        for survey, colour, name in ((before, 'tab:red', 'before'), (after, 'tab:green', 'after')):
            values = survey[key] - (np.mean(survey[key]) if centre is None else centre)
            ax.plot(shot, values, 'o', color=colour, markersize=4, label=name)
        ax.set_ylabel(f'{key} - {"mean" if centre is None else "nominal"} [{unit}]')
    if labels is not None:
        for survey, colour, name in ((before, 'tab:red', 'before'), (after, 'tab:green', 'after')):
            values = np.full(shot.size, np.nan)
            for k in range(int(labels.max()) + 1):
                members = labels == k
                azimuth = survey['azimuth_deg'][members]
                mean = circular_mean_deg(azimuth)
                values[members] = (azimuth - mean + 180.0) % 360.0 - 180.0
            axes[3].plot(shot, values, 'o', color=colour, markersize=4, label=name)
    axes[3].set_ylabel('roll-group azimuth - group mean [deg]')
    axes[3].set_xlabel('shot')
    for ax in axes:
        ax.axhline(0.0, color='black', linewidth=0.8)
    finish_figure(pyplot, fig, axes, path)
