"""
Captures for the node's services: samples that arrive after a call.

One Collector per node runs at most one capture at a time.  The services
``await`` it in a reentrant callback group, so the node keeps processing and
publishing every sample meanwhile.  The Collector also holds the answers the
services share: commit a model (write atomically, then apply), succeed,
refuse (nothing changed), and ``guarded``, which turns any failure of a
service into a refusal with the reason: no request crashes the node.

Who may change the calibration is one rule, ``change_refusal``: every
service that changes it (created with ``changes=True``), every commit and the
node's parameter callback ask it.  In field mode (the read-only parameter
``field_mode``) it refuses them all; everything else goes on.  A commit
writes through ``model.save_model`` (its history keeps the version replaced)
and never over a file another writer changed since the node read it: it is
refused (``CalibrationChanged``) rather than merged, as every stage is
measured through the stages before it (a level capture through the stand
and temperature stages the node held): a merge would join stages measured
against different predecessors.

A capture's memory is bounded: a counted one holds its ``count`` samples in
one array (at most the parameters' 1 000 000), a timed one (the rotation) at
most MAX_TIMED_ROWS, every other sample dropped whenever it is full, so what
it holds stays spread over the whole capture at any rate.

Feedback, on ``~/capture_progress`` (std_msgs/String, JSON, latched): while a
capture runs, every PROGRESS_PERIOD_S, the samples so far and needed, the
time left and the spread so far; then every service's answer.
"""

from dataclasses import dataclass, replace
import functools
import inspect
import json
import math
import traceback

from inclino_ros.calibration.model import CalibrationChanged, save_model
from inclino_ros.calibration.plausibility import check_for_sensor, Implausible
from inclino_ros.calibration.still_capture import CaptureRefused
from inclino_ros.core.screening import REASONS
import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from std_msgs.msg import String
from std_srvs.srv import Trigger

#: Seconds between two progress messages of a running capture.
PROGRESS_PERIOD_S = 0.2
#: Wall seconds of ROS time standing still after which a capture is refused: /clock of a
#: playing bag ticks many times a second; 5 s without a tick is no clock at all.
STALLED_CLOCK_S = 5.0
#: What a ROS time standing still under use_sim_time asks (a capture's refusal, diagnostics).
CLOCK_HINT = ('use_sim_time is set: does anything publish /clock? (ros2 bag play --clock; '
              'inclino play publishes none: set use_sim_time false)')

#: Most samples a timed capture holds (even: halved when full).
MAX_TIMED_ROWS = 65536
#: Columns of a captured row: raw (3), temperature, field (3), stamp.
COLUMNS = 8
#: Why a request that would change the calibration is refused in field mode.
FIELD_MODE_REFUSAL = 'the calibration is locked (field mode)'


def change_refusal(node):
    """
    Return why a request may not change ``node``'s calibration now; None when it may.

    The one rule every changing service, commit and parameter change asks.
    """
    return FIELD_MODE_REFUSAL if node.field_mode else None


@dataclass(frozen=True)
class Captured:
    """The samples of one capture, aligned."""

    raw: np.ndarray             # (N, 3) accepted accelerometer readings [m/s^2], tool axes
    temperatures_c: np.ndarray  # (N,) when every sample had one, else None
    field_nT: np.ndarray        # (N, 3) paired magnetometer readings, tool axes, NaN unpaired
    times_s: np.ndarray         # (N,) header stamps of the samples [s]
    # raw and field: the axes maps applied, no correction (pipeline.Survey.uncorrected_*)

    @property
    def temperature_c(self):
        """Return the capture's mean temperature [deg C]; None unless every sample had one."""
        return None if self.temperatures_c is None else float(np.mean(self.temperatures_c))


