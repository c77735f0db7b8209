"""
``inclino call SERVICE``: call one of the node's services and print its answer.

What ``ros2 service call /inclinometer/<SERVICE> std_srvs/srv/Trigger`` does
on a full ROS 2 install, with a progress bar while a capture collects its
samples (from the node's ``~/capture_progress``).  ``inclino calibrate`` is
``inclino call calibrate_level``.
"""

import json
import math
import sys
import time

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.live import (
    add_node_arguments, live_command, LiveSession, node_name, SERVICES, TEARDOWN_S)

#: Services whose request is sent again when no answer comes: doing one twice is doing it
#: once (each forgets what the node holds).  Every other one captures, stores a station or
#: changes the calibration: it is sent once, and an answer that never came is said as such.
RESENDABLE = ('clear_positions', 'clear_surveys')
#: Exit code of a call whose answer never came (the node may or may not have done it).
NO_ANSWER = 3


def register(subparsers):
    """Add the ``call`` subcommand."""
    listing = '\n'.join(f'  {name:<24} {meaning}' for name, meaning in SERVICES.items())
    parser = add_command(
        subparsers, 'call', "call one of the running node's services (calibrate, capture, solve)",
        'Call a service of the running inclinometer node and print its answer, as ros2 '
        'service call does on a full ROS 2 install; while a capture collects its samples a '
        'progress bar shows them (samples, time left, spread).',
        'Exit 0 when the node did it, 1 when it refused (the reason is printed; nothing was '
        'changed), 2 when no node answers within --wait-s, '
        f'{NO_ANSWER} when the request was sent but no answer came within --wait-s of it or of '
        "its capture's last progress (it may or may not have been done: inclino monitor shows "
        'the last answer of each service), 130 on Ctrl-C. Every call ends: at most --wait-s '
        'for the service, --wait-s for the node to have discovered the caller, --wait-s for the '
        f'answer after the last progress, {TEARDOWN_S} s to close. '
        f'{" and ".join(RESENDABLE)} are sent again while no answer comes (doing them twice is '
        'doing them once); no other service is.',
        epilog=f'services of inclinometer_node:\n{listing}')
    parser.add_argument('service', metavar='SERVICE',
                        help='one of the services below, or a full service name')
    add_node_arguments(parser)
    parser.set_defaults(func=run)


@live_command
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
    """
    Call the Trigger ``service`` (full name), showing a capture's progress; exit code.

    Bounded: at most ``wait_s`` for the service, ``wait_s`` for the node to
    have discovered this caller (``LiveSession.wait_heard_by``; sent anyway
    after that), then ``wait_s`` for the answer after the request or the
    last progress of its capture; a resendable service is sent again
    meanwhile, no other one.
    """
    from std_srvs.srv import Trigger

    target, name = service.rsplit('/', 1)
    with LiveSession('inclino_call') as session:
        try:
            client = session.node.create_client(Trigger, service)
            if not session.spin_until(client.service_is_ready, wait_s):
                print(f'inclino call: no service {service} within {wait_s:g} s: '
                      + session.not_found('nothing answers'), file=sys.stderr)
                return 2
            if name in SERVICES:   # an inclinometer node's: wait until it has matched us
                session.wait_heard_by(target, wait_s)
            with CaptureProgress(session, service) as progress:
                progress.start()

                def deadline():   # wait_s after the request, or after the capture's last sign
                    return max(progress.started, progress.heard) + wait_s

                def alive():
                    if not client.service_is_ready():
                        raise _Gone
                answered, sent = session.answer(
                    lambda: client.call_async(Trigger.Request()), deadline,
                    resend=name in RESENDABLE, check=alive)
        except KeyboardInterrupt:
            print(f'inclino call: interrupted: no answer from {service} (a capture the node '
                  'started goes on; its answer is on ~/capture_progress)', file=sys.stderr)
            return 130
        except _Gone:
            print(f'inclino call: {service} went away before it answered', file=sys.stderr)
            return 2
        if answered is None:
            sent = f'{sent} requests' if sent > 1 else 'the request'
            print(f'inclino call: no answer from {target} within {wait_s:g} s ({sent} sent to '
                  f'{name}): the request may or may not have been applied; check with '
                  f"'inclino monitor --node {target} --count 1' (the node's last answer of each "
                  'service)', file=sys.stderr)
            return NO_ANSWER
        response = answered.result()
        print(response.message)
        return 0 if response.success else 1


class _Gone(Exception):
    """The service went away while a call waited for its answer."""


class CaptureProgress:
    """A progress bar fed by ``<node>/capture_progress`` while one call waits."""

    def __init__(self, session, service):
        """Listen to the node's progress topic for the call of ``service``."""
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from std_msgs.msg import String

        self.service = service.rsplit('/', 1)[1]
        self.started = None
        self.heard = -math.inf   # when this call's capture last showed progress
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
        self.heard = time.monotonic()
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
