"""
``inclino fit-temperature``: a triad's temperature drift into the calibration file (seed 001).

Input: a CSV with the columns ``temperature_c, ax, ay, az`` (m/s^2; with
``--triad magnetometer``: ``bx, by, bz`` in nT) and optionally ``attitude``
(a label per row, any text: rows of one label share one attitude) or the reference
columns ``ref_ax, ref_ay, ref_az`` (``ref_bx, ...``); or a bag with the raw
sensor on ``/imu/data_raw`` (``--mag-topic`` /imu/mag for the magnetometer)
and sensor_msgs/Temperature on ``/imu/temperature``, the temperature
interpolated linearly to each stamp (samples outside the span of the
temperature messages are left out), the attitudes told apart by the
direction of the readings (``--attitude-separation-deg``).  The tool is held
still at each attitude while it heats.  A CSV with ``time_s`` and neither
attitude nor reference columns is a continuous log (optionally with the
gyro ``wx, wy, wz`` rad/s): its still segments are kept
(``continuous_log.log_segments``), the attitudes told apart as for a bag.

Heated at two or more attitudes (where every axis reads differently), each
axis gets a bias AND a scale drift, ``A_T = K_T(T) A + B_T(T)``
(``temperature.fit_temperature_drift``, seed 001 Eqs. 5-7 generalised).  At
one attitude (or with ref columns) only seed 001's scale factor K_T is
fitted (``temperature.fit_temperature``) and the report says what it cannot
see: a bias drift, absorbed into K_T at that attitude and wrong at every
other.  The reference of a one-attitude fit is its ref columns, else the mean
reading within ``--reference-window-c`` of 25 deg C.

The stage compensates the readings to the temperature the later stages'
readings stood for (stand and installation; for the magnetometer the rotation
fit), when they record one: a stand captured at 35 deg C keeps working.
The new stage replaces the old one of its triad; the other stages are kept.

Refused (exit 1, the calibration file untouched): readings not of a still
tool in m/s^2 (accelerometer) or no Earth field in nT (magnetometer), or
temperatures no sensor reads (``plausibility``), no reading near 25 deg C
for a one-attitude fit without ref columns, a fit ``temperature`` refuses
(too few distinct temperatures for the order, 25 deg C outside the data, an
axis that sees no gravity / cannot be told apart), later stages captured at
different temperatures, or their temperature outside the heated range.
"""

from dataclasses import replace
import sys

from inclino_ros.calibration.continuous_log import GYRO_COLUMNS, log_segments, TIME_COLUMN
from inclino_ros.calibration.plausibility import (
    check_accelerometer_readings, check_field_readings, check_temperatures,
    STANDARD_GRAVITY_MPS2)
from inclino_ros.calibration.temperature_fit import solve_temperature
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_common_arguments, axes_maps, AXIS_COLUMNS, finish_figure, is_bag, load_existing,
    matrix_lines, new_figure, node_option, read_csv, read_topic, Refused, report_paths,
    report_residuals, run_fit,
    sample_temperatures, save, tool_axes, write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import between
from inclino_ros.core.attitude import angle_between, inclination
from inclino_ros.core.stillness import label_attitudes, SegmentLimits, StillLimits
from inclino_ros.core.temperature import AXES, TemperatureFitRefused
from inclino_ros.io.report import Residual
import numpy as np

#: Still segments of a heating log: slow (5 s windows, 10 s at least), and the readings drift
#: with the temperature (a few hundredths of a degree a second): each window must be still,
#: not a whole segment, and a window moves only beyond 0.1 deg/s or 0.5 deg within it (a
#: hand turning the tool moves it by degrees).
HEATING_SEGMENTS = SegmentLimits(window_s=5.0, min_s=10.0, whole=False, still=StillLimits(
    max_drift_deg_per_s=0.1, max_sem_deg=0.5))
#: Highest order of K_T(T) and B_T(T) (seed 001 fits order 2).
MAX_ORDER = 6
REPORT_NAME = 'fit_temperature'
#: Width of a temperature bin of the residual table [C].
TEMPERATURE_BIN_C = 5.0
MAG_TOPIC = '/imu/mag'
#: Per triad: CSV columns, reference columns, unit, calibration section, later stages.
TRIADS = {
    'accelerometer': (('ax', 'ay', 'az'), ('ref_ax', 'ref_ay', 'ref_az'), 'm/s^2',
                      'temperature', ('stand', 'installation')),
    'magnetometer': (('bx', 'by', 'bz'), ('ref_bx', 'ref_by', 'ref_bz'), 'nT',
                     'magnetometer_temperature', ('magnetic',)),
}


