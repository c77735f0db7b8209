"""The report of ``inclino demo``: raw, live corrected and offline answers per station."""

from inclino_ros.core.msa import azimuth_difference_deg
from inclino_ros.report.compare import station_rows
import numpy as np


def station_table(truth, answers):
    """
    Return one row per station: truth and the mean raw/corrected/offline answers.

    ``truth`` (N, 3) of the station samples; ``answers`` maps raw, corrected,
    offline to (N, 3) aligned answers (NaN where none came).
    """
    rows = None
    for name, values in answers.items():
        per_station = station_rows(truth, values, min_inclination_deg=0.0)
        rows = rows or [{'station': k + 1, 'true_inclination_deg': r['true_inclination_deg'],
                         'true_toolface_deg': r['true_toolface_deg']}
                        for k, r in enumerate(per_station)]
        for row, r in zip(rows, per_station):
            row.update({f'{name}_inclination_deg': r['inclination_deg'],
                        f'{name}_toolface_deg': r['toolface_deg'],
                        f'{name}_samples': r['samples']})
    return rows


def table_lines(rows):
    """Return the lines of raw vs corrected vs true per station."""
    lines = [f'{"st":>3} {"true I":>8} {"raw I":>8} {"corr I":>8} {"err raw":>8} '
             f'{"err corr":>9} | {"true TF":>8} {"raw TF":>8} {"corr TF":>8} {"err raw":>8} '
             f'{"err corr":>9}   [deg]']
    for r in rows:
        ti, tt = r['true_inclination_deg'], r['true_toolface_deg']
        lines.append(f'{r["station"]:>3} {ti:8.3f} {r["raw_inclination_deg"]:8.3f} '
                     f'{r["corrected_inclination_deg"]:8.3f} {r["raw_inclination_deg"] - ti:8.3f} '
                     f'{r["corrected_inclination_deg"] - ti:9.4f} | {tt:8.2f} '
                     f'{r["raw_toolface_deg"]:8.2f} {r["corrected_toolface_deg"]:8.2f} '
                     f'{azimuth_difference_deg(r["raw_toolface_deg"], tt):8.2f} '
                     f'{azimuth_difference_deg(r["corrected_toolface_deg"], tt):9.3f}')
    return lines


def plot(rows, path, target_deg):
    """
    Write the signed errors per station as a PNG: raw, live corrected, offline, targets.

    Inclination target: +-``target_deg``; toolface: the error a tilt of
    ``target_deg`` causes, atan(tan(target) / sin(I)).  A symmetric-log axis shows degrees and
    thousandths of a degree on one scale.
    """
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    true_i = np.array([r['true_inclination_deg'] for r in rows])
    true_t = [r['true_toolface_deg'] for r in rows]
    fig, (ax_i, ax_t) = pyplot.subplots(2, 1, figsize=(8, 8), sharex=True)
    for name, style, label in (
            ('raw', {'marker': 'o', 'color': 'tab:red'}, 'live, uncalibrated'),
            ('corrected', {'marker': 's', 'color': 'tab:green'}, 'live, after ~/calibrate_level'),
            ('offline', {'marker': 'D', 'markersize': 10, 'markerfacecolor': 'none',
                         'color': 'tab:blue'}, 'offline, inclino process')):
        err_i = np.array([r[f'{name}_inclination_deg'] for r in rows]) - true_i
        err_t = azimuth_difference_deg([r[f'{name}_toolface_deg'] for r in rows], true_t)
        ax_i.plot(true_i, err_i, linestyle='', label=label, **style)
        ax_t.plot(true_i, err_t, linestyle='', label=label, **style)
    grid = np.geomspace(true_i.min(), true_i.max(), 200)
    target_t = np.degrees(np.arctan(np.tan(np.radians(target_deg)) / np.sin(np.radians(grid))))
    for ax, target, text in ((ax_i, np.full_like(grid, target_deg), f'target +-{target_deg} deg'),
                             (ax_t, target_t, f'target: a {target_deg} deg tilt error')):
        ax.fill_between(grid, -target, target, color='tab:green', alpha=0.15, label=text)
        ax.axhline(0.0, color='black', linewidth=0.8)
        ax.set_xscale('log')
        ax.set_yscale('symlog', linthresh=1e-3)
        ax.grid(True, which='both', alpha=0.3)
        ax.legend(fontsize='small')
    ax_i.set_ylabel('inclination error [deg]')
    ax_t.set_ylabel('toolface error [deg]')
    ax_t.set_xlabel('true inclination of the station [deg]')
    ax_i.set_title('inclino_ros demo: signed error per station (mean of its samples)')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    pyplot.close(fig)
