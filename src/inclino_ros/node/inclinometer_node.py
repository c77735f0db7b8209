"""
The inclinometer node: adapts ROS topics, parameters and services to the core.

Subscribes ``imu/data_raw`` (sensor_msgs/Imu, sensor-data QoS), publishes the
corrected ``survey``, ``inclination``, ``toolface`` and ``imu/data`` for every
accepted sample, reports health on ``/diagnostics`` and calibrates through
``~/calibrate_level``.  All arithmetic is in ``inclino_ros.pipeline`` and the
modules it uses.
"""

from dataclasses import replace
import math
import os
import sys

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped
from inclino_ros.level_capture import CaptureRefused, LevelLimits, solve_level_capture
from inclino_ros.model import (
    age_seconds, CalibrationFileError, CalibrationModel, load_model, save_model)
from inclino_ros.node.executor import init, spin
from inclino_ros.node.parameters import PARAMETERS
from inclino_ros.node.stats import InputStats
from inclino_ros.pipeline import imu_covariances, run, Settings
from inclino_ros.screening import ACCEPTED
import numpy as np
import rclpy
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.task import Future
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64
from std_srvs.srv import Trigger


class LevelCapture:
    """Raw accepted samples collected for one ~/calibrate_level call."""

    def __init__(self, count, future):
        """Collect ``count`` samples, then complete ``future`` with them."""
        self.count = count
        self.future = future
        self.samples = []

    def add(self, raw):
        """Add one raw reading; complete the future when enough are in."""
        self.samples.append(raw)
        if len(self.samples) == self.count and not self.future.done():
            self.future.set_result(np.array(self.samples))

    def expire(self):
        """Complete the future empty-handed: the time is up."""
        if not self.future.done():
            self.future.set_result(None)


