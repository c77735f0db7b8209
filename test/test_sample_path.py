"""
The node's sample path: the CDR it publishes reads back in rclpy as the values put in.

(rclpy's own serialization leaves its alignment padding unset, so bytes are
compared where there is no padding and messages where there is.)
"""

import math

from geometry_msgs.msg import Vector3Stamped
from inclino_ros.io import bag
from inclino_ros.node.sample_path import decode_messages
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import get_typestore, Stores
from sensor_msgs.msg import Imu
from std_msgs.msg import Float64


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
    """nanosec >= 1e9 read as 4 s later: the message is dropped, named; the others kept."""
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
