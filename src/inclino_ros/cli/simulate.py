"""
``inclino simulate``: record the virtual bench into a bag, with its truth.

The bag holds the raw sensor on ``/imu/data_raw`` and, at the same stamps, the
true attitude on ``/truth/survey``; ``OUT.truth.json`` holds the scenario and
its segments.  ``--stand`` records seed 001's nine stand positions instead
(plus ``/stand/attitude`` and ``/imu/temperature`` at 25 deg C), ``--heating``
a heating run from 20 to 100 deg C at one attitude (plus ``/imu/temperature``);
both use ``simulate.SensorErrors`` (K, bias, K_T(T)), whose truth goes to
the JSON file.  ``--csv`` writes the samples as CSV too.

``--magnetic`` (bench scenario) adds a magnetometer on ``/imu/mag``
(sensor_msgs/MagneticField, tesla, REP 145 z-up tool frame, the ideal tool
axes: the magnetometer is taken as mounted true, the accelerometer with its
gamma, beta).  Each station gets a magnetic azimuth (``--azimuth-deg FIRST
LAST``, linear over the stations; the truth on ``/truth/survey`` z, NaN on the
level segment where the tool is vertical); the field is the ISCWSA forward
model (``magnetics.forward``, gravity toolface = seed000 + 90 deg) of the
reference field, plus the drill string's interference (``--interference-nT``
in the ISCWSA axes of ``inclino simulate-well`` and ``inclino msa``: x, y
cross-axial, z toward the bit) and independent noise per sample, turned into
the tool frame with ``magnetics.iscwsa_from_tool``.  ``--rotation-s`` appends
a rotation segment: the tool turning about its axis (``--rotation-turns``) at
one inclination and azimuth, for ``inclino fit-rotation``.  Every magnetometer
message has the stamp of the accelerometer sample it goes with (one each, the
same stamps): ``inclino process --mag-topic`` pairs them exactly.
"""

import csv
from dataclasses import dataclass, replace
import json
import math
import sys

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.mounting import add_axes_map_arguments, settings_maps
from inclino_ros.core import magnetics
from inclino_ros.core.attitude import specific_force
from inclino_ros.core.mounting import to_sensor_axes
from inclino_ros.io.bag import (
    BagWriter, IMU, MAGNETIC_FIELD, MagneticFieldSeries, magnetometer, raw_imu, TEMPERATURE,
    TemperatureSeries, VECTOR3_STAMPED, Vector3Series)
from inclino_ros.pipeline import Settings
from inclino_ros.sim.bench import (
    Scenario, sensor_matrix, SensorErrors, SensorRun, simulate, simulate_heating,
    simulate_stand)
from inclino_ros.sim.well import WellScenario
import numpy as np

RAW_TOPIC = '/imu/data_raw'
TRUTH_TOPIC = '/truth/survey'
STAND_TOPIC = '/stand/attitude'
TEMPERATURE_TOPIC = '/imu/temperature'
MAG_TOPIC = '/imu/mag'
#: Default samples: per stand position (--stand), over the whole ramp (--heating).
DEFAULT_SAMPLES = {'stand': 100, 'heating': 1601}
FRAME_ID = 'inclinometer'


def register(subparsers):
    """Add the ``simulate`` subcommand."""
    defaults = Scenario()
    parser = add_command(
        subparsers, 'simulate', 'write a bag of a simulated inclinometer, with its truth',
        'Write a bag of a simulated inclinometer and, beside it, the truth.',
        'By default a bench run: the tool still on a levelled bench for --level-s, then held '
        'at 12 attitudes (inclination 0.5 to 60 deg) for --station-s each, its sensor mounted '
        '--gamma-deg and --beta-deg off (seed 000). The bag holds the raw sensor on '
        f'{RAW_TOPIC} and the truth on {TRUTH_TOPIC} (x inclination, y toolface, z magnetic '
        'azimuth with --magnetic, degrees); OUT.truth.json holds the scenario and the times '
        'of each segment.',
        f'--stand: the nine stand positions of seed 001, of a sensor with scale, '
        f'misalignment and bias errors (the attitude on {STAND_TOPIC}, 25 C on '
        f'{TEMPERATURE_TOPIC}). --heating: the same sensor heating from 20 to 100 C at one '
        f'attitude. --magnetic: a magnetometer on {MAG_TOPIC} with the drill-string '
        'interference, and --rotation-s a rotation for inclino fit-rotation. The mounting '
        'options write what a board mounted that way reads.')
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
    add_magnetic_arguments(parser)
    add_axes_map_arguments(parser, 'accelerometer', 'magnetometer', writing=True)
    parser.set_defaults(func=run, mode=None)


