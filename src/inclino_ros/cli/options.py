"""
Checked option types of the ``inclino`` commands, and the options every writing command has.

Every number on the command line is checked where argparse reads it: finite,
positive where it is physical, within the range it may have (the node's own
range for the options that are node parameters, ``node.parameters``), so a
wrong value is a usage message (exit code 2) before any work, never a NaN or
a disabled check further on.
"""

import argparse
import math
import os

from inclino_ros.calibration.plausibility import EARTH_FIELD_NT
from inclino_ros.node.parameters import PARAMETERS, refusal

#: Formats a report figure may be written in (by the extension of its name).
REPORT_FORMATS = ('png', 'pdf', 'svg')


def _number(text, kind=float):
    """Return ``text`` as a finite number of ``kind``; ArgumentTypeError if it is not one."""
    try:
        value = kind(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(
            f'{text!r} is not {"a whole number" if kind is int else "a number"}') from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f'{text!r} is not a finite number')
    return value


def between(low, high, kind=float, why=''):
    """Return an argparse type: a finite ``kind`` within [low, high] (None: unbounded)."""
    def parse(text):
        value = _number(text, kind)
        if (low is not None and value < low) or (high is not None and value > high):
            span = (f'between {low:g} and {high:g}' if low is not None and high is not None
                    else f'at least {low:g}' if low is not None else f'at most {high:g}')
            raise argparse.ArgumentTypeError(f'{text} is not {span}{why}')
        return value
    parse.__name__ = 'whole number' if kind is int else 'number'
    return parse


#: A finite number, any sign.
finite = between(None, None)
#: A finite number >= 0.
non_negative = between(0.0, None)
#: Longest wait [s] of a live tool for a node or a subscriber: a day; beyond, a typo.
MAX_WAIT_S = 86400.0
#: A wait [s] of a live tool.
wait_s = between(0.0, MAX_WAIT_S)


def positive(text):
    """Return a finite number > 0 (argparse type)."""
    value = _number(text)
    if not value > 0.0:
        raise argparse.ArgumentTypeError(f'{text} is not positive')
    return value


def node_parameter(name):
    """Return an argparse type with the range (and type) of the node's parameter ``name``."""
    (parameter,) = (p for p in PARAMETERS if p.name == name)
    kind = int if isinstance(parameter.default, int) else float
    in_range = between(parameter.low, parameter.high, kind, f" (the range of the node's {name})")

    def parse(text):
        value = in_range(text)
        reason = refusal(name, value)   # the node's rules beyond the range, the same
        if reason:
            raise argparse.ArgumentTypeError(reason)
        return value
    parse.__name__ = in_range.__name__
    parse.parameter = name   # test_option_parity: the range is the node's
    return parse


#: A reference field total [nT]: an Earth field.
reference_total_nT = between(*EARTH_FIELD_NT, why=' nT (an Earth field)')
#: A reference dip [deg]: the node's range.
dip_deg = node_parameter('magnetic.reference_dip_deg')
#: An inclination [deg].
inclination_deg = between(0.0, 180.0)


def report_path(text):
    """Return a report figure path whose extension names a format matplotlib writes."""
    extension = os.path.splitext(text)[1].lstrip('.').lower()
    if extension not in REPORT_FORMATS:
        raise argparse.ArgumentTypeError(
            f'{text}: a report is a figure, name it .{", .".join(REPORT_FORMATS)}')
    return text


def add_force_argument(parser):
    """Add ``--force``: replace outputs that exist (never an input of the command)."""
    parser.add_argument('--force', action='store_true',
                        help='replace outputs that exist already (an input is never replaced)')


def add_reference_temperature_argument(parser):
    """Add ``--at-reference-temperature`` (``calibration.provenance.missing_temperature``)."""
    parser.add_argument('--at-reference-temperature', action='store_true',
                        help='with a calibration that compensates temperature and no '
                             'temperature in the input, compensate at its reference '
                             'temperature (warned) instead of refusing')
