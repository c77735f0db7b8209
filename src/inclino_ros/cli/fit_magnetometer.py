"""
``inclino fit-magnetometer``: calibrate both triads from shots, without a stand or a reference.

Input: a CSV with the columns ``ax, ay, az`` (m/s^2, REP 145 specific
force, tool frame, z along the tool axis), ``bx, by, bz`` (nT, same frame)
and optionally ``roll_group`` (rows with the same non-empty value were
taken with the tool axis held in one direction and the tool turned about
it) and ``temperature_c``; one row per still shot.  Or a continuous log (a
CSV with a ``time_s`` column [s] and no ``roll_group``; the gyro ``wx, wy,
wz`` [rad/s] optional), or a bag: the still segments of the log, or of
``--raw-topic`` and ``--mag-topic``, are found by the one still rule of every
stream (``stillness.find_still_segments``, as for a
continuous log: windows of ``--still-window-s`` in which neither triad's
direction moves, significantly and by more than ``--max-still-deg`` or
faster than ``--max-drift-deg-per-s``, joined while neighbours agree, the
first and last window of a run left out, at least ``--min-still-s`` left)
and each becomes a shot; roll sets among them are found as in a CSV without
``roll_group`` (consecutive shots pointing one way while the tool turns).

One joint fit (``core.shots``) finds the magnetometer ellipsoid (hard iron,
full soft iron), the accelerometer's when the file has no stand stage, the
rotation between the triads (the dip is constant) and, from the roll
groups, the tool axis (seed 000's installation without a level bench).  The
file gets the stages ``magnetometer``, ``magnetometer_alignment``,
``tool_axis`` (with roll groups) and ``stand`` (method sphere, when fitted),
and ``magnetometer_nonlinear`` when the roll sets support it
(``magnetometer.nonlinear_stage``: ``--non-linear``, the held-out gate's
figures and decision in the report and on stdout); its other stages are
kept; the installation (level bench) too, carried into a new accelerometer
frame, unless roll groups measure the tool axis.
Nothing measuring the mount (a bag has no roll groups) is said loudly, on
stderr too.  The field is scaled to
``--reference-total-nT`` (or ``--site``) if given, else to the sensor's own
mean scale.

Report (``fit_magnetometer.txt``, and ``fit_magnetometer.png`` with
``--plot``: matplotlib alone takes longer to load than the whole fit): |g|,
|B| and dip per shot before (the file's correction, raw for a new file) and
after; the azimuth and inclination spread of each roll group before and after.

Refused, exit 1 with the reason and the calibration file byte-identical: a
missing column, non-finite rows (named), too few shots, readings in uT (or
another unit) where nT are expected, a field that never changes (no
rotation), all shots in one plane, a fit that does not make |B|, |g| and
the dip constant, a roll group not turned about its axis, outliers beyond
what the shots left can spare; every failed check at once, and the figures
of the refused fit in ``fit_magnetometer_refused.txt``.  Robust: an outlier
shot is named and left out while enough good shots remain; a roll group is
weighted by its own pointing wander (reported), and one that wandered beyond
2 deg RMS is taken as free shots (named).
"""

from dataclasses import replace
import sys

from inclino_ros.calibration.continuous_log import segment_limits
from inclino_ros.calibration.inputs import bag_shots, shots_input
from inclino_ros.calibration.magnetometer import calibrate_from_shots, NONLINEAR_CHOICES
from inclino_ros.calibration.plausibility import check_field_unit, Implausible
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_file_arguments, add_gravity_option, is_bag, load_existing, MAG_PAIRING_TOLERANCE_NT,
    node_option, Refused, report_paths, run_fit, save, source_of, TEMPERATURE_TOPIC, write_text)
from inclino_ros.cli.options import between, positive
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core import magnetics
from inclino_ros.core.shots import ShotFitRefused, ShotLimits
from inclino_ros.core.stillness import SegmentLimits
from inclino_ros.io import tables
from inclino_ros.io.report import residual_lines
from inclino_ros.report.common import Fitted
from inclino_ros.report.magnetometer import (
    fit_table_lines, plot_report, robust_lines, shot_residuals, summary_lines)

REPORT_NAME = 'fit_magnetometer'
GROUP_COLUMN = 'roll_group'