@dataclass(frozen=True)
class MagneticBench:
    """The magnetometer of ``--magnetic``: field, azimuths, interference, noise, rotation."""

    reference_total_nT: float
    reference_dip_deg: float
    azimuth_deg: tuple            # first and last station
    interference_nT: tuple        # ISCWSA axes (x, y cross-axial, z toward the bit)
    noise_nT: float               # per sample and axis, 1 sigma
    rotation_s: float             # 0: no rotation segment
    rotation_turns: float
    rotation_attitude_deg: tuple  # (inclination, azimuth) of the rotation


def add_magnetic_arguments(parser):
    """Add ``--magnetic`` and its options (defaults: those of ``inclino simulate-well``)."""
    well = WellScenario()
    group = parser.add_argument_group('magnetometer (--magnetic, bench scenario only)')
    group.add_argument('--magnetic', action='store_true',
                       help=f'add the magnetometer on {MAG_TOPIC} and the azimuth truth')
    group.add_argument('--reference-total-nT', type=float, default=well.reference_total_nT,
                       metavar='F', help='reference total field [nT] (default: %(default)s)')
    group.add_argument('--reference-dip-deg', type=float, default=well.reference_dip_deg,
                       metavar='D', help='reference dip [deg] (default: %(default)s)')
    group.add_argument('--azimuth-deg', type=float, nargs=2, default=well.azimuth_deg,
                       metavar=('FIRST', 'LAST'),
                       help='magnetic azimuth of the first and last station, linear between '
                            '(default: %(default)s)')
    group.add_argument('--interference-nT', type=float, nargs=3, default=well.interference_nT,
                       metavar=('EX', 'EY', 'EZ'),
                       help='drill-string interference in ISCWSA axes [nT]: cross-axial x, y '
                            'and axial z toward the bit (default: %(default)s)')
    group.add_argument('--mag-noise-nT', type=float, default=well.field_noise_nT,
                       metavar='NOISE_NT',
                       help='magnetometer noise per sample and axis, 1 sigma [nT] '
                            '(default: %(default)s)')
    group.add_argument('--rotation-s', type=float, default=0.0, metavar='S',
                       help='append a rotation segment of S seconds (default: none)')
    group.add_argument('--rotation-turns', type=float, default=2.0,
                       help='turns of the tool about its axis in the rotation '
                            '(default: %(default)s)')
    group.add_argument('--rotation-attitude-deg', type=float, nargs=2, default=(60.0, 90.0),
                       metavar=('INCLINATION', 'AZIMUTH'),
                       help='attitude held while turning (default: %(default)s)')


def magnetic_bench(args):
    """Return the MagneticBench of the command line; ValueError for impossible values."""
    bench = MagneticBench(
        reference_total_nT=args.reference_total_nT, reference_dip_deg=args.reference_dip_deg,
        azimuth_deg=tuple(args.azimuth_deg), interference_nT=tuple(args.interference_nT),
        noise_nT=args.mag_noise_nT, rotation_s=args.rotation_s,
        rotation_turns=args.rotation_turns,
        rotation_attitude_deg=tuple(args.rotation_attitude_deg))
    if not bench.reference_total_nT > 0.0 or bench.noise_nT < 0.0 or bench.rotation_s < 0.0:
        raise ValueError('--reference-total-nT must be positive, --mag-noise-nT and '
                         '--rotation-s not negative')
    return bench


