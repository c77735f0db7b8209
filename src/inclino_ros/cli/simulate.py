"""
``inclino simulate``: a physical inclinometer on the virtual bench, into a bag with its truth.

Every reading comes from the physical sensor model (``inclino_ros.sim.sensor_model``):
the tool's attitude, a board mounted in the tool with seed 000's gamma, beta
(and a roll about the tool axis) carrying both triads, each triad's 3x3
matrix, bias, temperature drift and noise, hard and soft iron, and the drill
string's field.  ``--sensor`` picks the triads: ``ideal`` (no sensor error),
``mems`` or ``quartz`` (quartz-flex accelerometer, fluxgate magnetometer).

The bag holds the raw accelerometer on ``/imu/data_raw`` and, at the same
stamps, the true attitude on ``/truth/survey``; ``OUT.truth.json`` holds the
scenario, its segments and every error source of the tool
(``sensor_model.truth_dict``).  Scenarios and what they simulate by default:

- bench (default): a level segment then 12 tilted stations; ideal triads on
  a board mounted gamma 0.8 deg, beta -1.2 deg, noise 0.002 m/s^2 per sample:
  the mount and the noise are the only errors (seed 000's demo).
- ``--stand``: seed 001's nine stand positions at 25 deg C (plus
  ``/stand/attitude`` and ``/imu/temperature``); ``--heating``: 20 -> 100 deg C
  at one attitude (plus ``/imu/temperature``), or at several in turn
  (``--heating-attitudes``: heated at the first, turned, cooled at the
  second, ...; two where each axis reads differently let ``inclino
  fit-temperature`` fit the bias drift besides the scale drift).  Both with the MEMS
  triads (seed 001's class of sensor) on the same mount by default: K, bias,
  bias and scale drift, 2 mg noise per sample; the stand holds 500 samples per
  position, the node's ``stand.samples``: at 2 mg ``inclino fit-stand`` needs
  151 for its default precision target (``--max-sem-deg`` 0.01 deg) and
  refuses 100 as too noisy.  ``--sensor quartz``: quartz-flex triads, ~10x
  smaller errors and 1e-4 g noise.

``--magnetic`` (bench scenario) adds the magnetometer on ``/imu/mag``
(sensor_msgs/MagneticField, tesla, its own axes: on the board, so turned by
the mount like the accelerometer, and by ``--magnetometer-deg`` further).
Each station gets a magnetic azimuth (``--azimuth-deg FIRST LAST``, linear
over the stations; the truth on ``/truth/survey`` z, NaN on the level segment
where the tool is vertical) in the reference field, plus the drill string's
interference (``--interference-nT`` in the ISCWSA axes of ``inclino
simulate-well`` and ``inclino msa``: x, y cross-axial, z toward the bit; the
model holds it in the tool frame, (x, -y, -z)).  ``--rotation-s`` appends a
rotation segment: the tool turning about its axis (``--rotation-turns``) at
one inclination and azimuth, for ``inclino fit-rotation``.  Every
magnetometer message has the stamp of the accelerometer sample it goes with
(one each, the same stamps): ``inclino process --mag-topic`` pairs them
exactly.  ``--csv`` writes the accelerometer samples as CSV too (with
``--heating`` an ``attitude`` column, the segment of each row, which
``inclino fit-temperature`` reads as the attitude label).

A run holds at most MAX_SAMPLES samples (about 0.6 GB of memory at the most);
OUT, OUT.truth.json and the CSV are written under temporary names, renamed
when all are complete, and refused when they exist unless ``--force``.
"""

from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.mounting import add_axes_map_arguments, settings_maps
from inclino_ros.cli.options import (
    add_force_argument, between, dip_deg, finite, reference_total_nT)
from inclino_ros.core.msa import MAX_INTERFERENCE_NT
from inclino_ros.io.files import Outputs
from inclino_ros.pipeline import Settings
from inclino_ros.sim.bench import (
    DEMO_BETA_DEG, DEMO_GAMMA_DEG, DEMO_MAG_NOISE_NT, DEMO_NOISE_MPS2, HEATING_ATTITUDE_DEG,
    PRESETS, Scenario)
from inclino_ros.sim.recording import (  # noqa: F401 (write_bag, write_csv: public here too)
    DEFAULT_SAMPLES, MAG_TOPIC, MAX_SAMPLES, RAW_TOPIC, record, simulated_run, STAND_TOPIC,
    TEMPERATURE_TOPIC, TRUTH_TOPIC, write_bag, write_csv)
from inclino_ros.sim.well import WellScenario

#: Seconds a segment may last (a day).
MAX_SEGMENT_S = 86_400.0


