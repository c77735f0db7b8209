"""
The latency floor: a relay with the node's QoS, spun by the node's executor code.

Subscribes ``imu/data_raw`` with the inclinometer node's subscription QoS
(sensor data: best effort, keep last, depth ``imu_queue_depth``) and
republishes every message unchanged on ``relay/imu`` with the QoS of the
node's outputs (reliable, depth 10).  It is spun by
``inclino_ros.node.executor.run_node``, so the only difference to the node is the
work done per message: what the benchmark compares the node against.

Run with the venv's interpreter: ``.venv/bin/python bench/relay.py``.
"""

import copy
import sys

from inclino_ros.node.executor import run_node
from inclino_ros.node.parameters import PARAMETERS
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Imu

#: The node's default depth of its imu/data_raw queue.
IMU_QUEUE_DEPTH = next(p.default for p in PARAMETERS if p.name == 'imu_queue_depth')


class Relay(Node):
    """Republishes imu/data_raw on relay/imu, nothing else."""

    def __init__(self, **kwargs):
        """Create the subscription and the publisher with the node's QoS."""
        super().__init__('imu_relay', **kwargs)
        # No QoS event handlers, as the node has none on its outputs: the same
        # executor work per wake-up.
        self.relay_pub = self.create_publisher(
            Imu, 'relay/imu', 10,
            event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        qos = copy.copy(qos_profile_sensor_data)
        qos.depth = IMU_QUEUE_DEPTH
        self.create_subscription(
            Imu, 'imu/data_raw', self.relay_pub.publish, qos,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))


def main(args=None):
    """Run the relay until SIGINT, SIGTERM or shutdown."""
    return run_node(Relay, args)


if __name__ == '__main__':
    sys.exit(main())
