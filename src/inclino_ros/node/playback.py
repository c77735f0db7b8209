"""
A recorded bag published again (``inclino play``, ``inclino demo``): rows into ROS messages.

Each row of a sensor series becomes its sensor_msgs message, stamped and
framed as recorded; ``publish_timed`` paces them by their stamps.  The
message classes are imported when first used, so that importing this module
loads no ROS.
"""

import time

from inclino_ros.io.bag import IMU, MAGNETIC_FIELD, TEMPERATURE


def _header(msg, series, i):
    """Stamp ``msg`` and name its frame as row ``i`` of ``series``; return it."""
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(series.stamps_ns[i]),
                                                            1_000_000_000)
    msg.header.frame_id = str(series.frame_ids[i])
    return msg


def _vector(target, values):
    """Set a geometry_msgs/Vector3 from three values."""
    target.x, target.y, target.z = (float(v) for v in values)


def message_class(msgtype):
    """Return the rclpy message class of a supported ``msgtype``."""
    from sensor_msgs.msg import Imu, MagneticField, Temperature
    return {IMU: Imu, MAGNETIC_FIELD: MagneticField, TEMPERATURE: Temperature}[msgtype]


def imu_message(series, i):
    """Return row ``i`` of an ImuSeries as a sensor_msgs/Imu."""
    msg = _header(message_class(IMU)(), series, i)
    o = series.orientation_xyzw[i]
    msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = map(float, o)
    _vector(msg.angular_velocity, series.angular_velocity_radps[i])
    _vector(msg.linear_acceleration, series.linear_acceleration_mps2[i])
    msg.orientation_covariance = series.orientation_covariance[i]
    msg.angular_velocity_covariance = series.angular_velocity_covariance[i]
    msg.linear_acceleration_covariance = series.linear_acceleration_covariance[i]
    return msg


def magnetic_field_message(series, i):
    """Return row ``i`` of a MagneticFieldSeries as a sensor_msgs/MagneticField (tesla)."""
    msg = _header(message_class(MAGNETIC_FIELD)(), series, i)
    _vector(msg.magnetic_field, series.magnetic_field_T[i])
    msg.magnetic_field_covariance = series.covariance_T2[i]
    return msg


def temperature_message(series, i):
    """Return row ``i`` of a TemperatureSeries as a sensor_msgs/Temperature."""
    msg = _header(message_class(TEMPERATURE)(), series, i)
    msg.temperature, msg.variance = float(series.temperature_c[i]), float(series.variance[i])
    return msg


MESSAGES = {IMU: imu_message, MAGNETIC_FIELD: magnetic_field_message,
            TEMPERATURE: temperature_message}


def publish_timed(timeline, publishers, rate, idle, published=None):
    """
    Publish the messages of ``timeline`` paced by their stamps; return how many.

    ``publishers`` maps each topic to its publisher; ``idle(seconds)`` is called
    while waiting for the next message's time (e.g. an executor's
    ``spin_once``); ``published(count)`` after each message.
    """
    start = time.monotonic()
    count = 0
    for k in range(len(timeline)):
        due = start + (timeline.stamps_ns[k] - timeline.stamps_ns[0]) * 1e-9 / rate
        while (wait := due - time.monotonic()) > 0:
            idle(wait)
        topic, msgtype, series, row = timeline.entry(k)
        publishers[topic].publish(MESSAGES[msgtype](series, row))
        count += 1
        if published is not None:
            published(count)
    return count
