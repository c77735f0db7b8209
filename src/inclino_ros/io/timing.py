"""
Pairing of two sensor streams by their stamps.

The azimuth (seed 002) needs, for each accelerometer sample, the
magnetometer reading of the same moment and attitude; the node, ``inclino
process`` and the fits pair them with the same function (``pair_nearest``).
"""

from dataclasses import dataclass

from inclino_ros.io.bag import (
    BagError, concatenate, IMU, list_topics, MAGNETIC_FIELD, read, TEMPERATURE)
import numpy as np


#: Sigmas per axis within which the two readings bracketing a sample agree (their
#: difference has sqrt(2) times one reading's noise): a still tool's pair exceeds it with a
#: chance of 3 x 5.7e-7, a change of attitude between two stations by thousands of nT does.
PAIRING_SIGMA = 5.0


def pairing_tolerance(noise_std):
    """Return the per-axis difference two readings of one attitude stay within (5 sigma)."""
    return PAIRING_SIGMA * np.sqrt(2.0) * float(noise_std)


def pair_nearest(stamps_ns, reading_stamps_ns, readings, max_gap_ns, tolerance):
    """
    Return (values (N, k), paired (N,)): per stamp the nearest reading of its attitude.

    The one pairing rule of the node and ``inclino process`` (and the fits).  A
    reading is the field at its own stamp; between two readings the tool may
    turn (a slow magnetometer, 10 Hz against 200 Hz, reads once per 20
    samples), so the nearest reading alone may be of another attitude: the
    last samples of a station took the next station's reading.  The rule:
    the readings bracketing the sample (the latest at or before it, the
    earliest after it) must agree within ``tolerance`` on every axis (the
    difference of two readings of one attitude: ``pairing_tolerance`` of their
    noise); if they differ more, the attitude changed between them, at an
    unknown moment, and the sample is unpaired (NaN, counted), never given a
    reading across that change.  Where they agree the nearest one is taken
    (of two equally near, the earlier); a reading at the sample's own stamp is
    always its own.  A sample with a reading on one side only (before the
    first reading, after the last one so far: the live node's newest samples)
    takes that one, as its attitude cannot be checked yet.

    ``reading_stamps_ns`` need not be sorted (a best-effort topic may deliver
    out of order).  A reading with a non-finite value is never paired (some
    drivers publish NaN between two measurements): the finite ones bracket.
    A stamp with no reading within ``max_gap_ns`` (inclusive) gets a NaN row.
    Stamps are int64 nanoseconds throughout, so no precision is lost.
    """
    stamps = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
    readings = np.asarray(readings, dtype=float)
    if readings.ndim == 1:
        readings = readings[:, None]
    unpaired = np.full((stamps.size, readings.shape[1]), np.nan)
    finite = np.isfinite(readings).all(axis=1)
    if not finite.any():
        return unpaired, np.zeros(stamps.size, dtype=bool)
    reading_stamps = np.asarray(reading_stamps_ns, dtype=np.int64).reshape(-1)[finite]
    readings = readings[finite]
    order = np.argsort(reading_stamps, kind='stable')
    reading_stamps = reading_stamps[order]
    readings = readings[order]
    last = reading_stamps.size - 1
    after = np.searchsorted(reading_stamps, stamps, side='right')   # first reading > stamp
    before = after - 1                                              # last reading <= stamp
    has_before, has_after = before >= 0, after <= last
    after, before = np.clip(after, 0, last), np.clip(before, 0, last)
    nearest = np.where(~has_before | has_after & (
        reading_stamps[after] - stamps < stamps - reading_stamps[before]), after, before)
    exact = has_before & (reading_stamps[before] == stamps)
    agree = np.all(np.abs(readings[after] - readings[before]) <= tolerance, axis=1)
    paired = (np.abs(reading_stamps[nearest] - stamps) <= max_gap_ns) & (
        exact | ~(has_before & has_after) | agree)
    return np.where(paired[:, None], readings[nearest], unpaired), paired


def in_window(stamps_ns, start_s=0.0, end_s=None):
    """
    Return which stamps lie from ``start_s`` up to, not at, ``end_s`` s after the first.

    Half open, so that windows that meet (``--end-s 3``, ``--start-s 3``) share no
    sample: a simulated segment starts exactly on its second.
    """
    offset_ns = np.asarray(stamps_ns, dtype=np.int64) - np.min(stamps_ns)
    keep = offset_ns >= round(start_s * 1e9)
    if end_s is not None:
        keep &= offset_ns < round(end_s * 1e9)
    return keep


#: What a sensor bag replays (``Timeline``): Imu, MagneticField and Temperature topics.
SENSOR_TYPES = (IMU, MAGNETIC_FIELD, TEMPERATURE)


@dataclass(frozen=True)
class Timeline:
    """Messages of several topics in stamp order: which topic, which row of its series."""

    topics: tuple           # ((topic, msgtype, series), ...)
    stamps_ns: np.ndarray   # (M,) sorted
    topic_index: np.ndarray  # (M,) into topics
    row: np.ndarray         # (M,) into that topic's series

    @classmethod
    def of(cls, topics):
        """Return the Timeline of ``(topic, msgtype, series)`` triples (stable stamp order)."""
        stamps = np.concatenate([series.stamps_ns for _, _, series in topics])
        index = np.concatenate([np.full(series.stamps_ns.size, k)
                                for k, (_, _, series) in enumerate(topics)])
        row = np.concatenate([np.arange(series.stamps_ns.size) for _, _, series in topics])
        order = np.argsort(stamps, kind='stable')
        return cls(tuple(topics), stamps[order], index[order], row[order])

    def __len__(self):
        """Return the number of messages."""
        return self.stamps_ns.size

    def window(self, start_s=0.0, end_s=None):
        """Return the messages from ``start_s`` up to (not at) ``end_s`` s after the first."""
        keep = in_window(self.stamps_ns, start_s, end_s)
        return Timeline(self.topics, self.stamps_ns[keep], self.topic_index[keep],
                        self.row[keep])

    def entry(self, k):
        """Return (topic, msgtype, series, row) of the k-th message."""
        topic, msgtype, series = self.topics[self.topic_index[k]]
        return topic, msgtype, series, int(self.row[k])


def load_timeline(path, topics=None):
    """Return the Timeline of the sensor topics of the bag ``path`` (or of ``topics``)."""
    available = list_topics(path)
    if topics is None:
        topics = sorted(t for t, (msgtype, count) in available.items()
                        if msgtype in SENSOR_TYPES and count)
        if not topics:
            raise BagError(f'{path} has no Imu, MagneticField or Temperature topic; it has: '
                           + ', '.join(f'{t} ({m})' for t, (m, _) in sorted(available.items())))
    for topic in topics:
        msgtype = available.get(topic, (None,))[0]
        if msgtype not in SENSOR_TYPES:
            raise BagError(f'{topic} in {path} is {msgtype or "not there"}; inclino play '
                           f'publishes {", ".join(SENSOR_TYPES)}')
    return Timeline.of([(topic, available[topic][0], concatenate(read(path, topic)))
                        for topic in topics if available[topic][1]])
