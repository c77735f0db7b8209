"""
The node's accelerometer calibration services: level bench (seed 000), stand (seed 001).

Captures go through the node's ``capture.Collector``.  A refused request
changes nothing: the model, its file and the captured stand positions stay
as they were.
"""

from dataclasses import replace

from inclino_ros.calibration.level_capture import CaptureRefused, LevelLimits, solve_level_capture
from inclino_ros.calibration.stand_capture import (
    average_position, check_new_attitude, solve_positions)
from inclino_ros.core.stand import StandFitRefused
import numpy as np
from rclpy.callback_groups import ReentrantCallbackGroup


class CalibrationServices:
    """~/calibrate_level, ~/capture_position, ~/solve_stand_calibration, ~/clear_positions."""

    def __init__(self, node, collector):
        """Create the services on ``node`` (an InclinometerNode), capturing with ``collector``."""
        self.node = node
        self.collector = collector
        self.positions = []
        # Reentrant: a capture awaits samples without holding the default group
        # (the subscriptions keep running) and a second call is answered at once.
        group = ReentrantCallbackGroup()
        for name, callback in (('calibrate_level', self.calibrate_level),
                               ('capture_position', self.capture_position),
                               ('solve_stand_calibration', self.solve_stand_calibration),
                               ('clear_positions', self.clear_positions)):
            collector.create_service(name, callback, group)

    async def calibrate_level(self, request, response):
        """Capture the tool on a level bench and apply gamma, beta (seed 000 Eqs. 11-14)."""
        node = self.node
        limits = LevelLimits(
            max_std_deg=node.param('level_capture.max_std_deg'),
            max_tilt_deg=node.param('level_capture.max_tilt_deg'),
            gravity_mps2=node.settings.gravity_mps2,
            g_total_tolerance_mps2=node.param('level_capture.g_total_tolerance_mps2'))
        try:
            captured = await self.collector.collect('level_capture')
            installation = solve_level_capture(
                node.model.apply(captured.raw, captured.temperatures_c, before='installation'),
                node.settings.accelerometer_axes, limits)
            self.collector.commit(replace(node.model, installation=installation))
        except CaptureRefused as err:
            return self.collector.refuse(response, str(err))
        return self.collector.answer(response, (
            f'calibrated from {installation.sample_count} samples: '
            f'gamma_deg={installation.gamma_deg:.4f} beta_deg={installation.beta_deg:.4f} '
            f'theta_deg={installation.theta_deg:.4f} (spread {installation.std_deg:.4f} deg)'))

    async def capture_position(self, request, response):
        """Average a still capture at the stand attitude held in the stand.* parameters."""
        node = self.node
        if node.settings.accelerometer_axes != 3:
            return self.collector.refuse(
                response, 'stand calibration needs a three-axis accelerometer')
        inclination_deg = node.param('stand.inclination_deg')
        toolface_deg = node.param('stand.toolface_deg')
        try:
            check_new_attitude(self.positions, inclination_deg, toolface_deg)
            captured = await self.collector.collect('stand')
            position = average_position(
                node.model.apply(captured.raw, captured.temperatures_c, before='stand'),
                inclination_deg, toolface_deg, node.param('stand.max_std_deg'))
        except CaptureRefused as err:
            return self.collector.refuse(
                response, str(err), f'{len(self.positions)} positions kept')
        self.positions.append(position)
        mean = ', '.join(f'{v:.5f}' for v in position.reading_mps2)
        response.success = True
        response.message = (
            f'position {len(self.positions)} captured at inclination_deg={inclination_deg} '
            f'toolface_deg={toolface_deg}: mean ({mean}) m/s^2, spread '
            f'{position.std_deg:.4f} deg from {position.samples} samples; '
            f'{len(self.positions)} positions held (solve needs at least 6)')
        node.get_logger().info(response.message)
        return response

    def solve_stand_calibration(self, request, response):
        """Fit K and b to the captured positions (seed 001 Eq. 10), persist and apply."""
        node = self.node
        try:
            stand = solve_positions(self.positions, node.settings.gravity_mps2,
                                    node.param('stand.max_rms_deg'))
            # K is fitted against the tool's attitude on the stand, so it already
            # holds the mounting misalignment: a kept gamma/beta would count it twice.
            self.collector.commit(replace(node.model, stand=stand, installation=None))
        except (StandFitRefused, CaptureRefused) as err:
            return self.collector.refuse(response, str(err))
        k = np.array(stand.scale_matrix)
        return self.collector.answer(response, (
            f'stand calibration from {stand.positions} positions: K diagonal '
            f'({", ".join(f"{v:.5f}" for v in np.diag(k))}), bias '
            f'({", ".join(f"{v:.5f}" for v in stand.bias_mps2)}) m/s^2, condition number '
            f'{stand.condition_number:.2f}, residual rms_inclination_deg='
            f'{stand.rms_inclination_deg:.4f}; installation correction reset (K holds it)'))

    def clear_positions(self, request, response):
        """Forget the captured stand positions."""
        count = len(self.positions)
        self.positions.clear()
        response.success = True
        response.message = f'cleared {count} stand positions'
        return response
