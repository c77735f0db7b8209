"""
``inclino simulate-well``: write the station CSV of a simulated well (``inclino_ros.sim.well``).

The well's stations go linearly from the first to the last inclination and
azimuth, toolfaces turning by the golden angle; the readings carry the drill
string's interference (axial and cross-axial, constant in the tool frame) and
noise.  The CSV (``md, gx, gy, gz`` in g, ``bx, by, bz`` in nT, ISCWSA frame,
and the truth ``true_inclination_deg, true_azimuth_deg, true_toolface_deg``)
is the input of ``inclino msa``.

At most MAX_STATIONS stations; OUT is written under a temporary name and
renamed when complete, and refused when it exists unless ``--force``.
"""

from inclino_ros.cli.options import (
    add_force_argument, between, dip_deg, finite, reference_total_nT)
from inclino_ros.cli.simulate import interference_nT
from inclino_ros.io.files import Outputs
from inclino_ros.sim.well import simulate_well, WellScenario, write_stations_csv

#: Most stations of a simulated well (a survey every 30 m: 3000 km of hole).
MAX_STATIONS = 100_000


def register(subparsers):
    """Add the ``simulate-well`` subcommand."""
    defaults = WellScenario()
    parser = subparsers.add_parser(
        'simulate-well', help='write the station CSV of a simulated well with drill-string '
                              'interference (input of inclino msa)',
        description=__doc__.split('\n\n', 1)[1])
    parser.add_argument('out', metavar='OUT.csv', help='station CSV to write')
    parser.add_argument('--stations', type=between(1, MAX_STATIONS, int),
                        default=defaults.stations,
                        help='number of stations (default: %(default)s)')
    for flag, name, meaning in (
            ('--inclination-deg', 'inclination_deg', 'first and last inclination [deg]'),
            ('--azimuth-deg', 'azimuth_deg', 'first and last magnetic azimuth [deg]')):
        parser.add_argument(flag, dest=name, type=finite, nargs=2, default=getattr(defaults, name),
                            metavar=('FIRST', 'LAST'), help=f'{meaning} (default: %(default)s)')
    parser.add_argument('--interference-nT', dest='interference_nT', type=interference_nT, nargs=3,
                        default=defaults.interference_nT, metavar=('EX', 'EY', 'EZ'),
                        help='drill-string interference in the tool frame [nT] (default: '
                             '%(default)s)')
    for flag, name, kind, meaning in (
            ('--reference-total-nT', 'reference_total_nT', reference_total_nT,
             'total field [nT]'),
            ('--reference-dip-deg', 'reference_dip_deg', dip_deg, 'dip [deg]'),
            ('--gravity-noise-g', 'gravity_noise', between(0.0, 0.1),
             'gravity noise per axis, 1 sigma [g]'),
            ('--field-noise-nT', 'field_noise_nT', between(0.0, 10_000.0),
             'field noise per axis, 1 sigma [nT]')):
        parser.add_argument(flag, dest=name, type=kind, default=getattr(defaults, name),
                            help=f'{meaning} (default: %(default)s)')
    parser.add_argument('--seed', type=between(0, 2 ** 63 - 1, int), default=defaults.seed,
                        help='seed of the noise generator (default: %(default)s)')
    add_force_argument(parser)
    parser.set_defaults(func=run)


def run(args):
    """Simulate the well and write its CSV; return the exit code."""
    outputs = Outputs(force=args.force)
    outputs.check(args.out)
    scenario = WellScenario(
        stations=args.stations, inclination_deg=tuple(args.inclination_deg),
        azimuth_deg=tuple(args.azimuth_deg), interference_nT=tuple(args.interference_nT),
        reference_total_nT=args.reference_total_nT, reference_dip_deg=args.reference_dip_deg,
        gravity_noise=args.gravity_noise, field_noise_nT=args.field_noise_nT, seed=args.seed)
    well = simulate_well(scenario)
    with outputs:
        write_stations_csv(outputs.path(args.out), well)
    print(f'wrote {args.out}: {scenario.stations} stations, interference '
          f'{", ".join(f"{v:g}" for v in scenario.interference_nT)} nT (x, y, z); correct with\n'
          f'  inclino msa {args.out} -o corrected.csv --reference-total-nT '
          f'{scenario.reference_total_nT:g} --reference-dip-deg {scenario.reference_dip_deg:g}')
    return 0
