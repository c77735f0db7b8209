"""
ROS 2 bags of Imu, MagneticField, Vector3Stamped and Temperature series as numpy arrays.

Bags are read and written with rosbags (mcap or sqlite3; the reader detects
which).  All four message types are a ``std_msgs/Header`` followed by float64s
only, so their CDR is encoded and decoded here for a whole batch at once with
numpy structured arrays instead of message by message: byte-for-byte what
rosbags' ``serialize_cdr`` gives (the tests check it), at a fraction of the
cost; a batch of a few messages (at most SMALL_BATCH: the node's usual batch
at low rates), or of frame_ids mostly distinct (fewer than SMALL_BATCH
messages per name), goes through ``struct`` instead, whose cost has no fixed part
(the same bytes and the same errors, tested).  Reading goes chunk by chunk
(at most CHUNK_SIZE messages and CHUNK_BYTES bytes), so a bag of any size,
or of huge frame_ids, streams in bounded memory; frame_ids are kept as one
Python string per distinct name.

A damaged bag is an error, never a silent gap: every failure of the
reader (rosbags, mcap, sqlite3, a truncated or overwritten record) is a
BagError with the reason, and a topic that yields a different number of
messages than the bag's own count (metadata.yaml) is one too, after the
last message.  (Bags written by rosbags carry no chunk checksum: bytes
changed inside a value cannot be told from a reading.)
"""

from contextlib import contextmanager
from dataclasses import dataclass, fields
from functools import lru_cache
import os
import stat
import struct

from inclino_ros.io.files import file_kind
import numpy as np
from rosbags.rosbag2 import Reader, ReaderError, StoragePlugin, Writer, WriterError
from rosbags.typesys import get_typestore, Stores

IMU = 'sensor_msgs/msg/Imu'
VECTOR3_STAMPED = 'geometry_msgs/msg/Vector3Stamped'
TEMPERATURE = 'sensor_msgs/msg/Temperature'
MAGNETIC_FIELD = 'sensor_msgs/msg/MagneticField'
#: nT per tesla: sensor_msgs/MagneticField is in tesla, the magnetic core in nT.
NT_PER_TESLA = 1e9
STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
CHUNK_SIZE = 10_000
#: Most bytes of messages read into one chunk.
CHUNK_BYTES = 32 * 1024 * 1024

#: CDR encapsulation header of little-endian plain CDR.
_CDR_LE = (0, 1, 0, 0)
#: Bytes before the header's frame_id characters: encapsulation, sec, nanosec, length.
_FRAME_OFFSET = 16
#: Batches of at most this many messages are encoded and decoded message by message with
#: ``struct`` (a few us each) rather than with numpy (~0.1 ms a batch, whatever its size).
SMALL_BATCH = 8
#: The CDR header before the frame_id: encapsulation, sec (as the uint32 of its bits), nanosec,
#: string length (with the NUL).
_HEADER = struct.Struct('<4BIII')


class BagError(Exception):
    """A bag, topic or message that cannot be read as asked."""


@dataclass(frozen=True)
class Vector3Series:
    """geometry_msgs/Vector3Stamped messages as arrays."""

    stamps_ns: np.ndarray   # (N,) int64 header stamps
    frame_ids: np.ndarray   # (N,) str
    vector: np.ndarray      # (N, 3) x, y, z

    def values(self):
        """Return the float64 fields after the header, one row per message."""
        return self.vector

    @classmethod
    def from_values(cls, stamps_ns, frame_ids, values):
        """Return the series whose post-header float64 fields are ``values`` (N x 3)."""
        return cls(stamps_ns, frame_ids, values)


