"""
What ``inclino fit-stand`` and ``inclino fit-temperature`` share.

Input is a bag (a directory, mcap or sqlite3) or a CSV file (any other path)
with a header row naming its columns; the calibration file is read if it
exists, changed in one stage and written atomically with ``model.save_model``
(its history keeps the version replaced; a file that another writer changed
while the fit ran is not written over); each fit leaves a PNG and a text
summary in the report folder, in the same commit as the calibration file:
all land together or none does.

Exit codes: 0 written, 1 refused (the reason printed, the file untouched),
2 an input that cannot be used (``CommandError``).
"""

import os
import sys

from inclino_ros.calibration.history import file_digest
from inclino_ros.calibration.inputs import Source
from inclino_ros.calibration.model import (
    CalibrationChanged, CalibrationFileError, check_sensor, load_model, save_model)
from inclino_ros.calibration.plausibility import Implausible
from inclino_ros.calibration.provenance import utc_now_iso
from inclino_ros.calibration.store import model_to_update
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.mounting import add_axes_map_arguments, axes_matrix
from inclino_ros.cli.options import node_parameter
from inclino_ros.core.mounting import to_tool_axes
from inclino_ros.core.refusal import Refused
from inclino_ros.io import tables
from inclino_ros.io.files import Outputs, write_text as write_file
from inclino_ros.io.report import certificate_html
from inclino_ros.io.timing import pairing_tolerance
from inclino_ros.node.parameters import PARAMETERS
import numpy as np

RAW_TOPIC = '/imu/data_raw'
TEMPERATURE_TOPIC = '/imu/temperature'
AXIS_COLUMNS = ('ax', 'ay', 'az')
#: The node's parameter defaults: the commands' options default to the same values.
NODE_DEFAULTS = {parameter.name: parameter.default for parameter in PARAMETERS}
#: The fits pair a bag's magnetometer with the node's rule at the node's default noise.
MAG_PAIRING_TOLERANCE_NT = pairing_tolerance(NODE_DEFAULTS['magnetometer_noise_std_nT'])


def add_file_arguments(parser, csv_help='CSV file with a header row'):
    """Add the input, --calibration, --sensor-id and --report-dir options."""
    parser.add_argument('input', metavar='BAG_OR_CSV',
                        help=f'bag directory (mcap or sqlite3) or {csv_help}')
    parser.add_argument('--calibration', required=True, metavar='FILE',
                        help='calibration file to update (created if missing)')
    add_sensor_argument(parser)
    parser.add_argument('--report-dir', metavar='DIR',
                        help='folder of the PNG and text report (default: that of FILE)')
    add_history_option(parser)


def add_history_option(parser):
    """Add --history-keep: how many versions the calibration file's history keeps."""
    node_option(parser, '--history-keep', 'calibration.history_keep',
                'versions kept in the history of the calibration file (FILE.history); a write '
                'removes the older ones and says which, never the one in use', metavar='N')


def history_report(command):
    """Return the ``report`` of ``model.save_model``: its line on stderr, a note of ``command``."""
    return lambda line: print(f'{command}: note: {line}', file=sys.stderr)


def add_common_arguments(parser):
    """Add the input, --calibration, --report-dir and accelerometer topic options."""
    add_file_arguments(parser)
    parser.add_argument('--raw-topic', default=RAW_TOPIC,
                        help='sensor_msgs/Imu topic of a bag (default: %(default)s)')
    parser.add_argument('--temperature-topic', default=TEMPERATURE_TOPIC,
                        help='sensor_msgs/Temperature topic of a bag (default: %(default)s)')
    add_axes_map_arguments(parser, 'accelerometer', 'magnetometer')


def axes_maps(args):
    """Return the (accelerometer, magnetometer) axes maps of the command line."""
    return args.accelerometer_axes_map, args.magnetometer_axes_map


def tool_axes(args, readings, sensor='accelerometer'):
    """Return sensor readings (N, 3) turned into the tool axes by ``--<sensor>-axes-map``."""
    return None if readings is None else to_tool_axes(readings, axes_matrix(args, sensor))


def source_of(args):
    """Return the ``inputs.Source`` of the command line: the input, its topics and window."""
    return Source(args.input, **{name: getattr(args, name) for name in (
        'raw_topic', 'temperature_topic', 'mag_topic', 'attitude_topic', 'start_s', 'end_s')
        if getattr(args, name, None) is not None})


def is_bag(path):
    """Return whether ``path`` names a bag (a directory) rather than a CSV file."""
    return os.path.isdir(path)


def read_csv(path, required, optional=(), text=(), max_rows=tables.MAX_ROWS):
    """Return the columns of a CSV file (``tables.read_csv``); CommandError if unusable."""
    try:
        return tables.read_csv(path, required, optional, text, max_rows=max_rows)
    except tables.TableError as err:
        raise CommandError(str(err)) from None


