"""
``inclino monitor``: a live view of the running node in the terminal.

Every ``--period-s``: the latest inclination, toolface and azimuth (``survey``),
the input rate and the accepted and dropped totals and the level and message
of each diagnostics status (``/diagnostics``), the calibration in use
(``~/calibration``) and a capture's progress or the last service answer
(``~/capture_progress``).  On a terminal the view is redrawn in place;
otherwise (a pipe, a log file) one block is printed per period.  ``--count``
counts the views from the first that shows a survey (or from ``--wait-s`` on,
when none comes): started beside its input, it shows that input.  What
``ros2 topic echo`` of those topics shows on a full ROS 2 install, in one place.
"""

import sys
import time

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.live import (
    add_node_arguments, domain_hint, live_command, LiveSession, namespace_of, node_name)
from inclino_ros.cli.options import between
from inclino_ros.report.monitor import progress_text, View  # noqa: F401 (progress_text: public)

#: ANSI: cursor home, clear the screen.
CLEAR = '\x1b[H\x1b[2J'


def register(subparsers):
    """Add the ``monitor`` subcommand."""
    parser = add_command(
        subparsers, 'monitor',
        'live view of the running node: angles, rates, drops, health, captures',
        'Show the running inclinometer node live: every --period-s the latest inclination, '
        'toolface and azimuth, the input rate, the samples accepted and dropped (and why), '
        'the level and message of each diagnostics status, the calibration in use, and the '
        'progress of a capture or the last answer of a service. What ros2 topic echo of those '
        'topics shows on a full ROS 2 install, in one place.',
        'On a terminal the view is redrawn in place; otherwise one block is printed per '
        'period. Ends on Ctrl-C (exit 0) or after --count views, counted from the first one '
        'that shows a survey (or, when none comes, from --wait-s on): a monitor started '
        'with the input it is to show counts the views of that input.')
    add_node_arguments(parser)
    parser.add_argument('--period-s', type=between(0.01, 3600.0), default=1.0, metavar='S',
                        help='seconds between two views, 0.01 .. 3600 (default: %(default)s)')
    parser.add_argument('--count', type=between(1, None, int), metavar='N',
                        help='stop after N views, counted from the first that shows a survey '
                             '(from --wait-s on, when none comes; default: run until Ctrl-C)')
    parser.set_defaults(func=run)


@live_command
def run(args):
    """Show the view every period until Ctrl-C or ``--count`` views; return 0."""
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import DurabilityPolicy, qos_profile_sensor_data, QoSProfile
    from std_msgs.msg import String

    if not args.period_s > 0 or (args.count is not None and args.count < 1):
        print('inclino monitor: error: --period-s must be positive and --count at least 1',
              file=sys.stderr)
        return 2
    target = node_name(args.node)
    namespace = namespace_of(target).rstrip('/')
    view = View(target)
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    redraw = sys.stdout.isatty()
    with LiveSession('inclino_monitor') as session:
        node = session.node
        node.create_subscription(Vector3Stamped, f'{namespace}/survey', view.on_survey,
                                 qos_profile_sensor_data)
        node.create_subscription(DiagnosticArray, '/diagnostics', view.on_diagnostics, 10)
        node.create_subscription(String, f'{target}/capture_progress', view.on_progress, latched)
        node.create_subscription(String, f'{target}/calibration', view.on_calibration, latched)
        started, shown = time.monotonic(), 0
        try:
            # The node's latched calibration arrives once it is discovered: wait for it first.
            if not session.spin_until(lambda: view.calibration is not None, args.wait_s):
                print(f'inclino monitor: no {target} within {args.wait_s:g} s: '
                      + session.not_found('still listening'), file=sys.stderr)
            while args.count is None or shown < args.count:
                session.spin(args.period_s)
                waited_s = time.monotonic() - started
                text = '\n'.join(view.lines(args.period_s, waited_s, args.wait_s, domain_hint))
                print(f'{CLEAR}{text}' if redraw else f'{text}\n', flush=True)
                # Views before the input's first survey are shown, not counted (until --wait-s).
                shown += view.survey is not None or waited_s >= args.wait_s
        except KeyboardInterrupt:
            print()
    return 0
