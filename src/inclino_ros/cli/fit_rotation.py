"""
``inclino fit-rotation``: the cross-axial magnetometer correction of a rotation (seed 002 §2.1).

Input: a bag with sensor_msgs/MagneticField on ``--mag-topic`` (tesla,
z-up tool frame), the messages between ``--start-s`` and ``--end-s``
(seconds after the topic's first message; default: all of them), or a CSV
with the columns ``bx, by, bz`` (nT, tool frame), one row per reading.  The
tool turns about its own axis at one attitude (what ``inclino simulate
--magnetic --rotation-s`` records): the cross-axial readings lie on an
ellipse that ``cross_axial.fit_cross_axial`` fits (hard iron c, symmetric
soft-iron correction W of ``B_xy = W (m_xy - c)``).

The magnetic stage of the calibration file gets ``hard_iron_nT``,
``soft_iron``, ``rotation_fitted_at`` and ``rotation_temperature_c`` (a CSV's
optional ``temperature_c`` column, a bag's ``--temperature-topic``), as
``~/capture_rotation`` does (one rule: ``rotation.solve_rotation``); its
interference is reset, as it was solved on the old cross-axial correction;
every other stage is kept.  Report: the radial residual and the cross-axial direction error
against the rotation angle, before and after, in ``fit_rotation.png``, the summary in
``fit_rotation.txt``.

Readings without a value (NaN, as some drivers publish between two
measurements) are left out and counted.  Refused (exit 1, the calibration
file untouched): readings that are no Earth field in nT
(``plausibility.check_field_readings``: a dead magnetometer, tesla or gauss
named), too few readings, none finite, no ellipse, too flat an ellipse, too
short an arc or too large a radial RMSE
(``cross_axial.RotationLimits``).
"""

from inclino_ros.calibration.rotation import solve_rotation
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_file_arguments, axes_maps, finish_figure, has_topic, is_bag, load_existing, new_figure,
    read_csv, read_topic, Refused, report_paths, report_residuals, run_fit, sample_temperatures,
    save,
    TEMPERATURE_TOPIC, tool_axes, write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.mounting import add_axes_map_arguments
from inclino_ros.cli.options import finite
from inclino_ros.core.cross_axial import apply_cross_axial, RotationFitRefused
from inclino_ros.io.report import Residual
import numpy as np

MAG_TOPIC = '/imu/mag'
FIELD_COLUMNS = ('bx', 'by', 'bz')
REPORT_NAME = 'fit_rotation'
#: Width of a sector of the turn in the residual table [deg].
SECTOR_DEG = 45


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


def load_readings(args):
    """
    Return the rotation's readings (N, 3) [nT, tool frame] and temperatures (N,) or None.

    The temperatures: a CSV's optional ``temperature_c`` column, a bag's
    ``--temperature-topic`` interpolated to each reading when the bag has it
    (readings outside its span left out).  CommandError if unusable.
    """
    if not is_bag(args.input):
        table = read_csv(args.input, FIELD_COLUMNS, optional=('temperature_c',))
        return (np.column_stack([table[name] for name in FIELD_COLUMNS]),
                table.get('temperature_c'))
    series = read_topic(args.input, args.mag_topic)
    seconds = (series.stamps_ns - series.stamps_ns.min()) / 1e9
    start_s = 0.0 if args.start_s is None else args.start_s
    end_s = seconds.max() if args.end_s is None else args.end_s
    window = (seconds >= start_s) & (seconds <= end_s)
    if not window.any():
        raise CommandError(f'no {args.mag_topic} message between {start_s} and {end_s} s '
                           f'(the topic spans 0 .. {seconds.max():.3f} s)')
    if not has_topic(args.input, args.temperature_topic):
        return series.field_nT[window], None
    temperature_c, inside = sample_temperatures(series, args.input, args.temperature_topic)
    window &= inside
    if not window.any():
        raise CommandError(f'no {args.mag_topic} message of the window lies within the time '
                           f'span of {args.temperature_topic}')
    return series.field_nT[window], temperature_c[window]


