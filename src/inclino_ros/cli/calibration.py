"""
``inclino calibration``: the versions of a calibration file (``calibration.history``).

- ``history FILE``: every version kept, oldest first, with its stages, age,
  writer, sensor and digest; whether the file on disk is the newest one; a
  damaged version is named (the others are listed, exit 0).
- ``restore FILE N``: writes version N back into FILE through
  ``model.save_model`` (the one door: the version replaced is kept, the
  restore is itself a new version).
- ``diff A B``: A and B are files or versions (``FILE@N``): the stages added,
  removed and changed (field by field), then what the change does to the
  corrected angles: the same raw readings of a few attitudes corrected by
  each model through ``pipeline.run``.

Exit codes: 0 done, 1 refused (restore over a file that changed meanwhile),
2 a file or version that cannot be used.
"""

import sys

from inclino_ros.calibration.history import file_digest
from inclino_ros.calibration.model import (
    age_seconds, CalibrationChanged, model_from_dict, read_model_history, save_model)
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import add_history_option, history_report, load_calibration
from inclino_ros.cli.helptext import add_command
from inclino_ros.io.files import loads_strict
from inclino_ros.report.diff import ALL_STAGES, angle_changes, stage_changes


def register(subparsers):
    """Add the ``calibration`` subcommand and its ``history``, ``restore`` and ``diff``."""
    parser = add_command(
        subparsers, 'calibration', 'versions of a calibration file: history, restore, diff',
        "Every write of a calibration file (the node's services, every inclino fit-*, inclino "
        'msa, a restore) keeps the new version in the history beside it, FILE.history: no '
        'calibration is ever lost. history lists the versions, restore brings one back (the '
        'file it replaces is kept too), diff shows what changed between two versions, stage by '
        'stage, and how much the corrected inclination and toolface move at a few attitudes.',
        'A damaged version in the history is named and skipped; it never stops the node from '
        'loading the file. Exit 0 done, 1 refused (the file changed during a restore), 2 a '
        'file or version that cannot be used.')
    actions = parser.add_subparsers(dest='action', required=True)
    history = actions.add_parser('history', help='list the versions of FILE')
    history.add_argument('file', metavar='FILE', help='calibration file')
    history.set_defaults(func=run_history)
    restore = actions.add_parser('restore', help='write version N of FILE back into FILE')
    restore.add_argument('file', metavar='FILE', help='calibration file')
    restore.add_argument('number', metavar='N', type=int, help='version number (see history)')
    add_history_option(restore)
    restore.set_defaults(func=run_restore)
    diff = actions.add_parser('diff', help='what changed between two calibrations')
    for name in ('a', 'b'):
        diff.add_argument(name, metavar=name.upper(),
                          help='a calibration file, or FILE@N: version N of its history')
    diff.set_defaults(func=run_diff)


def _version(path, number):
    """Return version ``number`` of ``path``'s history; CommandError if it is not there whole."""
    versions, problems = read_model_history(path)
    for version in versions:
        if version.number == number:
            return version
    damaged = [p for p in problems if p.startswith(f'version {number} ')]
    raise CommandError(damaged[0] if damaged else
                       f'{path} has no version {number} (its history holds '
                       f'{", ".join(str(v.number) for v in versions) or "none"})')


def _model_of_text(text, where):
    """Return the model of a version's text; CommandError if it is not one."""
    try:
        return model_from_dict(loads_strict(text))
    except (KeyError, TypeError, ValueError, OverflowError, RecursionError) as err:
        raise CommandError(f'{where} is not a valid calibration: {err}') from None


def _load(spec):
    """Return (model, label) of ``FILE`` or ``FILE@N``; CommandError if unusable."""
    path, _, number = spec.rpartition('@')
    if path and number.isdigit():
        version = _version(path, int(number))
        return _model_of_text(version.text, spec), f'{spec} ({version.written_at})'
    return load_calibration(spec, any_sensor=True), spec


def _stages(model):
    return [name for name in ALL_STAGES if getattr(model, name) is not None]


def run_history(args):
    """List the versions of ``args.file``; return the exit code."""
    versions, problems = read_model_history(args.file)
    try:
        current = file_digest(args.file)
    except OSError as err:
        raise CommandError(f'cannot read {args.file}: {err}') from None
    lines = [f'{args.file}: {len(versions)} versions kept in its history']
    for version in versions:
        model = _model_of_text(version.text, f'version {version.number}')
        age_days = age_seconds(version.written_at) / 86400.0
        marker = '  <- the file now' if version.sha256 == current else ''
        lines.append(
            f'{version.number:4d}  {version.written_at}  ({age_days:.2f} days ago)  '
            f'by {version.writer}  sensor {version.sensor_id}  sha256 {version.sha256[:16]}  '
            f'stages: {", ".join(_stages(model)) or "none"}{marker}')
    if current is None:
        lines.append(f'{args.file} does not exist now')
    elif not any(v.sha256 == current for v in versions[-1:]):
        lines.append(f'{args.file} now (sha256 {current[:16]}) is not the newest version: '
                     'changed outside inclino_ros; kept in the history at its next write')
    print('\n'.join(lines))
    for problem in problems:
        print(f'inclino calibration history: damaged: {problem}', file=sys.stderr)
    return 0


def run_restore(args):
    """Write version ``args.number`` back into ``args.file``; return the exit code."""
    try:
        based_on = file_digest(args.file)
    except OSError as err:
        raise CommandError(f'cannot read {args.file}: {err}') from None
    version = _version(args.file, args.number)
    model = _model_of_text(version.text, f'version {args.number}')
    try:
        save_model(args.file, model, f'inclino calibration restore {args.number}',
                   based_on=based_on, history_keep=args.history_keep,
                   report=history_report('inclino calibration restore'))
    except CalibrationChanged as err:
        print(f'inclino calibration restore: refused: {err}; nothing written', file=sys.stderr)
        return 1
    print(f'restored version {args.number} (written {version.written_at} by {version.writer}; '
          f'stages: {", ".join(_stages(model)) or "none"}) into {args.file}; the version it '
          'replaced is kept in the history')
    return 0


def run_diff(args):
    """Print what changed from ``args.a`` to ``args.b``; return the exit code."""
    (model_a, label_a), (model_b, label_b) = _load(args.a), _load(args.b)
    print('\n'.join([f'A: {label_a}', f'B: {label_b}'] + stage_changes(model_a, model_b)
                    + angle_changes(model_a, model_b)))
    return 0
