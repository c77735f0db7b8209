"""
``inclino fit-toolface-mark``: tie the toolface's zero to the tool's high-side mark, offline.

What ``inclino call capture_high_side_mark`` asks the running node to do: the
tool lay still on a bench tilted at least 5 deg off vertical with its
high-side mark up (its toolface 0 by definition) while the samples were
recorded; the board's toolface there is its roll about the tool axis, which
a level bench, a rotation, a sphere or a magnetometer fit cannot see
(``calibration.toolface_mark``, issue 19 item 6).  Input as ``inclino
fit-level``'s (``inputs.level_input``: a bag window, a CSV, a continuous
log's longest still part).  Every stage already in the file is applied first;
the ``toolface_mark`` stage is replaced, every other kept, the file written
atomically.

Refused (exit 1, the calibration file untouched): the tool moved or the mean
is not precise enough (``still_capture``), an implausible G-total, a tool
near vertical (no high side), a two-axis sensor.
"""

from dataclasses import replace
import sys

from inclino_ros.calibration.continuous_log import segment_limits
from inclino_ros.calibration.inputs import level_input
from inclino_ros.calibration.model import readings_temperature_c, temperature_conflict
from inclino_ros.calibration.toolface_mark import (
    CaptureRefused, MarkLimits, solve_toolface_mark)
from inclino_ros.cli.fitting import (
    add_capture_checks, add_common_arguments, add_still_options, add_window_arguments, axes_maps,
    load_existing, node_option, Refused, report_paths, run_fit, save, source_of, tool_axes,
    write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.report.common import Fitted
import numpy as np

REPORT_NAME = 'fit_toolface_mark'


def register(subparsers):
    """Add the ``fit-toolface-mark`` subcommand."""
    parser = add_command(
        subparsers, 'fit-toolface-mark',
        "tie the toolface zero to the tool's high-side mark (recorded samples)",
        'Measure the roll of the sensor board about the tool axis from samples recorded with '
        'the tool still on a bench tilted at least 5 deg off vertical, its high-side mark up '
        '(toolface 0 by definition), and write it into the calibration file as the '
        "toolface_mark stage: the toolface is then the tool's, not the board's. What inclino "
        'call capture_high_side_mark asks the running node to do, offline.',
        'Input: a bag with the raw sensor on /imu/data_raw, the samples from --start-s to '
        '--end-s seconds after its first message, or a CSV with the columns ax, ay, az (m/s^2, '
        'optional time_s and temperature_c). Every stage already in the file is applied first. '
        'The report, fit_toolface_mark.txt, goes beside the file or to --report-dir.',
        'Refused (exit 1, the file untouched): the tool moved or too few samples for the '
        'precision asked, an implausible G-total, a tool near vertical (no high side there), a '
        'temperature far from that of the other stages. Exit 2: unusable input.')
    add_common_arguments(parser)
    add_window_arguments(parser)
    add_still_options(parser, 'level_capture.max_sem_deg', 'tilts', 'a capture')
    add_capture_checks(parser, 'stand and level-bench stages')
    node_option(parser, '--toolface-convention', 'toolface_convention',
                'the toolface whose zero the mark is')
    parser.set_defaults(func=run)


def run(args):
    """Solve, report and write the toolface_mark stage; return the exit code."""
    return run_fit('fit-toolface-mark', args, fit)


def fit(args, lines, outputs):
    """Solve the toolface_mark stage of ``args.input`` into ``args.calibration``."""
    existing = load_existing(args.calibration, args.sensor_id, axes=3, maps=axes_maps(args))
    limits = segment_limits(args.max_drift_deg_per_s, args.max_sem_deg)
    readings, temperature_c, times_s, note = level_input(source_of(args), limits)
    if note:
        print(f'inclino fit-toolface-mark: {note}', file=sys.stderr)
    readings = tool_axes(args, readings)
    corrected = existing.apply(readings, None if existing.temperature is None else temperature_c,
                               before='toolface_mark')
    stood_for_c = readings_temperature_c(
        existing.temperature, None if temperature_c is None else float(np.mean(temperature_c)))
    reason = temperature_conflict(existing, stood_for_c, args.max_temperature_difference_c,
                                  ('stand', 'installation'))
    if reason is not None:
        raise Refused(reason)
    try:
        mark = solve_toolface_mark(
            corrected, MarkLimits(args.gravity_mps2, args.g_total_tolerance_mps2, limits.still),
            args.toolface_convention, times_s, stood_for_c)
    except CaptureRefused as err:
        raise Refused(str(err)) from None
    applied = [name for name in existing.stages if name != 'toolface_mark']
    lines += [f'high-side mark from {mark.sample_count} samples at inclination '
              f'{mark.inclination_deg:.3f} deg ({", ".join(applied) or "no"} stage(s) applied '
              'first)',
              f'offset_deg: {mark.offset_deg:.4f} (1 sigma {mark.std_deg:.4f} deg, '
              f"{mark.toolface_convention} toolface): the board's roll about the tool axis"]
    txt = report_paths(args, REPORT_NAME)[1]
    model = save(args, replace(existing, toolface_mark=mark), outputs, lines)
    lines += [f'wrote {args.calibration}: toolface_mark stage', f'report: {txt}']
    write_text(outputs.path(txt), lines)
    return Fitted(model)
