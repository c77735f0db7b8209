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

import json
import sys

from inclino_ros.calibration.model import (
    CalibrationChanged, CalibrationModel, STANDARD_GRAVITY_MPS2)
from inclino_ros.calibration.plausibility import check_field_readings, Implausible
from inclino_ros.calibration.stations import (
    raw_survey_inputs, solve_interference, with_interference)
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_history_option, add_sensor_argument, begin_update, load_existing, node_option, read_csv,
    Refused, save, write_certificate)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import add_force_argument, between, report_path
from inclino_ros.cli.process import add_limit_arguments
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core.msa import MAX_INTERFERENCE_NT, MsaRefused
from inclino_ros.io import tables
from inclino_ros.io.files import Outputs
from inclino_ros.io.report import residual_lines
from inclino_ros.io.tables import write_csv
from inclino_ros.report.common import Fitted
from inclino_ros.report.msa import (
    plot_report, result_lines, station_columns, station_residuals, summary, TRUTH_COLUMN)
import numpy as np

GRAVITY_COLUMNS = ('gx', 'gy', 'gz')
FIELD_COLUMNS = ('bx', 'by', 'bz')
METHODS = ('improved', 'classic', 'axial', 'short-collar')


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
    add_history_option(parser)
    parser.add_argument('--method', choices=METHODS, default='improved',
                        help='correction method (default: %(default)s)')
    parser.add_argument('--cross-axial-nT', nargs=2, metavar=('EX', 'EY'),
                        type=between(-MAX_INTERFERENCE_NT, MAX_INTERFERENCE_NT),
                        help='improved: known cross-axial interference [nT] (rotation fit)')
    node_option(parser, '--reference-total-std-nT', 'magnetic.reference_total_std_nT',
                '1 sigma of the reference total field [nT] (WMM 2025: 138; an IFR model ~half)')
    node_option(parser, '--reference-dip-std-deg', 'magnetic.reference_dip_std_deg',
                '1 sigma of the reference dip [deg] (WMM 2025: 0.20)')
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
            write_outputs(args, table, output, lines, outputs,
                          model or CalibrationModel(len(GRAVITY_COLUMNS)))
            if model is not None:
                fitted = store(args, model, output[0], lines, outputs)
                write_certificate('msa', args, lines, outputs, fitted, certificate)
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
    """
    Write the solved eps into the magnetic stage of ``args.calibration`` (tool frame).

    Return what was saved (``report.common.Fitted``: the model, the station residual rows).
    """
    model = with_interference(model, result, (args.reference_total_nT, args.reference_dip_deg))
    model = save(args, model, outputs)   # the zero is said by write_outputs
    lines.append('wrote the interference (tool x, y, z: '
                 + ', '.join(f'{v:.1f}' for v in model.magnetic.interference_nT)
                 + f' nT) to {args.calibration}')
    rows = station_residuals(result, (args.reference_total_std_nT, args.reference_dip_std_deg))
    lines += residual_lines(rows, 'B total and dip of each station after the correction')
    return Fitted(model, tuple(rows))


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


def write_outputs(args, table, output, lines, outputs, model):
    """
    Write OUT, OUT.msa.json and the report to their temporaries in ``outputs``.

    OUT's toolface zero (``toolface_zero`` in OUT.msa.json, and printed) is that
    of ``model`` (the calibration applied to G; without one the empty model:
    the zero of G as given, the board's).
    """
    result, source = output
    reference = (args.reference_total_nT, args.reference_dip_deg)
    columns = station_columns(table, result, args.toolface_max_std_deg,
                              args.azimuth_max_std_deg, args.declination_deg)
    write_csv(outputs.path(args.output), columns)
    json_path = f'{args.output}.msa.json'
    with open(outputs.path(json_path), 'x') as stream:
        json.dump(dict(summary(result, source, args.method, args.stations, reference,
                               args.declination_deg), toolface_zero=model.toolface_zero,
                       toolface_zero_meaning=model.toolface_zero_meaning), stream, indent=2)
        stream.write('\n')
    lines.append(f'wrote {args.output} ({table["G"].shape[0]} stations) and {json_path}')
    lines += model.toolface_zero_lines
    if args.report:
        plot_report(outputs.path(args.report), table, result, args.method, reference)
        lines.append(f'report: {args.report}')