@dataclass(frozen=True)
class TemperatureSeries:
    """sensor_msgs/Temperature messages as arrays."""

    stamps_ns: np.ndarray      # (N,) int64 header stamps
    frame_ids: np.ndarray      # (N,) str
    temperature_c: np.ndarray  # (N,) deg C
    variance: np.ndarray       # (N,) deg C^2, 0 = unknown

    def values(self):
        """Return the float64 fields after the header, one row per message."""
        return np.column_stack([self.temperature_c, self.variance])

    @classmethod
    def from_values(cls, stamps_ns, frame_ids, values):
        """Return the series whose post-header float64 fields are ``values`` (N x 2)."""
        return cls(stamps_ns, frame_ids, values[:, 0], values[:, 1])

    def at(self, stamps_ns):
        """
        Return the temperature at each of ``stamps_ns``, linearly interpolated in time.

        Before the first message the first temperature holds, after the last
        the last one; messages need not be in time order.  Non-finite
        temperatures are left out (never interpolated into a NaN compensation);
        BagError if none is finite.
        """
        finite = np.isfinite(self.temperature_c)
        if not finite.any():
            raise BagError('no finite temperature in the series')
        stamps, temperatures = self.stamps_ns[finite], self.temperature_c[finite]
        order = np.argsort(stamps, kind='stable')
        origin = stamps[order[0]]
        return np.interp((np.asarray(stamps_ns) - origin).astype(float),
                         (stamps[order] - origin).astype(float), temperatures[order])


@dataclass(frozen=True)
class MagneticFieldSeries:
    """sensor_msgs/MagneticField messages as arrays (SI: tesla)."""

    stamps_ns: np.ndarray         # (N,) int64 header stamps
    frame_ids: np.ndarray         # (N,) str
    magnetic_field_T: np.ndarray  # (N, 3) x, y, z [T]
    covariance_T2: np.ndarray     # (N, 9) row-major [T^2], all 0 = unknown

    def values(self):
        """Return the float64 fields after the header, one row per message."""
        return np.concatenate([self.magnetic_field_T, self.covariance_T2], axis=1)

    @classmethod
    def from_values(cls, stamps_ns, frame_ids, values):
        """Return the series whose post-header float64 fields are ``values`` (N x 12)."""
        return cls(stamps_ns, frame_ids, values[:, :3], values[:, 3:])

    @property
    def field_nT(self):
        """Return the field in nT, (N, 3)."""
        return self.magnetic_field_T * NT_PER_TESLA


@dataclass(frozen=True)
class ImuSeries:
    """sensor_msgs/Imu messages as arrays, fields in message order."""

    stamps_ns: np.ndarray                       # (N,) int64 header stamps
    frame_ids: np.ndarray                       # (N,) str
    orientation_xyzw: np.ndarray                # (N, 4)
    orientation_covariance: np.ndarray          # (N, 9) row-major
    angular_velocity_radps: np.ndarray          # (N, 3)
    angular_velocity_covariance: np.ndarray     # (N, 9)
    linear_acceleration_mps2: np.ndarray        # (N, 3)
    linear_acceleration_covariance: np.ndarray  # (N, 9)

    def values(self):
        """Return the float64 fields after the header, one row per message."""
        return np.concatenate([getattr(self, f.name) for f in fields(self)[2:]], axis=1)

    @classmethod
    def from_values(cls, stamps_ns, frame_ids, values):
        """Return the series whose post-header float64 fields are ``values`` (N x 37)."""
        return cls(stamps_ns, frame_ids, values[:, :4], values[:, 4:13], values[:, 13:16],
                   values[:, 16:25], values[:, 25:28], values[:, 28:])


#: Float64 count after the header, and the array type, of each supported message.
_LAYOUTS = {IMU: (37, ImuSeries), VECTOR3_STAMPED: (3, Vector3Series),
            TEMPERATURE: (2, TemperatureSeries), MAGNETIC_FIELD: (12, MagneticFieldSeries)}


def frame_id_array(frame_id, count):
    """Return ``frame_id`` (one str, or one per message) as a (count,) str array."""
    if isinstance(frame_id, str):
        return np.full(count, frame_id)
    return np.asarray(frame_id, dtype=str).reshape(count)


def not_measured_covariance(count):
    """Return (count, 9) covariances saying "not measured": element 0 is -1 (sensor_msgs/Imu)."""
    covariance = np.zeros((count, 9))
    covariance[:, 0] = -1.0
    return covariance