class InclinometerNode(Node):
    """Corrects an inclinometer's accelerometer stream with the stored calibration."""

    def __init__(self, **kwargs):
        """Declare parameters, load the calibration and create the interfaces."""
        super().__init__('inclinometer', **kwargs)
        for parameter in PARAMETERS:
            self.declare_parameter(parameter.name, parameter.default, parameter.descriptor())
        self.settings = Settings(
            accelerometer_axes=self._param('accelerometer_axes'),
            gravity_mps2=self._param('gravity_mps2'),
            accelerometer_range_mps2=self._param('accelerometer_range_mps2'),
            toolface_convention=self._param('toolface_convention'),
            toolface_min_inclination_deg=self._param('toolface_min_inclination_deg'))
        self.noise_std_mps2 = self._param('accelerometer_noise_std_mps2')
        self.frame_id = self._param('frame_id')
        self.calibration_file = os.path.expanduser(self._param('calibration_file'))
        self.model = self._load_model()
        self.capture = None
        self.stats = InputStats()

        self.survey_pub = self.create_publisher(Vector3Stamped, 'survey', 10)
        self.inclination_pub = self.create_publisher(Float64, 'inclination', 10)
        self.toolface_pub = self.create_publisher(Float64, 'toolface', 10)
        self.imu_pub = self.create_publisher(Imu, 'imu/data', 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        qos = qos_profile_sensor_data
        qos.depth = self._param('imu_queue_depth')
        self.create_subscription(Imu, 'imu/data_raw', self._on_imu, qos)
        # Reentrant: the capture awaits samples without holding the default group
        # (the subscription keeps running) and a second call is answered at once.
        self.create_service(Trigger, '~/calibrate_level', self._on_calibrate_level,
                            callback_group=ReentrantCallbackGroup())
        self.create_timer(self._param('diagnostics_period_s'), self._publish_diagnostics)

    def _param(self, name):
        return self.get_parameter(name).value

    def _load_model(self):
        """
        Return the stored model, an empty one if there is no file.

        Raises CalibrationFileError for a file that exists but is not valid.
        """
        axes = self.settings.accelerometer_axes
        try:
            model = load_model(self.calibration_file)
        except FileNotFoundError:
            self.get_logger().warning(
                f'no calibration file at {self.calibration_file}: running UNCALIBRATED '
                '(raw angles); call ~/calibrate_level with the tool on a level bench')
            return CalibrationModel(accelerometer_axes=axes)
        if model.accelerometer_axes != axes:
            raise CalibrationFileError(
                self.calibration_file,
                f'made for a {model.accelerometer_axes}-axis accelerometer, but '
                f'accelerometer_axes is {axes}')
        installation = model.installation
        if installation is not None:
            self.get_logger().info(
                f'loaded {self.calibration_file}: gamma_deg={installation.gamma_deg:.4f} '
                f'beta_deg={installation.beta_deg:.4f} captured {installation.captured_at}')
        return model

    def _on_imu(self, msg):
        acc = msg.linear_acceleration
        raw = (acc.x, acc.y, acc.z)
        survey = run(np.array([raw]), self.model, self.settings)
        code = int(survey.codes[0])
        if code != ACCEPTED:
            self.stats.drop(code)
            return
        self.stats.accept(float(survey.g_total_mps2[0]))
        if self.capture is not None:
            self.capture.add(raw)
        self._publish(msg.header, survey)

    def _publish(self, header, survey):
        if self.frame_id:
            header.frame_id = self.frame_id
        incl_deg = float(survey.inclination_deg[0])
        toolface_deg = float(survey.toolface_deg[0])
        out = Vector3Stamped(header=header)
        out.vector.x, out.vector.y, out.vector.z = incl_deg, toolface_deg, math.nan
        self.survey_pub.publish(out)
        self.inclination_pub.publish(Float64(data=incl_deg))
        self.toolface_pub.publish(Float64(data=toolface_deg))
        self.imu_pub.publish(self._corrected_imu(header, survey))

    def _corrected_imu(self, header, survey):
        """Return imu/data: corrected specific force and roll/pitch with covariances."""
        f = survey.corrected_mps2[0]
        imu = Imu(header=header)
        acc = imu.linear_acceleration
        acc.x, acc.y, acc.z = (float(v) for v in f)
        q = survey.orientation_wxyz[0]
        imu.orientation.w, imu.orientation.x = float(q[0]), float(q[1])
        imu.orientation.y, imu.orientation.z = float(q[2]), float(q[3])
        acceleration_cov, orientation_cov = imu_covariances(
            survey, self.model, self.settings, self.noise_std_mps2)
        imu.linear_acceleration_covariance = acceleration_cov[0].tolist()
        imu.orientation_covariance = orientation_cov[0].tolist()
        imu.angular_velocity_covariance[0] = -1.0  # no angular rate is measured
        return imu

    async def _on_calibrate_level(self, request, response):
        """Capture level-bench samples arriving after the call and apply gamma, beta."""
        if self.capture is not None:
            return self._refuse(response, 'a level capture is already running')
        count = self._param('level_capture.samples')
        timeout_s = self._param('level_capture.timeout_s')
        capture = LevelCapture(count, Future())
        self.capture = capture
        timer = self.create_timer(timeout_s, capture.expire)
        self.get_logger().info(f'level capture: collecting {count} samples on imu/data_raw')
        try:
            samples = await capture.future
        finally:
            self.destroy_timer(timer)
            self.capture = None
        if samples is None:
            return self._refuse(
                response, f'no data: {len(capture.samples)} of {count} samples arrived on '
                f'{self.resolve_topic_name("imu/data_raw")} within {timeout_s} s')
        limits = LevelLimits(
            max_std_deg=self._param('level_capture.max_std_deg'),
            max_tilt_deg=self._param('level_capture.max_tilt_deg'),
            gravity_mps2=self.settings.gravity_mps2,
            g_total_tolerance_mps2=self._param('level_capture.g_total_tolerance_mps2'))
        try:
            installation = solve_level_capture(
                samples, self.settings.accelerometer_axes, limits)
        except CaptureRefused as err:
            return self._refuse(response, str(err))
        model = replace(self.model, installation=installation)
        try:
            save_model(self.calibration_file, model)
        except OSError as err:
            return self._refuse(response, f'cannot write {self.calibration_file}: {err}')
        self.model = model
        response.success = True
        response.message = (
            f'calibrated from {installation.sample_count} samples: '
            f'gamma_deg={installation.gamma_deg:.4f} beta_deg={installation.beta_deg:.4f} '
            f'theta_deg={installation.theta_deg:.4f} '
            f'(spread {installation.std_deg:.4f} deg); saved to {self.calibration_file}')
        self.get_logger().info(response.message)
        return response

    def _refuse(self, response, reason):
        response.success = False
        response.message = f'refused: {reason}; previous calibration kept'
        self.get_logger().warning(response.message)
        return response

    def _publish_diagnostics(self):
        now = self.get_clock().now()
        array = DiagnosticArray()
        array.header.stamp = now.to_msg()
        array.status = [self._calibration_status(), self.stats.status(
            self.get_name(), now.nanoseconds * 1e-9, self.settings.gravity_mps2,
            self._param('level_capture.g_total_tolerance_mps2'))]
        self.diagnostics_pub.publish(array)

    def _calibration_status(self):
        status = DiagnosticStatus(name=f'{self.get_name()}: calibration',
                                  hardware_id=self.calibration_file)
        values = {'calibration_file': self.calibration_file,
                  'capture_running': str(self.capture is not None)}
        installation = self.model.installation
        if installation is None:
            status.level = DiagnosticStatus.WARN
            status.message = 'uncalibrated: raw angles published; call ~/calibrate_level'
        else:
            status.level = DiagnosticStatus.OK
            status.message = 'calibrated'
            values.update(
                gamma_deg=f'{installation.gamma_deg:.5f}',
                beta_deg=f'{installation.beta_deg:.5f}',
                theta_deg=f'{installation.theta_deg:.5f}',
                captured_at=installation.captured_at,
                age_s=f'{age_seconds(installation.captured_at):.0f}',
                sample_count=str(installation.sample_count))
        status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        return status


def main(args=None):
    """Run the node until shutdown; exit non-zero on a bad calibration file."""
    init(args)
    try:
        node = InclinometerNode()
    except (CalibrationFileError, ValueError) as err:
        rclpy.logging.get_logger('inclinometer').fatal(f'{err}: refusing to start')
        rclpy.try_shutdown()
        return 1
    try:
        spin(node)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
