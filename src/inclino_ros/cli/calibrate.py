"""
``inclino calibrate``: call the node's ~/calibrate_level and print the answer.

What ``ros2 service call /inclinometer/calibrate_level std_srvs/srv/Trigger``
does on a full ROS 2 install.
"""


def register(subparsers):
    """Add the ``calibrate`` subcommand."""
    parser = subparsers.add_parser(
        'calibrate', help='trigger a level-bench calibration of a running node')
    parser.add_argument('--node', default='/inclinometer',
                        help='fully qualified name of the node (default: %(default)s)')
    parser.add_argument('--timeout-s', type=float, default=60.0,
                        help='seconds to wait for the service and its answer '
                             '(default: %(default)s)')
    parser.set_defaults(func=run)


def run(args):
    """Call the service; exit 0 when the calibration was applied, 1 if refused, 2 if no answer."""
    import rclpy
    from std_srvs.srv import Trigger

    service = f'{args.node.rstrip("/")}/calibrate_level'
    rclpy.init()
    try:
        node = rclpy.create_node('inclino_calibrate')
        client = node.create_client(Trigger, service)
        if not client.wait_for_service(timeout_sec=args.timeout_s):
            print(f'no service {service} within {args.timeout_s} s: is the node running '
                  '(same ROS_DOMAIN_ID)?')
            return 2
        future = client.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(node, future, timeout_sec=args.timeout_s)
        if not future.done():
            print(f'no answer from {service} within {args.timeout_s} s')
            return 2
        response = future.result()
        print(response.message)
        return 0 if response.success else 1
    finally:
        rclpy.try_shutdown()
