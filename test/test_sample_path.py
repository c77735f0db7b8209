"""
The node's sample path: the CDR it publishes reads back in rclpy as the values put in.

Small batches (the node's at low rates) are coded with ``struct`` and corrected by the same
chain as large ones: bytes, arrays and numbers are compared between the two.

(rclpy's own serialization leaves its alignment padding unset, so bytes are
compared where there is no padding and messages where there is.)
"""

import dataclasses
from dataclasses import replace
import math

from geometry_msgs.msg import Vector3Stamped
from inclino_ros import scalar_chain
from inclino_ros.calibration import stages
from inclino_ros.calibration.model import CalibrationModel, Stand
from inclino_ros.core.attitude import TOOLFACE_CONVENTIONS
from inclino_ros.core.magnetics import QcLimits
from inclino_ros.core.mounting import to_sensor_axes
from inclino_ros.core.screening import ACCEPTED
from inclino_ros.io import bag
from inclino_ros.node.sample_path import decode_messages
from inclino_ros.pipeline import imu_covariances, MagneticSettings, run, Settings
from inclino_ros.sim import sensor_model as sm
from inclino_ros.stream import correct_batch, outputs
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import get_typestore, Stores
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64
from test_model_stages import BIAS_MPS2, K
from test_plausibility import ALL_STAGES


@pytest.mark.parametrize('value', [0.0, -1.5, 1e300, math.inf, -math.inf, 30.000123])
def test_float64_bytes_are_rclpys(value):
    """The batch encoder of std_msgs/Float64 writes what rclpy serializes."""
    assert bag.encode_float64([value]) == [serialize_message(Float64(data=value))]


def test_a_nan_float64_reads_back_as_nan():
    """A NaN (an angle withheld) survives the encoding."""
    (data,) = bag.encode_float64(np.array([math.nan]))
    assert math.isnan(deserialize_message(data, Float64).data)


@pytest.mark.parametrize('frame_id', ['', 'tool', 'inclinometer_link_0123456789'])
def test_survey_and_imu_read_back_in_rclpy(frame_id):
    """Vector3Stamped and Imu from the batch encoder: rclpy reads every value and the header."""
    stamp_ns = 1_700_000_123_456_789_012
    survey = bag.Vector3Series(np.array([stamp_ns]), np.array([frame_id], dtype=object),
                               np.array([[30.5, -0.25, 271.125]]))
    msg = Vector3Stamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.header.frame_id = frame_id
    msg.vector.x, msg.vector.y, msg.vector.z = 30.5, -0.25, 271.125
    (data,) = bag.encode(survey)
    assert deserialize_message(data, Vector3Stamped) == msg
    assert len(data) == len(serialize_message(msg))
    values = np.arange(37, dtype=float).reshape(1, 37) / 7.0
    imu = bag.ImuSeries.from_values(np.array([stamp_ns]), np.array([frame_id], dtype=object),
                                    values)
    decoded = deserialize_message(bag.encode(imu)[0], Imu)
    assert decoded.header == msg.header
    floats = [*(getattr(decoded.orientation, k) for k in 'xyzw'),
              *decoded.orientation_covariance,
              *(getattr(decoded.angular_velocity, k) for k in 'xyz'),
              *decoded.angular_velocity_covariance,
              *(getattr(decoded.linear_acceleration, k) for k in 'xyz'),
              *decoded.linear_acceleration_covariance]
    assert floats == values[0].tolist()


