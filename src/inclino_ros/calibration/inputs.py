"""
The readings each fit takes, from a bag or a CSV file (``inclino fit-*``).

A ``Source`` names the input and its topics; each reader returns the arrays
its fit takes.  An input that cannot be used raises ``tables.TableError`` (a
CSV) or ``bag.BagError`` (a bag): the command ends with exit code 2 and the
reason.  Axes maps are not applied here (the command turns the readings).
"""

from dataclasses import dataclass
import os

from inclino_ros.calibration.continuous_log import (
    GYRO_COLUMNS, log_segments, longest_still_part, TIME_COLUMN)
from inclino_ros.calibration.plausibility import (
    check_acceleration_unit, check_field_unit, check_temperatures, Implausible, temperature_ok)
from inclino_ros.core.refusal import Refused
from inclino_ros.core.stillness import (
    find_still_segments, label_attitudes, SegmentLimits, StillLimits)
from inclino_ros.io import tables
from inclino_ros.io.bag import (
    BagError, concatenate, IMU, ImuSeries, read, TEMPERATURE, TemperatureSeries, topic_info)
from inclino_ros.io.timing import in_window, pair_nearest
import numpy as np

AXIS_COLUMNS = ('ax', 'ay', 'az')
FIELD_COLUMNS = ('bx', 'by', 'bz')
ATTITUDE_COLUMNS = ('inclination_deg', 'toolface_deg')
AZIMUTH_COLUMN = 'azimuth_deg'
#: The column of a survey row's count of averaged readings (``survey_input``).
SAMPLES_COLUMN = 'samples'
#: Per triad of a heating run: its CSV columns and reference columns.
TRIAD_COLUMNS = {'accelerometer': (AXIS_COLUMNS, ('ref_ax', 'ref_ay', 'ref_az')),
                 'magnetometer': (FIELD_COLUMNS, ('ref_bx', 'ref_by', 'ref_bz'))}
#: Still segments of a heating log: slow (5 s windows, 10 s at least), and the readings drift
#: with the temperature (a few hundredths of a degree a second): each window must be still,
#: not a whole segment, and a window moves only beyond 0.1 deg/s or 0.5 deg within it (a
#: hand turning the tool moves it by degrees).
HEATING_SEGMENTS = SegmentLimits(window_s=5.0, min_s=10.0, whole=False, still=StillLimits(
    max_drift_deg_per_s=0.1, max_sem_deg=0.5, max_motion_deg=0.5))


@dataclass(frozen=True)
class Source:
    """A fit's input: a bag (a directory) or a CSV file at ``path``, and the bag's topics."""

    path: str
    raw_topic: str = '/imu/data_raw'
    temperature_topic: str = '/imu/temperature'
    mag_topic: str = '/imu/mag'
    attitude_topic: str = '/stand/attitude'
    start_s: float = None    # a bag's window [s after its first message], None: its start
    end_s: float = None      # None: its end

    @property
    def is_bag(self):
        """Return whether ``path`` names a bag (a directory) rather than a CSV file."""
        return os.path.isdir(self.path)


def read_topic(path, topic):
    """Return the whole series of ``topic`` in the bag ``path``; BagError if unreadable, empty."""
    chunks = list(read(path, topic))
    if not chunks:
        raise BagError(f'{topic} in {path} has no messages')
    return concatenate(chunks)


def has_topic(path, topic):
    """Return whether the bag ``path`` holds ``topic`` (of any type)."""
    try:
        topic_info(path, topic)
    except BagError:
        return False
    return True


def sample_temperatures(imu, path, topic):
    """
    Return the temperature at each Imu sample and which samples lie in its time span.

    The Temperature messages of ``topic`` are interpolated linearly to the
    Imu stamps (``TemperatureSeries.at``); samples before the first or after
    the last temperature message are outside.
    """
    series = read_topic(path, topic)
    inside = (imu.stamps_ns >= series.stamps_ns.min()) & (imu.stamps_ns <= series.stamps_ns.max())
    return series.at(imu.stamps_ns), inside


