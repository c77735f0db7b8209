"""
``inclino fit-stand``: seed 001's multi-position stand calibration into the calibration file.

Input: a CSV with the columns ``inclination_deg, toolface_deg, ax, ay, az``
(one row per sample or per averaged position; m/s^2, REP 145 z-up specific
force; an optional ``temperature_c``), and for the magnetometer
``azimuth_deg`` (the magnetic azimuth of the hole direction) and ``bx, by,
bz`` [nT, tool frame]; or a bag with the raw sensor on ``/imu/data_raw``,
the stand attitude on ``/stand/attitude`` (Vector3Stamped: x
inclination_deg, y seed-000 toolface_deg, z azimuth_deg; each Imu sample
takes the latest attitude at or before its stamp), optionally
``/imu/temperature`` and ``--mag-topic``.  Consecutive samples of one
attitude are averaged into one position; a later visit of an attitude (its
rows after another attitude's, or less than 1 deg from it) is a repeat:
weighed in the fit like any position, and the scatter of the visits is
reported as the stand's repeatability (deg, per attitude and overall).

A CSV with ``time_s`` and no attitude columns is a continuous log
(optionally with the gyro, ``wx, wy, wz`` rad/s): its still segments
(``continuous_log.log_segments``) are the readings of a sphere fit, one a
segment, the samples between them left out.  Every still sample of such a
log, in turn and without times, is grouped by pose
(``continuous_log.sphere_readings``).

With a reference field (``--reference-total-nT`` and
``--reference-dip-deg``, or ``--site``) and magnetometer readings, the
magnetometer's K_m and bias are fitted too (seed 001 Eq. 12: the same fit
against the field expected at each position), into the stages
``magnetometer`` and ``magnetometer_alignment``; refused beyond
``--max-field-rms-deg``.  Positions that differ only in azimuth are one
attitude for the accelerometer (repeats).

``--method stand`` fits ``A = K G + b`` to the positions (``stand.fit_stand``);
``--method sphere`` needs no attitude and fits every sample to ``|G| = g``
(``stand.fit_sphere``: K only up to a rotation, returned upper triangular).
A temperature stage already in the file is applied to the readings first
(at their temperature, else at its reference), as the model applies it
before the stand stage.  The new stand stage replaces the old one, keeps the
other stages and drops the installation and tool-axis stages: a stand K
contains the mounting misalignment, and after a sphere fit the level bench
must be measured again on the stand-corrected readings.

Refused (exit 1, the calibration file untouched): readings that are not
those of a still tool in m/s^2 (``plausibility.check_accelerometer_readings``:
g or mg named), a fit ``stand`` refuses (fewer than six distinct
attitudes, an ill-posed set), a position where the tool moved (its mean
drifts faster than ``--max-drift-deg-per-s`` against its own noise, or is
not steady) or whose mean misses ``--max-sem-deg`` (``still_capture``:
positions of fewer than 6 samples, e.g. averaged CSV rows, are not tested;
CSV times from an optional ``time_s`` column), positions whose temperatures
lie more than ``--max-temperature-difference-c`` apart without a
temperature stage, an RMS inclination residual above ``--max-rms-deg`` (for
a sphere fit: the RMS of ``|G| - g`` over g, as an angle).  The stage
records the temperature its readings stood for (the temperature stage's
reference, else their mean temperature).
"""

from functools import partial

from inclino_ros.calibration.continuous_log import (
    GYRO_COLUMNS, log_segments, segment_limits, sphere_readings, TIME_COLUMN)
from inclino_ros.calibration.magnetometer import fit_field_stand
from inclino_ros.calibration.model import CalibrationModel, readings_temperature_c
from inclino_ros.calibration.plausibility import check_accelerometer_readings
from inclino_ros.calibration.stand_fit import (
    check_temperature_span, group_positions, position_noise_deg, repeatability_note,
    solve_sphere, solve_stand, stood_for_c, with_stand)