def register(subparsers):
    """Add the ``fit-temperature`` subcommand."""
    parser = add_command(
        subparsers, 'fit-temperature',
        'fit the temperature drift (bias and K_T(T), seed 001) into a calibration file',
        'Fit how each axis of the accelerometer (or, with --triad magnetometer, of the '
        'magnetometer) drifts with temperature and write it into the calibration file. Heated '
        'at two or more attitudes, each axis gets a bias and a scale drift (A_T = K_T(T) A + '
        "B_T(T)); at one attitude only seed 001's scale factor K_T(T), a polynomial that is 1 "
        'at 25 C, and the report says that a bias drift cannot be seen.',
        'Input: the tool held still at one or more attitudes while it heats through 25 C: a '
        'bag with the raw sensor on /imu/data_raw (--mag-topic for the magnetometer) and '
        'sensor_msgs/Temperature on /imu/temperature (what inclino simulate --heating writes), '
        'or a CSV with the columns temperature_c, ax, ay, az (bx, by, bz in nT for the '
        'magnetometer), optional attitude (a label per row, any text such as up or 3) or '
        'ref_ax, ref_ay, ref_az (the reading at 25 C). Without them a one-attitude reference '
        'is the mean reading within --reference-window-c of 25 C.',
        'The stage compensates to the temperature the later stages stood for; it replaces the '
        'old one of its triad, every other stage is kept. The report, fit_temperature.png and '
        'fit_temperature.txt, goes beside the file or to --report-dir.',
        'Refused (exit 1, the file untouched): no reading near 25 C for a one-attitude fit, '
        'too few distinct temperatures for --order, an axis that sees no gravity, or later '
        'stages captured at different temperatures. Exit 2: unusable input.')
    add_common_arguments(parser)
    parser.add_argument('--triad', choices=sorted(TRIADS), default='accelerometer',
                        help='which sensor triad (default: %(default)s)')
    parser.add_argument('--mag-topic', default=MAG_TOPIC,
                        help='sensor_msgs/MagneticField topic of a bag, --triad magnetometer '
                             '(default: %(default)s)')
    parser.add_argument('--order', type=between(1, MAX_ORDER, int), default=2,
                        help='polynomial order of K_T(T) and B_T(T) (default: %(default)s)')
    parser.add_argument('--reference-window-c', type=between(1e-3, 100.0), default=1.0,
                        help='one attitude: readings within this many deg C of 25 deg C give '
                             'the reference when the input has no ref columns (default: '
                             '%(default)s)')
    parser.add_argument('--attitude-separation-deg', type=between(1e-3, 180.0), default=20.0,
                        help='bag: readings further apart in direction belong to different '
                             'attitudes (default: %(default)s)')
    node_option(parser, '--max-temperature-difference-c', 'temperature.max_stage_difference_c',
                'later stages whose temperatures differ by more [deg C] cannot share one '
                'compensation: refused')
    parser.set_defaults(func=run)


def run(args):
    """Fit, report and write the temperature stage; return the exit code."""
    return run_fit('fit-temperature', args, fit)


