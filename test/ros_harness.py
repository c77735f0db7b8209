"""Drive the real node over real rclpy: a subprocess and a probe node beside it."""

import json
import math
import os
import signal
import subprocess
import sys
import time

from ament_index_python.packages import get_package_prefix, PackageNotFoundError
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu, MagneticField, Temperature
from std_msgs.msg import Float64, String
from std_srvs.srv import Trigger


def installed_script(name):
    """
    Return the path of the console script ``name`` to test.

    Where ``ros2 run`` looks (``<prefix>/lib/inclino_ros``, as after ``colcon build``),
    else the console script beside this Python (``pip install`` into a venv).
    """
    try:
        path = os.path.join(get_package_prefix('inclino_ros'), 'lib', 'inclino_ros', name)
        if os.path.isfile(path):
            return path
    except (OSError, PackageNotFoundError):  # AMENT_PREFIX_PATH unset, or not indexed
        pass
    return os.path.join(os.path.dirname(sys.executable), name)


NODE_EXECUTABLE = installed_script('inclinometer_node')
G = 9.80665


class NodeProcess:
    """The ``inclinometer_node`` console script running as a child process."""

    def __init__(self, log_path, **parameters):
        """Start the node with ``parameters`` given as ``--ros-args -p``."""
        args = [NODE_EXECUTABLE, '--ros-args']
        for name, value in parameters.items():
            args += ['-p', f'{name}:={value}']
        self.log_path = log_path
        self._log = open(log_path, 'w')
        self.process = subprocess.Popen(args, stdout=self._log, stderr=subprocess.STDOUT)

    def stop(self, timeout_s=10.0):
        """Stop with SIGINT (as Ctrl-C would); return the exit code."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            code = self.process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.process.kill()
            code = self.process.wait()
        self._log.close()
        return code

    def log(self):
        """Return what the node printed so far."""
        self._log.flush()
        with open(self.log_path) as stream:
            return stream.read()


def imu_message(index, acceleration, frame_id='inclinometer', period_s=None):
    """Return an Imu message whose stamp encodes ``index`` (sec = index, or index * period_s)."""
    msg = Imu()
    if period_s is None:
        msg.header.stamp.sec = int(index)
    else:
        stamp_ns = round(index * period_s * 1e9)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.header.frame_id = frame_id
    acc = msg.linear_acceleration
    acc.x, acc.y, acc.z = (float(v) for v in acceleration)
    return msg


class Probe:
    """A test-side node: publishes raw samples, records outputs, calls the service."""

    def __init__(self, node_name='/inclinometer', best_effort=False):
        """Create the probe's publisher, subscriptions and service client."""
        self.node = rclpy.create_node('probe')
        qos = QoSProfile(depth=100)
        if best_effort:
            qos.reliability = ReliabilityPolicy.BEST_EFFORT
        self.publisher = self.node.create_publisher(Imu, 'imu/data_raw', qos)
        self.received = {'survey': [], 'inclination': [], 'toolface': [], 'imu/data': [],
                         'azimuth': [], '/diagnostics': []}
        self.subscriptions = [
            self.node.create_subscription(
                kind, topic, self.received[topic].append, QoSProfile(depth=1000))
            for topic, kind in (('survey', Vector3Stamped), ('inclination', Float64),
                                ('toolface', Float64), ('azimuth', Float64),
                                ('imu/data', Imu),
                                ('/diagnostics', DiagnosticArray))]
        self.services = {name: self.node.create_client(Trigger, f'{node_name}/{name}')
                         for name in ('calibrate_level', 'capture_position',
                                      'solve_stand_calibration', 'clear_positions',
                                      'capture_rotation', 'take_survey', 'solve_msa',
                                      'clear_surveys', 'capture_high_side_mark')}
        self.client = self.services['calibrate_level']
        self.parameters = AsyncParameterClient(self.node, node_name)
        self.mag_publisher = self.node.create_publisher(
            MagneticField, 'imu/mag', QoSProfile(depth=100))
        self.temperature_publisher = self.node.create_publisher(
            Temperature, 'imu/temperature', QoSProfile(depth=10))
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.sent = 0
        self.stamp_period_s = None  # None: stamp sec = index; else index * period

    def spin_for(self, seconds):
        """Process callbacks for ``seconds``."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)

    def spin_until(self, done, timeout_s=30.0):
        """Process callbacks until ``done()``; AssertionError after ``timeout_s``."""
        end = time.monotonic() + timeout_s
        while not done():
            assert time.monotonic() < end, 'the awaited condition never came'
            self.executor.spin_once(timeout_sec=0.01)

    def wait_for_node(self, timeout_s=60.0):
        """
        Wait until the node's subscription, outputs and service are matched, both ways.

        Matching is seen by each side on its own: the probe's publisher may know the
        node's subscription before that subscription knows the publisher, and a
        best-effort subscription drops what comes from a publisher it does not know
        yet (the first samples of a test, on a loaded machine).  So the node's own
        count is awaited too: its input diagnostics' ``imu_publishers``.  ``timeout_s``
        is a failsafe: 20 s ran out once on a 2-core host loaded three times over.
        """
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if (self.publisher.get_subscription_count() >= 1
                    and all(s.get_publisher_count() for s in self.subscriptions)
                    and all(c.service_is_ready() for c in self.services.values())
                    and self.parameters.services_are_ready()):
                break
            self.executor.spin_once(timeout_sec=0.05)
        else:
            raise TimeoutError('the node did not come up')
        self.received['/diagnostics'].clear()   # a status from now on counting the probe's
        self.spin_until(lambda: any(int(values['imu_publishers']) >= 1
                                    for values in self.status_values(': input')),
                        end - time.monotonic())

    def publish(self, acceleration):
        """Publish one raw sample; return its index."""
        index = self.sent
        self.publisher.publish(imu_message(index, acceleration, period_s=self.stamp_period_s))
        self.sent += 1
        return index

    def stream(self, sample_fn, rate_hz=200.0, until=None, count=None, timeout_s=20.0):
        """Publish ``sample_fn(i)`` at ``rate_hz`` until ``until`` is done or ``count`` sent."""
        period = 1.0 / rate_hz
        end = time.monotonic() + timeout_s
        sent = 0
        next_time = time.monotonic()
        while time.monotonic() < end:
            if until is not None and until.done():
                return
            if count is not None and sent >= count:
                return
            if time.monotonic() >= next_time:
                self.publish(sample_fn(sent))
                sent += 1
                next_time += period
            self.executor.spin_once(timeout_sec=min(period, 0.005))
        if until is not None and not until.done():
            raise TimeoutError('the service did not answer')

    def calibrate(self, sample_fn, rate_hz=200.0, timeout_s=20.0, service='calibrate_level'):
        """Call a capture service while streaming samples; return the response."""
        future = self.services[service].call_async(Trigger.Request())
        self.stream(sample_fn, rate_hz, until=future, timeout_s=timeout_s)
        return future.result()

    def call(self, service, timeout_s=10.0):
        """Call a Trigger service of the node without streaming; return the response."""
        future = self.services[service].call_async(Trigger.Request())
        end = time.monotonic() + timeout_s
        while not future.done() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)
        return future.result()

    def set_parameters(self, **values):
        """Set parameters of the node (dots in names written as __); assert they took."""
        parameters = [Parameter(name.replace('__', '.'), value=value)
                      for name, value in values.items()]
        future = self.parameters.set_parameters(parameters)
        self.executor.spin_until_future_complete(future, timeout_sec=10.0)
        assert all(result.successful for result in future.result().results), future.result()

    def publish_pair(self, acceleration, field_nT):
        """Publish one imu/mag reading (tesla) and then the raw sample of the same stamp."""
        mag = MagneticField()
        mag.header.stamp.sec = self.sent
        mag.magnetic_field.x, mag.magnetic_field.y, mag.magnetic_field.z = (
            float(v) * 1e-9 for v in field_nT)
        self.mag_publisher.publish(mag)
        return self.publish(acceleration)

    def publish_temperature(self, temperature_c):
        """Publish one imu/temperature reading."""
        self.temperature_publisher.publish(Temperature(temperature=float(temperature_c)))

    def set_temperature(self, temperature_c, timeout_s=30.0):
        """
        Publish ``temperature_c`` until the node's temperature diagnostics report it taken.

        Waits for the node's state, not for a fixed time: a loaded machine delivers late, and
        a message sent before the node's reader has discovered the probe is lost.
        """
        def taken():
            self.publish_temperature(temperature_c)
            return self.wait_status(': temperature')[1]['temperature_c'] == f'{temperature_c:.2f}'
        self.spin_until(taken, timeout_s)

    def listen_latched(self, topic):
        """Subscribe to a latched std_msgs/String topic; return the list its JSON goes to."""
        received = []
        self.node.create_subscription(
            String, topic, lambda msg: received.append(json.loads(msg.data)),
            QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        return received

    def wait_outputs(self, topic, count, timeout_s=10.0):
        """Spin until ``count`` messages arrived on ``topic``; return them."""
        end = time.monotonic() + timeout_s
        while len(self.received[topic]) < count and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)
        return self.received[topic]

    def survey_for(self, publish, retry_s=2.0, timeout_s=60.0, paired=False):
        """
        Call ``publish()`` (returns the index it stamped) until a survey of that stamp comes.

        Return the first survey stamped with an index ``publish`` sent (``stamp.sec``).  A
        sample sent while the node's reader has not yet discovered the probe's writer is
        lost (the publisher side matches first; on a loaded machine the other side can
        lag): after ``retry_s`` without its survey the same reading is sent again, with
        a new stamp.  ``paired``: only a survey with an azimuth counts (a magnetometer
        reading delivered after the sample of its stamp leaves that sample unpaired: the
        node corrects a sample as soon as it arrives), the pair is sent again at once.
        Earlier outputs are forgotten first, and those of this call stay in ``received``
        (a survey of an older sample arriving late is not taken).
        """
        self.spin_for(0.2)  # let outputs of earlier samples drain
        self.clear()
        sent = set()
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            sent.add(publish())
            retry = min(end, time.monotonic() + retry_s)
            while time.monotonic() < retry:
                ours = [s for s in self.received['survey'] if s.header.stamp.sec in sent]
                if ours and not paired:
                    return ours[0]
                if any(math.isfinite(s.vector.z) for s in ours):
                    return next(s for s in ours if math.isfinite(s.vector.z))
                if len(ours) == len(sent):   # all came, none paired: send again
                    break
                self.executor.spin_once(timeout_sec=0.01)
        raise AssertionError(f'no {"paired " if paired else ""}survey of the samples stamped '
                             f'{sorted(sent)} in {timeout_s} s')

    def status_values(self, suffix):
        """Return the values (dicts) of the diagnostics statuses named ``*suffix`` received."""
        return [{kv.key: kv.value for kv in status.values}
                for array in self.received['/diagnostics'] for status in array.status
                if status.name.endswith(suffix)]

    def wait_status(self, suffix, timeout_s=30.0):
        """
        Return (status, values dict) of the first diagnostics status named ``*suffix`` from now.

        Earlier /diagnostics messages are forgotten first, so the status is one the node built
        after the call (its state now); waits for it rather than for a fixed time (the
        node's timer comes late on a loaded machine).
        """
        self.received['/diagnostics'].clear()

        def found():
            return next((status for array in self.received['/diagnostics']
                         for status in array.status if status.name.endswith(suffix)), None)

        self.spin_until(lambda: found() is not None, timeout_s)
        status = found()
        return status, {kv.key: kv.value for kv in status.values}

    def clear(self):
        """Forget the messages received so far."""
        for messages in self.received.values():
            messages.clear()

    def destroy(self):
        """Destroy the probe node."""
        self.executor.shutdown()
        self.node.destroy_node()


def tilted_reading(inclination_deg, toolface_deg, gamma_deg=0.0, beta_deg=0.0, g=G):
    """
    Return the sensor reading of a still tool, installed with (gamma, beta).

    Built here from seed 000 Eq. 1 written out, independently of the package:
    true specific force g (sin I cos TF, sin I sin TF, cos I), then C.
    """
    i, t = math.radians(inclination_deg), math.radians(toolface_deg)
    f = g * np.array([math.sin(i) * math.cos(t), math.sin(i) * math.sin(t), math.cos(i)])
    cg, sg = math.cos(math.radians(gamma_deg)), math.sin(math.radians(gamma_deg))
    cb, sb = math.cos(math.radians(beta_deg)), math.sin(math.radians(beta_deg))
    c = np.array([[cg, 0.0, -sg], [-sb * sg, cb, -sb * cg], [cb * sg, sb, cb * cg]])
    return c @ f
