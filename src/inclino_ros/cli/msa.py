"""
``inclino msa``: correct the magnetic azimuth of a survey by multi-station analysis (seed 002).

Input: a CSV with a header row and the columns ``gx, gy, gz`` (gravity
vector, any consistent unit) and ``bx, by, bz`` (nT), one row per station,
in the ISCWSA survey frame (x, y cross-axial, z toward the bit); optional
``md`` (measured depth, m) and ``true_azimuth_deg`` (the magnetic azimuth known otherwise, e.g.
of a simulation: the report then plots the error).

Methods (``inclino_ros.core.msa``): ``improved`` (default, seed 002 Eqs. 23-33:
the cross-axial part first, then eps_z0 at the mean station, its search
bracket and the bounded minimum of V; a minimum on the bracket's edge is
refused); ``classic`` (Brooks: eps_x, eps_y, eps_z together); ``axial``
(eps_z only, the cross-axial part taken as zero); ``short-collar`` (each
station alone, Bx and By assumed right; NaN azimuth near east/west).  For
``improved`` the cross-axial (eps_x, eps_y) comes from ``--cross-axial-nT``,
from the calibration's rotation fit (seed 002 §2.1), else from the classic
solve when the toolfaces spread (largest gap <= 100 deg); otherwise it is
refused (``msa.improved_cross_axial``).  The geometry is judged at the
converged solution too.

How well it solved: the 1 sigma of eps from the fit AND from the reference
field's own uncertainty (``--reference-total-std-nT``,
``--reference-dip-std-deg``: WMM 2025 by default, smaller for IFR), and
each station's azimuth 1 sigma (that, plus the station's noise); an azimuth
whose 1 sigma exceeds ``--azimuth-max-std-deg`` and a toolface whose 1 sigma
(the stations' G noise over sin I) exceeds ``--toolface-max-std-deg`` are
NaN (a vertical station has neither).

Output: OUT (CSV, one row per station: ``md`` if given, ``inclination_deg,
toolface_deg, azimuth_raw_deg, azimuth_deg, azimuth_std_deg``,
``azimuth_true_north_deg`` with ``--declination-deg``, the QC of the
corrected survey: B-total and dip deltas and ``b_total_ok, dip_ok,
g_total_ok, used``, plus ``eps_z_nT, east_west`` for short-collar and
``true_azimuth_deg, azimuth_error_deg`` when the input has the truth) and
OUT.msa.json (the corrections and their 1 sigma, V before/after, the search
bracket, the diagnostics).

The reference field is ``--reference-total-nT`` and ``--reference-dip-deg``,
or the World Magnetic Model at ``--site LAT LON ALT_M DATE`` (explicit values
win; the site gives the declination too).

With ``--calibration FILE`` the stations' B are the magnetometer readings
before the file's magnetic stage: its cross-axial correction (hard and soft
iron of ``inclino fit-rotation``) is applied to them first (turned into the
ISCWSA axes), and for ``improved`` the cross-axial interference is then
taken as removed.  The solved eps, turned into the tool frame
(``magnetics.iscwsa_from_tool``), replaces the stage's ``interference_nT``
(its 1 sigma ``interference_std_nT``: the live azimuth's quality takes it),
with ``msa_method, msa_stations, msa_reference_*`` and ``msa_fitted_at``;
its hard and soft iron and every other stage are kept, the file written
atomically.  ``short-collar`` (one correction per station) cannot be stored.

OUT, OUT.msa.json and the report are written under temporary names and
renamed when all are complete; one that exists is refused unless
``--force``, and STATIONS.csv or the calibration file never
(``io.files.Outputs``).  Stations whose B is not an Earth field in nT are
refused with the unit named (``plausibility.check_field_readings``).

Exit codes: 0 corrected, 1 refused (the reason printed, nothing written,
the calibration file untouched), 2 unusable input.
"""

from dataclasses import asdict
import json
import sys

from inclino_ros.calibration.model import CalibrationChanged, STANDARD_GRAVITY_MPS2
from inclino_ros.calibration.plausibility import check_field_readings, Implausible
from inclino_ros.calibration.stations import (
    raw_survey_inputs, solve_interference, with_interference)
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_sensor_argument, begin_update, finish_figure, load_existing, new_figure, read_csv,
    Refused, report_residuals, save, write_certificate)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import add_force_argument, between, non_negative, report_path
