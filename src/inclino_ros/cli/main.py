"""
``inclino``: the command line of inclino_ros, one subcommand per module.

Each module in ``inclino_ros.cli`` named in COMMANDS (a dash in the command is an
underscore in the module name) has ``register(subparsers)`` adding its parser (with
``func`` set to its ``run(args)`` returning an exit code).
"""

import argparse
import importlib
import sys

from inclino_ros.cli.mounting import attach_map_values

COMMANDS = ('simulate', 'process', 'compare', 'play', 'calibrate', 'call', 'param', 'monitor',
            'demo', 'fit-level', 'fit-stand', 'fit-temperature', 'msa', 'simulate-well',
            'fit-rotation', 'fit-magnetometer', 'survey')


def build_parser():
    """Return the ``inclino`` argument parser with every subcommand."""
    parser = argparse.ArgumentParser(
        prog='inclino',
        description='Inclinometer correction tools of inclino_ros (no ros2 CLI needed).')
    parser.add_argument('--version', action='version', version=f'inclino {version()}')
    subparsers = parser.add_subparsers(dest='command', required=True)
    for name in COMMANDS:
        module = name.replace('-', '_')
        importlib.import_module(f'inclino_ros.cli.{module}').register(subparsers)
    return parser


def build_command_parser(argv):
    """
    Return the parser of the subcommand ``argv`` names (only its module imported), else all.

    Loading every subcommand's module costs more than a quick command's work.
    """
    if argv and argv[0] in COMMANDS:
        parser = argparse.ArgumentParser(prog='inclino')
        subparsers = parser.add_subparsers(dest='command', required=True)
        importlib.import_module(f'inclino_ros.cli.{argv[0].replace("-", "_")}').register(
            subparsers)
        return parser
    return build_parser()


def version():
    """Return the installed version of inclino_ros."""
    from importlib.metadata import PackageNotFoundError, version as installed
    try:
        return installed('inclino_ros')
    except PackageNotFoundError:
        return 'unknown (not installed)'


def main(argv=None):
    """Run one subcommand; return its exit code."""
    argv = attach_map_values(sys.argv[1:] if argv is None else argv)
    args = build_command_parser(argv).parse_args(argv)
    return args.func(args)


if __name__ == '__main__':
    sys.exit(main())
