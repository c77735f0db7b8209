"""
What the live commands (``play``, ``calibrate``, ``call``, ``param``, ``monitor``) share.

The ``--node`` and ``--wait-s`` options, node names, the node's services;
each command's rclpy node is a LiveSession (``node.session``: Ctrl-C and
SIGTERM end it cleanly, never with a traceback, its teardown never hangs).
"""

import argparse
import re

from inclino_ros.cli.options import MAX_WAIT_S, wait_s
from inclino_ros.node.session import (  # noqa: F401 (public here too)
    domain_hint, live_command, LiveSession, node_name, TEARDOWN_S)

DEFAULT_NODE = '/inclinometer'
#: Seconds a command waits for the node (its service, its subscription) by default.
DEFAULT_WAIT_S = 10.0
#: The Trigger services of inclinometer_node, what each does, in the user's words.
SERVICES = {
    'calibrate_level': 'tool on a levelled bench: measure the mounting error (gamma, beta)',
    'capture_position': 'tool on the stand at the attitude set in stand.*: one position',
    'solve_stand_calibration': 'fit the stand calibration K, b to the positions captured',
    'clear_positions': 'forget the stand positions captured',
    'capture_high_side_mark': 'tool still on a tilted bench, high-side mark up: tie the '
                              'toolface zero',
    'capture_rotation': 'record the tool turning about its axis: magnetometer hard/soft iron',
    'take_survey': 'average a still station and store it for the multi-station analysis',
    'solve_msa': 'multi-station analysis of the stored stations: the drill-string field',
    'clear_surveys': 'forget the stored stations',
}


def add_node_arguments(parser, wait=True):
    """Add ``--node`` (and ``--wait-s``)."""
    parser.add_argument('--node', default=DEFAULT_NODE, type=checked_node_name,
                        help='full name of the inclinometer node (default: %(default)s)')
    if wait:
        parser.add_argument('--wait-s', type=wait_s, default=DEFAULT_WAIT_S, metavar='S',
                            help='seconds to wait for the node before giving up, at most '
                                 f'{MAX_WAIT_S:g} (default: %(default)s)')


#: A full node name (ROS 2 naming rules: tokens of letters, digits and underscores, not
#: starting with a digit, separated by single slashes).
_NODE_NAME = re.compile(r'^(/[A-Za-z_][A-Za-z0-9_]*)+$')


def checked_node_name(text):
    """Return ``--node`` as a full node name (argparse type); an error names the rule broken."""
    name = node_name(text)
    if not _NODE_NAME.match(name):
        raise argparse.ArgumentTypeError(
            f'{text!r} is no ROS node name: letters, digits and underscores, not starting with '
            'a digit, namespaces separated by /')
    return name


def namespace_of(name):
    """Return the namespace of a full node name (where its public topics live)."""
    return node_name(name).rsplit('/', 1)[0] or '/'
