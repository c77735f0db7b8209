"""
The spin loop shared by the node and the relay benchmark.

The node's level capture is an ``async`` service callback, which only rclpy's
Python executors run (the C++ EventsExecutor rejects it), so the executor is a
SingleThreadedExecutor, spun with a timeout.

SIGINT and SIGTERM end the loop between two callbacks: rclpy is initialised
without its own signal handlers (``init``), because those shut the context
down while a message may be half taken, and rclpy then fails inside the take.

A node with a ``callback_lock`` has its callbacks run holding it (the node's
sample path runs in a thread of its own under the same lock,
``node.sample_path``); the executor's wait is outside the lock.
"""

from contextlib import nullcontext
import os
import signal
import sys
import threading

import rclpy
from rclpy.executors import (
    ConditionReachedException, ShutdownException, SingleThreadedExecutor, TimeoutException)
from rclpy.signals import SignalHandlerOptions


def init(args=None):
    """Initialise rclpy without its signal handlers (``spin`` handles the signals)."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)


def spin(node, period_s=0.1):
    """Spin ``node`` until SIGINT, SIGTERM or context shutdown; then return."""
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    lock = getattr(node, 'callback_lock', None) or nullcontext()
    try:
        while not stop.is_set() and rclpy.ok(context=node.context):
            spin_once(executor, period_s, lock)
    finally:
        executor.remove_node(node)
        executor.shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def spin_once(executor, timeout_s, lock):
    """
    Run one ready callback of ``executor`` holding ``lock``; wait at most ``timeout_s``.

    ``SingleThreadedExecutor.spin_once``'s own steps, the callback inside the lock.
    """
    try:
        handler, _, _ = executor.wait_for_ready_callbacks(timeout_sec=timeout_s)
    except (ShutdownException, TimeoutException, ConditionReachedException):
        return
    with lock:
        handler()
    if handler.exception() is not None:
        raise handler.exception()
    handler.result()


def run_node(make_node, args=None, refusals=()):
    """
    Initialise rclpy, build a node with ``make_node()`` and spin it; return the exit code.

    An exception of a type in ``refusals`` while building is logged as fatal
    and gives exit code 1 (e.g. a corrupt calibration file); so does a command
    line rclpy cannot parse (``--ros-args`` with a malformed rule or file),
    said in one line on stderr.
    """
    try:
        init(args)
    except Exception as err:  # rcl's own error type is private: its message is the point
        name = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else 'node'
        print(f'{name}: error: {err}; refusing to start', file=sys.stderr)
        return 1
    try:
        node = make_node()
    except refusals as err:
        rclpy.logging.get_logger('inclino_ros').fatal(f'{err}: refusing to start')
        rclpy.try_shutdown()
        return 1
    try:
        spin(node)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
