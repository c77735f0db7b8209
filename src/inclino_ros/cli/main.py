"""
``inclino``: the command line of inclino_ros, one subcommand per module.

Each module in ``inclino_ros.cli`` named in COMMANDS (a dash in the command is an
underscore in the module name) has ``register(subparsers)`` adding its parser (with
``func`` set to its ``run(args)`` returning an exit code).

Errors are messages, never tracebacks, in one place (``main``): an input,
option or output that cannot be used (``CommandError``, a bag, table or
output error, an OSError such as a full or read-only disk) is one line
``inclino CMD: error: ...`` and exit code 2; anything unexpected is one
line and exit code 1 (``--debug`` shows its traceback); Ctrl-C stops the
command with exit code 130, what it did so far said, and no output left
half-written (``io.files.Outputs``); a reader that closes the pipe (``| head``)
ends it quietly with 141, as SIGPIPE ends other tools.  A file name that is
not UTF-8 is printed as its bytes are (as ``ls`` does).
"""

import argparse
import importlib
import os
import sys

from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.mounting import attach_map_values
from inclino_ros.io.bag import BagError
from inclino_ros.io.files import OutputError
from inclino_ros.io.tables import TableError

COMMANDS = ('simulate', 'process', 'compare', 'play', 'calibrate', 'call', 'param', 'monitor',
            'demo', 'fit-level', 'fit-stand', 'fit-temperature', 'msa', 'simulate-well',
            'fit-rotation', 'fit-magnetometer', 'survey', 'calibration', 'fit-toolface-mark')
#: Errors of an input, option or output that cannot be used: exit code 2.
USAGE_ERRORS = (CommandError, BagError, OutputError, TableError, OSError)
#: Exit code of a command stopped by Ctrl-C (128 + SIGINT, as a shell reports it).
INTERRUPTED = 130
#: Exit code of a command whose reader closed the pipe (128 + SIGPIPE, as for any tool).
BROKEN_PIPE = 141


def _top_parser():
    """Return the ``inclino`` parser without subcommands, and its subparsers."""
    parser = argparse.ArgumentParser(
        prog='inclino',
        description='Inclinometer correction tools of inclino_ros (no ros2 CLI needed).')
    parser.add_argument('--version', action='version', version=f'inclino {version()}')
    parser.add_argument('--debug', action='store_true',
                        help='show the traceback of an unexpected error')
    return parser, parser.add_subparsers(dest='command', required=True)


def build_parser():
    """Return the ``inclino`` argument parser with every subcommand."""
    parser, subparsers = _top_parser()
    for name in COMMANDS:
        module = name.replace('-', '_')
        importlib.import_module(f'inclino_ros.cli.{module}').register(subparsers)
    return parser


def build_command_parser(argv):
    """
    Return the parser of the subcommand ``argv`` names (only its module imported), else all.

    Loading every subcommand's module costs more than a quick command's work.
    """
    named = [word for word in argv if word != '--debug'][:1]
    if named and named[0] in COMMANDS:
        parser, subparsers = _top_parser()
        importlib.import_module(f'inclino_ros.cli.{named[0].replace("-", "_")}').register(
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
    """Run one subcommand; return its exit code (2 unusable input, 1 unexpected, 130 Ctrl-C)."""
    argv = attach_map_values(sys.argv[1:] if argv is None else list(argv))
    for stream in (sys.stdout, sys.stderr):   # a file name that is not UTF-8 prints as is
        if hasattr(stream, 'reconfigure'):
            stream.reconfigure(errors='surrogateescape')
    try:
        args = build_command_parser(argv).parse_args(argv)
    except SystemExit as done:  # --help, or a usage error argparse has printed
        return done.code
    command = f'inclino {args.command}'
    try:
        return args.func(args)
    except BrokenPipeError:   # the reader left (inclino param list | head): no error
        try:   # nor one when Python flushes stdout at exit
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):   # stdout is no file (a test's buffer)
            pass
        return BROKEN_PIPE
    except KeyboardInterrupt as err:
        done = f' {err}' if str(err) else ''
        print(f'{command}: interrupted (Ctrl-C){done}; outputs not completed were removed, '
              'files already written are whole', file=sys.stderr)
        return INTERRUPTED
    except USAGE_ERRORS as err:
        if args.debug:
            raise
        print(f'{command}: error: {err}', file=sys.stderr)
        return 2
    except Exception as err:  # the last resort: a message, not a traceback
        if args.debug:
            raise
        print(f'{command}: error: unexpected {type(err).__name__}: {err} (inclino --debug '
              f'{args.command} ... shows where)', file=sys.stderr)
        return 1


if __name__ == '__main__':
    sys.exit(main())