def add_sensor_arguments(parser, gamma_deg, beta_deg, default_sensor):
    """Add ``--sensor``, the mount (``--gamma-deg`` ...) and ``--magnetometer-deg``."""
    group = parser.add_argument_group('sensor (the physical model, sim.sensor_model)')
    group.add_argument('--sensor', choices=sorted(PRESETS), default=None,
                       help='triads of the tool: ideal (no sensor error), mems (K, bias, bias '
                            'and scale drift, hard/soft iron; 2 mg, 100 nT noise), quartz '
                            '(quartz-flex and fluxgate, ~10x smaller; 1e-4 g, 5 nT) '
                            f'(default: {default_sensor})')
    for flag, default, meaning in (
            ('--gamma-deg', gamma_deg, 'mount: seed 000 gamma, the board turned about y'),
            ('--beta-deg', beta_deg, "mount: seed 000 beta, then about the new x'"),
            ('--roll-deg', 0.0, 'mount: the board turned about the tool axis first')):
        group.add_argument(flag, type=between(-360.0, 360.0) if flag == '--roll-deg' else
                           between(-45.0, 45.0), default=default,
                           help=f'{meaning} [deg]; both triads sit on the board '
                                '(default: %(default)s)')
    group.add_argument('--magnetometer-deg', type=between(-360.0, 360.0), nargs=3,
                       default=(0.0, 0.0, 0.0),
                       metavar=('X', 'Y', 'Z'),
                       help='the magnetometer triad turned further relative to the board, '
                            'about x, then the new y, then the new z [deg] '
                            '(default: %(default)s)')
    return group


def register(subparsers):
    """Add the ``simulate`` subcommand."""
    defaults = Scenario()
    parser = add_command(
        subparsers, 'simulate', 'write a bag of a physical inclinometer on a virtual bench',
        'Write a bag of a simulated inclinometer and, beside it, the truth. Every reading '
        'comes from a physical sensor model: the board mounted in the tool (--gamma-deg, '
        "--beta-deg, --roll-deg), each triad's matrix, bias, temperature drift and noise "
        '(--sensor ideal, mems or quartz).',
        'By default a bench run of ideal triads: the tool still on a levelled bench for '
        '--level-s, then held at 12 attitudes (inclination 0.5 to 60 deg) for --station-s '
        'each, its board mounted gamma 0.8, beta -1.2 deg, noise 0.002 m/s^2. The bag holds '
        f'the raw sensor on {RAW_TOPIC} and the truth on {TRUTH_TOPIC} (x inclination, y '
        'toolface, z magnetic azimuth with --magnetic, degrees); OUT.truth.json holds the '
        'scenario, the times of each segment and every error source.',
        f'--stand: the nine stand positions of seed 001 of a MEMS sensor, 500 samples each '
        f'(the attitude on {STAND_TOPIC}, 25 C on {TEMPERATURE_TOPIC}). --heating: the same '
        'sensor heating from 20 to 100 C at one attitude, or at several in turn '
        f'(--heating-attitudes). --magnetic: a magnetometer on {MAG_TOPIC} with the drill-'
        'string interference, and --rotation-s a rotation for inclino fit-rotation. The '
        'mounting options write what a board mounted that way reads.')
    parser.add_argument('out', metavar='OUT', help='bag directory to create')
    group = add_sensor_arguments(parser, DEMO_GAMMA_DEG, DEMO_BETA_DEG,
                                 'ideal for the bench, mems for --stand and --heating')
    group.add_argument('--noise-mps2', dest='noise_std_mps2', type=between(0.0, 10.0),
                       metavar='NOISE_MPS2',
                       help='accelerometer noise per sample and axis, 1 sigma [m/s^2] '
                            f'(default: {DEMO_NOISE_MPS2} with --sensor ideal, else the '
                            "preset's own)")
    group.add_argument('--axes', type=int, choices=(2, 3), default=3,
                       help='accelerometer axes; a 2-axis sensor reads z = 0.0 '
                            '(default: %(default)s)')
    for flag, name, kind, meaning in (
            ('--rate-hz', 'rate_hz', between(0.01, 100_000.0), 'sample rate [Hz]'),
            ('--level-s', 'level_s', between(0.0, MAX_SEGMENT_S),
             'duration of the level segment [s]'),
            ('--station-s', 'station_s', between(0.0, MAX_SEGMENT_S),
             'duration of each tilted station [s]')):
        parser.add_argument(flag, dest=name, type=kind, default=getattr(defaults, name),
                            metavar=flag[2:].upper().replace('-', '_'),
                            help=f'{meaning} (default: %(default)s)')
    parser.add_argument('--seed', type=between(0, 2 ** 63 - 1, int), default=defaults.seed,
                        help='seed of the noise generator (default: %(default)s)')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap',
                        help='bag storage format (default: %(default)s)')
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument('--stand', dest='mode', action='store_const', const='stand',
                      help=f'seed 001 stand: nine still positions at 25 deg C, the attitude '
                           f'on {STAND_TOPIC} (x inclination_deg, y toolface_deg, z NaN)')
    mode.add_argument('--heating', dest='mode', action='store_const', const='heating',
                      help='seed 001 heating run: 20 -> 100 deg C on '
                           f'{TEMPERATURE_TOPIC} at --heating-attitudes')
    parser.add_argument('--heating-attitudes', type=finite, nargs='+',
                        metavar='DEG',
                        help='--heating: the attitudes held in turn, INCLINATION TOOLFACE '
                             '[deg] pairs; the tool heats at the first, cools at the second, '
                             '...; e.g. 55 45 125 225 (turned over: every axis reads the '
                             'opposite) for a bias drift fit (default: '
                             f'{" ".join(f"{v:g}" for v in HEATING_ATTITUDE_DEG)})')
    parser.add_argument('--samples', type=between(1, MAX_SAMPLES, int),
                        help='--stand: samples per position (default: '
                             f'{DEFAULT_SAMPLES["stand"]}); --heating: samples over the ramp '
                             f'at each attitude (default: {DEFAULT_SAMPLES["heating"]})')
    parser.add_argument('--csv', metavar='FILE',
                        help='also write the samples to FILE: stamp_ns, inclination_deg, '
                             'toolface_deg, [temperature_c, attitude (--heating),] ax, ay, '
                             'az [m/s^2]')
    add_magnetic_arguments(parser)
    add_force_argument(parser)
    add_axes_map_arguments(parser, 'accelerometer', 'magnetometer', writing=True)
    parser.set_defaults(func=run, mode=None)