from inclino_ros.cli.process import add_limit_arguments
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core import magnetics
from inclino_ros.core.msa import (
    azimuth_difference_deg, MAX_INTERFERENCE_NT, misfit_nT2, MsaRefused, WMM_REFERENCE_STD)
from inclino_ros.core.uncertainty import toolface_std_rad
from inclino_ros.io import tables
from inclino_ros.io.files import Outputs
from inclino_ros.io.report import REFUSED, Residual, USED
from inclino_ros.io.tables import write_csv
import numpy as np

GRAVITY_COLUMNS = ('gx', 'gy', 'gz')
FIELD_COLUMNS = ('bx', 'by', 'bz')
TRUTH_COLUMN = 'true_azimuth_deg'
METHODS = ('improved', 'classic', 'axial', 'short-collar')
#: eps_z points of the V(eps_z) curves of the report.
CURVE_POINTS = 401


def register(subparsers):
    """Add the ``msa`` subcommand."""
    parser = add_command(
        subparsers, 'msa', 'correct magnetic azimuths by multi-station analysis (seed 002)',
        'Correct the magnetic azimuths of a survey for the magnetisation of the drill string '
        'by multi-station analysis (seed 002): find the interference that makes the field of '
        'every station agree with the reference field, and remove it.',
        'Input: a CSV, one row per survey station, with gx, gy, gz (gravity, any unit) and '
        'bx, by, bz (nT) in the ISCWSA survey frame (x, y across the tool, z toward the bit), '
        'optionally md (measured depth, m) and true_azimuth_deg (a known azimuth, e.g. of a '
        'simulation: the report plots the error). inclino simulate-well writes one.',
        'Methods: improved (seed 002, the default), classic (Brooks: all three components), '
        'axial (along the tool only), short-collar (each station alone; cannot be stored).',
        'Reference field: --reference-total-nT and --reference-dip-deg, or the World Magnetic '
        'Model at --site LAT LON ALT_M DATE.',
        'With --calibration FILE the stations hold raw magnetometer readings: the hard and '
        'soft iron of the file (inclino fit-rotation) are applied first, and the interference '
        'found is stored in the file (every other stage kept) for inclino process and the '
        'node.',
        'Output: OUT.csv (per station the raw and corrected azimuth and the check against the '
        'reference), OUT.csv.msa.json (the correction and its diagnostics), with --report a '
        'PNG.',
        'Exit 0 corrected, 1 refused (too few or too similar stations, stations failing the '
        'check; nothing written), 2 unusable input.')
    parser.add_argument('stations', metavar='STATIONS.csv', help='station CSV (see above)')
    parser.add_argument('-o', '--output', required=True, metavar='OUT.csv',
                        help='corrected stations CSV; the corrections go to OUT.msa.json')
    add_reference_arguments(parser)
    parser.add_argument('--calibration', metavar='FILE',
                        help='calibration file: its cross-axial correction is applied first, '
                             'the solved interference stored in its magnetic stage')
    add_sensor_argument(parser)
    parser.add_argument('--method', choices=METHODS, default='improved',
                        help='correction method (default: %(default)s)')
    parser.add_argument('--cross-axial-nT', nargs=2, metavar=('EX', 'EY'),
                        type=between(-MAX_INTERFERENCE_NT, MAX_INTERFERENCE_NT),
                        help='improved: known cross-axial interference [nT] (rotation fit)')
    parser.add_argument('--reference-total-std-nT', type=non_negative,
                        default=WMM_REFERENCE_STD[0],
                        help='1 sigma of the reference total field [nT] (default: WMM 2025, '
                             '%(default)s; an IFR model ~half)')
    parser.add_argument('--reference-dip-std-deg', type=non_negative, default=WMM_REFERENCE_STD[1],
                        help='1 sigma of the reference dip [deg] (default: WMM 2025, '
                             '%(default)s)')
    add_limit_arguments(parser)
    parser.add_argument('--exclude-failing', action='store_true',
                        help='leave stations failing QC out of the solve (named) instead of '
                             'refusing')
    parser.add_argument('--report', metavar='PNG', type=report_path,
                        help='write a report figure (.png, .pdf or .svg)')
    add_force_argument(parser)
    parser.set_defaults(func=run)