def add_rotation(sim, scenario, bench):
    """
    Return ``sim`` with a rotation segment appended: the tool turning about its axis.

    Inclination and azimuth are held (``bench.rotation_attitude_deg``) while
    the seed000 toolface goes through ``bench.rotation_turns`` turns; the
    accelerometer reads as on the stations (``C(gamma, beta) f + noise``).
    """
    n = round(bench.rotation_s * scenario.rate_hz)
    if n < 1:
        return sim
    period_ns = 1e9 / scenario.rate_hz
    stamps_ns = sim.stamps_ns[-1] + np.round(np.arange(1, n + 1) * period_ns).astype(np.int64)
    inclination_deg = np.full(n, bench.rotation_attitude_deg[0])
    toolface_deg = np.mod(np.arange(n) * 360.0 * bench.rotation_turns / n, 360.0)
    f = specific_force(np.radians(inclination_deg), np.radians(toolface_deg),
                       scenario.gravity_mps2)
    c = sensor_matrix(math.radians(scenario.gamma_deg), math.radians(scenario.beta_deg))
    rng = np.random.default_rng(scenario.seed + 1)
    raw = f @ c.T + rng.normal(0.0, scenario.noise_std_mps2, size=f.shape)
    index = int(sim.segment.max()) + 1
    record = {'index': index, 'kind': 'rotation', 'start_ns': int(stamps_ns[0]),
              'end_ns': int(stamps_ns[-1]), 'samples': n,
              'inclination_deg': bench.rotation_attitude_deg[0], 'toolface_deg': None,
              'turns': bench.rotation_turns}
    return replace(
        sim, stamps_ns=np.concatenate([sim.stamps_ns, stamps_ns]),
        raw_mps2=np.concatenate([sim.raw_mps2, raw]),
        inclination_deg=np.concatenate([sim.inclination_deg, inclination_deg]),
        toolface_deg=np.concatenate([sim.toolface_deg, toolface_deg]),
        segment=np.concatenate([sim.segment, np.full(n, index)]),
        truth=dict(sim.truth, segments=sim.truth['segments'] + [record]))


def station_azimuths_deg(sim, bench):
    """
    Return the true magnetic azimuth of every sample and add it to the truth's segments.

    Stations: linear from the first to the last of ``bench.azimuth_deg``;
    the rotation: its own; the level segment: NaN (vertical, no azimuth).
    """
    stations = [r for r in sim.truth['segments'] if r['kind'] == 'station']
    station_deg = np.mod(np.linspace(*bench.azimuth_deg, len(stations)), 360.0)
    by_index = {r['index']: float(a) for r, a in zip(stations, station_deg)}
    for record in sim.truth['segments']:
        record['azimuth_deg'] = (bench.rotation_attitude_deg[1] if record['kind'] == 'rotation'
                                 else by_index.get(record['index']))
    per_segment = np.array([math.nan if r['azimuth_deg'] is None else r['azimuth_deg']
                            for r in sim.truth['segments']])
    return per_segment[sim.segment]


def magnetic_readings_nT(sim, azimuth_deg, bench, seed):
    """
    Return the magnetometer readings (N, 3) [nT, z-up tool frame] of the samples of ``sim``.

    ISCWSA forward model of the true attitude (seed000 toolface + 90 deg is
    the ISCWSA gravity toolface; a NaN toolface or azimuth is taken as 0),
    plus the interference and the noise, in ISCWSA axes, then turned into
    the tool frame.
    """
    _, field = magnetics.forward(
        sim.inclination_deg, np.nan_to_num(azimuth_deg), np.nan_to_num(sim.toolface_deg) + 90.0,
        1.0, bench.reference_total_nT, bench.reference_dip_deg)
    rng = np.random.default_rng(seed + 2)
    field = field + np.asarray(bench.interference_nT) + rng.normal(0.0, bench.noise_nT,
                                                                   field.shape)
    return magnetics.iscwsa_from_tool(field)


def add_magnetics(sim, scenario, bench):
    """Return (sim with the rotation and magnetic truth, azimuth_deg (N,), field_nT (N, 3))."""
    sim = add_rotation(sim, scenario, bench)
    azimuth_deg = station_azimuths_deg(sim, bench)
    field_nT = magnetic_readings_nT(sim, azimuth_deg, bench, scenario.seed)
    interference = np.asarray(bench.interference_nT, dtype=float)
    truth = dict(sim.truth, magnetic={
        'reference_total_nT': bench.reference_total_nT,
        'reference_dip_deg': bench.reference_dip_deg,
        'interference_iscwsa_nT': interference.tolist(),
        'interference_tool_nT': magnetics.iscwsa_from_tool(interference).tolist(),
        'noise_nT': bench.noise_nT, 'topic': MAG_TOPIC,
        'frame': 'REP 145 z-up tool frame (ideal tool axes), tesla on the topic',
        'pairing': 'one message per accelerometer sample, same stamp'})
    return replace(sim, truth=truth), azimuth_deg, field_nT