def add_magnetic_arguments(parser):
    """Add ``--magnetic`` and its options (defaults: those of ``inclino simulate-well``)."""
    well = WellScenario()
    group = parser.add_argument_group('magnetometer (--magnetic, bench scenario only)')
    group.add_argument('--magnetic', action='store_true',
                       help=f'add the magnetometer on {MAG_TOPIC} and the azimuth truth')
    group.add_argument('--reference-total-nT', type=reference_total_nT,
                       default=well.reference_total_nT,
                       metavar='F', help='reference total field [nT] (default: %(default)s)')
    group.add_argument('--reference-dip-deg', type=dip_deg,
                       default=well.reference_dip_deg,
                       metavar='D', help='reference dip [deg] (default: %(default)s)')
    group.add_argument('--azimuth-deg', type=finite, nargs=2, default=well.azimuth_deg,
                       metavar=('FIRST', 'LAST'),
                       help='magnetic azimuth of the first and last station, linear between '
                            '(default: %(default)s)')
    group.add_argument('--interference-nT', type=interference_nT, nargs=3,
                       default=tuple(well.interference_iscwsa_nT.tolist()),
                       metavar=('EX', 'EY', 'EZ'),
                       help='drill-string interference in ISCWSA axes [nT]: cross-axial x, y '
                            'and axial z toward the bit, as inclino msa reports eps '
                            '(default: %(default)s, i.e. tool frame 80, 80, -2000)')
    group.add_argument('--mag-noise-nT', type=between(0.0, 10_000.0), metavar='NOISE_NT',
                       help='magnetometer noise per sample and axis, 1 sigma [nT] '
                            f'(default: {DEMO_MAG_NOISE_NT:g} with --sensor ideal, else the '
                            "preset's own)")
    group.add_argument('--rotation-s', type=between(0.0, MAX_SEGMENT_S), default=0.0,
                       metavar='S',
                       help='append a rotation segment of S seconds (default: none)')
    group.add_argument('--rotation-turns', type=between(-1e6, 1e6), default=2.0,
                       help='turns of the tool about its axis in the rotation '
                            '(default: %(default)s)')
    group.add_argument('--rotation-attitude-deg', type=finite, nargs=2,
                       default=(60.0, 90.0),
                       metavar=('INCLINATION', 'AZIMUTH'),
                       help='attitude held while turning (default: %(default)s)')


#: An interference [nT]: what the MSA may solve (``msa.MAX_INTERFERENCE_NT``).
interference_nT = between(-MAX_INTERFERENCE_NT, MAX_INTERFERENCE_NT, why=' nT (a drill string)')


def run(args):
    """Simulate and write the bag and its truth file; return the exit code."""
    outputs = Outputs(force=args.force)
    for path in (args.out, f'{args.out}.truth.json', args.csv):
        if path is not None:
            outputs.check(path)
    try:
        mounting = Settings(accelerometer_axes=args.axes, **settings_maps(args))
        simulated = simulated_run(args)
    except ValueError as err:
        raise CommandError(str(err)) from None
    sim, truth_path = simulated[2], f'{args.out}.truth.json'
    with outputs:
        topics, magnetic = record(args, outputs, simulated, mounting)
    print(f'wrote {args.out} ({args.storage}): {sim.stamps_ns.size} messages on each of '
          f'{", ".join(topics.values())}; {simulated[3]}{magnetic}')
    print(f'wrote {truth_path}: {len(sim.truth["segments"])} segments, every error source')
    if args.csv:
        print(f'wrote {args.csv}: {sim.stamps_ns.size} rows')
    return 0