def stand_input(source, need_attitude, pairing_tolerance_nT):
    """
    Return (readings (N, 3), attitude_deg, temperature_c, times_s, fields, gyro).

    Of ``inclino fit-stand``.  The attitude (N, 3: inclination, toolface,
    azimuth: 0 without the column) is read when ``need_attitude`` (a stand
    fit), None for a sphere fit or a CSV
    without attitude columns; ``temperature_c`` (N,) or None; ``times_s``
    (N,) or None (a CSV without ``time_s``); ``fields`` (N, 3) [nT] the
    paired magnetometer readings when the input has them, else None;
    ``gyro``: a continuous log (a CSV with ``time_s`` and no attitude
    columns) gives its ``wx, wy, wz`` [rad/s] (N, 3) or None without them;
    False: not a continuous log.  A bag's Imu samples take the latest
    attitude message at or before their stamp (samples before the first are
    left out) and the magnetometer message paired by ``timing.pair_nearest``
    (within 0.05 s and ``pairing_tolerance_nT``).
    """
    if not source.is_bag:
        table = tables.read_csv(
            source.path, AXIS_COLUMNS, optional=ATTITUDE_COLUMNS + (
                'temperature_c', TIME_COLUMN, AZIMUTH_COLUMN) + FIELD_COLUMNS + GYRO_COLUMNS)
        readings = np.column_stack([table[name] for name in AXIS_COLUMNS])
        has_attitude = all(name in table for name in ATTITUDE_COLUMNS)
        if need_attitude and not has_attitude and TIME_COLUMN not in table:
            missing = [name for name in ATTITUDE_COLUMNS if name not in table]
            raise tables.TableError(f'{source.path} lacks the column(s) {", ".join(missing)} (the '
                                    f'stand attitudes), and has no {TIME_COLUMN} column (a '
                                    'continuous log, whose still segments a sphere fit takes)')
        attitude_deg = (np.column_stack(
            [table[name] for name in ATTITUDE_COLUMNS]
            + [table.get(AZIMUTH_COLUMN, np.zeros(len(readings)))])
            if need_attitude and has_attitude else None)
        fields = (np.column_stack([table[name] for name in FIELD_COLUMNS])
                  if all(name in table for name in FIELD_COLUMNS) else None)
        gyro = False
        if not has_attitude and TIME_COLUMN in table:
            gyro = (np.column_stack([table[name] for name in GYRO_COLUMNS])
                    if all(name in table for name in GYRO_COLUMNS) else None)
        return (readings, attitude_deg, table.get('temperature_c'), table.get(TIME_COLUMN),
                fields, gyro)
    imu = read_topic(source.path, source.raw_topic)
    temperature_c = (sample_temperatures(imu, source.path, source.temperature_topic)[0]
                     if has_topic(source.path, source.temperature_topic) else None)
    times_s = imu.stamps_ns * 1e-9
    if not need_attitude:
        return imu.linear_acceleration_mps2, None, temperature_c, times_s, None, False
    fields = None
    if has_topic(source.path, source.mag_topic):
        mag = read_topic(source.path, source.mag_topic)
        fields = pair_nearest(imu.stamps_ns, mag.stamps_ns, mag.field_nT, round(0.05 * 1e9),
                              pairing_tolerance_nT)[0]
    attitude = read_topic(source.path, source.attitude_topic)
    order = np.argsort(attitude.stamps_ns, kind='stable')
    latest = np.searchsorted(attitude.stamps_ns[order], imu.stamps_ns, side='right') - 1
    held = latest >= 0
    if not held.any():
        raise BagError(f'no sample of {source.raw_topic} comes at or after the first '
                       f'{source.attitude_topic} message')
    attitude_deg = attitude.vector[order[latest[held]]]
    attitude_deg[~np.isfinite(attitude_deg[:, 2]), 2] = 0.0   # z NaN: no azimuth known
    return (imu.linear_acceleration_mps2[held], attitude_deg,
            None if temperature_c is None else temperature_c[held], times_s[held],
            None if fields is None else fields[held], False)


