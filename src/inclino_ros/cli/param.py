"""
``inclino param list|get|set``: the running node's parameters.

What ``ros2 param list|get|set /inclinometer ...`` does on a full ROS 2
install, through the node's standard parameter services
(``rclpy.parameter_client.AsyncParameterClient``).  ``set`` reads VALUE as
the type the parameter has (``true``/``false``, an integer, a number, text),
and the node checks it against its declared range and choices.
"""

import re
import sys
import time

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.live import add_node_arguments, live_command, LiveSession, node_name
from inclino_ros.node.parameters import format_value, parse_value

#: A negative number in any of Python's float spellings (argparse's own misses -1e-3, -inf).
NEGATIVE_NUMBER = re.compile(r'^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$',
                             re.IGNORECASE)
#: Seconds to wait for an answer of the parameter services once they are up (a read-only
#: request is sent again meanwhile, ``LiveSession.answer``; a set is sent once).
ANSWER_TIMEOUT_S = 10.0


def register(subparsers):
    """Add the ``param`` subcommand and its ``list``, ``get``, ``set``."""
    parser = add_command(
        subparsers, 'param', "list, read or change the running node's parameters",
        'List, read or change the parameters of the running inclinometer node, as ros2 param '
        'does on a full ROS 2 install (the table of doc/node-interfaces.md says what each '
        'means; "live" ones may be changed while it runs).',
        'Exit 0 on success, 1 when the node refused a value (the reason is printed), 2 when '
        'no node answers within --wait-s or it has no such parameter.')
    actions = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    listing = actions.add_parser('list', help='every parameter with its value',
                                 description='Print every parameter as "name: value", '
                                             'read-only ones marked.')
    get = actions.add_parser('get', help='print the value of one parameter',
                             description='Print the value of one parameter.')
    get.add_argument('name', metavar='NAME', help='parameter name, e.g. level_capture.samples')
    change = actions.add_parser(
        'set', help='change one parameter', description='Change one parameter of the running '
                                                        'node; it checks range and choices.')
    change.add_argument('name', metavar='NAME', help='parameter name, e.g. stand.toolface_deg')
    change.add_argument('value', metavar='VALUE',
                        help='new value, read as the type of the parameter (a negative number '
                             'such as -1e-3 is a value, not an option)')
    # argparse takes only -1 and -1.5 for negative numbers: -1e-3 would be an unknown option.
    change._negative_number_matcher = NEGATIVE_NUMBER
    for sub in (listing, get, change):
        add_node_arguments(sub)
        sub.set_defaults(func=run)


@live_command
def run(args):
    """Run ``param list|get|set``; return the exit code."""
    from rclpy.parameter_client import AsyncParameterClient

    target = node_name(args.node)
    with LiveSession('inclino_param') as session:
        try:
            client = AsyncParameterClient(session.node, target)
            if not session.spin_until(client.services_are_ready, args.wait_s):
                print(f'inclino param: no parameter services of {target} within '
                      f'{args.wait_s:g} s: ' + session.not_found('the node does not answer'),
                      file=sys.stderr)
                return 2
            session.wait_heard_by(target, args.wait_s)
            return ACTIONS[args.action](session, client, args)
        except KeyboardInterrupt:
            print('inclino param: interrupted', file=sys.stderr)
            return 130
        except (NoSuchParameter, TimeoutError) as err:
            print(f'inclino param: {err}', file=sys.stderr)
            return 2


def answer(session, send, read_only=True):
    """
    Send the request ``send`` makes; return the reply (TimeoutError if none comes in time).

    A ``read_only`` one (list, get, describe) is sent again while no answer
    comes; a set is sent once: no answer says it may or may not be set.
    """
    end = time.monotonic() + ANSWER_TIMEOUT_S
    future, sent = session.answer(send, lambda: end, resend=read_only)
    if future is None:
        raise TimeoutError(
            f'no answer from the parameter services within {ANSWER_TIMEOUT_S:g} s ('
            + (f'{sent} read-only requests sent)' if read_only else
               'the value may or may not have been set: check with inclino param get)'))
    return future.result()


def values(session, client, names):
    """Return ``{name: python value}``; a name the node does not have is missing."""
    from rcl_interfaces.msg import ParameterType
    from rclpy.parameter import parameter_value_to_python

    result = answer(session, lambda: client.get_parameters(names))
    return {name: parameter_value_to_python(value) for name, value in zip(names, result.values)
            if value.type != ParameterType.PARAMETER_NOT_SET}


def list_parameters(session, client, args):
    """Print ``name: value`` of every parameter, read-only ones marked."""
    names = sorted(answer(session, client.list_parameters).result.names)
    current = values(session, client, names)
    descriptors = answer(session, lambda: client.describe_parameters(names)).descriptors
    for name, descriptor in zip(names, descriptors):
        if name in current:
            print(f'{name}: {format_value(current[name])}'
                  + ('  (read-only)' if descriptor.read_only else ''))
    return 0


class NoSuchParameter(Exception):
    """The node has no parameter of that name."""


def value_of(session, client, args):
    """Return the current value of parameter ``args.name``; NoSuchParameter if none."""
    current = values(session, client, [args.name])
    if args.name not in current:
        raise NoSuchParameter(f'{node_name(args.node)} has no parameter {args.name!r} '
                              '(inclino param list shows them)')
    return current[args.name]


def get_parameter(session, client, args):
    """Print the value of one parameter."""
    print(format_value(value_of(session, client, args)))
    return 0


def set_parameter(session, client, args):
    """Set one parameter, VALUE read as its current type; print what the node said."""
    from rclpy.parameter import Parameter

    current = value_of(session, client, args)
    try:
        value = parse_value(args.value, current)
    except ValueError as err:
        print(f'inclino param: {args.name}: {err}', file=sys.stderr)
        return 2
    (result,) = answer(session, lambda: client.set_parameters(
        [Parameter(args.name, value=value)]), read_only=False).results
    if not result.successful:
        print(f'inclino param: {args.name} not set: {result.reason}', file=sys.stderr)
        return 1
    print(f'{args.name}: {format_value(value)}')
    return 0


ACTIONS = {'list': list_parameters, 'get': get_parameter, 'set': set_parameter}