def register(subparsers):
    """Add the ``fit-magnetometer`` subcommand."""
    parser = subparsers.add_parser(
        'fit-magnetometer',
        help='calibrate magnetometer and accelerometer from shots in many orientations '
             '(no stand, no reference)', description=__doc__.split('\n\n', 1)[1])
    add_file_arguments(parser, 'CSV file (ax, ay, az, bx, by, bz [, roll_group]; with time_s: '
                               'a log)')
    add_gravity_option(parser)
    parser.add_argument('--plot', action='store_true',
                        help='also draw the report as fit_magnetometer.png')
    parser.add_argument('--max-dip-rms-deg', type=between(1e-6, 90.0),
                        default=ShotLimits.max_dip_rms_deg,
                        help='largest RMS of the dip the fit may leave [deg] (default: '
                             '%(default)s)')
    parser.add_argument('--max-g-rms-fraction', type=between(1e-9, 1.0),
                        default=ShotLimits.max_g_rms_fraction,
                        help='largest RMS of |g| the fit may leave, a fraction of g (default: '
                             '%(default)s)')
    parser.add_argument('--max-b-rms-fraction', type=between(1e-9, 1.0),
                        default=ShotLimits.max_b_rms_fraction,
                        help='largest RMS of |B| the fit may leave, a fraction of the field '
                             '(default: %(default)s)')
    parser.add_argument('--non-linear', choices=NONLINEAR_CHOICES, default='auto',
                        help='the smooth non-linear stage fitted from the roll sets: auto (kept '
                        'only when it improves the azimuth agreement of roll sets held out of '
                        'its fit, each in turn, by more than 2 sigma), off, or on (kept '
                        'whatever that judgement says)')
    bag = parser.add_argument_group('bag input')
    bag.add_argument('--raw-topic', default='/imu/data_raw',
                     help='sensor_msgs/Imu topic (default: %(default)s)')
    bag.add_argument('--mag-topic', default='/imu/mag',
                     help='sensor_msgs/MagneticField topic (default: %(default)s)')
    bag.add_argument('--temperature-topic', default=TEMPERATURE_TOPIC,
                     help='sensor_msgs/Temperature topic, if the bag has it (default: '
                          '%(default)s)')
    bag.add_argument('--still-window-s', type=positive, default=SegmentLimits.window_s,
                     help='window of the stillness test [s] (default: %(default)s)')
    bag.add_argument('--max-still-deg', type=between(1e-6, 90.0), default=0.5,
                     help="a still segment's direction (either triad) moves no further from "
                          'its mean, significantly for its noise [deg] (default: %(default)s)')
    node_option(bag, '--max-drift-deg-per-s', 'still.max_drift_deg_per_s',
                'a window or segment whose direction drifts faster [deg/s], significantly for '
                'its noise, moved')
    bag.add_argument('--min-still-s', type=positive, default=SegmentLimits.min_s,
                     help='shortest still segment taken as a shot, its first and last window '
                          'left out [s] (default: %(default)s)')
    node_option(bag, '--max-pairing-s', 'magnetic.max_pairing_s',
                'largest time between an Imu sample and its magnetometer message [s]')
    add_reference_arguments(parser.add_argument_group(
        'reference field (optional: scales |B| and checks the dip found)'))
    parser.set_defaults(func=run)


def run(args):
    """Fit, report and write the stages; return the exit code."""
    return run_fit('fit-magnetometer', args, fit)


def still_limits(args):
    """Return the SegmentLimits of the command's still options (a bag's, a log's)."""
    return segment_limits(args.max_drift_deg_per_s, args.max_still_deg, '--max-still-deg',
                          window_s=args.still_window_s, min_s=args.min_still_s)


def read_bag_shots(args, lines):
    """Return the shots of a bag's still segments (``inputs.bag_shots``; roll groups: none)."""
    accel, field, temperature_c, paired = bag_shots(
        source_of(args), args.max_pairing_s, MAG_PAIRING_TOLERANCE_NT, still_limits(args))
    lines.append(f'{accel.shape[0]} still segment(s) found in {args.input} '
                 f'({paired} paired samples)')
    return accel, field, None, temperature_c


def fit(args, lines, outputs):
    """Fit the shots of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    existing = load_existing(args.calibration, args.sensor_id)
    try:
        total_nT, dip_ref, _, source = resolve_reference(args)
    except ValueError as err:
        raise CommandError(str(err)) from None
    if is_bag(args.input):
        accel, field, labels, temperature_c = read_bag_shots(args, lines)
    else:
        try:
            accel, field, labels, temperature_c, found = shots_input(
                args.input, still_limits(args), GROUP_COLUMN)
        except tables.TableError as err:
            raise Refused(str(err)) from None
        lines += found
    if accel.shape[0]:
        try:
            check_field_unit(field, 'bx, by, bz')
        except Implausible as err:
            raise Refused(err.reason) from None
    limits = replace(ShotLimits(), max_dip_rms_deg=args.max_dip_rms_deg,
                     max_b_rms_fraction=args.max_b_rms_fraction,
                     max_g_rms_fraction=args.max_g_rms_fraction)
    try:
        result = calibrate_from_shots(existing, accel, field, labels, temperature_c,
                                      args.gravity_mps2, total_nT, limits, args.non_linear)
    except ShotFitRefused as err:
        if err.fit is not None:
            # A refused fit reports beside, not over, the report of the fit in the file.
            lines += robust_lines(err.fit, labels) + fit_table_lines(err.fit, labels)
            lines += [f'REFUSED: {reason}' for reason in err.reasons]
            write_text(outputs.path(report_paths(args, REPORT_NAME + '_refused')[1]), lines)
        raise Refused(err.reason) from None
    labels = result.roll_group
    for note in result.notes:
        if note.startswith('WARNING'):
            print(f'inclino fit-magnetometer: {note}', file=sys.stderr)
    # G in the frame of B before seed 002's stage: before the toolface mark.
    before, after = (magnetics.survey_of(
        model.apply(accel, temperature_c, before='toolface_mark'),
        model.apply_magnetic(field, before='magnetic')) for model in (existing, result.model))
    lines += summary_lines(result, labels, before, after, total_nT, dip_ref, source)
    rows = shot_residuals(result.fit, labels)
    lines += residual_lines(rows, '|B| of each shot after the fit minus the fitted field')
    png, txt = report_paths(args, REPORT_NAME)
    if args.plot:
        plot_report(outputs.path(png), labels, before, after, result.fit.field_nT,
                    args.gravity_mps2)
    model = save(args, result.model, outputs, lines)
    written = ['magnetometer', 'magnetometer_alignment'] + (
        ['tool_axis'] if result.fit.tool_axis is not None else []) + (
        ['stand (method sphere)'] if result.fit.accel_matrix is not None else []) + (
        ['magnetometer_nonlinear'] if result.model.magnetometer_nonlinear is not None else [])
    lines += [f'wrote the stages {", ".join(written)} to {args.calibration}',
              f'report: {txt}' + (f', {png}' if args.plot else '')]
    write_text(outputs.path(txt), lines)
    return Fitted(model, tuple(rows))