class Capture:
    """Samples collected for one service call: ``count`` of them, or all within a time."""

    def __init__(self, count, wait_s=None, started_s=0.0, max_timed_rows=MAX_TIMED_ROWS):
        """Collect ``count`` samples (None: until ``expire``), then complete ``self.future``."""
        self.count = count
        self.future = Future()
        self._rows = np.empty((count if count is not None else max_timed_rows, COLUMNS))
        self.size = 0     # rows held
        self.seen = 0     # samples offered
        self.stride = 1   # a timed capture holds every stride-th sample
        self.wait_s, self.started_s = wait_s, started_s
        self._directions = [0.0, 0.0, 0.0]   # sum of the unit directions of the readings
        self.stalled = False                 # ended because ROS time stood still (ClockWatch)

    def add(self, raw, temperature_c, field_nT, stamp_s):
        """Add one accepted sample; complete the future when enough are in."""
        if self.future.done():
            return
        norm = math.sqrt(raw[0] * raw[0] + raw[1] * raw[1] + raw[2] * raw[2])
        if norm > 0.0:
            for axis in range(3):
                self._directions[axis] += raw[axis] / norm
        index, self.seen = self.seen, self.seen + 1
        if index % self.stride:
            return
        if self.size == self._rows.shape[0]:  # a full timed capture: keep every other row
            half = (self.size + 1) // 2
            self._rows[:half] = self._rows[:self.size:2]
            self.size, self.stride = half, 2 * self.stride
            if index % self.stride:
                return
        self._rows[self.size] = (*raw, np.nan if temperature_c is None else temperature_c,
                                 *field_nT, stamp_s)
        self.size += 1
        if self.size == self.count:
            self.future.set_result(self._rows[:self.size])

    def spread_deg(self):
        """
        Return the spread of the directions so far [deg], None below two samples.

        The RMS distance of the unit directions from their mean direction,
        sqrt(2 (1 - R)) with R the length of their mean: the RMS angle about
        the mean for a still tool, kept in three running sums.
        """
        if self.seen < 2:
            return None
        mean_length = math.sqrt(sum(v * v for v in self._directions)) / self.seen
        return math.degrees(math.sqrt(max(2.0 * (1.0 - mean_length), 0.0)))

    def progress(self, now_s):
        """Return the progress fields: samples, needed, elapsed_s, time_left_s, spread_deg."""
        elapsed_s = now_s - self.started_s
        return {'samples': self.seen, 'needed': self.count,
                'elapsed_s': round(elapsed_s, 3),
                'time_left_s': round(max(self.wait_s - elapsed_s, 0.0), 3),
                'spread_deg': self.spread_deg()}

    def expire(self):
        """Time is up: complete with what a timed capture holds, None for a counted one."""
        if not self.future.done():
            self.future.set_result(self._rows[:self.size] if self.count is None else None)

    def stall(self):
        """ROS time stands still: complete with nothing (``stalled`` says why)."""
        if not self.future.done():
            self.stalled = True
            self.future.set_result(None)


class ClockWatch:
    """
    Calls ``on_stall()`` when the node's ROS time stands still for STALLED_CLOCK_S of wall time.

    A capture's time limit runs on the node's clock, which is ROS time: with
    ``use_sim_time`` and nothing publishing ``/clock`` that time never moves,
    and the capture would wait for ever (its progress frozen).  Wall time
    bounds it: not as the limit itself (a bag played slower than real time
    legitimately stretches a capture in wall time), but as proof that ROS time
    moves at all.
    """

    def __init__(self, node, on_stall):
        """Watch ``node``'s clock once a wall-clock second."""
        self._node, self._on_stall = node, on_stall
        self._last_ns = node.get_clock().now().nanoseconds
        self._still_s = 0.0
        self._timer = node.create_timer(1.0, self._check, clock=Clock(
            clock_type=ClockType.STEADY_TIME))

    def _check(self):
        now_ns = self._node.get_clock().now().nanoseconds
        self._still_s = self._still_s + 1.0 if now_ns == self._last_ns else 0.0
        self._last_ns = now_ns
        if self._still_s >= STALLED_CLOCK_S:
            self._on_stall()

    def destroy(self):
        """Stop watching."""
        self._node.destroy_timer(self._timer)


