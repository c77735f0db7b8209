"""
``inclino play``: publish the sensor topics of a bag with their original timing.

What ``ros2 bag play`` does on a full ROS 2 install, for machines that have
rclpy from PyPI but no rosbag2.  Every topic of sensor_msgs/Imu,
sensor_msgs/MagneticField and sensor_msgs/Temperature (or those named with
``--topics``) is published as recorded, stamps and all, in the order of the
header stamps and paced by them (scaled by ``--rate``); ``--start-s`` and
``--end-s`` pick a window, ``--loop`` plays it again and again.  Play starts
once each subscribing node has heard it (``wait_heard``).  A progress
bar shows what went out; Ctrl-C or SIGTERM stops it cleanly ("published N of
M messages"), exit 0.
"""

import sys
import time

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.live import live_command, LiveSession
from inclino_ros.cli.options import between, MAX_WAIT_S, non_negative, positive, wait_s
from inclino_ros.io.bag import BagError
from inclino_ros.io.timing import load_timeline
from inclino_ros.node.playback import message_class, publish_timed

#: Seconds, after the first topic is matched, to wait for the others' subscribers.
MATCH_GRACE_S = 1.0


def register(subparsers):
    """Add the ``play`` subcommand."""
    parser = add_command(
        subparsers, 'play',
        'publish the sensor topics of a bag with their timing (ros2 bag play)',
        'Publish a recorded bag to the running node as ros2 bag play does on a full ROS 2 '
        'install: every sensor_msgs/Imu, MagneticField and Temperature topic (or those of '
        '--topics), messages as recorded, stamps and all, in the order and at the pace of '
        'their stamps (times --rate).',
        '--start-s and --end-s pick a window (seconds after the first message), --loop plays '
        'it again and again. The first message goes once every subscribing node has heard '
        'play (its ~/list_parameters answers), so a node just started loses none. A '
        'progress bar shows what went out. Ctrl-C, or SIGTERM (kill), '
        'stops it cleanly and says how far it got (exit 0). Exit 2 when nobody subscribes '
        'within --wait-s.')
    parser.add_argument('bag', metavar='BAG', help='bag folder (mcap or sqlite3)')
    parser.add_argument('--topics', nargs='+', metavar='TOPIC',
                        help='topics to publish (default: every Imu, MagneticField and '
                             'Temperature topic of the bag)')
    parser.add_argument('--rate', type=between(1e-3, 1e6), default=1.0,
                        help='speed factor, 0.001 .. 1e6: 2 plays twice as fast (default: '
                             '%(default)s)')
    parser.add_argument('--start-s', type=non_negative, default=0.0, metavar='S',
                        help='start S seconds after the first message (default: 0)')
    parser.add_argument('--end-s', type=positive, metavar='S',
                        help='stop before S seconds after the first message (default: at the '
                             'end)')
    parser.add_argument('--loop', action='store_true',
                        help='play the bag (or the window) again and again until Ctrl-C')
    parser.add_argument('--best-effort', action='store_true',
                        help='publish best-effort instead of reliable')
    parser.add_argument('--wait-s', type=wait_s, default=10.0, metavar='S',
                        help='seconds to wait for a subscriber before playing, at most '
                             f'{MAX_WAIT_S:g} (default: %(default)s)')
    parser.set_defaults(func=run)


def wait_for_subscribers(session, publishers, wait_s):
    """Wait for subscribers (all topics, or MATCH_GRACE_S after the first); return the unheard."""
    end = time.monotonic() + wait_s
    first = None
    while time.monotonic() < end:
        heard = {t for t, p in publishers.items() if p.get_subscription_count()}
        if len(heard) == len(publishers):
            return []
        if heard and first is None:
            first = time.monotonic()
        if first is not None and time.monotonic() - first >= MATCH_GRACE_S:
            break
        session.spin(0.05)
    return sorted(t for t, p in publishers.items() if not p.get_subscription_count())