from inclino_ros.calibration.still_capture import CaptureRefused
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_common_arguments, add_still_options, axes_maps, AXIS_COLUMNS, finish_figure, has_topic,
    is_bag, load_existing, MAG_PAIRING_TOLERANCE_NT, matrix_lines, new_figure, NODE_DEFAULTS,
    node_option, read_csv, read_topic, Refused, report_paths, report_residuals, run_fit,
    sample_temperatures, save, tool_axes, write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import between, node_parameter
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core.attitude import inclination
from inclino_ros.core.stand import StandFitRefused
from inclino_ros.io.report import Residual
from inclino_ros.io.timing import pair_nearest
import numpy as np

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
    parser.add_argument('--max-rms-deg', type=between(1e-6, 90.0), default=0.05,
                        help='largest RMS inclination residual accepted [deg] (default: '
                             '%(default)s)')
    add_still_options(parser, 'stand.max_sem_deg', 'direction of one position', 'a position')
    node_option(parser, '--max-temperature-difference-c', 'temperature.max_stage_difference_c',
                'without a temperature stage, positions further apart in temperature [deg C] '
                'are refused')
    parser.add_argument('--attitude-topic', default=ATTITUDE_TOPIC,
                        help='Vector3Stamped stand attitude topic of a bag (default: '
                             '%(default)s)')
    parser.add_argument('--gravity-mps2', type=node_parameter('gravity_mps2'),
                        default=NODE_DEFAULTS['gravity_mps2'],
                        help='local gravity [m/s^2] (default: %(default)s)')
    magnetic = parser.add_argument_group('magnetometer (seed 001 Eq. 12)')
    magnetic.add_argument('--mag-topic', default='/imu/mag',
                          help='sensor_msgs/MagneticField topic of a bag (default: %(default)s)')
    magnetic.add_argument('--max-field-rms-deg', type=node_parameter('stand.max_field_rms_deg'),
                          default=NODE_DEFAULTS['stand.max_field_rms_deg'],
                          help='largest RMS angle between the corrected and the expected field '
                               '[deg] (default: %(default)s)')
    add_reference_arguments(magnetic)
    parser.set_defaults(func=run)


def run(args):
    """Fit, report and write the stand stage; return the exit code."""
    return run_fit('fit-stand', args, fit)


