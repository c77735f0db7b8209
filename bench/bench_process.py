"""
Offline throughput of ``inclino process`` against reading the same bag.

On one simulated mcap bag of about 100k samples this times, in the same run,
(a) a read-and-deserialize-only pass over its Imu topic with rosbags (Reader +
``typestore.deserialize_cdr`` of every message) and (b) ``inclino process``
(read, correct, write /survey and /imu/data), and prints the messages per
second of each and the ratio (b)/(a).  The target is a ratio >= 0.8.

Run: ``.venv/bin/python bench/bench_process.py [--repeat N] [--keep DIR]``.
"""

import argparse
import contextlib
import io
import os
import shutil
import sys
import tempfile
import time

from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.model import CalibrationModel, save_model
from inclino_ros.cli.main import main as inclino
from inclino_ros.io.bag import read
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore, Stores

TOPIC = '/imu/data_raw'
#: 1 kHz for 3 s level + 12 stations x 8 s: 99,000 samples.
SIMULATE_ARGS = ['--rate-hz', '1000', '--level-s', '3', '--station-s', '8']
TARGET_RATIO = 0.8


def read_and_deserialize(path):
    """Return the number of Imu messages read and deserialized with plain rosbags."""
    typestore = get_typestore(Stores.ROS2_JAZZY)
    count = 0
    with Reader(path) as reader:
        connections = [c for c in reader.connections if c.topic == TOPIC]
        for connection, _, data in reader.messages(connections=connections):
            typestore.deserialize_cdr(data, connection.msgtype)
            count += 1
    return count


def timed(function, *args):
    """Return (result, seconds) of one call."""
    start = time.perf_counter()
    result = function(*args)
    return result, time.perf_counter() - start


def calibrate(bag_path, calibration_path):
    """Write a calibration from the first 3 s (the level segment) of the bag."""
    level = next(read(bag_path, TOPIC, chunk_size=3000)).linear_acceleration_mps2
    installation = solve_level_capture(level, 3, LevelLimits(
        max_tilt_deg=5.0, gravity_mps2=9.80665, g_total_tolerance_mps2=0.05))
    save_model(calibration_path, CalibrationModel(accelerometer_axes=3,
                                                  installation=installation))


def main(argv=None):
    """Run the benchmark; return 0 when the target ratio is met, 1 otherwise."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--repeat', type=int, default=3,
                        help='timed runs of each pass; the best of each counts')
    parser.add_argument('--keep', metavar='DIR', help='work in DIR and keep the bags')
    args = parser.parse_args(argv)
    work = args.keep or tempfile.mkdtemp(prefix='inclino-bench-')
    os.makedirs(work, exist_ok=True)
    try:
        bag_in = os.path.join(work, 'sim')
        calibration = os.path.join(work, 'calibration.json')
        with contextlib.redirect_stdout(io.StringIO()):
            if inclino(['simulate', bag_in, '--storage', 'mcap'] + SIMULATE_ARGS) != 0:
                raise RuntimeError('inclino simulate failed')
        calibrate(bag_in, calibration)
        read_s, process_s = [], []
        for run in range(args.repeat):
            count, seconds = timed(read_and_deserialize, bag_in)
            read_s.append(seconds)
            bag_out = os.path.join(work, f'out{run}')
            with contextlib.redirect_stdout(io.StringIO()), \
                    contextlib.redirect_stderr(io.StringIO()):
                code, seconds = timed(inclino, ['process', bag_in, bag_out,
                                                '--calibration', calibration])
            if code != 0:
                raise RuntimeError(f'inclino process failed with exit code {code}')
            process_s.append(seconds)
            shutil.rmtree(bag_out)
        read_rate = count / min(read_s)
        process_rate = count / min(process_s)
        ratio = process_rate / read_rate
        print(f'bag: {count} Imu messages (mcap), best of {args.repeat} runs')
        print(f'(a) rosbags read + deserialize: {read_rate:10.0f} msg/s')
        print(f'(b) inclino process:            {process_rate:10.0f} msg/s '
              '(read, correct, write 2 topics)')
        print(f'ratio (b)/(a): {ratio:.2f} (target >= {TARGET_RATIO})')
        return 0 if ratio >= TARGET_RATIO else 1
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == '__main__':
    sys.exit(main())
