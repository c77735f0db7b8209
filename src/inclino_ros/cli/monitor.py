"""
``inclino monitor``: a live view of the running node in the terminal.

Every ``--period-s``: the latest inclination, toolface and azimuth (``survey``),
the input rate and the accepted and dropped totals and the level and message
of each diagnostics status (``/diagnostics``), the calibration in use
(``~/calibration``) and a capture's progress or the last service answer
(``~/capture_progress``).  On a terminal the view is redrawn in place;
otherwise (a pipe, a log file) one block is printed per period.  What
``ros2 topic echo`` of those topics shows on a full ROS 2 install, in one place.
"""

import json
import math
import os
import sys
import time

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.live import (
    add_node_arguments, domain_hint, live_command, LiveSession, namespace_of, node_name)
from inclino_ros.cli.options import between

LEVELS = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}
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
        'period. Ends on Ctrl-C (exit 0) or after --count views.')
    add_node_arguments(parser)
    parser.add_argument('--period-s', type=between(0.01, 3600.0), default=1.0, metavar='S',
                        help='seconds between two views, 0.01 .. 3600 (default: %(default)s)')
    parser.add_argument('--count', type=between(1, None, int), metavar='N',
                        help='stop after N views (default: run until Ctrl-C)')
    parser.set_defaults(func=run)


class View:
    """What the monitor has heard from the node, and its rendering."""

    def __init__(self, node):
        """Start with nothing heard from ``node`` (full name)."""
        self.node = node
        self.short_name = node.rsplit('/', 1)[1]
        self.survey = None
        self.surveys_in_period = 0
        self.statuses = {}
        self.progress = None
        self.calibration = None

    def on_survey(self, msg):
        """Keep the latest survey vector."""
        self.survey = (msg.vector.x, msg.vector.y, msg.vector.z)
        self.surveys_in_period += 1

    def on_diagnostics(self, msg):
        """Keep the latest status of each of the node's diagnostics."""
        for status in msg.status:
            if status.name.startswith(f'{self.short_name}: '):
                self.statuses[status.name.split(': ', 1)[1]] = status

    def on_progress(self, msg):
        """Keep the latest capture progress or service answer."""
        self.progress = json.loads(msg.data)

    def on_calibration(self, msg):
        """Keep the calibration in use."""
        self.calibration = json.loads(msg.data)

    def lines(self, period_s, waited_s, wait_s):
        """Return the view as text lines; start a new period."""
        lines = [f'{self.node}   ROS_DOMAIN_ID={os.environ.get("ROS_DOMAIN_ID", "0")}   '
                 f'{time.strftime("%H:%M:%S")}']
        if self.survey is None:
            lines.append('angles        no survey yet'
                         + (f' -- {domain_hint()}' if waited_s >= wait_s else ''))
        else:
            incl, toolface, azimuth = self.survey
            lines.append(f'angles        inclination {incl:9.4f} deg   toolface '
                         f'{angle_text(toolface)}   azimuth {angle_text(azimuth)}'
                         + ('' if self.surveys_in_period else
                            f'   (none in the last {period_s:g} s)'))
        inputs = self.statuses.get('input')
        if inputs is not None:
            values = {kv.key: kv.value for kv in inputs.values}
            drops = ', '.join(f'{key[8:]} {value}' for key, value in values.items()
                              if key.startswith('dropped_') and key != 'dropped_total')
            lines.append(f'input         {float(values["rate_hz"]):7.1f} samples/s   accepted '
                         f'{values["accepted_total"]}   dropped {values["dropped_total"]} '
                         f'({drops})')
        if self.calibration is not None:
            stages = ', '.join(self.calibration['stages']
                               + (['magnetic'] if self.calibration['magnetic'] else []))
            lines.append(f'calibration   {stages or "none (raw angles)"}   '
                         f'{self.calibration["calibration_file"]}')
        for index, (name, status) in enumerate(sorted(self.statuses.items())):
            level = status.level[0] if isinstance(status.level, bytes) else status.level
            lines.append(f'{"diagnostics" if index == 0 else "":<14}'
                         f'{LEVELS.get(level, str(level)):<6}{name}: {status.message}')
        if self.progress is not None:
            lines.append(f'capture       {progress_text(self.progress)}')
        self.surveys_in_period = 0
        return lines


def angle_text(value_deg):
    """Return an angle for the view; NaN (undefined or not trusted) as a dash."""
    return f'{value_deg:8.3f} deg' if math.isfinite(value_deg) else '       -    '


def progress_text(doc):
    """Return a ``~/capture_progress`` message as one line."""
    if doc['state'] == 'collecting':
        needed = '' if doc['needed'] is None else f' of {doc["needed"]}'
        spread = doc.get('spread_deg')
        return (f'{doc["service"]}: collecting {doc["samples"]}{needed} samples, '
                f'{doc["time_left_s"]:.1f} s left'
                + ('' if spread is None else f', spread {spread:.4f} deg'))
    if doc['state'] == 'collected':
        return f'{doc["service"]}: {doc["samples"]} samples collected, solving'
    message = doc.get('message', '')
    state = '' if message.startswith(f'{doc["state"]}:') else f'{doc["state"]}: '
    return f'last answer of {doc["service"]}: {state}{message}'


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
                text = '\n'.join(view.lines(args.period_s, time.monotonic() - started,
                                            args.wait_s))
                print(f'{CLEAR}{text}' if redraw else f'{text}\n', flush=True)
                shown += 1
        except KeyboardInterrupt:
            print()
    return 0
