"""The report of a multi-station analysis (``inclino msa``): stations, record, figures."""

from dataclasses import asdict

from inclino_ros.core import magnetics
from inclino_ros.core.msa import (
    azimuth_difference_deg, MAX_INTERFERENCE_NT, misfit_nT2, station_toolface_deg)
from inclino_ros.io.report import REFUSED, Residual, USED
from inclino_ros.report.common import finish_figure, new_figure
import numpy as np

#: The column of a known azimuth in a station table.
TRUTH_COLUMN = 'true_azimuth_deg'
#: eps_z points of the V(eps_z) curves of the report.
CURVE_POINTS = 401


def station_columns(table, result, toolface_max_std_deg, azimuth_max_std_deg, declination_deg):
    """
    Return the columns of the corrected stations' CSV (``inclino msa`` OUT), in order.

    Per station: ``md`` if given, inclination, the toolface (NaN beyond
    ``toolface_max_std_deg``, ``msa.station_toolface_deg``), the raw and
    corrected azimuth (NaN beyond ``azimuth_max_std_deg``) and its 1 sigma,
    the true-north azimuth with ``declination_deg``, the QC of the corrected
    survey, ``used`` (``eps_z_nT, east_west`` for short-collar) and the error
    against ``true_azimuth_deg`` when the table has it.
    """
    G = table['G']
    columns = {}
    if 'md' in table:
        columns['md'] = table['md']
    columns.update(inclination_deg=magnetics.inclination_deg(G),
                   toolface_deg=station_toolface_deg(G, toolface_max_std_deg),
                   azimuth_raw_deg=result.azimuth_raw_deg, azimuth_deg=result.azimuth_deg)
    if not hasattr(result, 'east_west'):
        precise = result.azimuth_std_deg <= azimuth_max_std_deg
        columns.update(azimuth_deg=np.where(precise, result.azimuth_deg, np.nan),
                       azimuth_std_deg=result.azimuth_std_deg)
    if declination_deg is not None:
        columns['azimuth_true_north_deg'] = magnetics.true_azimuth_deg(
            result.azimuth_deg, declination_deg)
    qc = result.qc
    columns.update(b_total_delta_nT=qc.b_total_delta_nT, dip_delta_deg=qc.dip_delta_deg,
                   b_total_ok=qc.b_total_ok, dip_ok=qc.dip_ok, g_total_ok=qc.g_total_ok)
    if hasattr(result, 'east_west'):
        columns.update(eps_z_nT=result.eps_z_nT, east_west=result.east_west)
    else:
        columns['used'] = result.used
    if TRUTH_COLUMN in table:
        columns[TRUTH_COLUMN] = table[TRUTH_COLUMN]
        columns['azimuth_error_deg'] = azimuth_difference_deg(
            result.azimuth_deg, table[TRUTH_COLUMN])
    return columns


def station_residuals(result, reference_std):
    """
    Return the Residual rows of each station: B total and dip after the correction.

    Against the stated noise of the reference, ``reference_std`` (total
    field [nT], dip [deg]: ``--reference-total-std-nT``,
    ``--reference-dip-std-deg``); a station left out of the solve (QC,
    ``--exclude-failing``) is refused, one whose azimuth is NaN (near east or
    west for the short collar) too.
    """
    qc, rows = result.qc, []
    used = getattr(result, 'used', None)
    for i, (delta_nT, delta_deg) in enumerate(zip(qc.b_total_delta_nT, qc.dip_delta_deg)):
        status, note = USED, ''
        if i in getattr(result, 'excluded', ()) or used is not None and not used[i]:
            status, note = REFUSED, 'left out of the solve (QC)'
        elif hasattr(result, 'east_west') and result.east_west[i]:
            status, note = REFUSED, 'near east/west: no azimuth'
        rows += [Residual(f'station {i + 1} B total', float(delta_nT),
                          float(reference_std[0]), 'nT', status, note),
                 Residual(f'station {i + 1} dip', float(delta_deg),
                          float(reference_std[1]), 'deg', status, note)]
    return rows


