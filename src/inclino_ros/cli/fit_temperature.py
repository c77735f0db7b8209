"""
``inclino fit-temperature``: a triad's temperature drift into the calibration file (seed 001).

This module parses the options (their help is the user's documentation) and
prints; the rules live in the layers that own them: the input (a CSV with
attitude labels or reference columns, a continuous log, a bag with
``/imu/temperature``): ``calibration.inputs.temperature_input``; the fit
(bias and scale drift at two or more attitudes, K_T alone at one, the
reference temperature the later stages stood for):
``calibration.temperature_fit``; plausible readings and temperatures:
``calibration.plausibility``; the report: ``report.temperature``.  Exit 0
written, 1 refused (the calibration file untouched), 2 unusable input.
"""

from dataclasses import replace
import sys

from inclino_ros.calibration.inputs import temperature_input
from inclino_ros.calibration.plausibility import (
    check_accelerometer_readings, check_field_readings, check_temperatures, STANDARD_GRAVITY_MPS2)
from inclino_ros.calibration.temperature_fit import run_errors, solve_temperature
from inclino_ros.cli.fitting import (
    add_common_arguments, axes_maps, load_existing, node_option, Refused, report_paths, run_fit,
    save, source_of, tool_axes, write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import between
from inclino_ros.core.temperature import TemperatureFitRefused
from inclino_ros.io.report import residual_lines
from inclino_ros.report.common import Fitted
from inclino_ros.report.temperature import (
    fit_lines, plot, TEMPERATURE_BIN_C, temperature_residuals)
import numpy as np

#: Highest order of K_T(T) and B_T(T) (seed 001 fits order 2).
MAX_ORDER = 6
REPORT_NAME = 'fit_temperature'
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
    temperature_c, sensor_readings, sensor_reference, attitude, note = temperature_input(
        source_of(args), args.triad, args.attitude_separation_deg)
    if note:
        print(f'inclino fit-temperature: {note}', file=sys.stderr)
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
    before, after, what = run_errors(args.triad, previous, model, readings, temperature_c,
                                     attitude)
    lines.append(f'{what} over the run (vs each attitude at the stage reference): largest '
                 f'{np.abs(before).max():.4f} deg uncompensated, {np.abs(after).max():.4f} deg '
                 'compensated')
    rows = temperature_residuals(temperature_c, before, after, what)
    lines += residual_lines(rows, f'{what} per {TEMPERATURE_BIN_C:g} C of the run, compensated')
    plot(outputs.path(png), temperature_c, result, before, after, what)
    lines.append(f'report: {png}')
    save(args, model, outputs, lines)
    kept = [name for name in later if getattr(model, name) is not None]
    lines.append(f'wrote {args.calibration}: {section} stage (order {args.order}, '
                 f'{result.attitudes} attitude(s), compensating to '
                 f'{result.reference_temperature_c:g} C)'
                 + (f', {" and ".join(kept)} stage kept' if kept else ''))
    write_text(outputs.path(txt), lines)
    return Fitted(model, tuple(rows))
