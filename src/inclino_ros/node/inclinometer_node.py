"""
The inclinometer node: adapts ROS topics, parameters and services to the core.

Subscribes ``imu/data_raw`` (sensor_msgs/Imu, sensor-data QoS),
``imu/temperature`` (sensor_msgs/Temperature) and ``imu/mag``
(sensor_msgs/MagneticField), publishes the corrected ``survey``,
``inclination``, ``toolface``, ``azimuth`` and ``imu/data`` for every accepted
sample (or, with ``output.*``, for every averaged window), reports health on
``/diagnostics``, the calibration in use on the latched ``~/calibration``
(std_msgs/String, JSON) and calibrates through the services of
``node.services`` and ``node.magnetic_services`` (their progress on
``~/capture_progress``).  The raw inputs are taken in batches, serialized
(``node.sample_path``).  All arithmetic is in ``inclino_ros.pipeline`` and the
modules it uses.
"""

from dataclasses import replace
import json
import math
import os
import sys
import threading

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped
from inclino_ros.calibration.model import (
    CalibrationFileError, CalibrationModel, check_axes_maps, check_sensor, load_model,
    read_model_history, stage_ages_s, stale_stages, utc_now_iso)
from inclino_ros.calibration.plausibility import check_for_sensor, Implausible
from inclino_ros.calibration.stations import load_stations, StationsFileError
from inclino_ros.calibration.store import axes_refusal
from inclino_ros.core.averaging import Averager
from inclino_ros.core.magnetics import QcLimits
from inclino_ros.io.bag import encode, encode_float64, IMU, MAGNETIC_FIELD
from inclino_ros.node.capture import change_refusal, CLOCK_HINT, Collector, latched_qos
from inclino_ros.node.executor import run_node
from inclino_ros.node.magnetic_services import MagneticServices
from inclino_ros.node.parameters import PARAMETERS, refusal
from inclino_ros.node.sample_path import (
    BatchWaker, decode_messages, ServedElsewhere, take_serialized)
from inclino_ros.node.services import CalibrationServices
from inclino_ros.node.stats import InputStats, MagneticInput, TemperatureInput
from inclino_ros.pipeline import MagneticSettings, Settings
from inclino_ros.stream import correct_batch
import numpy as np
from rcl_interfaces.msg import (
    FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult)
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.exceptions import NameValidationException, ParameterException
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, qos_profile_sensor_data, QoSProfile, ReliabilityPolicy)
from sensor_msgs.msg import Imu, MagneticField, Temperature
from std_msgs.msg import Float64, String


def descriptor(parameter):
    """Return the ROS descriptor of a ``parameters.Parameter``: description, range, read-only."""
    result = ParameterDescriptor(
        name=parameter.name, description=parameter.description, read_only=parameter.read_only,
        additional_constraints='' if parameter.choices is None else
        f'one of: {", ".join(parameter.choices)}')
    if isinstance(parameter.default, bool) or parameter.low is None:
        return result
    if isinstance(parameter.default, int):
        result.integer_range = [IntegerRange(
            from_value=int(parameter.low), to_value=int(parameter.high), step=1)]
    else:
        result.floating_point_range = [FloatingPointRange(
            from_value=float(parameter.low), to_value=float(parameter.high), step=0.0)]
    return result


