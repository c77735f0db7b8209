"""
``inclino fit-stand``: seed 001's multi-position stand calibration into the calibration file.

This module parses the options (their help is the user's documentation) and
prints; the rules live where the node finds them too: the input (a CSV of
positions or a continuous log, a bag with ``/stand/attitude``):
``calibration.inputs.stand_input``; a log's still segments:
``calibration.continuous_log``; positions, repeats, the temperature span, the
stand and sphere fits, K(T) of a multi-temperature stand and what a new stand
drops: ``calibration.stand_fit`` (as ``~/solve_stand_calibration``); the
magnetometer's K_m and bias against a reference field (seed 001 Eq. 12):
``calibration.magnetometer.fit_field_positions``; plausible readings:
``calibration.plausibility``; the report: ``report.stand``; the atomic write
with its history: ``fitting.run_fit``.  Exit 0 written, 1 refused (the
calibration file untouched), 2 unusable input.
"""

from inclino_ros.calibration.continuous_log import log_segments, segment_limits, sphere_readings
from inclino_ros.calibration.inputs import stand_input
from inclino_ros.calibration.magnetometer import fit_field_positions
from inclino_ros.calibration.plausibility import check_accelerometer_readings
from inclino_ros.calibration.stand_fit import (
    check_temperature_span, repeatability_note, solve_sample_positions, solve_sphere,
    stand_readings, stood_for_c, with_stand)
from inclino_ros.calibration.still_capture import CaptureRefused
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_common_arguments, add_gravity_option, add_still_options, axes_maps, load_existing,
    MAG_PAIRING_TOLERANCE_NT, node_option, Refused, report_paths, run_fit, save, source_of,
    tool_axes, write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core.stand import StandFitRefused
from inclino_ros.report.common import Fitted
from inclino_ros.report.stand import field_lines, position_report, sphere_report

ATTITUDE_TOPIC = '/stand/attitude'
ATTITUDE_COLUMNS = ('inclination_deg', 'toolface_deg')
REPORT_NAME = 'fit_stand'
AZIMUTH_COLUMN = 'azimuth_deg'
FIELD_COLUMNS = ('bx', 'by', 'bz')


def register(subparsers):
    """Add the ``fit-stand`` subcommand."""
    parser = add_command(
        subparsers, 'fit-stand',
        'fit the stand calibration K, b (seed 001) into a calibration file',
        'Fit the stand calibration of seed 001, the 3x3 scale and misalignment matrix K and '
        'the bias b of the accelerometer (A = K G + b), and write it into the calibration '
        'file.',
        'Input: the tool held still at several known attitudes on a stand (six or more, well '
        'spread; nine are typical): a bag with the raw sensor on /imu/data_raw and the stand '
        'attitude on /stand/attitude (what inclino simulate --stand writes), or a CSV with the '
        'columns inclination_deg, toolface_deg, ax, ay, az (m/s^2, one row per sample or per '
        'averaged position; optional temperature_c). Consecutive samples of one attitude are '
        'averaged into one position; an attitude visited again is a repeat, fitted too, and '
        "the scatter of its visits reported as the stand's repeatability.",
        '--method sphere needs no attitudes: it fits |G| = g over readings in many '
        'orientations. It cannot see how the sensor is turned in the tool: calibrate the '
        'level bench afterwards. A CSV with time_s and no attitude columns is a continuous log '
        '(optional gyro wx, wy, wz in rad/s): its still segments are found and the mean of '
        'each is a reading of a sphere fit.',
        'A temperature stage already in the file is applied to the readings first. The stand '
        'stage replaces the old one and drops the level-bench stage (K holds the mounting '
        'error). The report, fit_stand.png and fit_stand.txt, goes beside the file or to '
        '--report-dir.',
        'Refused (exit 1, the file untouched): fewer than six distinct attitudes, the tool '
        'moved at a position (a mean drifting beyond --max-drift-deg-per-s, or less precise '
        'than --max-sem-deg), or the fit does not reproduce its '
        'positions within --max-rms-deg. Exit 2: unusable input.')
    add_common_arguments(parser)
    parser.add_argument('--method', choices=('stand', 'sphere'), default='stand',
                        help='stand: known attitudes; sphere: |G| = g only (default: '
                             '%(default)s)')
    node_option(parser, '--max-rms-deg', 'stand.max_rms_deg')
    node_option(parser, '--attitude-sigma-deg', 'stand.attitude_sigma_deg')
    add_still_options(parser, 'stand.max_sem_deg', 'direction of one position', 'a position')
    node_option(parser, '--max-temperature-difference-c', 'temperature.max_stage_difference_c',
                'without a temperature stage, positions further apart in temperature [deg C] '
                'are refused')
    parser.add_argument('--attitude-topic', default=ATTITUDE_TOPIC,
                        help='Vector3Stamped stand attitude topic of a bag (default: '
                             '%(default)s)')
    add_gravity_option(parser)
    magnetic = parser.add_argument_group('magnetometer (seed 001 Eq. 12)')
    magnetic.add_argument('--mag-topic', default='/imu/mag',
                          help='sensor_msgs/MagneticField topic of a bag (default: %(default)s)')
    node_option(magnetic, '--max-field-rms-deg', 'stand.max_field_rms_deg')
    add_reference_arguments(magnetic)
    parser.set_defaults(func=run)