def guarded(collector, callback):
    """
    Return ``callback`` (a service callback, plain or async) with failures made refusals.

    Every expected refusal is answered by the service itself; anything else
    (a bug, a numerical failure nobody foresaw) is logged with its traceback
    and answered as a refusal naming it, instead of ending the node.
    """
    if inspect.iscoroutinefunction(callback):
        @functools.wraps(callback)
        async def run_async(request, response):
            try:
                return await callback(request, response)
            except Exception as err:  # the last resort: a refusal, not a dead node
                return collector.fail(response, err)
        return run_async

    @functools.wraps(callback)
    def run(request, response):
        try:
            return callback(request, response)
        except Exception as err:  # the last resort: a refusal, not a dead node
            return collector.fail(response, err)
    return run


class Collector:
    """Runs the node's captures and the shared service answers."""

    def __init__(self, node):
        """Serve ``node`` (an InclinometerNode); create the ``~/capture_progress`` topic."""
        self.node = node
        self.capture = None
        self.service = None      # the service whose callback runs (set by create_service)
        self.progress_pub = node.create_publisher(String, '~/capture_progress', latched_qos())

    def create_service(self, name, callback, group, changes=False):
        """
        Create the Trigger service ``~/<name>``; its answers go to ``~/capture_progress``.

        ``changes``: it changes the calibration, so ``change_refusal`` is asked first.
        """
        async def reported(request, response):
            self.service = name
            reason = change_refusal(self.node) if changes else None
            if reason is not None:
                response = self.refuse(response, reason)
            else:
                response = guarded(self, callback)(request, response)
            if inspect.isawaitable(response):
                response = await response
            self.publish_progress(name, 'succeeded' if response.success else 'refused',
                                  message=response.message)
            return response

        self.node.create_service(Trigger, f'~/{name}', reported, callback_group=group)

    def publish_progress(self, service, state, capture=None, **fields):
        """Publish one ``~/capture_progress`` message (JSON)."""
        doc = {'service': service, 'state': state}
        if capture is not None:
            doc.update(capture.progress(self._now_s()))
        doc.update(fields)
        self.progress_pub.publish(String(data=json.dumps(doc)))

    def _now_s(self):
        return self.node.get_clock().now().nanoseconds * 1e-9

    def add_samples(self, raw, temperature_c, field_nT, stamps_s):
        """
        Give accepted samples to the running capture, if any.

        ``raw`` (M, 3) and ``field_nT`` (M, 3, NaN rows unpaired; None without a
        magnetometer) in the tool axes, ``temperature_c`` one value for the
        batch or None, ``stamps_s`` (M,).
        """
        if self.capture is None:
            return
        if field_nT is None:
            field_nT = np.full_like(raw, np.nan)
        for row, field, stamp_s in zip(raw.tolist(), field_nT.tolist(), stamps_s.tolist()):
            self.capture.add(row, temperature_c, field, stamp_s)

    async def collect(self, prefix, duration_s=None):
        """
        Return the Captured samples of a new capture, or raise CaptureRefused.

        Counted: ``<prefix>.samples`` within ``<prefix>.timeout_s``; timed: every
        sample within ``duration_s``.
        """
        if self.capture is not None:
            raise CaptureRefused('a capture is already running')
        node = self.node
        service = self.service
        # Samples queued before the call (the sample path batches them) are not its own.
        node.process_queued()
        count = None if duration_s else node.param(f'{prefix}.samples')
        wait_s = duration_s or node.param(f'{prefix}.timeout_s')
        capture = self.capture = Capture(count, wait_s, self._now_s())
        dropped_before = list(node.stats.dropped_total)
        timer = node.create_timer(wait_s, capture.expire)
        watch = ClockWatch(node, capture.stall)
        ticker = node.create_timer(PROGRESS_PERIOD_S, lambda: self.publish_progress(
            service, 'collecting', capture))
        self.publish_progress(service, 'collecting', capture)
        node.get_logger().info(f'{prefix}: collecting '
                               f'{f"{count} samples" if count else f"for {wait_s} s"}')
        try:
            rows = await capture.future
        finally:
            node.destroy_timer(timer)
            node.destroy_timer(ticker)
            watch.destroy()
            self.capture = None
            self.publish_progress(service, 'collected', capture)
        if capture.stalled:
            raise CaptureRefused(
                f'ROS time stood still for {STALLED_CLOCK_S:g} s of wall time: {CLOCK_HINT}')
        if rows is None or rows.shape[0] == 0:
            dropped = {reason: after - before for reason, after, before in zip(
                REASONS, node.stats.dropped_total, dropped_before) if after > before}
            raise CaptureRefused(
                f'no data: {capture.size} of {count or "any"} samples arrived on '
                f'{node.resolve_topic_name("imu/data_raw")} within {wait_s} s'
                + (f' ({sum(dropped.values())} dropped: '
                   + ', '.join(f'{n} {reason}' for reason, n in dropped.items()) + ')'
                   if dropped else ''))
        temperatures_c = rows[:, 3]
        if np.isnan(temperatures_c).any():
            if node.model.temperature is not None:
                raise CaptureRefused('no temperature on imu/temperature for some samples: the '
                                     'temperature stage of the model needs one')
            temperatures_c = None
        return Captured(raw=rows[:, :3], temperatures_c=temperatures_c, field_nT=rows[:, 4:7],
                        times_s=rows[:, 7])

    def commit(self, model):
        """
        Write ``model`` atomically, then apply it; CaptureRefused if it is not written.

        Refused when the calibration may not change (``change_refusal``) and
        when the file changed on disk since the node read it.
        """
        node = self.node
        reason = change_refusal(node)
        if reason is not None:
            raise CaptureRefused(reason)
        model = replace(model, sensor_id=node.sensor_id or model.sensor_id)
        try:
            check_for_sensor(model, node.settings.accelerometer_range_mps2)
            digest = save_model(node.calibration_file, model,
                                f'node {node.get_fully_qualified_name()}/{self.service}',
                                based_on=node.calibration_sha256,
                                history_keep=node.param('calibration.history_keep'),
                                report=node.get_logger().info)
        except CalibrationChanged as err:
            raise CaptureRefused(str(err)) from None
        except OSError as err:
            raise CaptureRefused(f'cannot write {self.node.calibration_file}: {err}') from None
        except (ValueError, Implausible) as err:  # what load_model would refuse
            raise CaptureRefused(f'the result is not a plausible calibration: {err}') from None
        node.calibration_sha256 = digest
        node.apply_model(model)

    def answer(self, response, message, saved=True):
        """Fill a successful response (and log it)."""
        response.success = True
        response.message = (f'{message}; saved to {self.node.calibration_file}; '
                            + '; '.join(self.node.model.toolface_zero_lines)) if saved \
            else message
        self.node.get_logger().info(response.message)
        return response

    def fail(self, response, error):
        """Answer an unexpected failure of a service as a refusal (logged with its traceback)."""
        self.node.get_logger().error(
            f'a service failed unexpectedly: {error!r}\n'
            + ''.join(traceback.format_exception(error)))
        return self.refuse(response, f'internal error ({type(error).__name__}: {error})')

    def refuse(self, response, reason, kept='previous calibration kept'):
        """Fill a refusal: nothing was changed (and log it)."""
        response.success = False
        response.message = f'refused: {reason}; {kept}'
        self.node.get_logger().warning(response.message)
        return response


def latched_qos():
    """Return the QoS of a latched topic: reliable, transient local, the last message kept."""
    return QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
