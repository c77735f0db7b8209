"""
``inclino simulate``: record the virtual bench into a bag, with its truth.

The bag holds the raw sensor on ``/imu/data_raw`` and, at the same stamps, the
true attitude on ``/truth/survey``; ``OUT.truth.json`` holds the scenario and
its segments.  ``--stand`` records seed 001's nine stand positions instead
(plus ``/stand/attitude`` and ``/imu/temperature`` at 25 deg C), ``--heating``
a heating run from 20 to 100 deg C at one attitude (plus ``/imu/temperature``);
both use ``simulate.SensorErrors`` (K, bias, K_T(T)), whose truth goes to
the JSON file.  ``--csv`` writes the samples as CSV too.
"""

import csv
import json
import sys

from inclino_ros.bag import (
    BagWriter, IMU, raw_imu, TEMPERATURE, TemperatureSeries, VECTOR3_STAMPED, Vector3Series)
from inclino_ros.simulate import (
    Scenario, SensorErrors, SensorRun, simulate, simulate_heating, simulate_stand)
import numpy as np

RAW_TOPIC = '/imu/data_raw'
TRUTH_TOPIC = '/truth/survey'
STAND_TOPIC = '/stand/attitude'
TEMPERATURE_TOPIC = '/imu/temperature'
#: Default samples: per stand position (--stand), over the whole ramp (--heating).
DEFAULT_SAMPLES = {'stand': 100, 'heating': 1601}
FRAME_ID = 'inclinometer'


def register(subparsers):
    """Add the ``simulate`` subcommand."""
    defaults = Scenario()
    parser = subparsers.add_parser(
        'simulate', help='write a bag of a misaligned inclinometer on a virtual bench',
        description='Simulate a level segment then tilted stations (seed 000 Eqs. 1-2) and '
                    f'write the raw sensor ({RAW_TOPIC}) and the truth ({TRUTH_TOPIC}: '
                    'x inclination_deg, y toolface_deg seed000, z NaN) to the bag OUT, '
                    'plus OUT.truth.json.')
    parser.add_argument('out', metavar='OUT', help='bag directory to create')
    for flag, name, meaning in (
            ('--gamma-deg', 'gamma_deg', 'installation angle gamma [deg]'),
            ('--beta-deg', 'beta_deg', 'installation angle beta [deg]'),
            ('--noise-mps2', 'noise_std_mps2', 'noise per axis, 1 sigma [m/s^2]'),
            ('--rate-hz', 'rate_hz', 'sample rate [Hz]'),
            ('--level-s', 'level_s', 'duration of the level segment [s]'),
            ('--station-s', 'station_s', 'duration of each tilted station [s]')):
        parser.add_argument(flag, dest=name, type=float, default=getattr(defaults, name),
                            metavar=flag[2:].upper().replace('-', '_'),
                            help=f'{meaning} (default: %(default)s)')
    parser.add_argument('--seed', type=int, default=defaults.seed,
                        help='seed of the noise generator (default: %(default)s)')
    parser.add_argument('--axes', type=int, choices=(2, 3), default=defaults.axes,
                        help='accelerometer axes; a 2-axis sensor reads z = 0.0 '
                             '(default: %(default)s)')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap',
                        help='bag storage format (default: %(default)s)')
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument('--stand', dest='mode', action='store_const', const='stand',
                      help=f'seed 001 stand: nine still positions at 25 deg C, the attitude '
                           f'on {STAND_TOPIC} (x inclination_deg, y toolface_deg, z NaN)')
    mode.add_argument('--heating', dest='mode', action='store_const', const='heating',
                      help=f'seed 001 heating run: inclination 55 deg, toolface 45 deg, '
                           f'20 -> 100 deg C on {TEMPERATURE_TOPIC}')
    parser.add_argument('--samples', type=int,
                        help='--stand: samples per position (default: '
                             f'{DEFAULT_SAMPLES["stand"]}); --heating: samples over the ramp '
                             f'(default: {DEFAULT_SAMPLES["heating"]})')
    parser.add_argument('--csv', metavar='FILE',
                        help='also write the samples to FILE: stamp_ns, inclination_deg, '
                             'toolface_deg, [temperature_c,] ax, ay, az [m/s^2]')
    parser.set_defaults(func=run, mode=None)