def wait_heard(session, publishers, wait_s):
    """
    Wait until every node subscribing has matched the publishers; return those unconfirmed.

    Matching is seen by each side on its own: a publisher may know a
    subscription before the subscription knows it, and a best-effort
    subscription (the node's, sensor data) drops what comes from a publisher
    it does not know yet: a play started with the node lost its first 18 of
    200 messages in 2 of 14 runs on a loaded host.  So each subscribing node
    (once the graph names it) answers ``~/list_parameters`` first
    (``LiveSession.wait_heard_by``); one without parameter services (the
    ros2 CLI's) is not waited for beyond MATCH_GRACE_S.
    """
    end = time.monotonic() + wait_s
    matched = sum(p.get_subscription_count() for p in publishers.values())

    def listed():
        return [info for topic in publishers
                for info in session.node.get_subscriptions_info_by_topic(topic)]

    session.spin_until(lambda: len(listed()) >= matched, wait_s)
    nodes = {f'{info.node_namespace.rstrip("/")}/{info.node_name}' for info in listed()}
    return sorted(name for name in nodes if not session.wait_heard_by(
        name, max(end - time.monotonic(), 0.0), ready_s=MATCH_GRACE_S))


@live_command
def run(args):
    """Replay the bag; exit 0 when played (or stopped by the user), 2 when it cannot be."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from tqdm import tqdm

    if not args.rate > 0:
        print('inclino play: error: --rate must be positive', file=sys.stderr)
        return 2
    try:
        timeline = load_timeline(args.bag, args.topics).window(args.start_s, args.end_s)
    except BagError as err:
        print(f'inclino play: error: {err}', file=sys.stderr)
        return 2
    if not len(timeline):
        print(f'inclino play: error: no message between {args.start_s} and {args.end_s} s',
              file=sys.stderr)
        return 2
    qos = QoSProfile(depth=1000)
    if args.best_effort:
        qos.reliability = ReliabilityPolicy.BEST_EFFORT
    names = ', '.join(topic for topic, _, _ in timeline.topics)
    done = {'count': 0, 'passes': 0}
    with LiveSession('inclino_play') as session:
        publishers = {topic: session.node.create_publisher(message_class(msgtype), topic, qos)
                      for topic, msgtype, _ in timeline.topics}
        try:
            unheard = wait_for_subscribers(session, publishers, args.wait_s)
            if len(unheard) == len(publishers):
                print(f'inclino play: nobody subscribes to {names} within {args.wait_s:g} s: '
                      + session.not_found('no subscriber'), file=sys.stderr)
                return 2
            if unheard:
                print(f'inclino play: note: nobody subscribes to {", ".join(unheard)}',
                      file=sys.stderr)
            unconfirmed = wait_heard(session, publishers, args.wait_s)
            if unconfirmed:
                print(f'inclino play: note: {", ".join(unconfirmed)} did not confirm it hears '
                      'play: its first messages may be lost', file=sys.stderr)
            span_s = (timeline.stamps_ns[-1] - timeline.stamps_ns[0]) * 1e-9 / args.rate
            print(f'playing {len(timeline)} messages of {names} ({span_s:.1f} s'
                  f'{", looped" if args.loop else ""})', file=sys.stderr)
            started = time.monotonic()
            while True:
                with tqdm(total=len(timeline), unit='msg', file=sys.stderr,
                          desc=f'inclino play (pass {done["passes"] + 1})' if args.loop
                          else 'inclino play') as bar:
                    done['count'] = 0
                    publish_timed(timeline, publishers, args.rate,
                                  lambda seconds: session.spin(min(seconds, 0.01)),
                                  lambda n: (done.update(count=n), bar.update()))
                done['passes'] += 1
                if not args.loop:
                    break
        except KeyboardInterrupt:
            print(f'\ninclino play: stopped: published {done["count"]} of {len(timeline)} '
                  f'messages' + (f' of pass {done["passes"] + 1}' if args.loop else ''),
                  file=sys.stderr)
            return 0
        session.spin(0.2)   # let the last messages leave before the node is destroyed
    print(f'published {len(timeline)} messages on {names} in '
          f'{time.monotonic() - started:.2f} s')
    return 0
