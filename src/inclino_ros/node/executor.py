"""
The spin loop shared by the node, the relay benchmark and the CLI tools.

The node's level capture is an ``async`` service callback, which only rclpy's
Python executors run (the C++ EventsExecutor rejects it), so the executor is a
SingleThreadedExecutor, spun with a timeout so that SIGINT and context
shutdown are seen promptly.
"""

import rclpy
from rclpy.executors import SingleThreadedExecutor


def spin(node, period_s=0.1):
    """Spin ``node`` on a SingleThreadedExecutor until the context shuts down."""
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        while rclpy.ok(context=node.context):
            try:
                executor.spin_once(timeout_sec=period_s)
            except Exception:
                # A take racing the SIGINT shutdown of the context fails inside
                # rclpy; after shutdown that is the end of the spin, not an error.
                if rclpy.ok(context=node.context):
                    raise
    finally:
        executor.remove_node(node)
        executor.shutdown()