def run(args):
    """Simulate and write the bag and its truth file; return the exit code."""
    if args.mode is None:
        scenario = Scenario(
            gamma_deg=args.gamma_deg, beta_deg=args.beta_deg,
            noise_std_mps2=args.noise_std_mps2, rate_hz=args.rate_hz, level_s=args.level_s,
            station_s=args.station_s, seed=args.seed, axes=args.axes)
        sim = simulate(scenario)
        what = (f'{scenario.axes}-axis sensor, gamma_deg={scenario.gamma_deg} '
                f'beta_deg={scenario.beta_deg}')
    else:
        if args.axes != 3:
            print('inclino simulate: error: --stand and --heating simulate a three-axis sensor',
                  file=sys.stderr)
            return 2
        errors = SensorErrors(gamma_deg=args.gamma_deg, beta_deg=args.beta_deg)
        sensor_run = SensorRun(errors=errors, noise_std_mps2=args.noise_std_mps2,
                               rate_hz=args.rate_hz, seed=args.seed)
        samples = DEFAULT_SAMPLES[args.mode] if args.samples is None else args.samples
        if samples < 1:
            print('inclino simulate: error: --samples must be at least 1', file=sys.stderr)
            return 2
        sim = (simulate_stand(sensor_run, samples=samples) if args.mode == 'stand' else
               simulate_heating(sensor_run, samples=samples))
        what = f'{args.mode} run of a three-axis sensor (K, bias, K_T(T) in the truth file)'
    topics = write_bag(args.out, args.storage, sim, args.noise_std_mps2, args.mode)
    truth_path = f'{args.out}.truth.json'
    with open(truth_path, 'w') as stream:
        json.dump(dict(sim.truth, bag=args.out, storage=args.storage, topics=topics,
                       frame_id=FRAME_ID), stream, indent=2)
        stream.write('\n')
    print(f'wrote {args.out} ({args.storage}): {sim.stamps_ns.size} messages on each of '
          f'{", ".join(topics.values())}; {what}, noise {args.noise_std_mps2} m/s^2')
    print(f'wrote {truth_path}: {len(sim.truth["segments"])} segments')
    if args.csv:
        write_csv(args.csv, sim)
        print(f'wrote {args.csv}: {sim.stamps_ns.size} rows')
    return 0


def write_bag(path, storage, sim, noise_std_mps2, mode):
    """Write the samples of ``sim`` to a new bag; return ``{role: topic}``."""
    n = sim.stamps_ns.size
    frame_ids = np.full(n, FRAME_ID)
    series = {
        RAW_TOPIC: raw_imu(sim.stamps_ns, FRAME_ID, sim.raw_mps2, noise_std_mps2),
        TRUTH_TOPIC: Vector3Series(sim.stamps_ns, frame_ids, np.stack(
            [sim.inclination_deg, sim.toolface_deg, np.full(n, np.nan)], axis=1))}
    topics = {'raw': RAW_TOPIC, 'truth': TRUTH_TOPIC}
    if mode == 'stand':
        series[STAND_TOPIC] = series[TRUTH_TOPIC]
        topics['stand_attitude'] = STAND_TOPIC
    if sim.temperature_c is not None:
        series[TEMPERATURE_TOPIC] = TemperatureSeries(sim.stamps_ns, frame_ids,
                                                      sim.temperature_c, np.zeros(n))
        topics['temperature'] = TEMPERATURE_TOPIC
    msgtypes = {Vector3Series: VECTOR3_STAMPED, TemperatureSeries: TEMPERATURE}
    with BagWriter(path, storage) as bag:
        for topic, values in series.items():
            bag.add_topic(topic, msgtypes.get(type(values), IMU))
        bag.write_series(series)
    return topics


def write_csv(path, sim):
    """Write one row per sample: stamp, true attitude, [temperature,] raw reading."""
    columns = {'stamp_ns': sim.stamps_ns, 'inclination_deg': sim.inclination_deg,
               'toolface_deg': sim.toolface_deg}
    if sim.temperature_c is not None:
        columns['temperature_c'] = sim.temperature_c
    columns.update(zip(('ax', 'ay', 'az'), sim.raw_mps2.T))
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(zip(*(values.tolist() for values in columns.values())))
