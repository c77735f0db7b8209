"""
``inclino simulate``: record the virtual bench into a bag, with its truth.

The bag holds the raw sensor on ``/imu/data_raw`` and, at the same stamps, the
true attitude on ``/truth/survey``; ``OUT.truth.json`` holds the scenario and
its segments.
"""

import json

from inclino_ros.bag import BagWriter, IMU, raw_imu, VECTOR3_STAMPED, Vector3Series
from inclino_ros.simulate import Scenario, simulate
import numpy as np

RAW_TOPIC = '/imu/data_raw'
TRUTH_TOPIC = '/truth/survey'
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
    parser.set_defaults(func=run)


def run(args):
    """Simulate and write the bag and its truth file; return the exit code."""
    scenario = Scenario(
        gamma_deg=args.gamma_deg, beta_deg=args.beta_deg, noise_std_mps2=args.noise_std_mps2,
        rate_hz=args.rate_hz, level_s=args.level_s, station_s=args.station_s,
        seed=args.seed, axes=args.axes)
    sim = simulate(scenario)
    truth = Vector3Series(
        stamps_ns=sim.stamps_ns, frame_ids=np.full(sim.stamps_ns.size, FRAME_ID),
        vector=np.stack([sim.inclination_deg, sim.toolface_deg,
                         np.full(sim.stamps_ns.size, np.nan)], axis=1))
    with BagWriter(args.out, args.storage) as bag:
        bag.add_topic(RAW_TOPIC, IMU)
        bag.add_topic(TRUTH_TOPIC, VECTOR3_STAMPED)
        bag.write_series({
            RAW_TOPIC: raw_imu(sim.stamps_ns, FRAME_ID, sim.raw_mps2, scenario.noise_std_mps2),
            TRUTH_TOPIC: truth})
    truth_path = f'{args.out}.truth.json'
    with open(truth_path, 'w') as stream:
        json.dump(dict(sim.truth, bag=args.out, storage=args.storage,
                       topics={'raw': RAW_TOPIC, 'truth': TRUTH_TOPIC}, frame_id=FRAME_ID),
                  stream, indent=2)
        stream.write('\n')
    print(f'wrote {args.out} ({args.storage}): {sim.stamps_ns.size} messages on {RAW_TOPIC} '
          f'and on {TRUTH_TOPIC}, {scenario.axes}-axis sensor, gamma_deg={scenario.gamma_deg} '
          f'beta_deg={scenario.beta_deg}, noise {scenario.noise_std_mps2} m/s^2')
    print(f'wrote {truth_path}: {len(sim.truth["segments"])} segments '
          f'(level + {len(scenario.stations_deg)} stations)')
    return 0
