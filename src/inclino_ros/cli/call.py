"""
``inclino call SERVICE``: call one of the node's services and print its answer.

What ``ros2 service call /inclinometer/<SERVICE> std_srvs/srv/Trigger`` does
on a full ROS 2 install, with a progress bar while a capture collects its
samples (from the node's ``~/capture_progress``).  ``inclino calibrate`` is
``inclino call calibrate_level``.
"""

import json
import sys
import time

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.live import (
    add_node_arguments, LiveSession, node_name, SERVICES)

#: Seconds between two checks that the node is still there while a call waits.
ALIVE_CHECK_S = 1.0


def register(subparsers):
    """Add the ``call`` subcommand."""
    listing = '\n'.join(f'  {name:<24} {meaning}' for name, meaning in SERVICES.items())
    parser = add_command(
        subparsers, 'call', "call one of the running node's services (calibrate, capture, solve)",
        'Call a service of the running inclinometer node and print its answer, as ros2 '
        'service call does on a full ROS 2 install; while a capture collects its samples a '
        'progress bar shows them (samples, time left, spread).',
        'Exit 0 when the node did it, 1 when it refused (the reason is printed; nothing was '
        'changed), 2 when no node answers within --wait-s, 130 on Ctrl-C.',
        epilog=f'services of inclinometer_node:\n{listing}')
    parser.add_argument('service', metavar='SERVICE',
                        help='one of the services below, or a full service name')
    add_node_arguments(parser)
    parser.set_defaults(func=run)


def run(args):
    """Call ``args.service`` of ``args.node``; return the exit code."""
    service = args.service
    if not service.startswith('/'):
        if service not in SERVICES:
            print(f'inclino call: error: unknown service {service!r}; the node has: '
                  f'{", ".join(SERVICES)}', file=sys.stderr)
            return 2
        service = f'{node_name(args.node)}/{service}'
    return call_service(service, args.wait_s)


def call_service(service, wait_s):
    """Call the Trigger ``service`` (full name), showing a capture's progress; exit code."""
    from std_srvs.srv import Trigger

    with LiveSession('inclino_call') as session:
        try:
            client = session.node.create_client(Trigger, service)
            if not session.spin_until(client.service_is_ready, wait_s):
                print(f'inclino call: no service {service} within {wait_s:g} s: '
                      + session.not_found('nothing answers'), file=sys.stderr)
                return 2
            with CaptureProgress(session, service) as progress:
                future = client.call_async(Trigger.Request())
                progress.start()
                while not future.done():
                    session.spin_until(future.done, ALIVE_CHECK_S)
                    if not future.done() and not client.service_is_ready():
                        print(f'inclino call: {service} went away before it answered',
                              file=sys.stderr)
                        return 2
        except KeyboardInterrupt:
            print(f'inclino call: interrupted: no answer from {service} (a capture the node '
                  'started goes on; its answer is on ~/capture_progress)', file=sys.stderr)
            return 130
        response = future.result()
        print(response.message)
        return 0 if response.success else 1


class CaptureProgress:
    """A progress bar fed by ``<node>/capture_progress`` while one call waits."""

    def __init__(self, session, service):
        """Listen to the node's progress topic for the call of ``service``."""
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from std_msgs.msg import String

        self.service = service.rsplit('/', 1)[1]
        self.started = None
        self.bar = None
        self.subscription = session.node.create_subscription(
            String, f'{service.rsplit("/", 1)[0]}/capture_progress', self._on_progress,
            QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))

    def __enter__(self):
        """Return the progress listener."""
        return self

    def __exit__(self, *exc_info):
        """Close the bar."""
        if self.bar is not None:
            self.bar.close()

    def start(self):
        """From now on, the messages of this call's capture count (older ones are not)."""
        self.started = time.monotonic()

    def _on_progress(self, msg):
        if self.started is None:
            return   # the latched message of an earlier call
        doc = json.loads(msg.data)
        if doc.get('service') != self.service or doc.get('state') != 'collecting':
            return
        from tqdm import tqdm
        counted = doc['needed'] is not None
        if self.bar is None:
            self.bar = tqdm(total=doc['needed'] if counted else doc['time_left_s'],
                            unit='sample' if counted else 's', file=sys.stderr,
                            desc=f'{self.service}: collecting',
                            bar_format=None if counted else
                            '{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s{postfix}')
        self.bar.n = doc['samples'] if counted else min(doc['elapsed_s'], self.bar.total)
        spread = doc.get('spread_deg')
        self.bar.set_postfix_str(
            f'{doc["samples"]} samples, {doc["time_left_s"]:.1f} s left'
            + ('' if spread is None else f', spread {spread:.4f} deg'))