def raw_imu(stamps_ns, frame_id, linear_acceleration_mps2, noise_std_mps2):
    """
    Return a raw accelerometer series as a driver publishes it.

    ``linear_acceleration_mps2`` is specific force (REP 145).  Orientation and
    angular velocity are not measured (zero, covariance[0] -1, as
    sensor_msgs/Imu asks); the acceleration covariance is ``noise_std_mps2^2``
    on the diagonal.
    """
    acc = np.asarray(linear_acceleration_mps2, dtype=float).reshape(-1, 3)
    n = acc.shape[0]
    acc_cov = np.zeros((n, 9))
    acc_cov[:, [0, 4, 8]] = noise_std_mps2 ** 2
    return ImuSeries(
        stamps_ns=np.asarray(stamps_ns, dtype=np.int64), frame_ids=frame_id_array(frame_id, n),
        orientation_xyzw=np.zeros((n, 4)), orientation_covariance=not_measured_covariance(n),
        angular_velocity_radps=np.zeros((n, 3)),
        angular_velocity_covariance=not_measured_covariance(n),
        linear_acceleration_mps2=acc, linear_acceleration_covariance=acc_cov)


def magnetometer(stamps_ns, frame_id, field_nT, noise_std_nT):
    """
    Return a magnetometer series as a driver publishes it, from readings in nT.

    The message holds tesla (``field_nT / NT_PER_TESLA``) and the covariance
    ``noise_std_nT^2`` (in T^2) on the diagonal; a NaN row stays NaN.
    """
    field = np.asarray(field_nT, dtype=float).reshape(-1, 3) / NT_PER_TESLA
    n = field.shape[0]
    covariance = np.zeros((n, 9))
    covariance[:, [0, 4, 8]] = (noise_std_nT / NT_PER_TESLA) ** 2
    return MagneticFieldSeries(np.asarray(stamps_ns, dtype=np.int64),
                               frame_id_array(frame_id, n), field, covariance)


def _values_offset(frame_len):
    """
    Return where the float64s start in a message whose frame_id has ``frame_len`` bytes.

    CDR aligns the first float64 to 8 bytes counted after the 4-byte
    encapsulation header; the string is a uint32 length (with the NUL) + bytes + NUL.
    """
    return 4 + (12 + frame_len + 1 + 7) // 8 * 8


@lru_cache(maxsize=64)
def _record_dtype(frame_field_len, values_offset, n_values):
    """Return the structured dtype of one message with a fixed-size frame_id field."""
    return np.dtype({
        'names': ['encapsulation', 'sec', 'nanosec', 'frame_len', 'frame_id', 'values'],
        'formats': [('u1', 4), '<i4', '<u4', '<u4', ('u1', frame_field_len),
                    ('<f8', n_values)],
        'offsets': [0, 4, 8, 12, _FRAME_OFFSET, values_offset],
        'itemsize': values_offset + 8 * n_values})


def _groups(keys):
    """
    Yield (key, index) per distinct value of ``keys``; index is ``slice(None)`` if one.

    The common case, one frame_id or one message size in a whole batch, is
    checked first and costs no sort; otherwise one stable sort splits the
    indices of every key at once (each ascending).
    """
    keys = np.asarray(keys)
    if keys.size and np.all(keys == keys[0]):
        yield keys[0], slice(None)
        return
    names, inverse = np.unique(keys, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind='stable')
    bounds = np.cumsum(np.bincount(inverse, minlength=names.size))[:-1]
    yield from zip(names, np.split(order, bounds))


def _mostly_distinct(groups, count):
    """Return whether ``count`` messages in ``groups`` make groups of fewer than SMALL_BATCH."""
    return len(groups) * SMALL_BATCH > count


def _gather(parts, count, dtype):
    """Return an array of ``count`` items from (index, values) parts of a partition."""
    if len(parts) == 1 and isinstance(parts[0][0], slice):
        return parts[0][1]
    out = np.empty((count,) + parts[0][1].shape[1:], dtype=dtype)
    for index, values in parts:
        out[index] = values
    return out