def result_lines(result):
    """Return the summary lines of an MsaResult."""
    d = result.diagnostics
    std = result.eps_std_nT
    finite = np.isfinite(result.azimuth_std_deg)
    eps = [f'{v:.1f} +- {s:.1f}' if s > 0 else f'{v:.1f}' for v, s in zip(result.eps_nT, std)]
    lines = [f'{result.method}: eps x, y, z = ' + ', '.join(eps) + ' nT (1 sigma: '
             f'the fit and the reference field, {result.reference_std[0]:g} nT and '
             f'{result.reference_std[1]:g} deg)',
             f'V before {result.v_before_nT2:.4g} nT^2, after {result.v_after_nT2:.4g} nT^2 '
             f'({result.iterations} iterations, residual {result.residual_std_nT:.2f} nT rms)',
             'station azimuth 1 sigma: ' + (
                 f'{result.azimuth_std_deg[finite].min():.3f} .. '
                 f'{result.azimuth_std_deg[finite].max():.3f} deg' if finite.any() else 'none')]
    if result.search_bracket_nT is not None:
        lines.append(f'eps_z0 (mean station) {result.eps_z0_nT:.1f} nT, search bracket '
                     f'[{result.search_bracket_nT[0]:.1f}, {result.search_bracket_nT[1]:.1f}] '
                     'nT (a search range, not a confidence interval)')
    lines.append(f'{d.stations_used} stations used, largest toolface gap '
                 f'{d.toolface_gap_deg:.1f} deg, inclination {d.inclination_range_deg[0]:.1f}'
                 f'..{d.inclination_range_deg[1]:.1f} deg, axial sensitivity '
                 f'{d.axial_sensitivity:.3f}, condition number {d.condition_number:.3g}')
    if result.excluded:
        lines.append('excluded (QC): station(s) '
                     + ', '.join(str(i + 1) for i in result.excluded))
    return lines


def summary(result, source, method, stations, reference, declination_deg):
    """
    Return the JSON-ready record of the corrections.

    ``method`` and ``stations`` (the input's path) as given, ``reference``
    (total field [nT], dip [deg]), ``declination_deg`` or None.
    """
    record = {'method': method, 'stations': stations,
              'reference_total_nT': reference[0], 'reference_dip_deg': reference[1],
              'declination_deg': declination_deg,
              'v_before_nT2': result.v_before_nT2, 'v_after_nT2': result.v_after_nT2}
    if hasattr(result, 'east_west'):
        record.update(eps_z_nT=[None if np.isnan(v) else v for v in result.eps_z_nT.tolist()],
                      east_west_stations=(np.flatnonzero(result.east_west) + 1).tolist())
        return record
    d = result.diagnostics
    bracket = result.search_bracket_nT
    record.update(
        eps_nT=result.eps_nT.tolist(), eps_std_nT=result.eps_std_nT.tolist(),
        eps_covariance_nT2=result.eps_covariance_nT2.tolist(),
        reference_total_std_nT=result.reference_std[0],
        reference_dip_std_deg=result.reference_std[1],
        residual_std_nT=result.residual_std_nT,
        azimuth_std_deg=[None if np.isnan(v) else v for v in result.azimuth_std_deg.tolist()],
        iterations=result.iterations, excluded_stations=[i + 1 for i in result.excluded],
        eps_z0_nT=None if bracket is None else result.eps_z0_nT,
        search_bracket_nT=None if bracket is None else list(bracket),
        cross_axial_source=source,
        diagnostics=dict(asdict(d), inclination_range_deg=list(d.inclination_range_deg)))
    return record


