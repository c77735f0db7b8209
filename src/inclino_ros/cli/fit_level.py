"""
``inclino fit-level``: the level-bench calibration (seed 000) of recorded samples.

What ``inclino calibrate`` asks the running node to do, offline: the tool
lay still on a levelled bench while the samples were recorded; their mean
gives the sensor's mounting error, gamma and beta (seed 000 Eqs. 11-14),
with the same checks as the node (still, plausible G-total, bench level).
Input: a bag (the raw sensor on ``/imu/data_raw``, the samples from
``--start-s`` to ``--end-s`` seconds after its first message) or a CSV with
the columns ``ax, ay, az`` (m/s^2, sensor axes) and optionally ``time_s``
and ``temperature_c``.  A CSV with ``time_s`` that moves is a continuous
log (optionally with the gyro, ``wx, wy, wz`` rad/s): its longest still
segment is the capture (``continuous_log.longest_still_part``), said.
The stages already in the file (temperature, stand) are applied first, as
the node does; the installation stage is replaced, a tool-axis stage dropped, every other
stage kept but a high-side mark captured through the old mount
(``invalidation.replace_stages``, said), the file written atomically.

Refused (exit 1, the calibration file untouched): the tool moved or the mean
is not precise enough (``still_capture``), an implausible G-total, a bench
that is not level, or a temperature far from the stand stage's.
"""

import sys

from inclino_ros.calibration.continuous_log import segment_limits
from inclino_ros.calibration.inputs import level_input
from inclino_ros.calibration.invalidation import replace_stages
from inclino_ros.calibration.level_capture import CaptureRefused, LevelLimits, solve_level_capture
from inclino_ros.calibration.model import readings_temperature_c, temperature_conflict
from inclino_ros.cli.fitting import (
    add_capture_checks, add_common_arguments, add_still_options, add_window_arguments, axes_maps,
    load_existing, node_option, Refused, report_paths, run_fit, save, source_of, tool_axes,
    write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.io.report import residual_lines
from inclino_ros.report.common import Fitted
from inclino_ros.report.level import block_residuals, BLOCKS, capture_lines, plot_level
import numpy as np

REPORT_NAME = 'fit_level'


def register(subparsers):
    """Add the ``fit-level`` subcommand."""
    parser = add_command(
        subparsers, 'fit-level', 'level-bench calibration (mounting error) of recorded samples',
        'Measure the mounting error of the sensor, gamma and beta (seed 000), from samples '
        'recorded with the tool still on a levelled bench, and write it into the calibration '
        'file: what inclino calibrate asks the running node to do, offline, with the same '
        'checks (the tool still, a plausible G-total, the bench level).',
        'Input: a bag with the raw sensor on /imu/data_raw, the samples from --start-s to '
        '--end-s seconds after its first message, or a CSV with the columns ax, ay, az (m/s^2, '
        'optional time_s and temperature_c). Temperature and stand stages already in the file are '
        'applied first, as the node does; the level-bench stage is replaced, a tool-axis stage '
        'dropped (it would count the mount twice), and so is a high-side mark captured through '
        'the old mount (said; capture it again); every other stage kept. The report, '
        'fit_level.png and fit_level.txt, goes beside the file or to --report-dir.',
        'Refused (exit 1, the file untouched): the tool moved or too few samples for the '
        'precision asked, an implausible G-total, a bench that is not level, or a temperature '
        'far from that of the other stages. Exit 2: unusable input.')
    add_common_arguments(parser)
    add_window_arguments(parser)
    parser.add_argument('--axes', type=int, choices=(2, 3),
                        help='accelerometer axes (default: those of the file, else 3)')
    add_still_options(parser, 'level_capture.max_sem_deg', 'axis tilts', 'a capture')
    node_option(parser, '--max-tilt-deg', 'level_capture.max_tilt_deg',
                'largest false tilt accepted as a mounting error [deg]')
    add_capture_checks(parser, 'stand stage')
    parser.set_defaults(func=run)


def run(args):
    """Solve, report and write the installation stage; return the exit code."""
    return run_fit('fit-level', args, fit)


def fit(args, lines, outputs):
    """Solve the installation stage of ``args.input`` into ``args.calibration``."""
    existing = load_existing(args.calibration, args.sensor_id, axes=args.axes,
                             maps=axes_maps(args))
    axes = args.axes or existing.accelerometer_axes
    readings, temperature_c, times_s, note = level_input(source_of(args), segment_limits(
        args.max_drift_deg_per_s, args.max_sem_deg, max_motion_deg=args.max_motion_deg))
    if note:
        print(f'inclino fit-level: {note}', file=sys.stderr)
    readings = tool_axes(args, readings)
    if axes == 2:
        readings[:, 2] = 0.0   # a two-axis sensor has no z reading
    level = existing.apply(readings, None if existing.temperature is None else temperature_c,
                           before='installation')
    limits = LevelLimits(
        max_tilt_deg=args.max_tilt_deg, gravity_mps2=args.gravity_mps2,
        g_total_tolerance_mps2=args.g_total_tolerance_mps2,
        still=segment_limits(args.max_drift_deg_per_s, args.max_sem_deg,
                             max_motion_deg=args.max_motion_deg).still)
    stood_for_c = readings_temperature_c(
        existing.temperature, None if temperature_c is None else float(np.mean(temperature_c)))
    reason = temperature_conflict(existing, stood_for_c, args.max_temperature_difference_c,
                                  ('stand',))
    if reason is not None:
        raise Refused(reason)
    try:
        installation = solve_level_capture(level, axes, limits, times_s, stood_for_c)
    except CaptureRefused as err:
        raise Refused(str(err)) from None
    applied = [name for name in ('temperature', 'stand') if getattr(existing, name)]
    # The level bench measures the whole mount: a tool axis on top would count twice.
    model, dropped = replace_stages(existing, installation=installation, tool_axis=None)
    lines += capture_lines(model, applied)
    g_mps2 = args.gravity_mps2 if axes == 2 else None
    rows = block_residuals(level, installation, g_mps2)
    lines += residual_lines(rows, f'tilt of each {BLOCKS}th of the capture minus the whole '
                                  "capture's")
    png, txt = report_paths(args, REPORT_NAME)
    plot_level(outputs.path(png), level, installation, g_mps2)
    lines += dropped
    model = save(args, model, outputs, lines)
    lines += [f'wrote {args.calibration}: installation stage'
              + (f', {" and ".join(applied)} stage kept' if applied else ''),
              f'report: {png}, {txt}']
    write_text(outputs.path(txt), lines)
    return Fitted(model, tuple(rows))
