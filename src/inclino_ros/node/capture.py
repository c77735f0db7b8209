"""
Captures for the node's services: samples that arrive after a call.

One Collector per node runs at most one capture at a time.  The services
``await`` it in a reentrant callback group, so the node keeps processing and
publishing every sample meanwhile.  The Collector also holds the answers the
services share: commit a model (write atomically, then apply), succeed,
refuse (nothing changed).
"""

from dataclasses import dataclass

from inclino_ros.calibration.level_capture import CaptureRefused
from inclino_ros.calibration.model import save_model
import numpy as np
from rclpy.task import Future


@dataclass(frozen=True)
class Captured:
    """The samples of one capture, aligned."""

    raw: np.ndarray             # (N, 3) accepted accelerometer readings [m/s^2], tool axes
    temperatures_c: np.ndarray  # (N,), or None when the model has no temperature stage
    field_nT: np.ndarray        # (N, 3) paired magnetometer readings, tool axes, NaN unpaired
    # raw and field: the axes maps applied, no correction (pipeline.Survey.uncorrected_*)


class Capture:
    """Samples collected for one service call: ``count`` of them, or all within a time."""

    def __init__(self, count):
        """Collect ``count`` samples (None: until ``expire``), then complete ``self.future``."""
        self.count = count
        self.future = Future()
        self.rows = []

    def add(self, raw, temperature_c, field_nT):
        """Add one accepted sample; complete the future when enough are in."""
        self.rows.append((*raw, np.nan if temperature_c is None else temperature_c, *field_nT))
        if len(self.rows) == self.count and not self.future.done():
            self.future.set_result(np.array(self.rows))

    def expire(self):
        """Time is up: complete with what a timed capture holds, None for a counted one."""
        if not self.future.done():
            self.future.set_result(np.array(self.rows).reshape(-1, 7)
                                   if self.count is None else None)


class Collector:
    """Runs the node's captures and the shared service answers."""

    def __init__(self, node):
        """Serve ``node`` (an InclinometerNode)."""
        self.node = node
        self.capture = None

    def add_sample(self, raw, temperature_c, field_nT):
        """Give an accepted sample to the running capture, if any."""
        if self.capture is not None:
            self.capture.add(raw, temperature_c, field_nT)

    async def collect(self, prefix, duration_s=None):
        """
        Return the Captured samples of a new capture, or raise CaptureRefused.

        Counted: ``<prefix>.samples`` within ``<prefix>.timeout_s``; timed: every
        sample within ``duration_s``.
        """
        if self.capture is not None:
            raise CaptureRefused('a capture is already running')
        node = self.node
        count = None if duration_s else node.param(f'{prefix}.samples')
        wait_s = duration_s or node.param(f'{prefix}.timeout_s')
        capture = self.capture = Capture(count)
        timer = node.create_timer(wait_s, capture.expire)
        node.get_logger().info(f'{prefix}: collecting '
                               f'{f"{count} samples" if count else f"for {wait_s} s"}')
        try:
            rows = await capture.future
        finally:
            node.destroy_timer(timer)
            self.capture = None
        if rows is None or rows.shape[0] == 0:
            raise CaptureRefused(
                f'no data: {len(capture.rows)} of {count or "any"} samples arrived on '
                f'{node.resolve_topic_name("imu/data_raw")} within {wait_s} s')
        temperatures_c = rows[:, 3]
        if node.model.temperature is None:
            temperatures_c = None
        elif np.isnan(temperatures_c).any():
            raise CaptureRefused('no temperature on imu/temperature for some samples: the '
                                 'temperature stage of the model needs one')
        return Captured(raw=rows[:, :3], temperatures_c=temperatures_c, field_nT=rows[:, 4:])

    def commit(self, model):
        """Write ``model`` atomically, then apply it; CaptureRefused if it is not written."""
        try:
            save_model(self.node.calibration_file, model)
        except OSError as err:
            raise CaptureRefused(f'cannot write {self.node.calibration_file}: {err}') from None
        except ValueError as err:  # save_model refuses what load_model would refuse
            raise CaptureRefused(f'the result is not a plausible calibration: {err}') from None
        self.node.model = model

    def answer(self, response, message, saved=True):
        """Fill a successful response (and log it)."""
        response.success = True
        response.message = f'{message}; saved to {self.node.calibration_file}' if saved \
            else message
        self.node.get_logger().info(response.message)
        return response

    def refuse(self, response, reason, kept='previous calibration kept'):
        """Fill a refusal: nothing was changed (and log it)."""
        response.success = False
        response.message = f'refused: {reason}; {kept}'
        self.node.get_logger().warning(response.message)
        return response
