"""
``inclino calibrate``: level-bench calibration of the running node (``~/calibrate_level``).

What ``ros2 service call /inclinometer/calibrate_level std_srvs/srv/Trigger``
does on a full ROS 2 install; the same as ``inclino call calibrate_level``.
"""

from inclino_ros.cli.call import call_service
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.live import add_node_arguments, live_command, node_name


def register(subparsers):
    """Add the ``calibrate`` subcommand."""
    parser = add_command(
        subparsers, 'calibrate', 'level-bench calibration of the running node (mounting error)',
        'With the tool still on a levelled bench and its samples arriving at the running '
        'inclinometer node, measure the mounting error of the sensor (gamma, beta): the node '
        'collects level_capture.samples samples after the call (a progress bar shows them), '
        'applies the correction at once and writes its calibration file. Prints the answer '
        'of the node. Same as: inclino call calibrate_level.',
        'Exit 0 when calibrated, 1 when the node refused (the reason is printed; the previous '
        'calibration is kept), 2 when no node answers within --wait-s, 130 on Ctrl-C.')
    add_node_arguments(parser)
    parser.set_defaults(func=run)


@live_command
def run(args):
    """Call ``~/calibrate_level``; return the exit code."""
    return call_service(f'{node_name(args.node)}/calibrate_level', args.wait_s)
