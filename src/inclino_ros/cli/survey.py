"""
``inclino survey``: inclination, toolface and azimuth of each shot of a CSV file.

Input: a CSV with ``ax, ay, az`` (m/s^2, REP 145 specific force, tool frame)
and ``bx, by, bz`` (nT, same frame), optionally ``temperature_c`` and
``samples``: the count of readings a row is the mean of (a station), whose
noise is then the per-sample noise / sqrt(samples) (default 1: each row one
reading); any other columns are carried through.  Every row goes through ``pipeline.run`` with
the calibration file, as in the node and ``inclino process``.

Output: the input columns (one whose name the output uses is kept as
``input_<name>``) plus ``inclination_deg``, ``toolface_deg``, ``azimuth_deg``,
``g_total_mps2``, ``b_total_nT``, ``dip_deg``, the 1 sigma of each
(``inclination_std_deg``, ``toolface_std_deg``, ``azimuth_std_deg``,
``g_total_std_mps2``, ``b_total_std_nT``, ``dip_std_deg``: the sensor noise
and the calibration's tilt, as ``pipeline.run`` propagates them) and ``status`` (``ok`` or why
the row gave no angles: ``non_finite``, ``saturated``, ``zero``).  The
azimuth is written wherever it is defined (a field of at least 1000 nT, a
1 sigma within ``--azimuth-max-std-deg``: not near vertical): QC is a column
here, not a filter.  With a reference field (``--reference-total-nT`` and
``--reference-dip-deg``, or ``--site``, else the calibration's MSA
reference) the QC columns follow: ``b_total_delta_nT``, ``dip_delta_deg``,
``g_total_delta_mps2`` and the flags ``qc_b_total``, ``qc_dip``,
``qc_g_total``, ``qc_ok`` (1 pass, 0 fail); with a declination also
``true_azimuth_deg``.

Exit codes: 0 written, 2 an input that cannot be used (missing column, a
field not in nT, no calibration file).
"""

import math
import sys

from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import load_calibration, NODE_DEFAULTS, node_option
from inclino_ros.cli.options import add_force_argument, node_parameter
from inclino_ros.cli.process import add_limit_arguments
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core.magnetics import field_unit_problem, QcLimits, true_azimuth_deg
from inclino_ros.core.screening import ACCEPTED, REASONS
from inclino_ros.io import tables
from inclino_ros.io.files import Outputs
from inclino_ros.pipeline import MagneticSettings, run as run_pipeline, Settings
import numpy as np

INPUT_COLUMNS = ('ax', 'ay', 'az', 'bx', 'by', 'bz')
ANGLE_COLUMNS = ('inclination_deg', 'toolface_deg', 'azimuth_deg', 'g_total_mps2',
                 'b_total_nT', 'dip_deg', 'inclination_std_deg', 'toolface_std_deg',
                 'azimuth_std_deg', 'g_total_std_mps2', 'b_total_std_nT', 'dip_std_deg')
#: The column of a row's count of averaged readings.
SAMPLES_COLUMN = 'samples'
QC_COLUMNS = ('b_total_delta_nT', 'dip_delta_deg', 'g_total_delta_mps2', 'qc_b_total',
              'qc_dip', 'qc_g_total', 'qc_ok')


def register(subparsers):
    """Add the ``survey`` subcommand."""
    parser = subparsers.add_parser(
        'survey', help='inclination, toolface, azimuth and QC of each shot of a CSV file',
        description=__doc__.split('\n\n', 1)[1])
    parser.add_argument('input', metavar='IN', help='CSV file (ax, ay, az, bx, by, bz)')
    parser.add_argument('-o', '--output', required=True, metavar='OUT', help='CSV file to write')
    parser.add_argument('--calibration', required=True, metavar='FILE',
                        help='calibration file to apply')
    parser.add_argument('--toolface-convention', choices=('seed000', 'iscwsa_highside'),
                        default=NODE_DEFAULTS['toolface_convention'],
                        help='gravity toolface definition (default: %(default)s)')
    parser.add_argument('--gravity-mps2', type=node_parameter('gravity_mps2'),
                        default=NODE_DEFAULTS['gravity_mps2'],
                        help='local gravity [m/s^2] (default: %(default)s)')
    node_option(parser, '--noise-mps2', 'accelerometer_noise_std_mps2',
                'accelerometer noise per sample, 1 sigma [m/s^2]: the 1 sigma of the angles',
                dest='noise_std_mps2', metavar='NOISE_MPS2')
    node_option(parser, '--mag-noise-nT', 'magnetometer_noise_std_nT',
                'magnetometer noise per sample, 1 sigma [nT]')
    add_limit_arguments(parser)
    add_force_argument(parser)
    add_reference_arguments(parser.add_argument_group('reference field (adds the QC columns)'))
    parser.set_defaults(func=run)


def run(args):
    """Write the survey of IN to OUT; return the exit code."""
    outputs = Outputs(inputs=[args.input, args.calibration], force=args.force)
    outputs.check(args.output)
    with outputs:
        rows, written = survey(args, outputs)
    print(f'wrote {args.output}: {rows} rows, {written} with an azimuth')
    return 0


def _numbers(rows, header, name):
    """Return column ``name`` as floats, NaN where a cell is not a number."""
    index = header.index(name)

    def number(text):
        try:
            return float(text)
        except ValueError:
            return math.nan
    return np.array([number(row[index]) if index < len(row) else math.nan for row in rows])