def temperature_input(source, triad, separation_deg):
    """
    Return (temperature_c (N,), readings (N, 3), reference (N, 3) or None, attitude (N,), note).

    Of ``inclino fit-temperature`` for ``triad`` (TRIAD_COLUMNS); attitudes
    further apart in direction than ``separation_deg`` are told apart (a bag,
    a continuous log), else a CSV's ``attitude`` labels; ``note``: what was
    left out of a continuous log (``log_still_samples``), else None.
    """
    columns, reference_columns = TRIAD_COLUMNS[triad]
    if not source.is_bag:
        table = tables.read_csv(
            source.path, ('temperature_c',) + columns,
            optional=reference_columns + (TIME_COLUMN,) + GYRO_COLUMNS + tuple(
                name for name in AXIS_COLUMNS if name not in columns), text=('attitude',))
        given = [name for name in reference_columns if name in table]
        if given and len(given) != 3:
            raise tables.TableError(f'{source.path} has {", ".join(given)}: give all of '
                                    f'{", ".join(reference_columns)} or none')
        readings = np.column_stack([table[name] for name in columns])
        reference = (np.column_stack([table[name] for name in reference_columns])
                     if given else None)
        if TIME_COLUMN in table and 'attitude' not in table and not given:
            return log_still_samples(source.path, table, readings, separation_deg)
        labels = table.get('attitude', [''] * readings.shape[0])
        # Any text is a label (a number, 'up', 'A3'): rows of one label share one attitude,
        # numbered in the order they first appear.
        first = {label: number for number, label in enumerate(dict.fromkeys(labels))}
        attitude = np.array([first[label] for label in labels])
        return table['temperature_c'], readings, reference, attitude, None
    if triad == 'accelerometer':
        series = read_topic(source.path, source.raw_topic)
        readings = series.linear_acceleration_mps2
    else:
        series = read_topic(source.path, source.mag_topic)
        readings = series.field_nT
    temperature_c, inside = sample_temperatures(series, source.path, source.temperature_topic)
    if not inside.any():
        raise BagError(f'no sample of the {triad} lies within the time span of '
                       f'{source.temperature_topic}')
    readings = readings[inside]
    return (temperature_c[inside], readings, None,
            label_attitudes(readings, separation_deg), None)


def log_still_samples(path, table, readings, separation_deg):
    """
    Return (temperature_c, readings, None, attitude, note) of a continuous log's still samples.

    A CSV with ``time_s`` and no attitude or reference columns: the still
    segments of the accelerometer (``continuous_log.log_segments``, with the
    gyro ``wx, wy, wz`` when given; for the magnetometer triad too, which
    turns with it) are kept, the samples of a tool being turned left out;
    the attitudes are told apart by direction as for a bag.
    """
    accel = (np.column_stack([table[name] for name in AXIS_COLUMNS])
             if all(name in table for name in AXIS_COLUMNS) else readings)
    gyro = (np.column_stack([table[name] for name in GYRO_COLUMNS])
            if all(name in table for name in GYRO_COLUMNS) else None)
    try:
        found = log_segments(table[TIME_COLUMN], accel, gyro, limits=HEATING_SEGMENTS)
    except ValueError as err:
        raise tables.TableError(f'{path}: {err}') from None
    if not found.ranges:
        raise tables.TableError(f'{path}: a continuous log (time_s) with no still segment')
    still = found.still
    return (table['temperature_c'][still], readings[still], None,
            label_attitudes(readings[still], separation_deg),
            f'{found.lines("log")[0]}; the samples between them left out')