def fit(args, lines, outputs):
    """Fit the stand stage of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    existing = load_existing(args.calibration, args.sensor_id, maps=axes_maps(args))
    readings, attitude_deg, temperature_c, times_s, fields, gyro = load_input(args)
    readings, fields = tool_axes(args, readings), tool_axes(args, fields, 'magnetometer')
    segment = None
    if attitude_deg is None and gyro is not False:   # a continuous log: its still samples
        segment, readings, temperature_c, times_s = still_samples(
            args, readings, gyro, temperature_c, times_s, lines)
    check_accelerometer_readings(readings, args.gravity_mps2)
    # What each reading stood for: the temperature stage's reference, else its own.
    stood_c = (None if existing.temperature is None and temperature_c is None else
               np.broadcast_to(readings_temperature_c(existing.temperature, temperature_c),
                               readings.shape[:1]).astype(float))
    if existing.temperature is not None:
        readings = CalibrationModel(3, temperature=existing.temperature).apply(
            readings, temperature_c)
        lines.append('temperature stage of the file applied to the readings first ('
                     + ('at their temperatures)' if temperature_c is not None else
                        'no temperatures in the input: at its reference temperature)'))
    field = None
    if args.method == 'stand':
        stage, refusal, draw = fit_positions(args, readings, attitude_deg, times_s, stood_c,
                                             lines)
        if not refusal:
            field = fit_magnetometer(args, existing, fields, attitude_deg, times_s,
                                     temperature_c, stage, lines)
    else:
        stage, refusal, draw = fit_readings(args, readings, stood_c, lines, segment)
    stood_for_c = stage.temperature_c
    lines.append('the readings stood for ' + ('an unknown temperature' if stood_for_c is None
                                              else f'{stood_for_c:.2f} C'))
    # A refused fit reports beside, not over, the report of the fit in the file.
    png, txt = report_paths(args, REPORT_NAME + ('_refused' if refusal else ''))
    draw(outputs.path(png))
    lines.append(f'report: {png}')
    write_text(outputs.path(txt), lines + ([f'REFUSED: {refusal}'] if refusal else []))
    if refusal:
        raise Refused(refusal)
    dropped = existing.installation is not None
    save(args, with_stand(existing, stage, field), outputs)
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


def load_input(args):
    """
    Return (readings (N, 3), attitude_deg, temperature_c, times_s, fields, gyro).

    The attitude (N, 3: inclination, toolface, azimuth: 0 without the
    column) is read for ``--method stand``, None for a sphere fit or a CSV
    without attitude columns; ``temperature_c`` (N,) or None; ``times_s``
    (N,) or None (a CSV without ``time_s``); ``fields`` (N, 3) [nT] the
    paired magnetometer readings when the input has them, else None;
    ``gyro``: a continuous log (a CSV with ``time_s`` and no attitude
    columns) gives its ``wx, wy, wz`` [rad/s] (N, 3) or None without them;
    False: not a continuous log.
    """
    need_attitude = args.method == 'stand'
    if not is_bag(args.input):
        table = read_csv(args.input, AXIS_COLUMNS,
                         optional=ATTITUDE_COLUMNS + ('temperature_c', TIME_COLUMN,
                                                      AZIMUTH_COLUMN) + FIELD_COLUMNS
                         + GYRO_COLUMNS)
        readings = np.column_stack([table[name] for name in AXIS_COLUMNS])
        has_attitude = all(name in table for name in ATTITUDE_COLUMNS)
        if need_attitude and not has_attitude and TIME_COLUMN not in table:
            missing = [name for name in ATTITUDE_COLUMNS if name not in table]
            raise CommandError(f'{args.input} lacks the column(s) {", ".join(missing)} (the '
                               f'stand attitudes), and has no {TIME_COLUMN} column (a '
                               'continuous log, whose still segments a sphere fit takes)')
        attitude_deg = (np.column_stack(
            [table[name] for name in ATTITUDE_COLUMNS]
            + [table.get(AZIMUTH_COLUMN, np.zeros(len(readings)))])
            if need_attitude and has_attitude else None)
        fields = (np.column_stack([table[name] for name in FIELD_COLUMNS])
                  if all(name in table for name in FIELD_COLUMNS) else None)
        gyro = False
        if not has_attitude and TIME_COLUMN in table:
            gyro = (np.column_stack([table[name] for name in GYRO_COLUMNS])
                    if all(name in table for name in GYRO_COLUMNS) else None)
        return (readings, attitude_deg, table.get('temperature_c'), table.get(TIME_COLUMN),
                fields, gyro)
    imu = read_topic(args.input, args.raw_topic)
    temperature_c = (sample_temperatures(imu, args.input, args.temperature_topic)[0]
                     if has_topic(args.input, args.temperature_topic) else None)
    times_s = imu.stamps_ns * 1e-9
    if not need_attitude:
        return imu.linear_acceleration_mps2, None, temperature_c, times_s, None, False
    fields = None
    if has_topic(args.input, args.mag_topic):
        mag = read_topic(args.input, args.mag_topic)
        fields = pair_nearest(imu.stamps_ns, mag.stamps_ns, mag.field_nT, round(0.05 * 1e9),
                              MAG_PAIRING_TOLERANCE_NT)[0]
    attitude = read_topic(args.input, args.attitude_topic)
    order = np.argsort(attitude.stamps_ns, kind='stable')
    latest = np.searchsorted(attitude.stamps_ns[order], imu.stamps_ns, side='right') - 1
    held = latest >= 0
    if not held.any():
        raise CommandError(f'no sample of {args.raw_topic} comes at or after the first '
                           f'{args.attitude_topic} message')
    attitude_deg = attitude.vector[order[latest[held]]]
    attitude_deg[~np.isfinite(attitude_deg[:, 2]), 2] = 0.0   # z NaN: no azimuth known
    return (imu.linear_acceleration_mps2[held], attitude_deg,
            None if temperature_c is None else temperature_c[held], times_s[held],
            None if fields is None else fields[held], False)


def still_samples(args, readings, gyro, temperature_c, times_s, lines):
    """
    Return (segment (M,), readings, temperature_c, times_s) of a log's still samples only.

    The still segments (``continuous_log.log_segments`` with the command's
    still limits) are what a sphere fit takes, one reading a segment; the
    samples between them (the tool turned by hand) are left out.
    """
    try:
        found = log_segments(times_s, readings, gyro, temperature_c,
                             segment_limits(args.max_drift_deg_per_s, args.max_sem_deg))
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
    return segment_limits(args.max_drift_deg_per_s, args.max_sem_deg).still


def fit_positions(args, readings, attitude_deg, times_s, stood_c, lines):
    """
    Return (Stand stage, refusal reason or None, draw) of a known-attitude stand fit.

    ``stand_fit.solve_stand``, as ``~/solve_stand_calibration`` fits the
    node's positions; ``stood_c``: the temperature each reading stood for
    (None: unknown).  ``draw(path)`` plots the report.
    """
    attitudes, means, counts, position = group_positions(readings, attitude_deg)
    temperatures_c = (None if stood_c is None else
                      np.bincount(position, weights=stood_c) / counts)
    try:
        spread_deg = position_noise_deg(readings, times_s, position, len(means),
                                        still_limits(args))
        solution = solve_stand(means, attitudes, args.gravity_mps2, args.max_rms_deg,
                               temperatures_c, args.max_temperature_difference_c,
                               ('--max-rms-deg', '--max-temperature-difference-c'))
    except (CaptureRefused, StandFitRefused) as err:
        raise Refused(str(err)) from None
    result, means = solution.fit, solution.readings
    raw_deg = np.degrees(inclination(means)) - attitudes[:, 0]
    after_deg = result.inclination_residual_deg
    lines += geometry_lines(result)
    lines.append(f'{"pos":>3} {"att":>3} {"incl_deg":>9} {"tf_deg":>8} {"az_deg":>7} '
                 f'{"samples":>7} {"noise_deg":>10} {"raw_err_deg":>11} {"residual_deg":>12}')
    lines += [f'{k + 1:>3} {a + 1:>3} {incl:9.3f} {tf:8.3f} {az:7.2f} {n:>7} {s:10.4f} '
              f'{before:11.4f} {after:12.6f}'
              for k, ((incl, tf, az), a, n, s, before, after) in enumerate(
                  zip(attitudes, result.attitude, counts, spread_deg, raw_deg, after_deg))]
    lines.append(repeatability_note(result))
    if solution.plateaus is not None:
        lines += plateau_lines(solution.plateaus)
    lines.append(f'RMS inclination residual: {result.rms_inclination_deg:.6f} deg (raw '
                 f'{np.sqrt(np.mean(raw_deg ** 2)):.4f} deg); RMS residual '
                 f'{result.rms_residual_mps2:.3g} m/s^2')
    report_residuals(args, lines, [
        Residual(f'position {k + 1} (I {attitude[0]:.1f}, TF {attitude[1]:.1f} deg, {n} '
                 'samples)', float(after), float(spread / np.sqrt(n)), 'deg')
        for k, (attitude, n, spread, after) in enumerate(
            zip(attitudes, counts, spread_deg, after_deg))],
        "inclination residual of each position against its mean's noise (spread / sqrt(n))")
    return (solution.stage, solution.refusal,
            partial(plot_positions, raw_deg=raw_deg, after_deg=after_deg,
                    rms_deg=result.rms_inclination_deg))


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
                                        plateaus.element_sigma, values)]


def fit_magnetometer(args, existing, fields, attitude_deg, times_s, temperature_c, stand,
                     lines):
    """
    Return the magnetometer fit (``FieldStandFit``) of the stand positions, or None.

    Fitted when the input has magnetometer readings and a reference field is
    given (seed 001 Eq. 12, ``magnetometer.fit_field_stand``); Refused as it
    refuses.
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
    paired = np.isfinite(fields).all(axis=1)
    temperature_c = None if temperature_c is None else temperature_c[paired]
    fields = existing.apply_magnetic(fields[paired], temperature_c, before='magnetometer')
    positions, means, counts, position = group_positions(fields, attitude_deg[paired])
    # What each position's field stood for: its temperature stage's reference, else its own.
    stood_c = (None if existing.magnetometer_temperature is None and temperature_c is None
               else np.bincount(position, weights=np.broadcast_to(readings_temperature_c(
                   existing.magnetometer_temperature, temperature_c), position.shape)) / counts)
    try:
        position_noise_deg(fields, None if times_s is None else times_s[paired], position,
                           len(means), still_limits(args), ' (magnetometer)')
        fit = fit_field_stand(means, positions, total_nT, dip_deg, stand,
                              args.max_field_rms_deg, stood_c)
    except (CaptureRefused, StandFitRefused) as err:
        raise Refused(str(err)) from None
    lines.append(f'magnetometer (seed 001 Eq. 12) against {total_nT:.1f} nT, dip '
                 f'{dip_deg:.3f} deg ({source}): {len(means)} positions, field residual '
                 f'{fit.rms_residual_deg:.4f} deg RMS (worst {fit.residual_deg.max():.4f})')
    if fit.plateaus is not None:
        lines += plateau_lines(fit.plateaus, 'nT', ('RMS field residual', fit.plateau_rms_deg))
    lines += matrix_lines('K_m (m = K_m B + b_m, symmetric part)',
                          fit.magnetometer.scale_matrix, '10.6f')
    lines.append('bias_nT: ' + ' '.join(f'{v:.1f}' for v in fit.magnetometer.bias_nT)
                 + f"; axes turned {fit.alignment.angle_deg:.4f} deg into the accelerometer's")
    return fit


def fit_readings(args, readings, stood_c, lines, segment=None):
    """
    Return (Stand stage, refusal reason or None, draw) of a sphere fit of every reading.

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
    result = solution.fit
    rms_deg = np.degrees(result.rms_residual_mps2 / args.gravity_mps2)
    lines += geometry_lines(result)
    lines.append(f'RMS |G| - g: {result.rms_residual_mps2:.3g} m/s^2 ({rms_deg:.6f} deg as an '
                 f'angle) over {readings.shape[0]} readings')
    return (solution.stage, solution.refusal,
            partial(plot_readings, raw_mps2=np.linalg.norm(readings, axis=1) - args.gravity_mps2,
                    after_mps2=result.residual_mps2))


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