def encode(series):
    """Return the little-endian CDR of every message of ``series`` (list of bytes)."""
    values = np.asarray(series.values(), dtype=float)
    stamps_ns = np.asarray(series.stamps_ns, dtype=np.int64)
    groups = [] if stamps_ns.size <= SMALL_BATCH else list(_groups(series.frame_ids))
    if stamps_ns.size <= SMALL_BATCH or _mostly_distinct(groups, stamps_ns.size):
        return _encode_small(stamps_ns, series.frame_ids, values)   # no fixed cost per group
    messages = [None] * stamps_ns.size
    for name, index in groups:
        frame = str(name).encode()
        offset = _values_offset(len(frame))
        records = np.zeros(stamps_ns[index].size,
                           dtype=_record_dtype(len(frame) + 1, offset, values.shape[1]))
        records['encapsulation'] = _CDR_LE
        records['sec'], records['nanosec'] = np.divmod(stamps_ns[index], 1_000_000_000)
        records['frame_len'] = len(frame) + 1
        records['frame_id'] = np.frombuffer(frame + b'\0', dtype=np.uint8)
        records['values'] = values[index]
        blob = records.tobytes()
        size = records.dtype.itemsize
        encoded = [blob[i:i + size] for i in range(0, len(blob), size)]
        if isinstance(index, slice):
            return encoded
        for i, data in zip(index.tolist(), encoded):
            messages[i] = data
    return messages


def _encode_small(stamps_ns, frame_ids, values):
    """Return ``encode``'s bytes message by message (``struct``; padding zero as there)."""
    row = struct.Struct(f'<{values.shape[1]}d')
    messages = []
    for stamp_ns, name, value in zip(stamps_ns.tolist(), np.asarray(frame_ids).tolist(),
                                     values.tolist()):
        frame = str(name).encode()
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        messages.append(_HEADER.pack(*_CDR_LE, sec & 0xFFFFFFFF, nanosec, len(frame) + 1)
                        + frame + bytes(_values_offset(len(frame)) - _FRAME_OFFSET - len(frame))
                        + row.pack(*value))
    return messages


def encode_float64(values):
    """Return the little-endian CDR of std_msgs/Float64 messages of ``values`` (list of bytes)."""
    if np.size(values) <= SMALL_BATCH:
        return [_FLOAT64.pack(*_CDR_LE, value) for value in np.reshape(values, -1).tolist()]
    records = np.zeros(np.size(values), dtype=np.dtype(
        {'names': ['encapsulation', 'data'], 'formats': [('u1', 4), '<f8'], 'offsets': [0, 4],
         'itemsize': 12}))
    records['encapsulation'] = _CDR_LE
    records['data'] = np.reshape(values, -1)
    blob = records.tobytes()
    return [blob[i:i + 12] for i in range(0, len(blob), 12)]


#: std_msgs/Float64: the encapsulation and the value.
_FLOAT64 = struct.Struct('<4Bd')


def _frame_ids(frame_bytes, lengths):
    """
    Return the frame_id strings (object array) of rows of frame_id field bytes.

    ``lengths`` are the CDR string lengths (with the NUL); the bytes after the
    string are alignment padding, which a sender need not zero.  An empty
    string is read as its NUL alone, which numpy's ``S`` type drops.
    """
    frame_ids = np.empty(lengths.size, dtype=object)
    for length, index in _groups(lengths):
        width = max(int(length) - 1, 1)
        raw = np.ascontiguousarray(frame_bytes[index, :width]).view(f'S{width}').reshape(-1)
        strings = np.empty(raw.size, dtype=object)
        names = list(_groups(raw))
        try:
            if _mostly_distinct(names, raw.size):   # one by one: no fixed cost per name
                strings[:] = [name.decode() for name in raw.tolist()]
            else:
                for name, where in names:
                    strings[where] = name.decode()
        except UnicodeDecodeError as err:
            raise BagError(f'a frame_id is not UTF-8 ({err}): a damaged message') from None
        frame_ids[index] = strings
    return frame_ids


