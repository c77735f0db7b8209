"""
The node's accelerometer calibration services: level bench (seed 000), stand (seed 001).

And the high-side mark (``calibration.toolface_mark``): the toolface's zero
tied to the tool on a tilted bench, without a stand (issue 19 item 6).

Captures go through the node's ``capture.Collector``.  A refused request
changes nothing: the model, its file and the captured stand positions stay
as they were.
"""

from dataclasses import replace

from inclino_ros.calibration.invalidation import replace_stages
from inclino_ros.calibration.level_capture import (
    angles_sigma_text, CaptureRefused, LevelLimits, solve_level_capture)
from inclino_ros.calibration.model import readings_temperature_c, temperature_conflict
from inclino_ros.calibration.plausibility import Implausible
from inclino_ros.calibration.stand_capture import (
    average_position, repeated_position, solve_positions)
from inclino_ros.calibration.stand_fit import with_stand
from inclino_ros.calibration.toolface_mark import MarkLimits, solve_toolface_mark
from inclino_ros.core.stand import StandFitRefused
from inclino_ros.core.stillness import StillLimits
import numpy as np
from rclpy.callback_groups import ReentrantCallbackGroup


#: The services that change the calibration (refused in field mode: ``capture.change_refusal``).
CHANGING = ('calibrate_level', 'solve_stand_calibration', 'capture_high_side_mark')


