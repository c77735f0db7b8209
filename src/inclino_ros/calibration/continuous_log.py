"""
A continuous log as the fits take it: its still segments (``stillness.find_still_segments``).

A user's own recording (a CSV with a time column, the accelerometer and
optionally a gyro and the temperature) holds the tool still in several poses
with motion between them.  The fits use only the still segments, found by
the still test every capture passes: a sphere fit takes each segment's mean
as one reading, a level fit the longest segment, a temperature fit the
still samples (each segment's direction an attitude).
"""

from dataclasses import dataclass

from inclino_ros.core.stand import consecutive_poses
from inclino_ros.core.stillness import (
    assess, find_still_segments, MIN_SAMPLES, motion, SegmentLimits, StillLimits, tangent_angles)
import numpy as np

#: Log columns: the time [s] (increasing), the gyro [rad/s] (optional).
TIME_COLUMN = 'time_s'
GYRO_COLUMNS = ('wx', 'wy', 'wz')


@dataclass(frozen=True)
class LogSegments:
    """The still segments of a log: sample ranges, means and what each stood for."""

    ranges: tuple               # ((start, end), ...) sample index ranges
    means: np.ndarray           # (S, 3) mean reading of each segment
    samples: np.ndarray         # (S,) samples in each
    temperature_c: np.ndarray   # (S,) mean temperature of each, or None
    still: np.ndarray           # (N,) bool: the sample lies in a segment
    segment: np.ndarray         # (N,) segment number of each sample, -1 outside

    def lines(self, what='log'):
        """Return a summary of the segments as text lines."""
        if not self.ranges:
            return [f'no still segment found in the {what}']
        duration = [end - start for start, end in self.ranges]
        return [f'{len(self.ranges)} still segment(s) found in the {what}: '
                f'{int(self.still.sum())} of {self.still.size} samples '
                f'({min(duration)}..{max(duration)} samples a segment)']


def segment_limits(max_drift_deg_per_s, max_sem_deg, sem_name='--max-sem-deg',
                   max_motion_deg=None, motion_name='--max-motion-deg', **segment):
    """
    Return the SegmentLimits of a command's still options (the capture's own limits).

    ``sem_name``: the option of ``max_sem_deg`` as the messages name it;
    ``max_motion_deg`` (``StillLimits``), named ``motion_name``; None:
    ``max_sem_deg`` under ``sem_name`` (a segment's one tolerance);
    ``segment``: other SegmentLimits fields (``window_s``, ``min_s``,
    ``max_rate_deg_per_s``), their defaults otherwise.
    """
    if max_motion_deg is None:
        max_motion_deg, motion_name = max_sem_deg, sem_name
    still = StillLimits(max_drift_deg_per_s=max_drift_deg_per_s, max_sem_deg=max_sem_deg,
                        max_motion_deg=max_motion_deg, drift_name='--max-drift-deg-per-s',
                        sem_name=sem_name, motion_name=motion_name)
    return SegmentLimits(still=still, **segment)


def log_segments(times_s, readings, gyro_radps=None, temperature_c=None,
                 limits=SegmentLimits(), fields=None):
    """
    Return the LogSegments of a continuous log (``stillness.find_still_segments``).

    ``times_s`` (N,) [s], increasing (ValueError otherwise: a log written
    out of order or with repeated times is not a continuous log);
    ``readings`` (N, 3); ``gyro_radps`` (N, 3) or None; ``temperature_c``
    (N,) or None; ``fields`` (N, 3): the magnetometer's readings at the same
    samples, still too in a segment, or None.
    """
    times_s = np.asarray(times_s, dtype=float).reshape(-1)
    if not (np.all(np.isfinite(times_s)) and np.all(np.diff(times_s) > 0.0)):
        raise ValueError('the time column must hold finite, increasing times (a continuous '
                         'log in the order it was recorded)')
    readings = np.asarray(readings, dtype=float).reshape(-1, 3)
    ranges = find_still_segments(times_s, readings, gyro_radps, limits, fields)
    segment = np.full(times_s.size, -1)
    for number, (start, end) in enumerate(ranges):
        segment[start:end] = number
    means = np.array([readings[start:end].mean(axis=0) for start, end in ranges]).reshape(-1, 3)
    temperatures = (None if temperature_c is None else np.array(
        [np.mean(np.asarray(temperature_c, dtype=float)[start:end]) for start, end in ranges]))
    return LogSegments(ranges=tuple(ranges), means=means,
                       samples=np.array([end - start for start, end in ranges], dtype=int),
                       temperature_c=temperatures, still=segment >= 0, segment=segment)


def longest_still_part(times_s, readings, gyro_radps=None, limits=SegmentLimits()):
    """
    Return (index array of the samples a one-attitude capture takes, note or None).

    A capture whose samples are still as a whole (``stillness.motion``) is
    taken whole (note None).  A continuous log that moved gives its longest
    still segment (``log_segments``), said in the note; ValueError when it
    has none.
    """
    readings = np.asarray(readings, dtype=float).reshape(-1, 3)
    everything = np.arange(readings.shape[0])
    if readings.shape[0] >= MIN_SAMPLES and np.all(np.isfinite(readings)) and motion(
            assess(tangent_angles(readings), times_s), limits.still) is None:
        return everything, None
    found = log_segments(times_s, readings, gyro_radps, limits=limits)
    if not found.ranges:
        raise ValueError('the log moves and has no still segment (still for at least '
                         f'{limits.min_s:g} s)')
    longest = int(np.argmax(found.samples))
    start, end = found.ranges[longest]
    return everything[start:end], (
        f'the log moves: its longest still segment taken, samples {start + 1}..{end} '
        f'({end - start} samples, {times_s[end - 1] - times_s[start]:.2f} s; '
        f'{len(found.ranges)} still segment(s) in all)')


def sphere_readings(readings, segment=None, stood_c=None):
    """
    Return (readings, stood_c, note or None) a sphere fit takes: one per still pose.

    ``segment`` (N,): each reading's still segment of a continuous log
    (``log_segments``), or None: readings taken one after the other are
    grouped by pose when they are the samples of still poses in turn
    (``stand.consecutive_poses``; a single sample's noise is no residual of
    the model), else each is one reading (shots).  ``stood_c`` (N,) or None:
    the temperature each stood for, averaged likewise.  Readings of no pose
    (-1) are left out.
    """
    readings = np.asarray(readings, dtype=float).reshape(-1, 3)
    note = None
    if segment is None:
        segment = consecutive_poses(readings)
        if segment is None:
            return readings, stood_c, None
        note = (f'the {readings.shape[0]} readings are samples of {segment.max() + 1} still '
                "poses in turn (their direction jumps between poses): each pose's mean is one "
                "reading (a single sample's noise is no residual of the model)")
    poses = np.unique(segment[segment >= 0])
    means = np.array([readings[segment == k].mean(axis=0) for k in poses]).reshape(-1, 3)
    if stood_c is not None:
        stood_c = np.array([np.mean(np.asarray(stood_c)[segment == k]) for k in poses])
    return means, stood_c, note