def _check_nanosec(nanosec, msgtype):
    """Raise BagError when a stamp's nanosec is 1e9 or more: no time (not a carry into sec)."""
    late = np.asarray(nanosec) >= 1_000_000_000
    if np.any(late):
        raise BagError(f'a {msgtype} message is stamped with nanosec '
                       f'{int(np.asarray(nanosec)[late][0])} (at most 999999999): not a time')


def decode(messages, msgtype):
    """
    Return the series of ``msgtype`` held in ``messages`` (a list of CDR bytes).

    Raises BagError for a message that is not little-endian CDR of that type,
    or whose stamp is no time (nanosec of 1e9 or more: not a carry into sec).
    """
    n_values, series_type = _LAYOUTS[msgtype]
    if 0 < len(messages) <= SMALL_BATCH:
        return series_type.from_values(*_decode_small(messages, msgtype, n_values))
    sizes = np.fromiter(map(len, messages), dtype=np.int64, count=len(messages))
    stamps, frame_ids, values = [], [], []
    for size, index in _groups(sizes):
        offset = int(size) - 8 * n_values
        if offset < _values_offset(0):
            raise BagError(f'a {msgtype} message of {size} bytes is too short')
        group = messages if isinstance(index, slice) else [messages[i] for i in index.tolist()]
        records = np.frombuffer(b''.join(group),
                                dtype=_record_dtype(offset - _FRAME_OFFSET, offset, n_values))
        lengths = records['frame_len'].astype(np.int64)
        if np.any(records['encapsulation'] != _CDR_LE) \
                or np.any(lengths < 1) or np.any(_values_offset(lengths - 1) != offset):
            raise BagError(f'a {msgtype} message is not little-endian CDR of that type')
        _check_nanosec(records['nanosec'], msgtype)
        stamps.append((index, records['sec'].astype(np.int64) * 1_000_000_000
                       + records['nanosec']))
        frame_ids.append((index, _frame_ids(records['frame_id'], lengths)))
        values.append((index, records['values']))
    n = sizes.size
    series = ((_gather(stamps, n, np.int64), _gather(frame_ids, n, object),
               _gather(values, n, float)) if n else
              (np.empty(0, np.int64), np.empty(0, object), np.empty((0, n_values))))
    return series_type.from_values(*series)


def _decode_small(messages, msgtype, n_values):
    """Return ``decode``'s (stamps, frame_ids, values) message by message (``struct``)."""
    row = struct.Struct(f'<{n_values}d')
    stamps_ns, frame_ids, values = [], [], []
    for data in messages:
        offset = len(data) - 8 * n_values
        if offset < _values_offset(0):
            raise BagError(f'a {msgtype} message of {len(data)} bytes is too short')
        *encapsulation, sec, nanosec, length = _HEADER.unpack_from(data)
        if tuple(encapsulation) != _CDR_LE or length < 1 \
                or _values_offset(length - 1) != offset:
            raise BagError(f'a {msgtype} message is not little-endian CDR of that type')
        # As numpy's bytes type reads it: trailing NULs dropped (padding a sender left).
        name = bytes(data[_FRAME_OFFSET:_FRAME_OFFSET + max(length - 1, 1)]).rstrip(b'\0')
        try:
            frame_ids.append(name.decode())
        except UnicodeDecodeError as err:
            raise BagError(f'a frame_id is not UTF-8 ({err}): a damaged message') from None
        if nanosec >= 1_000_000_000:   # (a plain comparison: this path is for latency)
            _check_nanosec(np.array([nanosec]), msgtype)
        stamps_ns.append((sec - ((sec & 0x80000000) << 1)) * 1_000_000_000 + nanosec)
        values.append(row.unpack_from(data, offset))
    frame_array = np.empty(len(frame_ids), dtype=object)
    frame_array[:] = frame_ids
    return (np.array(stamps_ns, dtype=np.int64), frame_array,
            np.array(values, dtype=float).reshape(-1, n_values))