def plot_report(path, table, result, method, reference):
    """Plot azimuths (and errors vs truth), then V(eps_z) wide and near the solution, to path."""
    has_truth = int(TRUTH_COLUMN in table)
    pyplot, fig, axes = new_figure(3 + has_truth, f'inclino msa --method {method}')
    station = table.get('md', np.arange(1, table['G'].shape[0] + 1))
    axes[0].plot(station, result.azimuth_raw_deg, 'o-', color='tab:red', label='raw')
    std = getattr(result, 'azimuth_std_deg', None)
    axes[0].errorbar(station, result.azimuth_deg, yerr=std, fmt='o-', color='tab:green',
                     capsize=2, label='corrected' + ('' if std is None else ' (+- 1 sigma)'))
    axes[0].set_ylabel('magnetic azimuth [deg]')
    if has_truth:
        truth = table[TRUTH_COLUMN]
        axes[0].plot(station, truth, 'k.', label='truth')
        for azimuth, colour, name in ((result.azimuth_raw_deg, 'tab:red', 'raw'),
                                      (result.azimuth_deg, 'tab:green', 'corrected')):
            error = azimuth_difference_deg(azimuth, truth)
            usable = np.isfinite(error)
            axes[1].plot(station, error, 'o-', color=colour, label=f'{name}: max |error| ' + (
                f'{np.max(np.abs(error[usable])):.3f} deg' if usable.any() else 'none usable'))
        if std is not None:
            axes[1].fill_between(station, -std, std, color='tab:green', alpha=0.2,
                                 label='+- 1 sigma (noise, eps, reference field)')
        axes[1].set_ylabel('azimuth - truth [deg]')
    for ax in axes[:1 + has_truth]:
        ax.set_xlabel('measured depth [m]' if 'md' in table else 'station [number]')
    if hasattr(result, 'east_west'):
        plot_short_collar(axes[1 + has_truth:], station, result)
    else:
        plot_misfit(axes[1 + has_truth:], table, result, reference)
    finish_figure(pyplot, fig, axes, path)


def plot_misfit(axes, table, result, reference):
    """Plot V(eps_z), eps_x and eps_y solved: over +-10000 nT (Fig. 5) and zoomed (Fig. 6)."""
    G, B = table['G'][result.used], table['B'][result.used]
    eps = result.eps_nT
    bracket = result.search_bracket_nT
    if bracket is None:
        zoom = (eps[2] - 100.0, eps[2] + 100.0)
    else:
        half = bracket[1] - bracket[0]
        zoom = (bracket[0] - half, bracket[1] + half)
    for ax, span in zip(axes, ((-MAX_INTERFERENCE_NT, MAX_INTERFERENCE_NT), zoom)):
        eps_z = np.linspace(*span, CURVE_POINTS)
        misfit = [misfit_nT2(G, B, reference[0], reference[1], (eps[0], eps[1], z))
                  for z in eps_z]
        ax.plot(eps_z, misfit, color='tab:blue', label='V(eps_z) (seed 002 Eq. 10)')
        ax.axvline(eps[2], color='tab:green', label=f'eps_z = {eps[2]:.1f} nT')
        ax.axvspan(eps[2] - result.eps_std_nT[2], eps[2] + result.eps_std_nT[2],
                   color='tab:green', alpha=0.3, label='eps_z +- 1 sigma')
        if bracket is not None:
            ax.axvspan(*bracket, color='tab:orange', alpha=0.15,
                       label='search bracket eps_z0 +- d (Eq. 28)')
            ax.axvline(result.eps_z0_nT, color='tab:orange', linestyle='--',
                       label=f'eps_z0 = {result.eps_z0_nT:.1f} nT (Eq. 27)')
        ax.set_yscale('log')
        ax.set_ylabel('V [nT^2]')
        ax.set_xlabel('eps_z [nT]')


def plot_short_collar(axes, station, result):
    """Plot each station's axial correction and the azimuth change it makes."""
    axes[0].plot(station, result.eps_z_nT, 'o-', color='tab:blue', label='eps_z per station')
    axes[0].plot(station[result.east_west], result.eps_z_nT[result.east_west], 'rx',
                 label='near east/west: not usable')
    axes[0].set_ylabel('eps_z [nT]')
    axes[1].plot(station, result.azimuth_deg - result.azimuth_raw_deg, 'o-',
                 color='tab:green', label='azimuth correction')
    axes[1].set_ylabel('corrected - raw [deg]')
