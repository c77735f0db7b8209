"""
``inclino play``: publish a bag's Imu messages with their original timing.

What ``ros2 bag play`` does on a full ROS 2 install, for machines that have
rclpy from PyPI but no rosbag2.  Messages are published as recorded (stamps
and all), paced by their header stamps, scaled by ``--rate``.
"""

import time

from inclino_ros.io.bag import read


def register(subparsers):
    """Add the ``play`` subcommand."""
    parser = subparsers.add_parser(
        'play', help='publish the sensor_msgs/Imu of a bag with its original timing')
    parser.add_argument('bag', help='bag folder or file (mcap or sqlite3)')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='speed factor of the replay (default: %(default)s)')
    parser.add_argument('--topic', default='/imu/data_raw',
                        help='topic to read and publish (default: %(default)s)')
    parser.add_argument('--best-effort', action='store_true',
                        help='publish best-effort instead of reliable')
    parser.add_argument('--wait-s', type=float, default=10.0,
                        help='seconds to wait for a subscriber before playing '
                             '(default: %(default)s)')
    parser.set_defaults(func=run)


def imu_messages(series):
    """Yield ``(stamp_ns, sensor_msgs.msg.Imu)`` for every message of an ImuSeries."""
    from sensor_msgs.msg import Imu
    for i, stamp_ns in enumerate(series.stamps_ns.tolist()):
        msg = Imu()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        msg.header.frame_id = str(series.frame_ids[i])
        o = series.orientation_xyzw[i]
        msg.orientation.x, msg.orientation.y = float(o[0]), float(o[1])
        msg.orientation.z, msg.orientation.w = float(o[2]), float(o[3])
        v = series.angular_velocity_radps[i]
        msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = map(float, v)
        a = series.linear_acceleration_mps2[i]
        msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = \
            map(float, a)
        msg.orientation_covariance = series.orientation_covariance[i]
        msg.angular_velocity_covariance = series.angular_velocity_covariance[i]
        msg.linear_acceleration_covariance = series.linear_acceleration_covariance[i]
        yield stamp_ns, msg


def publish_timed(publisher, chunks, rate, idle):
    """
    Publish the messages of ``chunks`` (ImuSeries) paced by their stamps.

    ``idle(seconds)`` is called while waiting for the next message's time
    (e.g. an executor's ``spin_once``).  Returns the number published.
    """
    start = first_stamp_ns = None
    count = 0
    for series in chunks:
        for stamp_ns, msg in imu_messages(series):
            if start is None:
                start, first_stamp_ns = time.monotonic(), stamp_ns
            due = start + (stamp_ns - first_stamp_ns) * 1e-9 / rate
            while (wait := due - time.monotonic()) > 0:
                idle(wait)
            publisher.publish(msg)
            count += 1
    return count


def run(args):
    """Replay the bag; exit 0 when every message was published, 2 on no subscriber."""
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import Imu

    if args.rate <= 0:
        print('--rate must be positive')
        return 2
    rclpy.init()
    try:
        node = rclpy.create_node('inclino_play')
        qos = QoSProfile(depth=1000)
        if args.best_effort:
            qos.reliability = ReliabilityPolicy.BEST_EFFORT
        publisher = node.create_publisher(Imu, args.topic, qos)
        deadline = time.monotonic() + args.wait_s
        while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        if publisher.get_subscription_count() == 0:
            print(f'no subscriber on {args.topic} within {args.wait_s} s '
                  '(same ROS_DOMAIN_ID?)')
            return 2
        started = time.monotonic()
        count = publish_timed(publisher, read(args.bag, args.topic), args.rate,
                              lambda seconds: time.sleep(min(seconds, 0.01)))
        print(f'published {count} messages on {args.topic} in '
              f'{time.monotonic() - started:.2f} s')
        return 0
    finally:
        rclpy.try_shutdown()