def sliced(series, start, stop):
    """Return messages ``start:stop`` of a series, as a series of the same type."""
    return type(series)(*(getattr(series, f.name)[start:stop] for f in fields(series)))


def concatenate(chunks):
    """Return one series made of a non-empty sequence of series of the same type."""
    chunks = list(chunks)
    return type(chunks[0])(*(np.concatenate([getattr(c, f.name) for c in chunks])
                             for f in fields(chunks[0])))


@contextmanager
def _open(path):
    """Open the bag at ``path`` for reading; BagError if it is not a readable bag."""
    _check_regular_files(path)
    try:
        reader = Reader(path)
        reader.open()
    except Exception as err:  # rosbags, mcap, sqlite3, YAML: whatever fails, it is unreadable
        raise BagError(f'cannot read the bag {path}: {_reason(err)}') from None
    try:
        yield reader
    finally:
        try:
            reader.close()
        except Exception:  # a damaged file may fail to close too; the reason is given already
            pass


def _check_regular_files(path):
    """Raise BagError when the bag ``path`` or a file in its folder is not a regular file."""
    try:
        entries = [path] if not os.path.isdir(path) else [
            os.path.join(path, name) for name in os.listdir(path)]
        kinds = {entry: os.stat(entry).st_mode for entry in entries}
    except OSError:
        return  # the reader says why it cannot read it
    for entry, kind in kinds.items():
        if not (stat.S_ISREG(kind) or stat.S_ISDIR(kind)):
            raise BagError(f'cannot read the bag {path}: {entry} is {file_kind(kind)}, not a '
                           'regular file: refused, nothing read')


def _reason(err):
    """Return an exception of the reader as text: its type unless it is rosbags' own."""
    return str(err) if isinstance(err, (ReaderError, FileNotFoundError)) \
        else f'{type(err).__name__}: {err}'


def _topic_connections(reader, topic):
    """Return (connections, msgtype) of ``topic``; BagError unless it holds one supported type."""
    connections = [c for c in reader.connections if c.topic == topic]
    msgtypes = {c.msgtype for c in connections}
    if not connections:
        present = ', '.join(sorted(f'{c.topic} ({c.msgtype})' for c in reader.connections))
        raise BagError(f'no topic {topic} in {reader.path}; it has: {present or "nothing"}')
    if len(msgtypes) != 1 or not msgtypes <= set(_LAYOUTS):
        raise BagError(f'{topic} in {reader.path} holds {sorted(msgtypes)}, not one of '
                       f'{sorted(_LAYOUTS)}')
    return connections, msgtypes.pop()


def list_topics(path):
    """Return ``{topic: (msgtype, message count)}`` of every topic of the bag ``path``."""
    with _open(path) as reader:
        found = {}
        for connection in reader.connections:
            msgtype, count = found.get(connection.topic, (connection.msgtype, 0))
            found[connection.topic] = (msgtype, count + connection.msgcount)
        return found


def custom_data(path):
    """Return the ``custom_data`` of the bag's metadata (``{}``: none); BagError if unreadable."""
    with _open(path) as reader:
        metadata = getattr(reader.storage, 'metadata', None)   # rosbags' reader of a bag folder
        return dict(getattr(metadata, 'custom', None) or {})


def topic_info(path, topic):
    """Return (msgtype, message count) of ``topic``; BagError if it cannot be read."""
    with _open(path) as reader:
        connections, msgtype = _topic_connections(reader, topic)
        return msgtype, sum(c.msgcount for c in connections)