def run(args):
    """Fit, report and write the stand stage; return the exit code."""
    return run_fit('fit-stand', args, fit)


def fit(args, lines, outputs):
    """Fit the stand stage of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    existing = load_existing(args.calibration, args.sensor_id, maps=axes_maps(args))
    readings, attitude_deg, temperature_c, times_s, fields, gyro = stand_input(
        source_of(args), args.method == 'stand', MAG_PAIRING_TOLERANCE_NT)
    readings, fields = tool_axes(args, readings), tool_axes(args, fields, 'magnetometer')
    segment = None
    if attitude_deg is None and gyro is not False:   # a continuous log: its still samples
        segment, readings, temperature_c, times_s = still_samples(
            args, readings, gyro, temperature_c, times_s, lines)
    check_accelerometer_readings(readings, args.gravity_mps2)
    readings, stood_c = stand_readings(existing, readings, temperature_c)
    if existing.temperature is not None:
        lines.append('temperature stage of the file applied to the readings first ('
                     + ('at their temperatures)' if temperature_c is not None else
                        'no temperatures in the input: at its reference temperature)'))
    field = None
    if args.method == 'stand':
        stage, refusal, draw, rows = fit_positions(args, readings, attitude_deg, times_s,
                                                   stood_c, lines)
        if not refusal:
            field = fit_magnetometer(args, existing, fields, attitude_deg, times_s,
                                     temperature_c, stage, lines)
    else:
        stage, refusal, draw, rows = fit_readings(args, readings, stood_c, lines, segment)
    stood_for_c = stage.temperature_c
    lines.append('the readings stood for ' + ('an unknown temperature' if stood_for_c is None
                                              else f'{stood_for_c:.2f} C'))
    # A refused fit reports beside, not over, the report of the fit in the file.
    png, txt = report_paths(args, REPORT_NAME + ('_refused' if refusal else ''))
    draw(outputs.path(png))
    lines.append(f'report: {png}')
    if refusal:
        write_text(outputs.path(txt), lines + [f'REFUSED: {refusal}'])
        raise Refused(refusal)
    dropped = existing.installation is not None
    model, notes = with_stand(existing, stage, field)
    model = save(args, model, outputs, lines)
    lines.append(f'wrote {args.calibration}: stand stage ({args.method}, {stage.positions} '
                 f'{"positions" if args.method == "stand" else "readings"})'
                 + (', temperature stage kept' if existing.temperature else ''))
    if dropped:
        lines.append('installation stage dropped: ' + (
            'the stand K already contains the mounting misalignment' if args.method == 'stand'
            else 'a sphere fit cannot see the mounting rotation; calibrate the level bench '
                 'again (inclino calibrate) on the stand-corrected readings'))
    elif args.method == 'sphere':
        lines.append('a sphere fit cannot see the mounting rotation: calibrate the level bench '
                     '(inclino calibrate) next')
    lines += notes
    write_text(outputs.path(txt), lines)
    return Fitted(model, tuple(rows))


def still_samples(args, readings, gyro, temperature_c, times_s, lines):
    """
    Return (segment (M,), readings, temperature_c, times_s) of a log's still samples only.

    The still segments (``continuous_log.log_segments`` with the command's
    still limits) are what a sphere fit takes, one reading a segment; the
    samples between them (the tool turned by hand) are left out.
    """
    try:
        found = log_segments(times_s, readings, gyro, temperature_c,
                             segment_limits(args.max_drift_deg_per_s, args.max_sem_deg,
                                            max_motion_deg=args.max_motion_deg))
    except ValueError as err:
        raise CommandError(f'{args.input}: {err}') from None
    lines.extend(found.lines(f'log {args.input}'))
    lines.append("no attitude columns: a continuous log; each still segment's mean is one "
                 'reading of a sphere fit (--method sphere)' + (
                     ', the gyro (wx, wy, wz) checked too' if gyro is not None else
                     ' (no gyro columns: the accelerometer alone tells still from moving)'))
    args.method = 'sphere'
    still = found.still
    return (found.segment[still], readings[still],
            None if temperature_c is None else temperature_c[still], times_s[still])


def still_limits(args):
    """Return the still test of a position from --max-drift-deg-per-s and --max-sem-deg."""
    return segment_limits(args.max_drift_deg_per_s, args.max_sem_deg,
                          max_motion_deg=args.max_motion_deg).still


def fit_positions(args, readings, attitude_deg, times_s, stood_c, lines):
    """
    Return (Stand stage, refusal or None, draw, residual rows) of a known-attitude stand fit.

    ``stand_fit.solve_sample_positions``, as ``~/solve_stand_calibration``
    fits the node's positions; ``stood_c``: the temperature each reading stood for
    (None: unknown).  ``draw(path)`` plots the report.
    """
    try:
        solution, attitudes, counts, spread_deg = solve_sample_positions(
            readings, attitude_deg, times_s, stood_c, still_limits(args), args.gravity_mps2,
            args.max_rms_deg, args.max_temperature_difference_c,
            ('--max-rms-deg', '--max-temperature-difference-c', '--attitude-sigma-deg'),
            args.attitude_sigma_deg)
    except (CaptureRefused, StandFitRefused) as err:
        raise Refused(str(err)) from None
    report, rows, draw = position_report(solution, attitudes, counts, spread_deg,
                                         repeatability_note(solution.fit))
    lines += report
    return solution.stage, solution.refusal, draw, rows


def fit_magnetometer(args, existing, fields, attitude_deg, times_s, temperature_c, stand,
                     lines):
    """
    Return the magnetometer fit (``FieldStandFit``) of the stand positions, or None.

    Fitted when the input has magnetometer readings and a reference field is
    given (seed 001 Eq. 12, ``magnetometer.fit_field_positions``); Refused
    as it refuses.
    """
    try:
        total_nT, dip_deg, _, source = resolve_reference(args)
    except ValueError as err:
        raise CommandError(str(err)) from None
    if fields is None or total_nT is None or dip_deg is None:
        lines.append('magnetometer not fitted: ' + (
            'no bx, by, bz (or magnetometer topic) in the input' if fields is None else
            'no reference field (--reference-total-nT and --reference-dip-deg, or --site)'))
        return None
    try:
        fit, positions = fit_field_positions(
            existing, fields, attitude_deg, times_s, temperature_c, stand, (total_nT, dip_deg),
            args.max_field_rms_deg, still_limits(args))
    except (CaptureRefused, StandFitRefused) as err:
        raise Refused(str(err)) from None
    lines += field_lines(fit, total_nT, dip_deg, source, positions)
    return fit


def fit_readings(args, readings, stood_c, lines, segment=None):
    """
    Return (Stand stage, refusal or None, draw, residual rows (none)) of a sphere fit.

    ``segment`` (N,): each reading's still segment of a continuous log, or
    None; one reading a pose (``continuous_log.sphere_readings``).
    """
    readings, stood_c, note = sphere_readings(readings, segment, stood_c)
    if note:
        lines.append(note)
    try:
        check_temperature_span(stood_c, args.max_temperature_difference_c,
                               '--max-temperature-difference-c')
        solution = solve_sphere(readings, args.gravity_mps2, args.max_rms_deg,
                                stood_for_c(stood_c))
    except StandFitRefused as err:
        raise Refused(err.reason) from None
    report, draw = sphere_report(solution, readings, args.gravity_mps2)
    lines += report
    return solution.stage, solution.refusal, draw, []