def _samples(path, rows, header):
    """Return the per-row count of averaged readings (1 without the column); CommandError."""
    if SAMPLES_COLUMN not in header:
        return 1
    counts = _numbers(rows, header, SAMPLES_COLUMN)
    bad = np.flatnonzero(~((counts >= 1) & (np.mod(counts, 1.0) == 0.0)))
    if bad.size:
        value = rows[bad[0]][header.index(SAMPLES_COLUMN)]
        raise CommandError(f'{path}: column {SAMPLES_COLUMN} must be a whole count >= 1 '
                           f'(row {bad[0] + 1} has {value!r})')
    return counts


def survey(args, outputs):
    """Compute and write the survey; return (rows, rows with an azimuth)."""
    try:
        header, rows = tables.read_rows(args.input)
    except tables.TableError as err:
        raise CommandError(str(err)) from None
    missing = [name for name in INPUT_COLUMNS if name not in header]
    if missing:
        raise CommandError(f'{args.input} lacks the column(s) {", ".join(missing)}; it has '
                           f'{", ".join(header)}')
    raw, field = (np.column_stack([_numbers(rows, header, n) for n in names])
                  for names in (INPUT_COLUMNS[:3], INPUT_COLUMNS[3:]))
    temperature_c = (_numbers(rows, header, 'temperature_c') if 'temperature_c' in header
                     else None)
    averaged = _samples(args.input, rows, header)
    magnitude = np.linalg.norm(field, axis=1)
    if np.isfinite(magnitude).any():
        problem = field_unit_problem(np.nanmedian(magnitude))
        if problem:
            raise CommandError(f'bx, by, bz must be in nT: {problem}')
    model = load_calibration(args.calibration, any_sensor=True)
    if model.accelerometer_axes != 3:
        raise CommandError(f'{args.calibration} is for a two-axis accelerometer: a survey '
                           'needs three axes')
    try:
        total_nT, dip_deg, declination_deg, _ = resolve_reference(args, model)
        settings = Settings(gravity_mps2=args.gravity_mps2,
                            accelerometer_range_mps2=NODE_DEFAULTS['accelerometer_range_mps2'],
                            toolface_convention=args.toolface_convention,
                            noise_std_mps2=args.noise_std_mps2,
                            toolface_max_std_deg=args.toolface_max_std_deg)
    except ValueError as err:
        raise CommandError(str(err)) from None
    if (total_nT is None) != (dip_deg is None):
        raise CommandError('the reference needs both --reference-total-nT and '
                           '--reference-dip-deg (or --site)')
    magnetic = MagneticSettings(reference_total_nT=total_nT or 0.0,
                                reference_dip_deg=dip_deg or 0.0,
                                declination_deg=declination_deg or 0.0, limits=QcLimits(),
                                noise_std_nT=args.mag_noise_nT,
                                azimuth_max_std_deg=args.azimuth_max_std_deg)
    result = run_pipeline(raw, model, settings, temperature_c, field, magnetic, averaged)
    columns = output_columns(result, declination_deg, total_nT is not None)
    write(outputs.path(args.output), header, rows, result.codes, columns)
    return len(rows), int(np.isfinite(columns['azimuth_deg'][1]).sum())


def output_columns(result, declination_deg, with_qc):
    """Return ``{name: (accepted mask, values of the accepted rows)}`` of the output."""
    accepted = result.accepted
    azimuth = result.magnetic
    values = {'inclination_deg': result.inclination_deg, 'toolface_deg': result.toolface_deg,
              'azimuth_deg': azimuth.defined_azimuth_deg, 'g_total_mps2': result.g_total_mps2,
              'b_total_nT': azimuth.b_total_nT, 'dip_deg': azimuth.dip_deg,
              'inclination_std_deg': result.inclination_std_deg,
              'toolface_std_deg': result.toolface_std_deg,
              'azimuth_std_deg': azimuth.azimuth_std_deg,
              'g_total_std_mps2': azimuth.g_total_std_mps2,
              'b_total_std_nT': azimuth.b_total_std_nT, 'dip_std_deg': azimuth.dip_std_deg}
    if declination_deg is not None:
        values['true_azimuth_deg'] = true_azimuth_deg(azimuth.defined_azimuth_deg,
                                                      declination_deg)
    if with_qc:
        qc = azimuth.qc
        values.update(b_total_delta_nT=qc.b_total_delta_nT, dip_delta_deg=qc.dip_delta_deg,
                      g_total_delta_mps2=qc.g_total_delta, qc_b_total=qc.b_total_ok,
                      qc_dip=qc.dip_ok, qc_g_total=qc.g_total_ok, qc_ok=qc.ok)
    return {name: (accepted, value) for name, value in values.items()}


def write(path, header, rows, codes, columns):
    """Write the input rows with the output columns (and the status) to ``path``."""
    names = list(columns) + ['status']
    renamed = [f'input_{name}' if name in names else name for name in header]
    if renamed != header:
        print('inclino survey: input column(s) '
              + ', '.join(n for n, r in zip(header, renamed) if n != r)
              + ' kept as input_<name>', file=sys.stderr)
    status = ['ok' if code == ACCEPTED else REASONS[code] for code in codes]
    full = {}
    for name, (accepted, values) in columns.items():
        column = np.full(len(rows), math.nan, dtype=object)
        column[accepted] = list(values)
        full[name] = column
    try:
        tables.write_csv(path, [(name, [row[k] for row in rows])
                                for k, name in enumerate(renamed)]
                         + [(name, full[name]) for name in columns] + [('status', status)])
    except OSError as err:
        raise CommandError(f'cannot write {path}: {err}') from None