def read(path, topic, chunk_size=CHUNK_SIZE, chunk_bytes=CHUNK_BYTES):
    """
    Yield the messages of ``topic`` as series of at most ``chunk_size`` messages.

    A chunk also ends once it holds ``chunk_bytes`` of messages.  The topic
    must hold sensor_msgs/Imu, sensor_msgs/MagneticField,
    geometry_msgs/Vector3Stamped or sensor_msgs/Temperature; raises BagError
    naming the topics there are when it does not, BagError for any failure
    of the reader, and BagError after the last message when the topic held
    another number of messages than the bag says it has (a damaged bag).
    """
    with _open(path) as reader:
        connections, msgtype = _topic_connections(reader, topic)
        expected = sum(c.msgcount for c in connections)
        stream = reader.messages(connections=connections)
        count = 0
        while True:
            messages, size = [], 0
            try:
                for _, _, data in stream:
                    messages.append(data)
                    size += len(data)
                    if len(messages) >= chunk_size or size >= chunk_bytes:
                        break
            except Exception as err:  # the reader's, on a damaged file: never a traceback
                raise BagError(f'the bag {path} is damaged: reading {topic} failed after '
                               f'{count + len(messages)} of its {expected} messages '
                               f'({_reason(err)})') from None
            if not messages:
                break
            count += len(messages)
            yield decode(messages, msgtype)
        if count != expected:
            raise BagError(f'the bag {path} is damaged: {count} messages of {topic} could be '
                           f'read, but the bag says it holds {expected}')


class BagWriter:
    """
    A new bag of Imu, MagneticField, Vector3Stamped and Temperature topics, from series.

    Use as a context manager; on an exception the bag is left unfinished by
    rosbags' own abort.  Series written together are interleaved message by
    message (same stamps), so the bag is in time order.
    """

    def __init__(self, path, storage='mcap'):
        """Prepare the bag ``path`` (which must not exist) in ``storage`` format."""
        if storage not in STORAGES:
            raise ValueError(f'storage must be one of {sorted(STORAGES)}, not {storage!r}')
        self.path = path
        try:
            self._writer = Writer(path, version=9, storage_plugin=STORAGES[storage])
        except WriterError as err:
            raise BagError(str(err)) from None
        self._typestore = get_typestore(Stores.ROS2_JAZZY)
        self._connections = {}

    def __enter__(self):
        """Open the bag."""
        self._writer.__enter__()
        return self

    def __exit__(self, *exc_info):
        """Close the bag, or abort it on an exception."""
        return self._writer.__exit__(*exc_info)

    def set_custom_data(self, key, value):
        """Note ``key: value`` (text) in the bag's metadata (rosbag2's ``custom_data``)."""
        self._writer.set_custom_data(key, value)

    def add_topic(self, topic, msgtype):
        """Declare ``topic`` of ``msgtype`` (a supported type: IMU, MAGNETIC_FIELD, ...)."""
        if msgtype not in _LAYOUTS:
            raise ValueError(f'msgtype must be one of {sorted(_LAYOUTS)}, not {msgtype!r}')
        self._connections[topic] = self._writer.add_connection(
            topic, msgtype, typestore=self._typestore)

    def write(self, stamps_ns, encoded):
        """
        Write messages already encoded, ``{topic: list of CDR bytes}``, all at ``stamps_ns``.

        Each list holds one message per stamp; the bag's log time is the stamp.
        """
        stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
        if any(len(messages) != stamps_ns.size for messages in encoded.values()):
            raise ValueError('every topic needs exactly one message per stamp')
        if stamps_ns.size and stamps_ns.min() < 0:
            raise BagError(f'a header stamp of {int(stamps_ns.min())} ns lies before 1970: it '
                           'cannot be the log time of a bag message')
        connections = [self._connections[topic] for topic in encoded]
        write = self._writer.write
        for stamp, *row in zip(stamps_ns.tolist(), *encoded.values()):
            for connection, data in zip(connections, row):
                write(connection, stamp, data)

    def write_series(self, series_by_topic, chunk_size=CHUNK_SIZE):
        """
        Encode and write ``{topic: series}``; all series share the same stamps.

        Encoded ``chunk_size`` messages at a time, so that only one chunk's
        bytes are held at once.
        """
        stamps_ns = next(iter(series_by_topic.values())).stamps_ns
        for start in range(0, stamps_ns.size, chunk_size):
            stop = start + chunk_size
            self.write(stamps_ns[start:stop], {
                topic: encode(sliced(series, start, stop))
                for topic, series in series_by_topic.items()})