def fit(args, lines, outputs):
    """Fit the rotation of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    existing = load_existing(args.calibration, args.sensor_id, maps=axes_maps(args))
    field_nT, temperature_c = load_readings(args)
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
    report_residuals(args, lines, sector_residuals(angle_deg, after_nT, result),
                     'radial residual per 45 deg sector of the turn')
    png, txt = report_paths(args, REPORT_NAME)
    plot_rotation(outputs.path(png), readings, corrected, result)
    save(args, solution.model, outputs)
    stood_for_c = solution.model.magnetic.rotation_temperature_c
    lines += [f'wrote the magnetic stage (hard and soft iron) to {args.calibration}'
              + ('' if existing.magnetic is None or existing.magnetic.msa_method is None else
                 '; MSA interference reset: it was solved on the old cross-axial correction '
                 '(run inclino msa again)'),
              'the readings stood for ' + ('an unknown temperature' if stood_for_c is None
                                           else f'{stood_for_c:.2f} C'),
              f'report: {png}, {txt}']
    write_text(outputs.path(txt), lines)


def summary_lines(result, readings):
    """Return the text summary of a CrossAxialFit of ``readings``."""
    w = result.correction
    radial_nT = np.linalg.norm(readings[:, :2] - readings[:, :2].mean(axis=0), axis=1)
    return [
        f'rotation: {result.sample_count} readings, coverage {result.coverage_deg:.1f} deg, '
        f'axial field {readings[:, 2].mean():.1f} nT (spread {readings[:, 2].std():.1f} nT)',
        f'hard iron c (tool x, y): {result.offset_nT[0]:.2f}, {result.offset_nT[1]:.2f} nT',
        f'soft iron W: [[{w[0, 0]:.6f}, {w[0, 1]:.6f}], [{w[1, 0]:.6f}, {w[1, 1]:.6f}]]',
        f'axis ratio {result.axis_ratio:.5f}, circle radius {result.radius_nT:.1f} nT',
        f'radial RMSE after {result.rmse_nT:.2f} nT (about the raw mean: '
        f'{np.std(radial_nT):.2f} nT)']


def rotation_angles(readings, corrected, result):
    """
    Return per reading: the rotation angle, radial residual before and after, direction error.

    The angle [deg, 0..360) is the direction of the corrected cross-axial
    field; the radial residuals [nT] are the reading's radius minus the
    circle's, before (about the origin: the raw magnetometer) and after the
    correction (the fit's residual); the direction error [deg] is how far
    the raw reading's cross-axial direction is from the corrected one: what
    the fit removes from the toolface and, through it, from the azimuth.
    """
    angle_deg = np.degrees(np.arctan2(corrected[:, 1], corrected[:, 0])) % 360.0
    before_nT = np.hypot(readings[:, 0], readings[:, 1]) - result.radius_nT
    after_nT = np.hypot(corrected[:, 0], corrected[:, 1]) - result.radius_nT
    raw_deg = np.degrees(np.arctan2(readings[:, 1], readings[:, 0]))
    error_deg = (raw_deg - angle_deg + 180.0) % 360.0 - 180.0
    return angle_deg, before_nT, after_nT, error_deg


def sector_residuals(angle_deg, after_nT, result):
    """
    Return the Residual rows of each 45 deg sector of the turn the readings cover.

    Per sector the RMS radial residual after the correction [nT] against the
    fit's radial RMSE (its stated noise): a sector far above it is a part of
    the turn the ellipse does not describe (a magnetised spot, a jerk).
    """
    rows = []
    for start in range(0, 360, SECTOR_DEG):
        inside = (angle_deg >= start) & (angle_deg < start + SECTOR_DEG)
        if inside.any():
            rows.append(Residual(
                f'{start:3d}-{start + SECTOR_DEG:3d} deg ({int(inside.sum())} readings)',
                float(np.sqrt(np.mean(after_nT[inside] ** 2))), float(result.rmse_nT), 'nT'))
    return rows


def plot_rotation(path, readings, corrected, result):
    """
    Plot what the fit changes against the rotation angle, before and after.

    The readings and the circle are not drawn: a centre of tens of nT and an
    axis ratio near 1 cannot be seen on a circle of tens of thousands.  The
    first panel shows each reading's radial residual (its radius minus the
    circle's), the second the error of its cross-axial direction, which the
    toolface and the azimuth inherit; the band is the fit's noise (radial RMSE,
    and RMSE / r in angle).
    """
    angle_deg, before_nT, after_nT, error_deg = rotation_angles(readings, corrected, result)
    noise_deg = np.degrees(result.rmse_nT / result.radius_nT)
    pyplot, fig, axes = new_figure(
        2, f'inclino fit-rotation: hard iron |c| {np.hypot(*result.offset_nT):.1f} nT, '
           f'axis ratio {result.axis_ratio:.4f}, radius {result.radius_nT:.0f} nT')
    order = np.argsort(angle_deg)
    panels = ((before_nT, after_nT, result.rmse_nT, 'nT',
               'radial residual |B_xy| - r [nT]'),
              (error_deg, np.zeros_like(error_deg), noise_deg, 'deg',
               'cross-axial direction error [deg]'))
    for ax, (before, after, noise, unit, ylabel) in zip(axes, panels):
        ax.axhspan(-noise, noise, color='tab:green', alpha=0.15,
                   label=f'fit noise +-{noise:.3g} {unit} (1 sigma)')
        ax.plot(angle_deg[order], before[order], '.', color='tab:red', markersize=3,
                label=f'before: raw readings (largest {np.max(np.abs(before)):.3g} {unit})')
        ax.axhline(0.0, color='black', linewidth=0.8)
        ax.set_xlim(0.0, 360.0)
        ax.set_xticks(np.arange(0, 361, 45))
        ax.set_xlabel('rotation angle: direction of the corrected cross-axial field [deg]')
        ax.set_ylabel(ylabel)
    axes[0].plot(angle_deg[order], after_nT[order], '.', color='tab:green', markersize=3,
                 label=f'after: W (m - c), RMSE {result.rmse_nT:.2f} nT')
    axes[1].plot([], [], '.', color='tab:green',
                 label=f'after: the corrected direction is the reference; its noise '
                       f'RMSE / r = {noise_deg:.3g} deg')
    finish_figure(pyplot, fig, axes, path)