def fit(args, lines, outputs):
    """Fit the temperature stage of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    _, _, unit, section, later = TRIADS[args.triad]
    existing = load_existing(args.calibration, args.sensor_id, maps=axes_maps(args))
    temperature_c, sensor_readings, sensor_reference, attitude = load_input(args)
    readings = tool_axes(args, sensor_readings, args.triad)
    if args.triad == 'accelerometer':
        check_accelerometer_readings(readings, STANDARD_GRAVITY_MPS2)
    else:
        check_field_readings(readings)
    check_temperatures(temperature_c)
    try:
        # Fitted per SENSOR axis, applied through its axes map (issue 19 item 7).
        stage, result, notes = solve_temperature(
            existing, args.triad, temperature_c, sensor_readings, attitude, args.order,
            sensor_reference, args.reference_window_c, args.max_temperature_difference_c,
            getattr(args, f'{args.triad}_axes_map'))
    except TemperatureFitRefused as err:
        raise Refused(err.reason) from None
    lines += notes
    model = replace(existing, **{section: stage})
    previous = replace(existing, **{section: None})
    lines += fit_lines(result, unit)
    png, txt = report_paths(args, REPORT_NAME)
    if args.triad == 'accelerometer':
        before, after, what = inclination_errors(previous, model, readings, temperature_c,
                                                 attitude)
    else:
        before, after, what = direction_errors(previous, model, readings, temperature_c,
                                               attitude)
    lines.append(f'{what} over the run (vs each attitude at the stage reference): largest '
                 f'{np.abs(before).max():.4f} deg uncompensated, {np.abs(after).max():.4f} deg '
                 'compensated')
    report_residuals(args, lines, temperature_residuals(temperature_c, before, after, what),
                     f'{what} per {TEMPERATURE_BIN_C:g} C of the run, compensated')
    plot(outputs.path(png), temperature_c, result, before, after, what)
    lines.append(f'report: {png}')
    save(args, model, outputs)
    kept = [name for name in later if getattr(model, name) is not None]
    lines.append(f'wrote {args.calibration}: {section} stage (order {args.order}, '
                 f'{result.attitudes} attitude(s), compensating to '
                 f'{result.reference_temperature_c:g} C)'
                 + (f', {" and ".join(kept)} stage kept' if kept else ''))
    write_text(outputs.path(txt), lines)


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


def _per_attitude_reference(values, attitude, temperature_c, reference_c):
    """Return each sample's attitude value nearest ``reference_c`` (the run's own baseline)."""
    baseline = np.empty_like(values)
    for label in np.unique(attitude):
        mine = attitude == label
        nearest = np.argmin(np.abs(temperature_c[mine] - reference_c))
        baseline[mine] = values[mine][nearest]
    return baseline


def inclination_errors(previous, model, readings, temperature_c, attitude):
    """Return (before, after, name): inclination change over the run per attitude [deg]."""
    reference_c = model.temperature.reference_temperature_c
    before = np.degrees(inclination(previous.apply(readings)))
    after = np.degrees(inclination(model.apply(readings, temperature_c)))
    baseline = _per_attitude_reference(after, attitude, temperature_c, reference_c)
    return before - baseline, after - baseline, 'inclination error'


def direction_errors(previous, model, readings, temperature_c, attitude):
    """Return (before, after, name): field direction change over the run per attitude [deg]."""
    reference_c = model.magnetometer_temperature.reference_temperature_c
    before = previous.apply_magnetic(readings)
    after = model.apply_magnetic(readings, temperature_c)
    baseline = _per_attitude_reference(after, attitude, temperature_c, reference_c)
    return (np.degrees(angle_between(before, baseline)),
            np.degrees(angle_between(after, baseline)), 'field direction error')


def load_input(args):
    """Return (temperature_c (N,), readings (N, 3), reference (N, 3) or None, attitude (N,))."""
    columns, reference_columns, _, _, _ = TRIADS[args.triad]
    if not is_bag(args.input):
        table = read_csv(args.input, ('temperature_c',) + columns,
                         optional=reference_columns + (TIME_COLUMN,) + GYRO_COLUMNS + tuple(
                             name for name in AXIS_COLUMNS if name not in columns),
                         text=('attitude',))
        given = [name for name in reference_columns if name in table]
        if given and len(given) != 3:
            raise CommandError(f'{args.input} has {", ".join(given)}: give all of '
                               f'{", ".join(reference_columns)} or none')
        readings = np.column_stack([table[name] for name in columns])
        reference = (np.column_stack([table[name] for name in reference_columns])
                     if given else None)
        if TIME_COLUMN in table and 'attitude' not in table and not given:
            return log_still_samples(args, table, readings)
        labels = table.get('attitude', [''] * readings.shape[0])
        # Any text is a label (a number, 'up', 'A3'): rows of one label share one attitude,
        # numbered in the order they first appear.
        first = {label: number for number, label in enumerate(dict.fromkeys(labels))}
        attitude = np.array([first[label] for label in labels])
        return table['temperature_c'], readings, reference, attitude
    if args.triad == 'accelerometer':
        series = read_topic(args.input, args.raw_topic)
        readings = series.linear_acceleration_mps2
    else:
        series = read_topic(args.input, args.mag_topic)
        readings = series.field_nT
    temperature_c, inside = sample_temperatures(series, args.input, args.temperature_topic)
    if not inside.any():
        raise CommandError(f'no sample of the {args.triad} lies within the time span of '
                           f'{args.temperature_topic}')
    readings = readings[inside]
    return (temperature_c[inside], readings, None,
            label_attitudes(readings, args.attitude_separation_deg))


def log_still_samples(args, table, readings):
    """
    Return (temperature_c, readings, None, attitude) of a continuous log's still samples.

    A CSV with ``time_s`` and no attitude or reference columns: the still
    segments of the accelerometer (``continuous_log.log_segments``, with the
    gyro ``wx, wy, wz`` when given; for the magnetometer triad too, which
    turns with it) are kept, the samples of a tool being turned left out;
    the attitudes are told apart by direction as for a bag.
    """
    accel = (np.column_stack([table[name] for name in AXIS_COLUMNS])
             if all(name in table for name in AXIS_COLUMNS) else readings)
    gyro = (np.column_stack([table[name] for name in GYRO_COLUMNS])
            if all(name in table for name in GYRO_COLUMNS) else None)
    try:
        found = log_segments(table[TIME_COLUMN], accel, gyro, limits=HEATING_SEGMENTS)
    except ValueError as err:
        raise CommandError(f'{args.input}: {err}') from None
    if not found.ranges:
        raise CommandError(f'{args.input}: a continuous log (time_s) with no still segment')
    still = found.still
    print(f'inclino fit-temperature: {found.lines("log")[0]}; the samples between them left '
          'out', file=sys.stderr)
    return (table['temperature_c'][still], readings[still], None,
            label_attitudes(readings[still], args.attitude_separation_deg))


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
