"""
``inclino simulate-well``: write the station CSV of a simulated well (``inclino_ros.sim.well``).

The well's stations go linearly from the first to the last inclination and
azimuth, toolfaces turning by the golden angle.  Each station is read by the
physical sensor model (``sim.sensor_model``): the reference field plus the
drill string's interference (a constant vector in the tool frame, axial and
cross-axial), through the tool's mount and triads, averaged over
``--samples-per-station`` readings.  By default the triads are ideal, the
mount true and the noise 1e-4 g and 5 nT per station: the interference is the
only error, what ``inclino msa`` corrects.  ``--sensor``, ``--gamma-deg`` ...
add sensor and mount errors.  The CSV (``md, gx, gy, gz`` in g, ``bx, by, bz``
in nT, ISCWSA frame, and the truth ``true_inclination_deg, true_azimuth_deg,
true_toolface_deg`` (high side)) is the input of ``inclino msa``;
``OUT.csv.truth.json`` holds every error source of the tool.

At most MAX_STATIONS stations; OUT and its truth file are written under
temporary names and renamed when complete, and refused when they exist
unless ``--force``.
"""

import json

from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import (
    add_force_argument, between, dip_deg, finite, reference_total_nT)
from inclino_ros.cli.simulate import add_sensor_arguments, interference_nT
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.io.files import Outputs
from inclino_ros.sim.bench import command_tool, tool_from_iscwsa
from inclino_ros.sim.well import (
    simulate_well, WELL_FIELD_NOISE_NT, WELL_GRAVITY_NOISE_G, well_truth, WellScenario,
    write_stations_csv)

#: Most stations of a simulated well (a survey every 30 m: 3000 km of hole).
MAX_STATIONS = 100_000


def register(subparsers):
    """Add the ``simulate-well`` subcommand."""
    defaults = WellScenario()
    parser = add_command(
        subparsers, 'simulate-well',
        'write the station CSV of a simulated well with drill-string interference (input of '
        'inclino msa)',
        'Write the survey stations of a simulated well, the input of inclino msa: inclination '
        'and azimuth go linearly from the first to the last station, the toolfaces spread; '
        'each station is read by the physical sensor model: the reference field plus the '
        'interference of the drill string, through the mount and triads (ideal by default; '
        '--sensor, --gamma-deg ... add their errors), averaged over --samples-per-station.',
        'Columns: md (measured depth, m), gx, gy, gz (g), bx, by, bz (nT), in the ISCWSA '
        'survey frame (x, y across the tool, z toward the bit), and the truth: '
        'true_inclination_deg, true_azimuth_deg, true_toolface_deg; OUT.csv.truth.json holds '
        'every error source of the tool.')
    parser.add_argument('out', metavar='OUT.csv', help='station CSV to write')
    parser.add_argument('--stations', type=between(1, MAX_STATIONS, int),
                        default=defaults.stations,
                        help='number of stations (default: %(default)s)')
    for flag, name, meaning in (
            ('--inclination-deg', 'inclination_deg', 'first and last inclination [deg]'),
            ('--azimuth-deg', 'azimuth_deg', 'first and last magnetic azimuth [deg]')):
        parser.add_argument(flag, dest=name, type=finite, nargs=2, default=getattr(defaults, name),
                            metavar=('FIRST', 'LAST'), help=f'{meaning} (default: %(default)s)')
    parser.add_argument('--interference-nT', dest='interference_nT', type=interference_nT,
                        nargs=3, default=tuple(defaults.interference_iscwsa_nT.tolist()),
                        metavar=('EX', 'EY', 'EZ'),
                        help='drill-string interference in ISCWSA axes [nT]: cross-axial x, y '
                             'and axial z toward the bit, as inclino msa reports eps '
                             '(default: %(default)s, i.e. tool frame 80, 80, -2000)')
    for flag, name, kind, meaning in (
            ('--reference-total-nT', 'reference_total_nT', reference_total_nT,
             'total field [nT]'),
            ('--reference-dip-deg', 'reference_dip_deg', dip_deg, 'dip [deg]')):
        parser.add_argument(flag, dest=name, type=kind, default=getattr(defaults, name),
                            help=f'{meaning} (default: %(default)s)')
    group = add_sensor_arguments(parser, 0.0, 0.0, 'ideal')
    group.add_argument('--gravity-noise-g', dest='gravity_noise', type=between(0.0, 0.1),
                       help='accelerometer noise per reading and axis, 1 sigma [g] (default: '
                            f"{WELL_GRAVITY_NOISE_G:g} with --sensor ideal, else the preset's "
                            'own)')
    group.add_argument('--field-noise-nT', dest='field_noise_nT', type=between(0.0, 10_000.0),
                       help='magnetometer noise per reading and axis, 1 sigma [nT] (default: '
                            f"{WELL_FIELD_NOISE_NT:g} with --sensor ideal, else the preset's "
                            'own)')
    group.add_argument('--samples-per-station', type=between(1, 100_000, int),
                       default=defaults.samples_per_station,
                       help='readings averaged into each station (default: %(default)s)')
    parser.add_argument('--seed', type=between(0, 2 ** 63 - 1, int), default=defaults.seed,
                        help='seed of the noise generator (default: %(default)s)')
    add_force_argument(parser)
    parser.set_defaults(func=run)


def tool_of(args):
    """Return (preset, ``sensor_model.Tool``) of the command line (``bench.command_tool``)."""
    sensor = args.sensor or 'ideal'
    g = STANDARD_GRAVITY_MPS2
    return sensor, command_tool(
        sensor, (args.gamma_deg, args.beta_deg, args.roll_deg, args.magnetometer_deg),
        None if args.gravity_noise is None else args.gravity_noise * g, args.field_noise_nT,
        (WELL_GRAVITY_NOISE_G * g, WELL_FIELD_NOISE_NT), ('--gravity-noise-g', '--field-noise-nT'))


def run(args):
    """Simulate the well and write its CSV and truth; return the exit code."""
    truth_path = f'{args.out}.truth.json'
    outputs = Outputs(force=args.force)
    outputs.check(args.out)
    outputs.check(truth_path)
    try:
        sensor, tool = tool_of(args)
        scenario = WellScenario(
            stations=args.stations, inclination_deg=tuple(args.inclination_deg),
            azimuth_deg=tuple(args.azimuth_deg),
            interference_tool_nT=tool_from_iscwsa(args.interference_nT),
            reference_total_nT=args.reference_total_nT,
            reference_dip_deg=args.reference_dip_deg, tool=tool,
            samples_per_station=args.samples_per_station, seed=args.seed)
    except ValueError as err:
        raise CommandError(str(err)) from None
    well = simulate_well(scenario)
    with outputs:
        write_stations_csv(outputs.path(args.out), well)
        with open(outputs.path(truth_path), 'x') as stream:
            json.dump(dict(well_truth(well), sensor=sensor, csv=str(args.out)), stream,
                      indent=2)
            stream.write('\n')
    mount = tool.mount
    print(f'wrote {args.out}: {scenario.stations} stations, interference '
          f'{", ".join(f"{v:g}" for v in args.interference_nT)} nT (ISCWSA x, y, z), '
          f'{sensor} sensor, mount gamma {mount.gamma_deg:g} beta {mount.beta_deg:g} roll '
          f'{mount.roll_deg:g} deg; {truth_path}: every error source; correct with\n'
          f'  inclino msa {args.out} -o corrected.csv --reference-total-nT '
          f'{scenario.reference_total_nT:g} --reference-dip-deg {scenario.reference_dip_deg:g}')
    return 0