def node_option(parser, flag, parameter, help_text=None, **kwargs):
    """
    Add the option ``flag`` of the type, range (or choices), default of the node's ``parameter``.

    The one definition of an option that is a node parameter too
    (``node.parameters.PARAMETERS``); ``help_text`` None: the parameter's own
    description.  The action records ``node_parameter`` (the name), which
    test_option_parity checks every option against.
    """
    (declared,) = (p for p in PARAMETERS if p.name == parameter)
    kind = ({'choices': declared.choices} if declared.choices else
            {'type': node_parameter(parameter)})
    text = declared.description if help_text is None else help_text
    action = parser.add_argument(flag, default=declared.default, **kind, **kwargs,
                                 help=f"{text.replace('%', '%%')} (default: %(default)s, as "
                                      f'{parameter})')
    action.node_parameter = parameter
    return action


def add_bias_instability_arguments(parser, magnetic):
    """Add --bias-instability-mps2 (to ``parser``) and --mag-bias-instability-nT (``magnetic``)."""
    node_option(parser, '--bias-instability-mps2', 'accelerometer_bias_instability_mps2',
                'accelerometer bias instability B (IEEE Std 952) [m/s^2]: adds its flicker '
                "(1.6 B) to the 1 sigma of every station's or window's mean; 0: none",
                metavar='B_MPS2')
    node_option(magnetic, '--mag-bias-instability-nT', 'magnetometer_bias_instability_nT',
                'magnetometer bias instability B [nT]: as --bias-instability-mps2, for the '
                'azimuth', metavar='B_NT')


def add_still_options(parser, sem_parameter, mean_of, capture):
    """
    Add --max-sem-deg, --max-drift-deg-per-s, --max-motion-deg: a capture's still test.

    The test is ``still_capture``'s; ``sem_parameter``: the node parameter of
    the precision limit; ``mean_of`` and ``capture`` name what is averaged
    and what may move in the help texts.
    """
    node_option(parser, '--max-sem-deg', sem_parameter,
                f'largest standard error of the mean {mean_of} [deg]')
    node_option(parser, '--max-drift-deg-per-s', 'still.max_drift_deg_per_s',
                f'{capture} whose mean drifts faster [deg/s], significantly for its noise, moved')
    node_option(parser, '--max-motion-deg', 'still.max_motion_deg',
                f'{capture} whose attitude at a part lies further from its mean [deg], '
                'significantly for its noise, moved; a smaller motion is in the 1 sigma')


def add_window_arguments(parser):
    """Add --start-s and --end-s: the window of a bag a still capture is read from."""
    parser.add_argument('--start-s', type=float, default=0.0, metavar='S',
                        help='bag: first sample, seconds after the first message (default: 0)')
    parser.add_argument('--end-s', type=float, metavar='S',
                        help='bag: samples before S seconds after the first message (default: '
                             'to the last message)')


def add_capture_checks(parser, other_stages):
    """Add the G-total, temperature and gravity options of a still capture's fit."""
    node_option(parser, '--g-total-tolerance-mps2', 'level_capture.g_total_tolerance_mps2',
                'largest deviation of G-total from gravity [m/s^2]')
    node_option(parser, '--max-temperature-difference-c', 'temperature.max_stage_difference_c',
                'without a temperature stage, a capture further in temperature [deg C] from '
                f'the {other_stages} is refused')
    add_gravity_option(parser)


def add_gravity_option(parser):
    """Add --gravity-mps2: the local gravity, the node's ``gravity_mps2``."""
    node_option(parser, '--gravity-mps2', 'gravity_mps2', 'local gravity [m/s^2]')


def add_sensor_argument(parser):
    """Add --sensor-id: the sensor the calibration file must belong to (and is stamped with)."""
    parser.add_argument('--sensor-id', metavar='ID',
                        help='the sensor the calibration belongs to: a file of another sensor is '
                             'refused; a new or unnamed file is stamped with it (default: none)')


def load_calibration(path, sensor_id=None, required=True, any_sensor=False):
    """
    Return the model of the calibration file ``path``: the one way a command loads one.

    CommandError for a file that cannot be used (``model.load_model``) or
    that belongs to another sensor than ``sensor_id`` (``model.check_sensor``;
    not checked with ``any_sensor``), and for a missing file when
    ``required`` (else None).
    """
    try:
        model = load_model(path)
        if not any_sensor:
            check_sensor(model, sensor_id, path)
    except FileNotFoundError:
        if required:
            raise CommandError(f'no calibration file {path}') from None
        return None
    except (CalibrationFileError, OSError) as err:
        raise CommandError(str(err)) from None
    return model


def load_existing(path, sensor_id=None, axes=3, maps=None):
    """Return the model a fit updates (``store.model_to_update``); CommandError if unusable."""
    try:
        return model_to_update(load_calibration(path, sensor_id, required=False), path,
                               sensor_id, axes, maps)
    except (CalibrationFileError, ValueError) as err:
        raise CommandError(str(err)) from None