def run(args):
    """Simulate and write the bag and its truth file; return the exit code."""
    magnetic = None
    try:
        mounting = Settings(accelerometer_axes=args.axes, **settings_maps(args))
    except ValueError as err:
        print(f'inclino simulate: error: {err}', file=sys.stderr)
        return 2
    if args.mode is None:
        scenario = Scenario(
            gamma_deg=args.gamma_deg, beta_deg=args.beta_deg,
            noise_std_mps2=args.noise_std_mps2, rate_hz=args.rate_hz, level_s=args.level_s,
            station_s=args.station_s, seed=args.seed, axes=args.axes)
        sim = simulate(scenario)
        what = (f'{scenario.axes}-axis sensor, gamma_deg={scenario.gamma_deg} '
                f'beta_deg={scenario.beta_deg}')
        if args.magnetic:
            try:
                bench = magnetic_bench(args)
            except ValueError as err:
                print(f'inclino simulate: error: {err}', file=sys.stderr)
                return 2
            sim, azimuth_deg, field_nT = add_magnetics(sim, scenario, bench)
            field_nT = to_sensor_axes(field_nT, mounting.magnetometer_matrix)
            magnetic = (azimuth_deg, magnetometer(sim.stamps_ns, FRAME_ID, field_nT,
                                                  bench.noise_nT))
            what += (f'; magnetometer on {MAG_TOPIC}, interference '
                     f'{", ".join(f"{v:g}" for v in bench.interference_nT)} nT (ISCWSA x, y, z)')
    else:
        if args.magnetic:
            print('inclino simulate: error: --magnetic goes with the bench scenario, not '
                  '--stand or --heating', file=sys.stderr)
            return 2
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
    # The bag holds what a board mounted so reads: sensor = M^-1 tool.
    sim = replace(sim, raw_mps2=to_sensor_axes(sim.raw_mps2, mounting.accelerometer_matrix))
    topics = write_bag(args.out, args.storage, sim, args.noise_std_mps2, args.mode, magnetic)
    truth_path = f'{args.out}.truth.json'
    with open(truth_path, 'w') as stream:
        json.dump(dict(sim.truth, bag=args.out, storage=args.storage, topics=topics,
                       frame_id=FRAME_ID, mounting={
                           'accelerometer_axes_map': args.accelerometer_axes_map,
                           'magnetometer_axes_map': args.magnetometer_axes_map}),
                  stream, indent=2)
        stream.write('\n')
    print(f'wrote {args.out} ({args.storage}): {sim.stamps_ns.size} messages on each of '
          f'{", ".join(topics.values())}; {what}, noise {args.noise_std_mps2} m/s^2')
    print(f'wrote {truth_path}: {len(sim.truth["segments"])} segments')
    if args.csv:
        write_csv(args.csv, sim)
        print(f'wrote {args.csv}: {sim.stamps_ns.size} rows')
    return 0


def write_bag(path, storage, sim, noise_std_mps2, mode, magnetic=None):
    """
    Write the samples of ``sim`` to a new bag; return ``{role: topic}``.

    ``magnetic``: None, or (true azimuth_deg (N,), MagneticFieldSeries) at the
    same stamps: the azimuth goes to the truth's z, the series to MAG_TOPIC.
    """
    n = sim.stamps_ns.size
    frame_ids = np.full(n, FRAME_ID)
    azimuth_deg = np.full(n, np.nan) if magnetic is None else magnetic[0]
    series = {
        RAW_TOPIC: raw_imu(sim.stamps_ns, FRAME_ID, sim.raw_mps2, noise_std_mps2),
        TRUTH_TOPIC: Vector3Series(sim.stamps_ns, frame_ids, np.stack(
            [sim.inclination_deg, sim.toolface_deg, azimuth_deg], axis=1))}
    topics = {'raw': RAW_TOPIC, 'truth': TRUTH_TOPIC}
    if magnetic is not None:
        series[MAG_TOPIC] = magnetic[1]
        topics['magnetometer'] = MAG_TOPIC
    if mode == 'stand':
        series[STAND_TOPIC] = series[TRUTH_TOPIC]
        topics['stand_attitude'] = STAND_TOPIC
    if sim.temperature_c is not None:
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
