"""
What ``inclino simulate`` records: a simulated run as a bag (and a CSV), and the run's limits.

The topics a simulated bag holds (the raw sensor, the truth, the stand
attitude, the temperature, the magnetometer), one message per sample on
each, and the checks a run's options must pass before it is simulated
(``check_run``).
"""

from inclino_ros.io import tables
from inclino_ros.io.bag import (
    BagWriter, IMU, MAGNETIC_FIELD, MagneticFieldSeries, raw_imu, TEMPERATURE,
    TemperatureSeries, VECTOR3_STAMPED, Vector3Series)
from inclino_ros.sim.bench import Scenario, STAND_POSITIONS_DEG
import numpy as np

RAW_TOPIC = '/imu/data_raw'
TRUTH_TOPIC = '/truth/survey'
STAND_TOPIC = '/stand/attitude'
TEMPERATURE_TOPIC = '/imu/temperature'
MAG_TOPIC = '/imu/mag'
FRAME_ID = 'inclinometer'
#: Most samples of one run (1 000 000: 83 min of a 200 Hz bench).
MAX_SAMPLES = 1_000_000


def check_run(mode, magnetic, axes, heating_attitudes, attitudes_given, samples, rate_hz,
              segments_s):
    """
    Refuse (ValueError) a run that cannot be simulated as asked.

    ``mode`` None (the bench), 'stand' or 'heating'; ``magnetic`` the bench's
    magnetometer; ``axes`` of the accelerometer; ``heating_attitudes`` the
    flat INCLINATION TOOLFACE list, ``attitudes_given`` whether the user gave
    it; ``samples`` per stand position or heating attitude; ``segments_s``
    (level, station, rotation) [s] of the bench.  A run of more than
    MAX_SAMPLES samples is refused before it is simulated.  Return the
    (inclination, toolface) pairs of the heating attitudes.
    """
    if mode is not None and magnetic:
        raise ValueError('--magnetic goes with the bench scenario, not --stand or --heating')
    if mode is not None and axes != 3:
        raise ValueError('--stand and --heating simulate a three-axis sensor')
    if attitudes_given and mode != 'heating':
        raise ValueError('--heating-attitudes goes with --heating')
    if len(heating_attitudes) % 2:
        raise ValueError('--heating-attitudes takes INCLINATION TOOLFACE pairs, '
                         f'not {len(heating_attitudes)} numbers')
    pairs = tuple(zip(heating_attitudes[::2], heating_attitudes[1::2]))
    if mode is None:
        level_s, station_s, rotation_s = segments_s
        total = rate_hz * (level_s + station_s * len(Scenario().stations_deg)
                           + (rotation_s if magnetic else 0.0))
    else:
        total = samples * (len(STAND_POSITIONS_DEG) if mode == 'stand' else len(pairs))
    if total > MAX_SAMPLES:
        raise ValueError(f'{total:.0f} samples asked for, at most {MAX_SAMPLES} are '
                         'simulated: shorten the segments or lower --rate-hz / --samples')
    return pairs


def describe(sensor, tool):
    """Return one line naming the preset, the mount and the noise of ``tool``."""
    mount = tool.mount
    noise = np.max(tool.accelerometer.noise_std)
    return (f'{sensor} sensor ({tool.accelerometer_axes}-axis accelerometer), mount '
            f'gamma {mount.gamma_deg:g} beta {mount.beta_deg:g} roll {mount.roll_deg:g} deg, '
            f'noise {noise:g} m/s^2')


def write_bag(path, storage, sim, noise_std_mps2, mode, magnetic=None):
    """
    Write the samples of ``sim`` to a new bag; return ``{role: topic}``.

    ``magnetic``: None, or the MagneticFieldSeries at the same stamps (the
    true azimuth then goes to the truth's z); ``mode`` 'stand' or 'heating'
    adds the temperature topic, 'stand' the stand attitude.
    """
    n = sim.stamps_ns.size
    frame_ids = np.full(n, FRAME_ID)
    azimuth_deg = np.full(n, np.nan) if magnetic is None else sim.azimuth_deg
    series = {
        RAW_TOPIC: raw_imu(sim.stamps_ns, FRAME_ID, sim.raw_mps2, noise_std_mps2),
        TRUTH_TOPIC: Vector3Series(sim.stamps_ns, frame_ids, np.stack(
            [sim.inclination_deg, sim.toolface_deg, azimuth_deg], axis=1))}
    topics = {'raw': RAW_TOPIC, 'truth': TRUTH_TOPIC}
    if magnetic is not None:
        series[MAG_TOPIC] = magnetic
        topics['magnetometer'] = MAG_TOPIC
    if mode == 'stand':
        series[STAND_TOPIC] = series[TRUTH_TOPIC]
        topics['stand_attitude'] = STAND_TOPIC
    if mode is not None:
        series[TEMPERATURE_TOPIC] = TemperatureSeries(sim.stamps_ns, frame_ids,
                                                      sim.temperature_c, np.zeros(n))
        topics['temperature'] = TEMPERATURE_TOPIC
    msgtypes = {Vector3Series: VECTOR3_STAMPED, TemperatureSeries: TEMPERATURE,
                MagneticFieldSeries: MAGNETIC_FIELD}
    with BagWriter(path, storage) as bag:
        for topic, values in series.items():
            bag.add_topic(topic, msgtypes.get(type(values), IMU))
        bag.write_series(series)
    return topics


def write_csv(path, sim, temperature, attitude=False):
    """Write one row per sample: stamp, true attitude, [temperature, attitude,] raw reading."""
    columns = {'stamp_ns': sim.stamps_ns, 'inclination_deg': sim.inclination_deg,
               'toolface_deg': sim.toolface_deg}
    if temperature:
        columns['temperature_c'] = sim.temperature_c
    if attitude:
        columns['attitude'] = sim.segment
    columns.update(zip(('ax', 'ay', 'az'), sim.raw_mps2.T))
    tables.write_csv(path, columns)