def begin_update(args, command):
    """
    Note what ``save`` needs before the calibration file is read: its digest now, the writer.

    A file another writer replaces while the command runs is then not written
    over (``model.CalibrationChanged``).
    """
    args.writer = f'inclino {command}'
    try:
        args.calibration_sha256 = file_digest(args.calibration)
    except OSError as err:
        raise CommandError(f'cannot read {args.calibration}: {err}') from None


def save(args, model, outputs, lines=None):
    """
    Write ``model`` to ``args.calibration`` among ``outputs`` (``model.save_model``); return it.

    The toolface zero the saved model gives (``CalibrationModel.toolface_zero_lines``)
    is appended to the fit's report ``lines`` (issue 19 item 6; None: said elsewhere).

    Refused when the fitted model is one load_model would refuse (an
    implausible result) or the file changed since ``begin_update``,
    CommandError when the file cannot be written.
    """
    try:
        save_model(args.calibration, model, args.writer, outputs, args.calibration_sha256,
                   args.history_keep, history_report(args.writer))
    except ValueError as err:
        raise Refused(f'the result is not a plausible calibration: {err}') from None
    except OSError as err:
        raise CommandError(f'cannot write {args.calibration}: {err}') from None
    if lines is not None:
        lines.extend(model.toolface_zero_lines)
    return model


def report_paths(args, name):
    """Return (png, txt) paths of the report ``name`` in --report-dir or beside the file."""
    folder = args.report_dir or os.path.dirname(os.path.abspath(
        os.path.expanduser(args.calibration)))
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, f'{name}.png'), os.path.join(folder, f'{name}.txt')


def write_certificate(command, args, lines, outputs, fitted, path=None):
    """
    Write the fit's calibration certificate as one of ``outputs``; nothing if none was saved.

    ``fitted``: the ``report.common.Fitted`` the fit returned (the model it
    saved and its residual rows; None: nothing saved).  ``path``:
    ``fit_NAME_certificate.html`` beside the other reports (``report_paths``)
    unless given; the text report, written already, does not name it (what a
    fit prints is its text report).  It holds the calibration file as saved,
    the residual rows, the PNG figures among ``outputs`` and the text report
    (``io.report.certificate_html``).
    """
    if fitted is None:
        return
    if path is None:
        name = command.replace('-', '_')
        path = os.path.join(os.path.dirname(report_paths(args, name)[0]),
                            f'{name}_certificate.html')
    figures = [(os.path.basename(final), temporary)
               for final, temporary in outputs.pending('.png')]
    page = certificate_html(command, os.path.abspath(args.calibration), fitted.model.to_dict(),
                            list(fitted.residuals), figures, lines, utc_now_iso())
    write_file(path, page, outputs=outputs)


def run_fit(command, args, fit):
    """
    Run ``fit(args, lines, outputs)`` and report; return the exit code.

    ``fit`` returns what it saved (``report.common.Fitted``), appends the
    summary lines to ``lines`` (printed as they are, and written to the text
    report by the fit) and writes its report files to
    ``outputs.path(final)`` (``io.files.Outputs``), the calibration file too
    (``save``): they replace the report of the previous fit whole, never the
    input, and land together with the calibration file or not at all; the
    report is kept when the fit is refused (the refusal's report) but not
    when the command fails.  Refused and Implausible (readings no sensor gives,
    ``calibration.plausibility``) give 1; other errors propagate to ``main``.
    """
    lines = []
    begin_update(args, command)
    refusal = None
    try:
        with Outputs(inputs=[args.input, args.calibration], force=True) as outputs:
            try:
                write_certificate(command, args, lines, outputs, fit(args, lines, outputs))
            except (Refused, Implausible) as err:
                refusal = err
    except CalibrationChanged as err:  # at the commit: nothing of this command was written
        refusal, lines = f'{err}; nothing written', []
    if refusal is not None:
        if lines:
            print('\n'.join(lines))
        print(f'inclino {command}: refused: {refusal}; {args.calibration} left unchanged',
              file=sys.stderr)
        return 1
    print('\n'.join(lines))
    return 0


def write_text(path, lines):
    """Write the summary ``lines`` to the new file ``path``."""
    with open(path, 'x') as stream:
        stream.write('\n'.join(lines) + '\n')


def warn_outside_range(model, temperature_c, command):
    """Say on stderr how many temperatures lie outside a multi-temperature stand's range."""
    if temperature_c is None:
        return
    for name, stage in model.polynomial_stages:
        outside = int(np.count_nonzero(stage.outside_range(temperature_c)))
        if outside:
            print(f'{command}: warning: {outside} of {np.size(temperature_c)} temperature '
                  f"readings lie outside the {name} stage's fitted range {stage.t_min_c:g} .. "
                  f'{stage.t_max_c:g} C: K and b held at the nearer end there',
                  file=sys.stderr)