def test_a_big_endian_sender_is_decoded_through_rclpy():
    """A big-endian CDR sample (another machine's driver) is read, not refused or misread."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    little = bag.encode(bag.raw_imu([1_500_000_000], 'tool', [[1.0, 2.0, 9.5]], 0.01))[0]
    big = bytes(typestore.serialize_cdr(typestore.deserialize_cdr(little, bag.IMU), bag.IMU,
                                        little_endian=False))
    assert big[:2] == b'\x00\x00' and little[:2] == b'\x00\x01'
    with pytest.raises(bag.BagError):
        bag.decode([big], bag.IMU)
    series = decode_messages([big, little], bag.IMU, Imu)
    np.testing.assert_array_equal(series.linear_acceleration_mps2, [[1.0, 2.0, 9.5]] * 2)
    assert series.stamps_ns.tolist() == [1_500_000_000] * 2
    assert series.frame_ids.tolist() == ['tool'] * 2


def test_a_stamp_with_nanosec_beyond_a_second_is_no_time():
    """A nanosec >= 1e9 read as 4 s later: the message is dropped, named; the others kept."""
    good = [Imu(), Imu()]
    for k, msg in enumerate(good):
        msg.header.stamp.sec, msg.header.stamp.nanosec = 100 + k, 5
        msg.linear_acceleration.z = 9.8
    bad = Imu()
    bad.header.stamp.sec, bad.header.stamp.nanosec = 100, 4_000_000_000
    messages = [serialize_message(m) for m in (good[0], bad, good[1])]
    with pytest.raises(bag.BagError, match='nanosec 4000000000'):
        bag.decode(messages, bag.IMU)
    dropped = []
    series = decode_messages(messages, bag.IMU, Imu, dropped)
    assert series.stamps_ns.tolist() == [100_000_000_005, 101_000_000_005]
    assert len(dropped) == 1 and 'not a time' in dropped[0]
    assert decode_messages(messages[1:2], bag.IMU, Imu).stamps_ns.size == 0


FRAME_IDS = ['', 'a', 'tool', 'imu_link', 'inclinometer', 'ünïcode_frame', 'x' * 29]
#: Stamps before 1970, at 0, around the int32 seconds limit and far beyond it (numpy wraps).
STAMPS_NS = [-1_500_000_001, 0, 2_147_483_647_999_999_999, 2_147_483_648_000_000_001,
             1_700_000_123_456_789_012, 9_000_000_000_000_000_000]


def series_of(kind, count, rng):
    """Return a series of ``count`` messages of every frame_id and odd values (NaN, inf)."""
    width = {bag.ImuSeries: 37, bag.Vector3Series: 3, bag.TemperatureSeries: 2,
             bag.MagneticFieldSeries: 12}[kind]
    values = rng.normal(0.0, 1e3, (count, width))
    values.flat[::7] = np.nan
    values.flat[3::11] = -np.inf
    stamps = np.array([STAMPS_NS[i % len(STAMPS_NS)] + i for i in range(count)], dtype=np.int64)
    frames = np.array([FRAME_IDS[i % len(FRAME_IDS)] for i in range(count)], dtype=object)
    return kind.from_values(stamps, frames, values)


@pytest.mark.parametrize('kind, msgtype', [(bag.ImuSeries, bag.IMU),
                                           (bag.Vector3Series, bag.VECTOR3_STAMPED),
                                           (bag.TemperatureSeries, bag.TEMPERATURE),
                                           (bag.MagneticFieldSeries, bag.MAGNETIC_FIELD)])
def test_small_batches_are_coded_as_large_ones(kind, msgtype):
    """
    Batches of 1..SMALL_BATCH messages (``struct``) give the bytes and arrays of numpy's codec.

    Numpy's path is a batch of at least SMALL_BATCH messages per frame_id whose first
    messages are the same.  A batch of distinct frame_ids (``struct`` whatever its
    size) decodes as numpy's path does.
    """
    rng = np.random.default_rng(3)
    for count in range(1, bag.SMALL_BATCH + 1):
        large = series_of(kind, count + bag.SMALL_BATCH * len(FRAME_IDS), rng)
        small = bag.sliced(large, 0, count)
        encoded = bag.encode(large)
        assert bag.encode(small) == encoded[:count]
        # Stamps beyond the int32 seconds come back wrapped, by both paths alike.
        decoded, expected = bag.decode(encoded[:count], msgtype), bag.decode(encoded, msgtype)
        np.testing.assert_array_equal(decoded.stamps_ns, expected.stamps_ns[:count])
        assert decoded.frame_ids.tolist() == expected.frame_ids.tolist()[:count]
        assert decoded.values().tobytes() == np.asarray(expected.values())[:count].tobytes()
        assert decoded.values().tobytes() == np.asarray(small.values()).tobytes()
    distinct = series_of(kind, 40, rng)
    names = np.array([f'frame/{i:04d}' for i in range(40)], dtype=object)
    distinct = kind.from_values(distinct.stamps_ns, names, distinct.values())
    many = kind.from_values(np.tile(distinct.stamps_ns, 8), np.tile(names, 8),
                            np.tile(distinct.values(), (8, 1)))   # 8 of each: numpy's path
    encoded = bag.encode(distinct)
    assert encoded == bag.encode(many)[:40]
    decoded, expected = bag.decode(encoded, msgtype), bag.decode(bag.encode(many), msgtype)
    assert decoded.frame_ids.tolist() == expected.frame_ids.tolist()[:40] == names.tolist()
    assert decoded.values().tobytes() == np.asarray(expected.values())[:40].tobytes()
    values = np.array([0.0, -1.5, math.nan, math.inf, 1e-300, 30.000123, -0.0, 7.0, 1.0])
    assert bag.encode_float64(values[:bag.SMALL_BATCH]) == bag.encode_float64(values)[:-1]


def test_small_batches_refuse_what_large_ones_refuse():
    """A damaged message alone (``struct``) or among SMALL_BATCH good ones (numpy): one error."""
    good = bag.encode(bag.raw_imu([1_500_000_000], 'tool', [[1.0, 2.0, 9.5]], 0.01))[0]
    odd_length = bytearray(good)
    odd_length[12] = 20   # the frame_id said 20 bytes long: the floats would start elsewhere
    not_utf8 = bytearray(good)
    not_utf8[16] = 0xFF
    for damaged in (good[:40], b'\x00\x00' + good[2:], bytes(odd_length), bytes(not_utf8)):
        errors = []
        for batch in ([damaged], [damaged] + [good] * bag.SMALL_BATCH):
            with pytest.raises(bag.BagError) as raised:
                bag.decode(batch, bag.IMU)
            errors.append(str(raised.value))
        assert errors[0] == errors[1]


def numbers(survey):
    """Return every number a Survey gives per accepted sample (what the node publishes)."""
    out = {name: getattr(survey, name) for name in (
        'uncorrected_mps2', 'corrected_mps2', 'inclination_deg', 'toolface_deg',
        'orientation_wxyz', 'g_total_mps2', 'covariance_mps2', 'toolface_std_deg',
        'inclination_std_deg')}
    out['acceleration_cov'], out['orientation_cov'] = imu_covariances(survey)
    magnetic = survey.magnetic
    if magnetic is None:
        return {name: np.asarray(value, dtype=float) for name, value in out.items()}
    out.update({f'magnetic.{name}': getattr(magnetic, name) for name in (
        'uncorrected_nT', 'azimuth_deg', 'true_azimuth_deg', 'b_total_nT', 'dip_deg',
        'trusted', 'azimuth_std_deg', 'precise', 'defined_azimuth_deg')})
    out.update({f'qc.{name}': getattr(magnetic.qc, name) for name in ('ok',)})
    return {name: np.asarray(value, dtype=float) for name, value in out.items()}


def test_a_sample_alone_gives_the_numbers_it_gives_in_a_batch():
    """
    One sample at a time (the node's batches at low rates) = the same samples in one batch.

    The physical simulator's MEMS tool at 60 deg C read at 150 attitudes, vertical ones
    (toolface and azimuth NaN) and nearly vertical ones (toolface NaN by its 1 sigma) among
    them, plus samples screened out (NaN, beyond range, not gravity) and unpaired
    magnetometer rows; a model with every stage.  Every angle, 1 sigma, covariance, QC flag
    and screening code agrees to 1e-12 (relative, or absolute near zero), NaNs in the same
    places; the CDR published for a batch of one (``struct``) and within 150 (numpy) decodes
    to the same values.
    """
    rng = np.random.default_rng(11)
    count = 150
    incl = rng.uniform(0.0, 120.0, count)
    incl[:6] = [0.0, 0.0, 0.01, 0.05, 180.0, 90.0]
    reading = sm.read(sm.MEMS, incl, rng.uniform(0.0, 360.0, count),
                      rng.uniform(0.0, 360.0, count), temperature_c=60.0, rng=rng)
    raw, field = reading.accel_mps2, reading.mag_nT
    raw[6], raw[7], raw[8] = (np.nan, 1.0, 2.0), (30.0, 0.0, 0.0), raw[8] * 1.5
    field[9:20] = np.nan
    settings = Settings(noise_std_mps2=0.02)
    # QC limits wide enough for a model that is not this tool's own (most azimuths pass).
    magnetic = MagneticSettings(reference_total_nT=50000.0, reference_dip_deg=60.0,
                                declination_deg=3.5, noise_std_nT=100.0, limits=QcLimits(
                                    b_total_tolerance_nT=5000.0, dip_tolerance_deg=10.0,
                                    g_total_tolerance=1.0))
    batch = run(raw, ALL_STAGES, settings, 60.0, field, magnetic)
    singles = [run(raw[i:i + 1], ALL_STAGES, settings, 60.0, field[i:i + 1], magnetic)
               for i in range(count)]
    assert batch.codes.tolist() == [s.codes[0] for s in singles]
    assert 130 < np.count_nonzero(batch.accepted) < count
    single_numbers = [numbers(s) for s in singles if s.accepted[0]]
    for name, values in numbers(batch).items():
        np.testing.assert_allclose(np.concatenate([n[name] for n in single_numbers]), values,
                                   rtol=1e-12, atol=1e-12, err_msg=name)
    # The NaN rules were exercised: toolfaces and azimuths withheld, others published.
    for published in (batch.toolface_deg, batch.magnetic.azimuth_deg):
        assert 0 < np.count_nonzero(np.isnan(published)) < published.size // 2
    stamps = np.arange(count, dtype=np.int64) * 1_000_000
    frames = np.full(count, 'imu_link', dtype=object)
    whole = outputs(stamps[batch.accepted], frames[batch.accepted], batch)
    one_by_one = [outputs(stamps[i:i + 1], frames[i:i + 1], s)
                  for i, s in enumerate(singles) if s.accepted[0]]
    for topic, msgtype in (('survey', bag.VECTOR3_STAMPED), ('imu', bag.IMU)):
        expected = bag.decode(bag.encode(getattr(whole, topic)), msgtype).values()
        alone = np.concatenate([bag.decode(bag.encode(getattr(o, topic)), msgtype).values()
                                for o in one_by_one])
        np.testing.assert_allclose(alone, expected, rtol=1e-12, atol=1e-12, err_msg=topic)


def stage_types():
    """Return every stage type of ``calibration.stages`` (the frozen dataclasses it defines)."""
    return {kind for kind in vars(stages).values() if isinstance(kind, type)
            and dataclasses.is_dataclass(kind) and kind.__module__ == stages.__name__}


#: Covariances of the drift fits (scale, bias per axis): the temperature stage's own 1 sigma.
DRIFT_COVARIANCE = (((4e-10, 1e-11), (1e-11, 9e-8)),) * 3
#: K(T), b(T) of a stand fitted at several temperatures (issue 18), about 40 deg C.
STAND_KT = Stand(scale_matrix=K, bias_mps2=BIAS_MPS2, method='stand', condition_number=2.1,
                 rms_inclination_deg=0.002, positions=18, fitted_at='2026-03-01T10:20:30+00:00',
                 temperature_c=40.0, scale_coefficients=(K, ((1e-4, 2e-5, 0.0), (0.0, -2e-4, 0.0),
                                                             (1e-5, 0.0, 3e-4))),
                 bias_coefficients_mps2=(BIAS_MPS2, (1e-4, -2e-4, 5e-5)), t_min_c=20.0,
                 t_max_c=80.0)
THREE_AXES = Settings(noise_std_mps2=0.02)


def covariance(sigmas, seed):
    """Return a random symmetric positive definite matrix of about ``sigmas`` 1 sigma."""
    size = len(sigmas)
    root = np.random.default_rng(seed).normal(size=(size, size)) / np.sqrt(size)
    root *= np.asarray(sigmas)[:, None]
    return tuple(map(tuple, (root @ root.T).tolist()))


#: The covariance of STAND_KT's 24 coefficients (power by power: K row-major, then b
#: [m/s^2]; per deg C for the second power).
STAND_KT_COVARIANCE = covariance([1e-5] * 9 + [3e-4] * 3 + [1e-6] * 9 + [3e-5] * 3, 24)
#: (model, settings) of the float chain's cases: every stage, both sensors, both toolfaces,
#: a turned mounting; the temperature stage with and without its fit's covariance.
CASES = {
    'every stage': (ALL_STAGES, THREE_AXES),
    'K(T) stand, drift covariance, mounting': (
        replace(ALL_STAGES, stand=STAND_KT, temperature=replace(
            ALL_STAGES.temperature, parameter_covariance=DRIFT_COVARIANCE)),
        Settings(noise_std_mps2=0.02, accelerometer_axes_map='rpy:3,-2,91',
                 toolface_convention='iscwsa_highside')),
    'K(T) stand with its coefficients covariance': (
        replace(ALL_STAGES, stand=replace(STAND_KT, parameter_covariance=STAND_KT_COVARIANCE)),
        THREE_AXES),
    'two axes': (CalibrationModel(accelerometer_axes=2, installation=ALL_STAGES.installation,
                                  tool_axis=ALL_STAGES.tool_axis),
                 Settings(accelerometer_axes=2, noise_std_mps2=0.1,
                          accelerometer_axes_map='-Y+X+Z')),
    'uncalibrated': (CalibrationModel(accelerometer_axes=3), THREE_AXES),
}


def simulated_samples(rng, count, settings):
    """
    Return raw samples (count, 3) of the physical simulator's MEMS tool at 60 deg C.

    In the sensor axes of ``settings`` (its axes map turns them into the tool's).

    Vertical and nearly vertical ones (toolface NaN: undefined, or by its 1 sigma), and
    samples each screening rule drops: NaN, beyond the range, not gravity, zero (two
    axes: over g, and too steep); exactly vertical and exactly along x (where the float
    chain would divide by zero) and a toolface of 2 pi less 1e-18 rad for an uncalibrated
    tool.
    """
    axes = settings.accelerometer_axes
    incl = rng.uniform(0.0, 120.0 if axes == 3 else 75.0, count)
    incl[:6] = [0.0, 0.0, 0.01, 0.05, 180.0, 90.0]
    raw = sm.read(sm.MEMS, incl, rng.uniform(0.0, 360.0, count), rng.uniform(0.0, 360.0, count),
                  temperature_c=60.0, rng=rng).accel_mps2
    raw[6], raw[7], raw[8], raw[9] = (np.nan, 1.0, 2.0), (30.0, 0.0, 0.0), raw[8] * 1.5, 0.0
    raw[10], raw[11] = (0.0, 0.0, 9.80665), (9.80665, 0.0, 0.0)
    raw[16] = (5.0, -1e-17, 8.0)   # a toolface of -1e-18 rad: 2 pi, given as 0
    if axes == 2:
        raw[12] = (9.0, 5.0, 0.0)
    return to_sensor_axes(raw, settings.accelerometer_matrix)


@pytest.mark.parametrize('case', CASES)
@pytest.mark.parametrize('temperature', ['none', 'one', 'per sample'])
def test_the_float_chain_gives_the_vectorised_numbers(case, temperature):
    """
    ``scalar_chain.run`` = ``pipeline.run`` to 1e-12 for batches of 1..MAX_SAMPLES samples.

    The physical simulator's samples (``simulated_samples``), 200 of them in batches of
    every size the float chain takes; every screening code, angle, 1 sigma, covariance
    and NaN the same (relative 1e-12, or absolute near zero).  Temperatures: none (the
    references), 60 deg C, or one per sample across and beyond the fitted ranges (NaN
    among them).  What the float chain leaves to numpy (a division by zero) is
    ``stream.correct_batch``'s to give the same way.
    """
    model, settings = CASES[case]
    rng = np.random.default_rng(23)
    raw = simulated_samples(rng, 200, settings)
    temperature_c = {'none': None, 'one': 60.0,
                     'per sample': rng.uniform(0.0, 120.0, 200)}[temperature]
    if temperature == 'per sample':
        temperature_c[::17] = np.nan
    floats, start, size = [], 0, 1
    while start < raw.shape[0]:
        rows = slice(start, start + size)
        t = temperature_c[rows] if temperature == 'per sample' else temperature_c
        expected = run(raw[rows], model, settings, t)
        survey = scalar_chain.run(raw[rows], model, settings, t)
        if survey is None:   # numpy's inf or NaN: the batch is stream's to run vectorised
            survey = correct_batch(raw[rows], np.zeros(size), np.full(size, ''), model,
                                   settings, t).survey
        else:
            floats.append(survey)
        assert survey.codes.tolist() == expected.codes.tolist()
        for name, values in numbers(expected).items():
            np.testing.assert_allclose(numbers(survey)[name], values, rtol=1e-12, atol=1e-12,
                                       err_msg=f'{name} of samples {start}..{start + size}')
        start, size = start + size, size % scalar_chain.MAX_SAMPLES + 1
    # Most batches were the float chain's, with toolfaces withheld and others published.
    assert len(floats) > 40
    toolfaces = np.concatenate([s.toolface_deg for s in floats])
    assert 0 < np.count_nonzero(np.isnan(toolfaces)) < toolfaces.size // 2
    dead = 2 if settings.accelerometer_axes == 3 else 3   # zero, or over g
    assert {code for s in floats for code in s.codes} >= {ACCEPTED, 0, 1, dead}


def test_every_stage_type_is_in_the_float_chains_cases():
    """
    Each stage type of ``calibration.stages`` is in a case of the float chain's test.

    And each toolface convention is written in the float chain (both are in the cases).

    The magnetometer's stages are in the cases' models too, but a batch with
    magnetometer readings is the vectorised chain's (``scalar_chain.applies``); a new
    stage type fails here until a case holds it.
    """
    present = {type(getattr(model, field.name)) for model, _ in CASES.values()
               for field in dataclasses.fields(model)}
    assert stage_types() - present == set()
    assert set(scalar_chain.TOOLFACE_ARGUMENTS) == set(TOOLFACE_CONVENTIONS)
    assert not scalar_chain.applies(1, field_nT=np.zeros((1, 3)))
    assert scalar_chain.applies(scalar_chain.MAX_SAMPLES)
    assert not scalar_chain.applies(scalar_chain.MAX_SAMPLES + 1)