def run(args):
    """Correct, write OUT and OUT.msa.json, print the corrections; return the exit code."""
    lines = []
    outputs = Outputs(inputs=[args.stations, args.calibration], force=args.force)
    certificate = None if args.calibration is None else f'{args.output}.certificate.html'
    for path in (args.output, f'{args.output}.msa.json', args.report, certificate):
        if path is not None:
            outputs.check(path)
    if args.calibration is not None:
        begin_update(args, 'msa')
    try:
        with outputs:
            table = load_stations(args)
            check_field_readings(table['B'], "the stations' B")
            model = None if args.calibration is None else calibrated_field(args, table, lines)
            output = correct(args, table, lines)
            write_outputs(args, table, output, lines, outputs)
            if model is not None:
                store(args, model, output[0], lines, outputs)
                write_certificate('msa', args, lines, outputs, certificate)
                lines.append(f'certificate: {certificate}')
    except (MsaRefused, Refused, Implausible, CalibrationChanged) as err:
        print('\n'.join(lines + [f'inclino msa: refused: {err}; nothing written']),
              file=sys.stderr)
        return 1
    print('\n'.join(lines))
    return 0


def load_stations(args):
    """
    Return the station table; CommandError for a bad file or reference.

    The reference resolved (options, then ``--site``) is put back in
    ``args.reference_total_nT``, ``args.reference_dip_deg`` and
    ``args.declination_deg``.
    """
    try:
        reference = resolve_reference(args)
    except ValueError as err:
        raise CommandError(str(err)) from None
    if reference[0] is None or reference[1] is None:
        raise CommandError('the reference field is needed: --reference-total-nT and '
                           '--reference-dip-deg, or --site')
    args.reference_total_nT, args.reference_dip_deg, args.declination_deg = reference[:3]
    if args.calibration is not None and args.method == 'short-collar':
        raise CommandError('short-collar gives one correction per station: it cannot be '
                           'stored in --calibration')
    table = read_csv(args.stations, GRAVITY_COLUMNS + FIELD_COLUMNS,
                     optional=('md', TRUTH_COLUMN), max_rows=tables.MAX_SHOTS)
    table['G'] = np.column_stack([table[name] for name in GRAVITY_COLUMNS])
    table['B'] = np.column_stack([table[name] for name in FIELD_COLUMNS])
    return table


def calibrated_field(args, table, lines):
    """
    Return the model of ``args.calibration``, its corrections applied to the table's G and B.

    The stations hold raw readings: ``stations.raw_survey_inputs`` corrects
    them as ``~/solve_msa`` corrects its stations (``msa_inputs``).
    """
    model = load_existing(args.calibration, args.sensor_id)
    table['G'], table['B'] = raw_survey_inputs(model, table['G'], table['B'],
                                               STANDARD_GRAVITY_MPS2)
    if model.stages:
        lines.append(f'accelerometer stages of {args.calibration} applied to G: '
                     f'{", ".join(model.stages)}')
    before = tuple(name for name in model.magnetometer_stages if name != 'magnetic')
    if before or model.stand is not None:
        lines.append(f"magnetometer stages of {args.calibration} before seed 002's applied "
                     f'to B: {", ".join(before) or "the accelerometer frame turn"}')
    stage = model.magnetic
    if stage is not None and stage.rotation_fitted_at is not None:
        table['rotation_fitted_at'] = stage.rotation_fitted_at
        lines.append(f'hard and soft iron of {args.calibration} applied to B')
    return model


def store(args, model, result, lines, outputs):
    """Write the solved eps into the magnetic stage of ``args.calibration`` (tool frame)."""
    model = with_interference(model, result, (args.reference_total_nT, args.reference_dip_deg))
    save(args, model, outputs)
    lines.append('wrote the interference (tool x, y, z: '
                 + ', '.join(f'{v:.1f}' for v in model.magnetic.interference_nT)
                 + f' nT) to {args.calibration}')
    report_residuals(args, lines, station_residuals(args, result),
                     'B total and dip of each station after the correction')