def level_input(source, limits):
    """
    Return the window of ``inclino fit-level``: readings (N, 3), temperature_c, times_s, note.

    ``temperature_c`` (N,) or None; ``times_s`` (N,) or None (a CSV without
    ``time_s``: the samples in order).  A bag's window: ``start_s`` to
    ``end_s`` (``timing.in_window``); a CSV log that moved: its longest
    still part (``continuous_log.longest_still_part`` with ``limits``, a
    SegmentLimits), said in ``note`` (else None).
    """
    if not source.is_bag:
        table = tables.read_csv(source.path, AXIS_COLUMNS,
                                optional=('temperature_c', TIME_COLUMN) + GYRO_COLUMNS)
        readings = np.column_stack([table[name] for name in AXIS_COLUMNS])
        temperature_c, times_s = table.get('temperature_c'), table.get(TIME_COLUMN)
        if times_s is None:
            return readings, temperature_c, times_s, None
        gyro = (np.column_stack([table[name] for name in GYRO_COLUMNS])
                if all(name in table for name in GYRO_COLUMNS) else None)
        try:
            taken, note = longest_still_part(times_s, readings, gyro, limits)
        except ValueError as err:
            raise Refused(f'{source.path}: {err}') from None
        return (readings[taken], None if temperature_c is None else temperature_c[taken],
                times_s[taken], note)
    imu = read_topic(source.path, source.raw_topic)
    window = in_window(imu.stamps_ns, source.start_s, source.end_s)
    if not window.any():
        raise BagError(f'no {source.raw_topic} message from {source.start_s} to {source.end_s} '
                       f's (the topic spans 0 .. '
                       f'{(imu.stamps_ns.max() - imu.stamps_ns.min()) * 1e-9:.3f} s)')
    temperature_c = (sample_temperatures(imu, source.path, source.temperature_topic)[0][window]
                     if has_topic(source.path, source.temperature_topic) else None)
    return (imu.linear_acceleration_mps2[window], temperature_c, imu.stamps_ns[window] * 1e-9,
            None)


def rotation_input(source):
    """
    Return the rotation's readings (N, 3) [nT] and temperatures (N,) or None (fit-rotation).

    The temperatures: a CSV's optional ``temperature_c`` column, a bag's
    ``temperature_topic`` interpolated to each reading when the bag has it
    (readings outside its span left out); a bag's window ``start_s`` to
    ``end_s`` [s after its first message] (None: its ends).
    """
    if not source.is_bag:
        table = tables.read_csv(source.path, FIELD_COLUMNS, optional=('temperature_c',))
        return (np.column_stack([table[name] for name in FIELD_COLUMNS]),
                table.get('temperature_c'))
    series = read_topic(source.path, source.mag_topic)
    seconds = (series.stamps_ns - series.stamps_ns.min()) / 1e9
    start_s = 0.0 if source.start_s is None else source.start_s
    end_s = seconds.max() if source.end_s is None else source.end_s
    window = (seconds >= start_s) & (seconds <= end_s)
    if not window.any():
        raise BagError(f'no {source.mag_topic} message between {start_s} and {end_s} s '
                       f'(the topic spans 0 .. {seconds.max():.3f} s)')
    if not has_topic(source.path, source.temperature_topic):
        return series.field_nT[window], None
    temperature_c, inside = sample_temperatures(series, source.path, source.temperature_topic)
    window &= inside
    if not window.any():
        raise BagError(f'no {source.mag_topic} message of the window lies within the time '
                       f'span of {source.temperature_topic}')
    return series.field_nT[window], temperature_c[window]


def bag_shots(source, max_pairing_s, pairing_tolerance_nT, limits):
    """
    Return (accel (S, 3), field (S, 3), temperature_c (S,) or None, paired samples).

    Of a bag's shots (fit-magnetometer).  Each Imu sample of ``raw_topic`` is
    paired with a ``mag_topic`` reading (``timing.pair_nearest`` within
    ``max_pairing_s`` and ``pairing_tolerance_nT``); the still segments of the
    paired stream, both triads still (``stillness.find_still_segments`` with
    ``limits``, a SegmentLimits), are the shots, each the mean of its
    segment, and its mean ``temperature_topic`` reading when the bag has that
    topic (``sample_temperatures``; None when a segment lies outside its time
    span).  Refused with fewer than two paired samples or more segments than
    a fit takes (``tables.MAX_SHOTS``).
    """
    imu = read_topic(source.path, source.raw_topic)
    mag = read_topic(source.path, source.mag_topic)
    field, paired = pair_nearest(imu.stamps_ns, mag.stamps_ns, mag.field_nT,
                                 round(max_pairing_s * 1e9), pairing_tolerance_nT)
    temperature_c = None
    if has_topic(source.path, source.temperature_topic):
        temperature_c, inside = sample_temperatures(imu, source.path, source.temperature_topic)
        temperature_c = np.where(inside, temperature_c, np.nan)
    order = np.argsort(imu.stamps_ns[paired], kind='stable')
    stamps = imu.stamps_ns[paired][order]
    accel = imu.linear_acceleration_mps2[paired][order]
    field = field[paired][order]
    if stamps.size < 2:
        raise Refused(f'{source.path}: fewer than two {source.raw_topic} samples with a paired '
                      f'{source.mag_topic} reading')
    segments = find_still_segments((stamps - stamps[0]) * 1e-9, accel, limits=limits,
                                   fields=field)
    _check_shot_count(len(segments))
    if temperature_c is not None:
        temperature_c = np.array([np.mean(temperature_c[paired][order][a:b])
                                  for a, b in segments])
        if not np.all(np.isfinite(temperature_c)):
            temperature_c = None
    return (np.array([accel[a:b].mean(axis=0) for a, b in segments]).reshape(-1, 3),
            np.array([field[a:b].mean(axis=0) for a, b in segments]).reshape(-1, 3),
            temperature_c, stamps.size)