class CalibrationServices:
    """~/calibrate_level, ~/capture_high_side_mark and the stand's services."""

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
                               ('clear_positions', self.clear_positions),
                               ('capture_high_side_mark', self.capture_high_side_mark)):
            collector.create_service(name, callback, group, changes=name in CHANGING)

    def still_limits(self, prefix):
        """Return the StillLimits of the captures of ``prefix`` (its max_sem_deg)."""
        return StillLimits(
            max_drift_deg_per_s=self.node.param('still.max_drift_deg_per_s'),
            max_sem_deg=self.node.param(f'{prefix}.max_sem_deg'),
            max_motion_deg=self.node.param('still.max_motion_deg'),
            drift_name='still.max_drift_deg_per_s', sem_name=f'{prefix}.max_sem_deg',
            motion_name='still.max_motion_deg')

    def stage_temperature(self, captured, names):
        """
        Return the temperature the captured readings stand for; CaptureRefused on a conflict.

        The stages ``names`` must stand for the same temperature within
        ``temperature.max_stage_difference_c`` (``model.temperature_conflict``).
        """
        model = self.node.model
        temperature_c = readings_temperature_c(model.temperature, captured.temperature_c)
        reason = temperature_conflict(model, temperature_c,
                                      self.node.param('temperature.max_stage_difference_c'),
                                      names)
        if reason is not None:
            raise CaptureRefused(reason)
        return temperature_c

    async def calibrate_level(self, request, response):
        """Capture the tool on a level bench and apply gamma, beta (seed 000 Eqs. 11-14)."""
        node = self.node
        limits = LevelLimits(
            max_tilt_deg=node.param('level_capture.max_tilt_deg'),
            gravity_mps2=node.settings.gravity_mps2,
            g_total_tolerance_mps2=node.param('level_capture.g_total_tolerance_mps2'),
            still=self.still_limits('level_capture'))
        try:
            captured = await self.collector.collect('level_capture')
            temperature_c = self.stage_temperature(captured, ('stand',))
            installation = solve_level_capture(
                node.model.apply(captured.raw, captured.temperatures_c, before='installation'),
                node.settings.accelerometer_axes, limits, captured.times_s, temperature_c)
            # The level bench measures the whole mount: a tool axis on top would count twice.
            model, dropped = replace_stages(node.model, installation=installation,
                                            tool_axis=None)
            self.collector.commit(model)
        except CaptureRefused as err:
            return self.collector.refuse(response, str(err))
        return self.collector.answer(response, (
            f'calibrated from {installation.sample_count} samples: '
            f'gamma_deg={installation.gamma_deg:.4f} beta_deg={installation.beta_deg:.4f} '
            f'theta_deg={installation.theta_deg:.4f} (noise {installation.std_deg:.4f} deg per '
            f'sample, {angles_sigma_text(model)})'
            + ''.join(f'; {note}' for note in dropped)))

    async def capture_high_side_mark(self, request, response):
        """
        Capture the tool still on a tilted bench, high-side mark up: tie the toolface's zero.

        The level capture's settings (``level_capture.samples``, ``timeout_s``,
        ``max_sem_deg``, ``g_total_tolerance_mps2``); the readings go through
        every other stage first (``solve_toolface_mark``), the stage replaced.
        """
        node = self.node
        if node.settings.accelerometer_axes != 3:
            return self.collector.refuse(
                response, 'a high-side mark needs a three-axis accelerometer')
        limits = MarkLimits(
            gravity_mps2=node.settings.gravity_mps2,
            g_total_tolerance_mps2=node.param('level_capture.g_total_tolerance_mps2'),
            still=self.still_limits('level_capture'))
        try:
            captured = await self.collector.collect('level_capture')
            mark = solve_toolface_mark(
                node.model.apply(captured.raw, captured.temperatures_c, before='toolface_mark'),
                limits, node.settings.toolface_convention, captured.times_s,
                self.stage_temperature(captured, ('stand', 'installation')))
            self.collector.commit(replace(node.model, toolface_mark=mark))
        except CaptureRefused as err:
            return self.collector.refuse(response, str(err))
        return self.collector.answer(response, (
            f'high-side mark from {mark.sample_count} samples at inclination '
            f'{mark.inclination_deg:.2f} deg: offset_deg={mark.offset_deg:.4f} (1 sigma '
            f'{mark.std_deg:.4f} deg, {mark.toolface_convention} toolface)'))

    async def capture_position(self, request, response):
        """Average a still capture at the stand attitude held in the stand.* parameters."""
        node = self.node
        if node.settings.accelerometer_axes != 3:
            return self.collector.refuse(
                response, 'stand calibration needs a three-axis accelerometer')
        inclination_deg = node.param('stand.inclination_deg')
        toolface_deg = node.param('stand.toolface_deg')
        azimuth_deg = node.param('stand.azimuth_deg')
        reference = self.reference()
        try:
            repeats = repeated_position(self.positions, inclination_deg, toolface_deg,
                                        azimuth_deg, reference)
            captured = await self.collector.collect('stand')
            fields = (None if reference is None else
                      node.model.apply_magnetic(captured.field_nT, captured.temperatures_c,
                                                before='magnetometer'))
            position = average_position(
                node.model.apply(captured.raw, captured.temperatures_c, before='stand'),
                inclination_deg, toolface_deg, self.still_limits('stand'), captured.times_s,
                readings_temperature_c(node.model.temperature, captured.temperature_c),
                fields, azimuth_deg, gravity_mps2=node.settings.gravity_mps2,
                field_temperature_c=readings_temperature_c(node.model.magnetometer_temperature,
                                                           captured.temperature_c))
        except (CaptureRefused, Implausible) as err:
            return self.collector.refuse(
                response, str(err), f'{len(self.positions)} positions kept')
        self.positions.append(position)
        mean = ', '.join(f'{v:.5f}' for v in position.reading_mps2)
        field = ('' if reference is None else
                 '; no paired imu/mag reading' if position.field_nT is None else
                 f'; field ({", ".join(f"{v:.0f}" for v in position.field_nT)}) nT, spread '
                 f'{position.field_std_deg:.4f} deg')
        response.success = True
        response.message = (
            f'position {len(self.positions)} captured at inclination_deg={inclination_deg} '
            f'toolface_deg={toolface_deg} azimuth_deg={azimuth_deg}: mean ({mean}) m/s^2, '
            f'noise {position.std_deg:.4f} deg per sample from {position.samples} '
            f'samples{field}; '
            + ('' if repeats is None else
               f"a repeat of position {repeats} (its scatter is the stand's repeatability); ")
            + f'{len(self.positions)} positions held (solve needs at least 6)')
        node.get_logger().info(response.message)
        return response

    def reference(self):
        """Return the reference field (total nT, dip deg), None while it is unknown."""
        settings = self.node.magnetic_settings
        if settings.reference_total_nT <= 0:
            return None
        return settings.reference_total_nT, settings.reference_dip_deg

    def solve_stand_calibration(self, request, response):
        """Fit K and b (seed 001 Eq. 10), and K_m, b_m (Eq. 12) with a reference; apply."""
        node = self.node
        try:
            stand, field, note, repeats = solve_positions(
                self.positions, node.settings.gravity_mps2, node.param('stand.max_rms_deg'),
                self.reference(), node.param('stand.max_field_rms_deg'),
                node.param('temperature.max_stage_difference_c'),
                node.param('stand.attitude_sigma_deg'))
            model, dropped = with_stand(node.model, stand, field)
            self.collector.commit(model)
        except (StandFitRefused, CaptureRefused) as err:
            return self.collector.refuse(response, str(err))
        k = np.array(stand.scale_matrix)
        magnetometer = note if field is None else (
            f'magnetometer K_m, b_m fitted (seed 001 Eq. 12): field residual '
            f'{field.rms_residual_deg:.4f} deg RMS, bias '
            f'({", ".join(f"{v:.1f}" for v in field.magnetometer.bias_nT)}) nT'
            + ('' if field.plateaus is None else
               f', K_m(T) and b_m(T) of order {field.plateaus.order} over '
               f'{field.magnetometer.t_min_c:g} .. {field.magnetometer.t_max_c:g} C'))
        return self.collector.answer(response, (
            f'stand calibration from {len(self.positions)} positions: K diagonal '
            f'({", ".join(f"{v:.5f}" for v in np.diag(k))}), bias '
            f'({", ".join(f"{v:.5f}" for v in stand.bias_mps2)}) m/s^2, condition number '
            f'{stand.condition_number:.2f}, residual rms_inclination_deg='
            f'{stand.rms_inclination_deg:.4f}; {repeats}; {magnetometer}; installation '
            'correction reset (K holds it)' + ''.join(f'; {note}' for note in dropped)))

    def clear_positions(self, request, response):
        """Forget the captured stand positions."""
        count = len(self.positions)
        self.positions.clear()
        response.success = True
        response.message = f'cleared {count} stand positions'
        return response