class InclinometerNode(Node):
    """Corrects an inclinometer's accelerometer stream with the stored calibration."""

    def __init__(self, **kwargs):
        """Declare parameters, load the calibration and create the interfaces."""
        super().__init__('inclinometer', **kwargs)
        for parameter in PARAMETERS:
            self.declare_parameter(parameter.name, parameter.default, descriptor(parameter))
            reason = refusal(parameter.name, self.param(parameter.name))
            if reason:
                raise ValueError(reason)
        self.settings = Settings(
            accelerometer_axes=self.param('accelerometer_axes'),
            gravity_mps2=self.param('gravity_mps2'),
            accelerometer_range_mps2=self.param('accelerometer_range_mps2'),
            toolface_convention=self.param('toolface_convention'),
            noise_std_mps2=self.param('accelerometer_noise_std_mps2'),
            bias_instability_mps2=self.param('accelerometer_bias_instability_mps2'),
            toolface_max_std_deg=self.param('toolface_max_std_deg'),
            g_total_tolerance_mps2=self.param('g_total_tolerance_mps2'),
            two_axis_max_inclination_deg=self.param('two_axis_max_inclination_deg'),
            accelerometer_axes_map=self.param('accelerometer_axes_map'),
            magnetometer_axes_map=self.param('magnetometer_axes_map'),
            allow_left_handed_axes=self.param('allow_left_handed_axes'))
        self.frame_id = self.param('frame_id')
        self.calibration_file = os.path.expanduser(self.param('calibration_file'))
        self.sensor_id = self.param('sensor_id') or None
        self.field_mode = self.param('field_mode')
        self.get_logger().info(f'calibration mode: {self.calibration_mode()}')
        self.model, self.calibration_sha256 = self._load_model()
        self.history_problems = self._check_history()
        self.stations_file = os.path.expanduser(self.param('stations_file'))
        stations = load_stations(self.stations_file)
        self.magnetic_settings = self._magnetic_settings()
        self.add_on_set_parameters_callback(self._check_parameters)
        self.add_post_set_parameters_callback(self._on_parameters_set)
        self.stats = InputStats()
        self.temperature = TemperatureInput()
        self._missing_said = None
        self.magnetometer = MagneticInput()

        # Every QoS event handler is one more waitable the executor polls on every
        # wake-up (~150 us per message with rclpy's defaults on all seven entities):
        # only the raw input keeps one, to say why a publisher does not match.
        quiet = PublisherEventCallbacks(use_default_callbacks=False)
        self.survey_pub, self.inclination_pub, self.toolface_pub, self.azimuth_pub, \
            self.imu_pub, self.diagnostics_pub = (
                self.create_publisher(kind, topic, 10, event_callbacks=quiet)
                for kind, topic in ((Vector3Stamped, 'survey'), (Float64, 'inclination'),
                                    (Float64, 'toolface'), (Float64, 'azimuth'),
                                    (Imu, 'imu/data'), (DiagnosticArray, '/diagnostics')))
        self._take_limit = self.param('imu_queue_depth')
        sensor_qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=self._take_limit,
            reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
        # The raw inputs are taken by _on_batch, woken by the BatchWaker (node.sample_path):
        # the executor never calls these subscriptions' callbacks.
        served = ServedElsewhere()
        self._imu_subscription = self.create_subscription(
            Imu, 'imu/data_raw', served_elsewhere, sensor_qos, callback_group=served,
            event_callbacks=SubscriptionEventCallbacks(
                incompatible_qos=self._on_incompatible_qos, use_default_callbacks=False))
        self._mag_subscription = self.create_subscription(
            MagneticField, 'imu/mag', served_elsewhere, sensor_qos, callback_group=served,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        self.create_subscription(
            Temperature, 'imu/temperature', self._on_temperature, qos_profile_sensor_data,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        average_samples, rate_hz = self.param('output.average_samples'), \
            self.param('output.rate_hz')
        self.averager = (Averager(average_samples, rate_hz)
                         if average_samples > 1 or rate_hz > 0 else None)
        self.calibration_pub = self.create_publisher(String, '~/calibration', latched_qos())
        self.apply_model(self.model)
        self.collector = Collector(self)
        self.calibration = CalibrationServices(self, self.collector)
        self.magnetic = MagneticServices(self, self.collector, stations)
        # Wall time: under use_sim_time without /clock a ROS-time timer never fires.
        self._diagnostics_ros_ns = None
        self.create_timer(self.param('diagnostics_period_s'), self._publish_diagnostics,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        if self.averager is not None:
            self.stats.count_windows(0, 0)
        # The executor runs every callback holding callback_lock (node.executor.spin), and the
        # sample path's thread runs _on_batch holding it too (node.sample_path).
        self.callback_lock = threading.RLock()
        # A capture awaits samples in an executor task: woken when a batch gave it some.
        self._capture_fed = self.create_guard_condition(lambda: None)
        self._waker = BatchWaker(self, [self._imu_subscription, self._mag_subscription],
                                 self.param('input_batch_period_s'), self._on_batch,
                                 self.callback_lock)

    def destroy_node(self):
        """Stop the sample path's waker, then destroy the node."""
        self._waker.stop()
        return super().destroy_node()

    def apply_model(self, model):
        """Use ``model`` from now on and publish it on the latched ``~/calibration``."""
        self.model = model
        self.calibration_pub.publish(String(data=json.dumps({
            'calibration_file': self.calibration_file, 'stages': list(model.stages),
            'magnetic': model.magnetic is not None, 'applied_at': utc_now_iso(),
            # What the published toolface's zero is tied to (issue 19 item 6).
            'toolface_zero': model.toolface_zero,
            'toolface_zero_meaning': model.toolface_zero_meaning,
            'model': model.to_dict()})))

    def param(self, name):
        """Return the current value of parameter ``name``."""
        return self.get_parameter(name).value

    def calibration_mode(self):
        """Return the mode the calibration is in, as the startup log and diagnostics say it."""
        return ('field (locked: no service or parameter may change the calibration)'
                if self.field_mode else 'bench (writable: the calibration services may change it)')

    def _check_history(self):
        """Return what is wrong with the calibration file's history (logged); never raises."""
        _, problems = read_model_history(self.calibration_file)
        for problem in problems:
            self.get_logger().warning(f'calibration history: {problem} (the calibration file '
                                      'itself is used as it is)')
        return problems

    def _load_model(self):
        """
        Return the stored model and the digest of the file read, an empty one and None without.

        Raises CalibrationFileError for a file that exists but is not valid.
        """
        axes = self.settings.accelerometer_axes
        try:
            model, sha256 = load_model(self.calibration_file, with_digest=True)
        except FileNotFoundError:
            self.get_logger().warning(
                f'no calibration file at {self.calibration_file}: running UNCALIBRATED '
                '(raw angles); call ~/calibrate_level with the tool on a level bench')
            return CalibrationModel(accelerometer_axes=axes, sensor_id=self.sensor_id,
                                    axes_maps=self._axes_maps), None
        check_sensor(model, self.sensor_id, self.calibration_file)
        check_axes_maps(model, self._axes_maps, self.calibration_file)
        if model.sensor_id is None and self.sensor_id is not None:
            self.get_logger().warning(
                f'{self.calibration_file} names no sensor: taken as sensor_id '
                f'{self.sensor_id!r}, written into it on the next calibration')
        reason = axes_refusal(model, axes, self.calibration_file)
        if reason is not None:
            raise CalibrationFileError(self.calibration_file, reason)
        try:
            check_for_sensor(model, self.settings.accelerometer_range_mps2)
        except Implausible as err:
            raise CalibrationFileError(self.calibration_file, err.reason) from None
        self.get_logger().info(
            f'loaded {self.calibration_file}: stages {", ".join(model.stages) or "none"}')
        # What a new capture is made in: the maps checked above.
        return replace(model, axes_maps=self._axes_maps), sha256

    @property
    def _axes_maps(self):
        """Return the (accelerometer, magnetometer) axes maps of the parameters."""
        return (self.settings.accelerometer_axes_map, self.settings.magnetometer_axes_map)

    def _on_incompatible_qos(self, event):
        self.get_logger().warning(
            f'a publisher on imu/data_raw has an incompatible QoS (policy '
            f'{event.last_policy_kind}): its samples will not arrive')

    def _on_temperature(self, msg):
        self.temperature.update(msg.temperature, self.get_clock().now().nanoseconds * 1e-9)

    def _magnetic_settings(self):
        return MagneticSettings(
            reference_total_nT=self.param('magnetic.reference_total_nT'),
            reference_dip_deg=self.param('magnetic.reference_dip_deg'),
            declination_deg=self.param('magnetic.declination_deg'),
            noise_std_nT=self.param('magnetometer_noise_std_nT'),
            bias_instability_nT=self.param('magnetometer_bias_instability_nT'),
            azimuth_max_std_deg=self.param('magnetic.azimuth_max_std_deg'),
            limits=QcLimits(
                b_total_tolerance_nT=self.param('magnetic.b_total_tolerance_nT'),
                dip_tolerance_deg=self.param('magnetic.dip_tolerance_deg'),
                g_total_tolerance=self.param('magnetic.g_total_tolerance_mps2')))

    def _check_parameters(self, parameters):
        locked = change_refusal(self)
        if locked is not None:  # field mode: no parameter of the job changes
            return SetParametersResult(successful=False, reason=f'refused: {locked}')
        reasons = [r for r in (refusal(p.name, p.value) for p in parameters) if r]
        return SetParametersResult(successful=not reasons, reason='; '.join(reasons))

    def _on_parameters_set(self, parameters):
        if any(p.name.startswith('magnetic.') for p in parameters):
            self.magnetic_settings = self._magnetic_settings()

    def process_queued(self):
        """Correct and publish what waits on the inputs now (before a capture starts)."""
        self._on_batch()

    def _on_batch(self):
        """
        Correct and publish every sample queued on imu/data_raw, as one batch.

        The magnetometer readings queued are kept first (the samples pair with
        them).  Every accepted sample is published, or with ``output.*``
        averaging the windows it closes (``core.averaging``,
        ``pipeline.average``; a window of a moving tool is dropped, counted).
        """
        dropped = []
        mags = take_serialized(self._mag_subscription, self._take_limit)
        if mags:
            fields = decode_messages(mags, MAGNETIC_FIELD, MagneticField, dropped)
            if fields.stamps_ns.size:
                self.magnetometer.update(fields)
        messages = take_serialized(self._imu_subscription, self._take_limit)
        batch = decode_messages(messages, IMU, Imu, dropped) if messages else None
        if dropped:
            self.get_logger().warning(f'{len(dropped)} input message(s) dropped: {dropped[0]}',
                                      throttle_duration_sec=5.0)
        if batch is None or not batch.stamps_ns.size:
            return
        temperature_c = self.temperature.value_c
        refused, missing = self._missing_temperature()
        field_nT = None
        if self.magnetometer.stamp_ns is not None:  # no azimuth work without a magnetometer
            field_nT = self.magnetometer.paired(batch.stamps_ns,
                                                self.param('magnetic.max_pairing_s'),
                                                self.param('magnetometer_noise_std_nT'))
        frame_ids = (np.full(batch.stamps_ns.size, self.frame_id) if self.frame_id
                     else batch.frame_ids)
        result = correct_batch(batch.linear_acceleration_mps2, batch.stamps_ns, frame_ids,
                               self.model, self.settings, temperature_c, field_nT,
                               self.magnetic_settings, self.averager)
        survey = result.survey
        self.stats.count(survey)
        field_nT = None if survey.magnetic is None else survey.magnetic.uncorrected_nT
        if field_nT is not None:
            self.magnetometer.count(survey.magnetic)
        if self.collector.capture is not None:
            self.collector.add_samples(survey.uncorrected_mps2, temperature_c, field_nT,
                                       batch.stamps_ns[survey.accepted] * 1e-9)
            self._capture_fed.trigger()
        if self.averager is not None:
            self.stats.count_windows(result.windows_moving, result.windows_dropped)
            for text in self.stats.check_noise(result.noise_measured, (
                    self.settings.noise_std_mps2, self.param('magnetometer_noise_std_nT'))):
                self.get_logger().warning(text)
        if refused:
            self.temperature.withheld += sum(out.survey.stamps_ns.size
                                             for out in result.published)
            return
        for out in result.published:
            self._publish(out)

    def _missing_temperature(self):
        """
        Return (refused, text) of the shared rule for a missing temperature (``stats``).

        Logged when it changes (ERROR refused, WARN compensated at the
        reference): the node says so loudly once, not per batch.
        """
        refused, text = self.temperature.missing(self.model,
                                                 self.param('temperature.at_reference'))
        if text != self._missing_said:
            self._missing_said = text
            if text is not None and refused:   # (rclpy: one severity per call site)
                self.get_logger().error(text)
            elif text is not None:
                self.get_logger().warning(text)
        return refused, text

    def _publish(self, out):
        """Publish a batch's Outputs (``stream.outputs``), serialized at once."""
        for publisher, messages in (
                (self.survey_pub, encode(out.survey)),
                (self.inclination_pub, encode_float64(out.inclination_deg)),
                (self.toolface_pub, encode_float64(out.toolface_deg)),
                (self.azimuth_pub, () if out.true_azimuth_deg is None
                 else encode_float64(out.true_azimuth_deg)),
                (self.imu_pub, encode(out.imu))):
            for data in messages:
                publisher.publish(data)

    def _publish_diagnostics(self):
        now = self.get_clock().now()
        now_s = now.nanoseconds * 1e-9
        array = DiagnosticArray()
        array.header.stamp = now.to_msg()
        inputs = self.stats.status(self.get_name(), now_s, self.settings.gravity_mps2,
                                   self.param('level_capture.g_total_tolerance_mps2'),
                                   self._imu_subscription.get_publisher_count())
        stood_still = now.nanoseconds == self._diagnostics_ros_ns
        self._diagnostics_ros_ns = now.nanoseconds
        if stood_still and self.get_parameter('use_sim_time').value:
            inputs.level = max(inputs.level, DiagnosticStatus.WARN)
            inputs.message = (f'ROS time stood still since the last status: {CLOCK_HINT}; '
                              + inputs.message)
        array.status = [
            self._calibration_status(),
            inputs,
            self.temperature.status(self.get_name(), now_s, self.param('temperature.max_age_s'),
                                    temperature_stage(self.model), self._missing_temperature()),
            self.magnetometer.status(self.get_name(), self.magnetic_settings,
                                     self.model.magnetic, len(self.magnetic.stations),
                                     self.model)]
        self.diagnostics_pub.publish(array)

    def _calibration_status(self):
        status = DiagnosticStatus(name=f'{self.get_name()}: calibration',
                                  hardware_id=self.calibration_file)
        model = self.model
        values = {'calibration_file': self.calibration_file,
                  'calibration_mode': self.calibration_mode(),
                  'history_problems': '; '.join(self.history_problems) or 'none',
                  'sensor_id': str(model.sensor_id),
                  'capture_running': str(self.collector.capture is not None),
                  'stand_positions_held': str(len(self.calibration.positions)),
                  'tilt_std_deg': f'{math.degrees(model.tilt_std_rad):.5f}',
                  'uncertainty_notes': '; '.join(model.uncertainty_notes) or 'none',
                  # 'board': the published toolface is the board's (issue 19 item 6).
                  'toolface_zero': model.toolface_zero,
                  'toolface_zero_meaning': model.toolface_zero_meaning}
        values.update({f'{name}_age_days': f'{age_s / 86400.0:.2f}'
                       for name, age_s, _ in stage_ages_s(model)})
        stale = stale_stages(model, self.param('calibration.max_age_days') * 86400.0,
                             self.param('magnetic.interference_max_age_days') * 86400.0)
        if not model.calibrated:
            status.level = DiagnosticStatus.WARN
            status.message = 'uncalibrated: raw angles published; call ~/calibrate_level'
        elif stale:
            status.level = DiagnosticStatus.WARN
            status.message = 'stale: ' + '; '.join(
                f'{name} is {age_s / 86400.0:.1f} days old (limit {limit_s / 86400.0:g})'
                for name, age_s, limit_s in stale)
        else:
            status.level = DiagnosticStatus.OK
            status.message = (f'calibrated: {", ".join(model.stages)}; toolface zero: '
                              f'{model.toolface_zero}')
        if model.temperature is not None:
            values.update(temperature_range_c=f'{model.temperature.t_min_c:g} .. '
                                              f'{model.temperature.t_max_c:g}',
                          temperature_fitted_at=model.temperature.fitted_at)
        if model.stand is not None:
            values.update(stand_method=model.stand.method,
                          stand_rms_inclination_deg=str(model.stand.rms_inclination_deg),
                          stand_fitted_at=model.stand.fitted_at)
        if model.installation is not None:
            installation = model.installation
            values.update(
                gamma_deg=f'{installation.gamma_deg:.5f}',
                beta_deg=f'{installation.beta_deg:.5f}',
                theta_deg=f'{installation.theta_deg:.5f}',
                captured_at=installation.captured_at,
                sample_count=str(installation.sample_count))
        status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        return status


def served_elsewhere(_):
    """Stand for the callback of a subscription the executor never serves (``_on_batch`` does)."""
    raise AssertionError('a subscription of the sample path was served by the executor')


def temperature_stage(model):
    """
    Return the stage whose fitted temperature range the temperature diagnostics watch, or None.

    The temperature stage, else the magnetometer's, else a multi-temperature stand of either
    triad (K(T), b(T), clamped beyond its range: issue 18).
    """
    polynomial = next((stage for _, stage in model.polynomial_stages), None)
    return model.temperature or model.magnetometer_temperature or polynomial


def main(args=None):
    """Run the node until shutdown; exit 1 on a bad parameter, calibration or stations file."""
    return run_node(InclinometerNode, args,
                    refusals=(CalibrationFileError, StationsFileError, ValueError,
                              ParameterException, NameValidationException))


if __name__ == '__main__':
    sys.exit(main())
