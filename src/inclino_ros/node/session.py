"""
An rclpy session of a live command of its own, spun by hand (``inclino`` live commands, demo).

A LiveSession is one rclpy node; rclpy is initialised without its signal
handlers (as the node is): Ctrl-C raises KeyboardInterrupt in Python, and
SIGTERM (``kill``, what a script sends to a background job) is turned into
the same, so each command ends cleanly and says what it did, never with a
traceback.  A DemoSession (``inclino demo``) replays bag segments to the
node and records its surveys.  rclpy is imported only when a session starts.
"""

import os
import signal
import sys
import time

from inclino_ros.io.bag import IMU
from inclino_ros.io.timing import Timeline
from inclino_ros.node.playback import publish_timed
import numpy as np

#: Seconds the rclpy teardown of a live command may take before the kernel ends it (SIGALRM):
#: milliseconds normally, 24 minutes once under ~90 concurrent calls (issue 21).
TEARDOWN_S = 20


def domain_hint():
    """Return what to check when the node cannot be found, naming this shell's settings."""
    domain = os.environ.get('ROS_DOMAIN_ID', '0 (unset)')
    scope = os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE', 'SUBNET (unset)')
    return (f'is inclinometer_node running, and started with the same ROS_DOMAIN_ID '
            f'(this shell: {domain}) and ROS_AUTOMATIC_DISCOVERY_RANGE (this shell: {scope})?')


class LiveSession:
    """One rclpy node of a live command; use as a context manager."""

    def __init__(self, name):
        """Initialise rclpy (no signal handlers) and create node ``name``."""
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self._previous_term = signal.signal(signal.SIGTERM, _interrupt)
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(name, start_parameter_services=False)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)

    def __enter__(self):
        """Return the session."""
        return self

    def __exit__(self, *exc_info):
        """
        Destroy the node, shut rclpy down, restore SIGTERM; never hang there.

        What the command says is said by now (flushed).  The teardown runs in
        the DDS layer, where Python's signal handlers never run: under ~90
        concurrent calls one caller spun in ``destroy_node`` for 24 minutes,
        deaf to SIGTERM.  So during it SIGTERM and SIGINT kill the process
        (their default action, taken by the kernel), and ``signal.alarm``
        ends it after ``TEARDOWN_S`` (exit status 128 + SIGALRM), whatever
        the DDS layer does.  In order: the executor first (nothing spins any
        more), then the node, then the context.
        """
        import rclpy
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        previous_int = signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        previous_alarm = signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(TEARDOWN_S)
        try:
            self.executor.shutdown()
            self.node.destroy_node()
            rclpy.try_shutdown()
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, previous_alarm)
            signal.signal(signal.SIGINT, previous_int)
            signal.signal(signal.SIGTERM, self._previous_term)

    def spin(self, seconds):
        """Process callbacks for ``seconds``."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self.executor.spin_once(timeout_sec=min(left, 0.05))

    def spin_until(self, done, timeout_s, step_s=0.05):
        """Spin until ``done()`` or ``timeout_s`` passed (None: no limit); return ``done()``."""
        end = None if timeout_s is None else time.monotonic() + timeout_s
        while not done():
            if end is not None and time.monotonic() >= end:
                break
            self.executor.spin_once(timeout_sec=step_s)
        return done()

    def other_nodes(self):
        """Return the full names of the ROS nodes this session sees, itself left out."""
        own = self.node.get_fully_qualified_name()
        return sorted(f'{ns.rstrip("/")}/{name}'
                      for name, ns in self.node.get_node_names_and_namespaces()
                      if f'{ns.rstrip("/")}/{name}' != own)

    def not_found(self, what):
        """Return the message for a node that did not answer: what, where, what to check."""
        seen = self.other_nodes()
        return (f'{what}; {domain_hint()} Nodes seen: '
                + (', '.join(seen) if seen else 'none'))


def _interrupt(signum, frame):
    raise KeyboardInterrupt


class DemoSession(LiveSession):
    """The demo's own rclpy node: replays bag segments, records the node's surveys."""

    def __init__(self, rate):
        """Create the publisher, the survey recorder and the service client; replay at ``rate``."""
        from geometry_msgs.msg import Vector3Stamped
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import Imu
        from std_srvs.srv import Trigger

        super().__init__('inclino_demo')
        self.rate = rate
        self.publisher = self.node.create_publisher(Imu, 'imu/data_raw', QoSProfile(depth=1000))
        self.surveys = {}
        self.survey_sub = self.node.create_subscription(
            Vector3Stamped, 'survey', self._on_survey, QoSProfile(depth=1000))
        self.client = self.node.create_client(Trigger, '/inclinometer/calibrate_level')
        self.trigger = Trigger.Request

    def _on_survey(self, msg):
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.surveys[stamp_ns] = (msg.vector.x, msg.vector.y, msg.vector.z)

    def wait_for_node(self, timeout_s=30.0):
        """Wait until the node's subscription, survey and service are matched."""
        if not self.spin_until(lambda: (self.publisher.get_subscription_count()
                                        and self.client.service_is_ready()
                                        and self.survey_sub.get_publisher_count()),
                               timeout_s):
            raise RuntimeError('inclinometer_node did not come up')
        self.spin(0.3)

    def play(self, series):
        """Publish an ImuSeries with its timing (``rate`` times faster)."""
        publish_timed(Timeline.of([('imu/data_raw', IMU, series)]),
                      {'imu/data_raw': self.publisher}, self.rate,
                      lambda seconds: self.spin(min(seconds, 0.01)))

    def replay(self, series):
        """Publish an ImuSeries with its timing; return the node's surveys of it (N, 3)."""
        self.surveys = {}
        self.play(series)
        self.spin(0.5)
        answers = np.array([self.surveys.get(stamp, (np.nan,) * 3)
                            for stamp in series.stamps_ns.tolist()])
        print(f'   {np.count_nonzero(np.isfinite(answers[:, 0]))} of {series.stamps_ns.size} '
              'surveys received')
        return answers

    def calibrate_during(self, series):
        """Call ~/calibrate_level while the level segment plays; return the answer."""
        future = self.client.call_async(self.trigger())
        self.play(series)
        self.spin_until(future.done, 15.0)
        return future.result() if future.done() else None