def station_residuals(args, result):
    """
    Return the Residual rows of each station: B total and dip after the correction.

    Against the stated noise of the reference (``--reference-total-std-nT``,
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
                          float(args.reference_total_std_nT), 'nT', status, note),
                 Residual(f'station {i + 1} dip', float(delta_deg),
                          float(args.reference_dip_std_deg), 'deg', status, note)]
    return rows


def correct(args, table, lines):
    """Return the msa result of ``args.method`` and the cross-axial source (improved)."""
    result, source = solve_interference(
        args.method, table['G'], table['B'], (args.reference_total_nT, args.reference_dip_deg),
        (args.reference_total_std_nT, args.reference_dip_std_deg),
        table.get('rotation_fitted_at'), args.cross_axial_nT, args.exclude_failing,
        args.azimuth_max_std_deg)
    if args.method == 'short-collar':
        lines.append(f'short-collar: eps_z per station {np.nanmin(result.eps_z_nT):.1f} .. '
                     f'{np.nanmax(result.eps_z_nT):.1f} nT; {int(result.east_west.sum())} '
                     'station(s) near east/west flagged (azimuth NaN)')
        return result, None
    if source is not None:
        lines.append(source)
    lines += result_lines(result)
    return result, source


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


def write_outputs(args, table, output, lines, outputs):
    """Write OUT, OUT.msa.json and the report to their temporaries in ``outputs``."""
    result, source = output
    G = table['G']
    columns = {}
    if 'md' in table:
        columns['md'] = table['md']
    columns.update(inclination_deg=magnetics.inclination_deg(G),
                   toolface_deg=station_toolface_deg(G, args.toolface_max_std_deg),
                   azimuth_raw_deg=result.azimuth_raw_deg, azimuth_deg=result.azimuth_deg)
    if not hasattr(result, 'east_west'):
        precise = result.azimuth_std_deg <= args.azimuth_max_std_deg
        columns.update(azimuth_deg=np.where(precise, result.azimuth_deg, np.nan),
                       azimuth_std_deg=result.azimuth_std_deg)
    if args.declination_deg is not None:
        columns['azimuth_true_north_deg'] = magnetics.true_azimuth_deg(
            result.azimuth_deg, args.declination_deg)
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
    write_csv(outputs.path(args.output), columns)
    json_path = f'{args.output}.msa.json'
    with open(outputs.path(json_path), 'x') as stream:
        json.dump(summary(args, result, source), stream, indent=2)
        stream.write('\n')
    lines.append(f'wrote {args.output} ({G.shape[0]} stations) and {json_path}')
    if args.report:
        plot_report(args, table, result, outputs.path(args.report))
        lines.append(f'report: {args.report}')


def station_toolface_deg(G, max_std_deg):
    """
    Return the stations' gravity toolface [deg], NaN where its 1 sigma exceeds ``max_std_deg``.

    The 1 sigma is ``sigma_G / (|G| sin I)`` (``uncertainty.toolface_std_rad``)
    with sigma_G the scatter of the stations' |G|; a vertical station has none.
    """
    noise = np.std(magnetics.g_total(G), ddof=1) if G.shape[0] > 1 else 0.0
    f = magnetics.specific_force_from_gravity(G)
    std_deg = np.degrees(toolface_std_rad(f, noise ** 2 * np.broadcast_to(np.eye(3), (len(f), 3,
                                                                                      3))))
    return np.where(std_deg <= max_std_deg, magnetics.gravity_toolface_deg(G), np.nan)


def summary(args, result, source):
    """Return the JSON-ready record of the corrections."""
    record = {'method': args.method, 'stations': args.stations,
              'reference_total_nT': args.reference_total_nT,
              'reference_dip_deg': args.reference_dip_deg,
              'declination_deg': args.declination_deg,
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


def plot_report(args, table, result, path):
    """Plot azimuths (and errors vs truth), then V(eps_z) wide and near the solution, to path."""
    has_truth = int(TRUTH_COLUMN in table)
    pyplot, fig, axes = new_figure(3 + has_truth, f'inclino msa --method {args.method}')
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
        plot_misfit(axes[1 + has_truth:], args, table, result)
    finish_figure(pyplot, fig, axes, path)


def plot_misfit(axes, args, table, result):
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
        misfit = [misfit_nT2(G, B, args.reference_total_nT, args.reference_dip_deg,
                             (eps[0], eps[1], z)) for z in eps_z]
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
