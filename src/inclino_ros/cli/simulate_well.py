"""
``inclino simulate-well``: write the station CSV of a simulated well (``inclino_ros.sim.well``).

The well's stations go linearly from the first to the last inclination and
azimuth, toolfaces turning by the golden angle; the readings carry the drill
string's interference (axial and cross-axial, constant in the tool frame) and
noise.  The CSV (``md, gx, gy, gz`` in g, ``bx, by, bz`` in nT, ISCWSA frame,
and the truth ``true_inclination_deg, true_azimuth_deg, true_toolface_deg``)
is the input of ``inclino msa``.
"""

from inclino_ros.cli.helptext import add_command
from inclino_ros.sim.well import simulate_well, WellScenario, write_stations_csv


def register(subparsers):
    """Add the ``simulate-well`` subcommand."""
    defaults = WellScenario()
    parser = add_command(
        subparsers, 'simulate-well',
        'write the station CSV of a simulated well with drill-string interference (input of '
        'inclino msa)',
        'Write the survey stations of a simulated well, the input of inclino msa: inclination '
        'and azimuth go linearly from the first to the last station, the toolfaces spread; '
        'the gravity and field of each station carry the interference of the drill string and '
        'noise.',
        'Columns: md (measured depth, m), gx, gy, gz (g), bx, by, bz (nT), in the ISCWSA '
        'survey frame (x, y across the tool, z toward the bit), and the truth: '
        'true_inclination_deg, true_azimuth_deg, true_toolface_deg.')
    parser.add_argument('out', metavar='OUT.csv', help='station CSV to write')
    parser.add_argument('--stations', type=int, default=defaults.stations,
                        help='number of stations (default: %(default)s)')
    for flag, name, meaning in (
            ('--inclination-deg', 'inclination_deg', 'first and last inclination [deg]'),
            ('--azimuth-deg', 'azimuth_deg', 'first and last magnetic azimuth [deg]')):
        parser.add_argument(flag, dest=name, type=float, nargs=2, default=getattr(defaults, name),
                            metavar=('FIRST', 'LAST'), help=f'{meaning} (default: %(default)s)')
    parser.add_argument('--interference-nT', dest='interference_nT', type=float, nargs=3,
                        default=defaults.interference_nT, metavar=('EX', 'EY', 'EZ'),
                        help='drill-string interference in the tool frame [nT] (default: '
                             '%(default)s)')
    for flag, name, meaning in (
            ('--reference-total-nT', 'reference_total_nT', 'total field [nT]'),
            ('--reference-dip-deg', 'reference_dip_deg', 'dip [deg]'),
            ('--gravity-noise-g', 'gravity_noise', 'gravity noise per axis, 1 sigma [g]'),
            ('--field-noise-nT', 'field_noise_nT', 'field noise per axis, 1 sigma [nT]')):
        parser.add_argument(flag, dest=name, type=float, default=getattr(defaults, name),
                            help=f'{meaning} (default: %(default)s)')
    parser.add_argument('--seed', type=int, default=defaults.seed,
                        help='seed of the noise generator (default: %(default)s)')
    parser.set_defaults(func=run)


def run(args):
    """Simulate the well and write its CSV; return the exit code."""
    if args.stations < 1:
        print('inclino simulate-well: error: --stations must be at least 1')
        return 2
    scenario = WellScenario(
        stations=args.stations, inclination_deg=tuple(args.inclination_deg),
        azimuth_deg=tuple(args.azimuth_deg), interference_nT=tuple(args.interference_nT),
        reference_total_nT=args.reference_total_nT, reference_dip_deg=args.reference_dip_deg,
        gravity_noise=args.gravity_noise, field_noise_nT=args.field_noise_nT, seed=args.seed)
    write_stations_csv(args.out, simulate_well(scenario))
    print(f'wrote {args.out}: {scenario.stations} stations, interference '
          f'{", ".join(f"{v:g}" for v in scenario.interference_nT)} nT (x, y, z); correct with\n'
          f'  inclino msa {args.out} -o corrected.csv --reference-total-nT '
          f'{scenario.reference_total_nT:g} --reference-dip-deg {scenario.reference_dip_deg:g}')
    return 0
