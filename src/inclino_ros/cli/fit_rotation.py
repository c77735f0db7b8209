"""
``inclino fit-rotation``: the cross-axial magnetometer correction of a rotation (seed 002 §2.1).

This module parses the options (their help is the user's documentation) and
prints; the input (a bag's ``--mag-topic`` window, a CSV of bx, by, bz):
``calibration.inputs.rotation_input``; the fit, the stage and the reset of
the multi-station interference, one rule with ``~/capture_rotation``:
``calibration.rotation.solve_rotation`` (limits: ``cross_axial.RotationLimits``);
the report (radial residual and direction error against the turn):
``report.rotation``.  Exit 0 written, 1 refused (the calibration file
untouched), 2 unusable input.
"""

from inclino_ros.calibration.inputs import rotation_input
from inclino_ros.calibration.rotation import solve_rotation
from inclino_ros.cli.fitting import (
    add_file_arguments, axes_maps, load_existing, Refused, report_paths, run_fit, save, source_of,
    TEMPERATURE_TOPIC, tool_axes, write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.mounting import add_axes_map_arguments
from inclino_ros.cli.options import finite
from inclino_ros.core.cross_axial import apply_cross_axial, RotationFitRefused
from inclino_ros.io.report import residual_lines
from inclino_ros.report.common import Fitted
from inclino_ros.report.rotation import (
    plot_rotation, rotation_angles, sector_residuals, summary_lines)
import numpy as np

MAG_TOPIC = '/imu/mag'
FIELD_COLUMNS = ('bx', 'by', 'bz')
REPORT_NAME = 'fit_rotation'


def register(subparsers):
    """Add the ``fit-rotation`` subcommand."""
    parser = add_command(
        subparsers, 'fit-rotation',
        'fit the magnetometer hard and soft iron of a rotation (seed 002) into a calibration '
        'file',
        'Fit the cross-axial magnetometer correction of seed 002, hard iron c and soft iron W '
        '(B = W (m - c) across the tool), from a rotation of the tool about its own axis at '
        'one attitude, and write it into the calibration file.',
        'Input: a bag with sensor_msgs/MagneticField on --mag-topic (tesla), the readings from '
        '--start-s to --end-s seconds after its first message (inclino simulate --magnetic '
        '--rotation-s records one; its window is in OUT.truth.json), or a CSV with the '
        'columns bx, by, bz (nT). Readings without a value (NaN) are left out and counted.',
        'The drill-string interference of a multi-station analysis is reset (it was solved on '
        'the old cross-axial correction: run inclino msa again); every other stage is kept, '
        'and the stage records the temperature the readings stood for (a CSV column '
        'temperature_c, or --temperature-topic). The report, fit_rotation.png (the radial '
        'residual and the cross-axial direction error against the rotation angle, before and '
        'after the correction), fit_rotation.txt and the calibration certificate '
        'fit_rotation_certificate.html, goes beside the file or to --report-dir.',
        'Refused (exit 1, the file untouched): less than 270 deg of the turn covered, too flat '
        'or too noisy an ellipse, too few readings. Exit 2: unusable input.')
    add_file_arguments(parser, 'CSV file with bx, by, bz [nT]')
    parser.add_argument('--mag-topic', default=MAG_TOPIC,
                        help='sensor_msgs/MagneticField topic of a bag (default: %(default)s)')
    parser.add_argument('--start-s', type=finite,
                        help='bag: first reading, seconds after the first message (default: 0)')
    parser.add_argument('--end-s', type=finite,
                        help='bag: last reading, seconds after the first message '
                             '(default: the last message)')
    parser.add_argument('--temperature-topic', default=TEMPERATURE_TOPIC,
                        help='bag: sensor_msgs/Temperature topic, used when the bag has it '
                             '(default: %(default)s)')
    add_axes_map_arguments(parser, 'accelerometer', 'magnetometer')
    parser.set_defaults(func=run)


def run(args):
    """Fit, report and write the cross-axial correction; return the exit code."""
    return run_fit('fit-rotation', args, fit)


def fit(args, lines, outputs):
    """Fit the rotation of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    existing = load_existing(args.calibration, args.sensor_id, maps=axes_maps(args))
    field_nT, temperature_c = rotation_input(source_of(args))
    try:
        solution = solve_rotation(existing, tool_axes(args, field_nT, 'magnetometer'),
                                  temperature_c, 'the magnetometer readings')
    except RotationFitRefused as err:
        raise Refused(str(err)) from None
    if solution.left_out:  # a driver's NaN between two measurements
        lines.append(f'left out {solution.left_out} readings without a value (NaN)')
    result, readings = solution.fit, solution.readings_nT
    corrected = apply_cross_axial(readings, result)
    lines += summary_lines(result, readings)
    angle_deg, _, after_nT, error_deg = rotation_angles(readings, corrected, result)
    lines.append(f'cross-axial direction error the fit removes: up to '
                 f'{np.max(np.abs(error_deg)):.3f} deg (RMS '
                 f'{np.sqrt(np.mean(error_deg ** 2)):.3f} deg); left after it: noise RMSE / r = '
                 f'{np.degrees(result.rmse_nT / result.radius_nT):.4f} deg')
    rows = sector_residuals(angle_deg, after_nT, result)
    lines += residual_lines(rows, 'radial residual per 45 deg sector of the turn')
    png, txt = report_paths(args, REPORT_NAME)
    plot_rotation(outputs.path(png), readings, corrected, result)
    model = save(args, solution.model, outputs, lines)
    stood_for_c = solution.model.magnetic.rotation_temperature_c
    lines += [f'wrote the magnetic stage (hard and soft iron) to {args.calibration}'
              + ('' if existing.magnetic is None or existing.magnetic.msa_method is None else
                 '; MSA interference reset: it was solved on the old cross-axial correction '
                 '(run inclino msa again)'),
              'the readings stood for ' + ('an unknown temperature' if stood_for_c is None
                                           else f'{stood_for_c:.2f} C'),
              f'report: {png}, {txt}']
    write_text(outputs.path(txt), lines)
    return Fitted(model, tuple(rows))