def _check_shot_count(segments):
    """Refuse more still segments than a shot fit takes (``tables.MAX_SHOTS``)."""
    if segments > tables.MAX_SHOTS:
        raise Refused(f'{segments} still segments are more shots than a fit takes '
                      f'({tables.MAX_SHOTS}): take a longer --min-still-s')


def shots_input(path, limits, group_column='roll_group'):
    """
    Return (accel (S, 3), field (S, 3), labels or None, temperature_c or None, lines).

    Of ``inclino fit-magnetometer``'s CSV: one row a shot (``tables.read_shots``,
    roll groups from ``group_column``), or a continuous log, a CSV with a
    ``time_s`` column and no roll group given: its still segments, both triads
    still and the gyro ``wx, wy, wz`` (optional) turning no faster than the
    limit (``continuous_log.log_segments`` with ``limits``, the one still rule
    of a bag's), each segment's mean one shot.  ``lines``: what was found.
    TableError if unusable.
    """
    header = tables.header_of(path)
    if TIME_COLUMN not in header or (group_column in header and any(
            tables.read_csv(path, (), text=(group_column,))[group_column])):
        return (*tables.read_shots(path, AXIS_COLUMNS, FIELD_COLUMNS, group_column), [])
    table = tables.read_csv(path, (TIME_COLUMN,) + AXIS_COLUMNS + FIELD_COLUMNS,
                            optional=('temperature_c',) + GYRO_COLUMNS)
    accel, field = (np.column_stack([table[name] for name in names])
                    for names in (AXIS_COLUMNS, FIELD_COLUMNS))
    gyro = (np.column_stack([table[name] for name in GYRO_COLUMNS])
            if all(name in table for name in GYRO_COLUMNS) else None)
    try:
        found = log_segments(table[TIME_COLUMN], accel, gyro, table.get('temperature_c'),
                             limits, fields=field)
    except ValueError as err:
        raise tables.TableError(f'{path}: {err}') from None
    _check_shot_count(len(found.ranges))
    means = np.array([field[start:end].mean(axis=0)
                      for start, end in found.ranges]).reshape(-1, 3)
    return found.means, means, None, found.temperature_c, found.lines(f'log {path}') + [
        f'a continuous log ({TIME_COLUMN} column): each still segment is one shot'
        + ('' if gyro is None else ', the gyro (wx, wy, wz) checked too')]


def log_series(path):
    """
    Return (ImuSeries, TemperatureSeries or None) of a CSV log (``inclino process``).

    Each row is one sample stamped ``time_s`` (ns, frame ``csv``); the gyro
    columns go to the angular velocity (zero without them), the temperature
    column to a series of one value per row.  TableError if unusable.
    """
    table = tables.read_csv(path, (TIME_COLUMN,) + AXIS_COLUMNS,
                            optional=GYRO_COLUMNS + ('temperature_c',))
    times_s = table[TIME_COLUMN]
    if not (np.all(np.isfinite(times_s)) and np.all(np.diff(times_s) > 0.0)
            and np.all(np.abs(times_s) < 9.2e9)):
        raise tables.TableError(f'{path}: {TIME_COLUMN} must hold finite, increasing times '
                                '[s] (a continuous log in the order it was recorded)')
    stamps_ns = np.round(times_s * 1e9).astype(np.int64)
    count = stamps_ns.size
    frames = np.full(count, 'csv', dtype=object)
    gyro = (np.column_stack([table[name] for name in GYRO_COLUMNS])
            if all(name in table for name in GYRO_COLUMNS) else np.zeros((count, 3)))
    imu = ImuSeries(stamps_ns, frames, np.tile([0.0, 0.0, 0.0, 1.0], (count, 1)),
                    np.zeros((count, 9)), gyro, np.zeros((count, 9)),
                    np.column_stack([table[name] for name in AXIS_COLUMNS]),
                    np.zeros((count, 9)))
    temperature = (None if 'temperature_c' not in table else TemperatureSeries(
        stamps_ns, frames, table['temperature_c'], np.zeros(count)))
    return imu, temperature


def known_temperatures(series, name, path):
    """
    Return the TemperatureSeries of the readings a sensor gives; TableError if none.

    ``name``: the topic or column of ``series`` in the input ``path``, as the error says.
    """
    kept = temperature_ok(series.temperature_c)
    if not kept.any():
        raise tables.TableError(f'{name} in {path} holds no temperature a sensor reads')
    return TemperatureSeries(series.stamps_ns[kept], series.frame_ids[kept],
                             series.temperature_c[kept], series.variance[kept])


def imu_count(path, topic):
    """Return the message count of ``topic`` in the bag ``path``; BagError unless Imu messages."""
    msgtype, count = topic_info(path, topic)
    if msgtype != IMU:
        raise BagError(f'{topic} in {path} holds {msgtype}, not {IMU}')
    return count


def bag_temperatures(path, topic):
    """
    Return the TemperatureSeries of ``topic`` in the bag ``path`` (``known_temperatures``).

    BagError unless it holds Temperature messages.
    """
    msgtype, count = topic_info(path, topic)
    if msgtype != TEMPERATURE or count == 0:
        raise BagError(f'{topic} in {path} holds {count} {msgtype} messages, not '
                       f'{TEMPERATURE} ones')
    return known_temperatures(concatenate(read(path, topic)), topic, path)


def survey_input(path, gravity_mps2):
    """
    Return (header, rows, raw (N, 3), field (N, 3) or None, samples or None) of a survey CSV.

    ``ax, ay, az`` [m/s^2] required, ``bx, by, bz`` [nT] all three or none,
    ``samples`` (the readings each row averages) optional; TableError for a
    missing column or readings in another unit
    (``plausibility.check_acceleration_unit``, ``check_field_unit``).
    """
    header, rows = tables.read_rows(path)
    has_field = [name in header for name in FIELD_COLUMNS]
    missing = [name for name in AXIS_COLUMNS if name not in header] + (
        [name for name, has in zip(FIELD_COLUMNS, has_field) if not has]
        if any(has_field) else [])
    if missing:
        raise tables.TableError(f'{path} lacks the column(s) {", ".join(missing)}; it has '
                                f'{", ".join(header)}')
    raw = np.column_stack([tables.number_column(rows, header, n) for n in AXIS_COLUMNS])
    field = (np.column_stack([tables.number_column(rows, header, n) for n in FIELD_COLUMNS])
             if any(has_field) else None)
    averaged = tables.count_column(path, rows, header, SAMPLES_COLUMN)
    try:
        check_acceleration_unit(raw, gravity_mps2, 'ax, ay, az')
        if field is not None:
            check_field_unit(field, 'bx, by, bz')
    except Implausible as err:
        raise tables.TableError(err.reason) from None
    return header, rows, raw, field, averaged


def survey_temperatures(path, header, rows):
    """
    Return the ``temperature_c`` column [deg C] of a survey CSV; TableError if unusable.

    Every cell must be a number a sensor reads (``plausibility.TEMPERATURE_C``:
    1e6 or text is no temperature).
    """
    temperature_c = tables.number_column(rows, header, 'temperature_c')
    unread = np.flatnonzero(~np.isfinite(temperature_c))
    if unread.size:
        raise tables.TableError(
            f'{path} data row {unread[0] + 1}: temperature_c '
            f'{rows[unread[0]][header.index("temperature_c")]!r} is not a number '
            f'({unread.size} such row(s))')
    try:
        check_temperatures(temperature_c, f'{path} temperature_c')
    except Implausible as err:
        raise tables.TableError(err.reason) from None
    return temperature_c
