"""
``inclino survey``: inclination, toolface and azimuth of each shot of a CSV file.

Input: a CSV with ``ax, ay, az`` (m/s^2, REP 145 specific force, tool frame)
and optionally ``bx, by, bz`` (nT, same frame), ``temperature_c`` and
``samples``: the count of readings a row is the mean of (a station), whose
noise is then the per-sample noise / sqrt(samples) (default 1: each row one
reading); any other columns are carried through.  Every row goes through
``pipeline.run`` with the calibration file, as in the node and ``inclino
process``; without ``--calibration`` the raw readings give the raw angles.
Without ``bx, by, bz`` (an accelerometer-only tool) the output has
inclination and toolface, no azimuth columns, and says so once.

Output: the input columns (one whose name the output uses is kept as
``input_<name>``) plus ``inclination_deg``, ``toolface_deg``, ``azimuth_deg``,
``g_total_mps2``, ``b_total_nT``, ``dip_deg``, the 1 sigma of each
(``inclination_std_deg``, ``toolface_std_deg``, ``azimuth_std_deg``,
``g_total_std_mps2``, ``b_total_std_nT``, ``dip_std_deg``: the sensor noise
and the calibration's tilt, as ``pipeline.run`` propagates them),
``toolface_zero`` (``stand``: the toolface is the tool's, its zero
calibrated on a stand; ``board``: measured from the sensor board's x axis,
off the tool's high side by the board's unknown roll; said on stdout too,
with its meaning) and ``status`` (``ok`` or why
the row gave no angles: ``non_finite``, ``saturated``, ``zero``; or
``temperature_outside_fit``: a temperature outside the calibration's fitted
range).  The
azimuth is written wherever it is defined (a field of at least 1000 nT, a
1 sigma within ``--azimuth-max-std-deg``: not near vertical): QC is a column
here, not a filter.  With a reference field (``--reference-total-nT`` and
``--reference-dip-deg``, or ``--site``, else the calibration's MSA
reference) the QC columns follow: ``b_total_delta_nT``, ``dip_delta_deg``,
``g_total_delta_mps2`` and the flags ``qc_b_total``, ``qc_dip``,
``qc_g_total``, ``qc_ok`` (1 pass, 0 fail); with a declination also
``true_azimuth_deg``.

Exit codes: 0 written, 2 an input that cannot be used (missing column, a
row with a cell too many or too few, a blank line, readings not in m/s^2 or
nT, a temperature missing, not a number or not one a sensor reads, no
calibration file).
"""

import sys

from inclino_ros.calibration.inputs import survey_input, survey_temperatures
from inclino_ros.calibration.model import CalibrationModel
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_bias_instability_arguments, add_gravity_option, load_calibration, NODE_DEFAULTS,
    node_option, warn_outside_range)
from inclino_ros.cli.options import (
    add_force_argument, add_reference_temperature_argument)
from inclino_ros.cli.process import add_limit_arguments, refuse_missing_temperature
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core.magnetics import QcLimits
from inclino_ros.io import tables
from inclino_ros.io.files import Outputs
from inclino_ros.pipeline import MagneticSettings, run as run_pipeline, Settings, station_counts
from inclino_ros.stream import OUTSIDE_FIT, outside_fit, survey_columns, survey_table
import numpy as np


def register(subparsers):
    """Add the ``survey`` subcommand."""
    parser = subparsers.add_parser(
        'survey', help='inclination, toolface, azimuth and QC of each shot of a CSV file',
        description=__doc__.split('\n\n', 1)[1])
    parser.add_argument('input', metavar='IN',
                        help='CSV file (ax, ay, az; optional bx, by, bz and temperature_c)')
    parser.add_argument('-o', '--output', required=True, metavar='OUT', help='CSV file to write')
    parser.add_argument('--calibration', metavar='FILE',
                        help='calibration file to apply (default: none, the raw angles)')
    node_option(parser, '--toolface-convention', 'toolface_convention',
                'gravity toolface definition')
    add_gravity_option(parser)
    node_option(parser, '--noise-mps2', 'accelerometer_noise_std_mps2',
                'accelerometer noise per sample, 1 sigma [m/s^2]: the 1 sigma of the angles',
                dest='noise_std_mps2', metavar='NOISE_MPS2')
    node_option(parser, '--mag-noise-nT', 'magnetometer_noise_std_nT',
                'magnetometer noise per sample, 1 sigma [nT]')
    add_bias_instability_arguments(parser, parser)
    add_limit_arguments(parser)
    add_force_argument(parser)
    add_reference_temperature_argument(parser)
    add_reference_arguments(parser.add_argument_group('reference field (adds the QC columns)'))
    parser.set_defaults(func=run)


def run(args):
    """Write the survey of IN to OUT; return the exit code."""
    outputs = Outputs(inputs=[args.input] + ([args.calibration] if args.calibration else []),
                      force=args.force)
    outputs.check(args.output)
    with outputs:
        rows, written, model = survey(args, outputs)
    print(f'wrote {args.output}: {rows} rows'
          + ('' if written is None else f', {written} with an azimuth'))
    print('\n'.join(model.toolface_zero_lines))
    return 0


def _temperatures(args, header, rows, model):
    """
    Return the temperature_c column [deg C] (None without one; ``inputs.survey_temperatures``).

    A calibration with a temperature stage needs the column unless
    ``--at-reference-temperature`` (the one rule of ``inclino process`` too:
    ``provenance.missing_temperature``).
    """
    if 'temperature_c' not in header:
        refuse_missing_temperature(args, model, f'{args.input} has no temperature_c column')
        return None
    return survey_temperatures(args.input, header, rows)


def _model(path):
    """
    Return the calibration model of ``path`` (``fitting.load_calibration``, any sensor).

    None (no ``--calibration``): the empty model, every stage absent: the raw
    angles (said on stderr).
    """
    if path is None:
        print('inclino survey: no --calibration: raw angles (no correction applied)',
              file=sys.stderr)
        return CalibrationModel(3)
    return load_calibration(path, any_sensor=True)


def survey(args, outputs):
    """Compute and write the survey; return (rows, rows with an azimuth or None, the model)."""
    header, rows, raw, field, averaged = survey_input(args.input, args.gravity_mps2)
    if field is None:
        print(f'inclino survey: no bx, by, bz in {args.input}: inclination and toolface '
              'only (an accelerometer-only tool: no azimuth columns)', file=sys.stderr)
    model = _model(args.calibration)
    if model.accelerometer_axes != 3:
        raise CommandError(f'{args.calibration} is for a two-axis accelerometer: a survey '
                           'needs three axes')
    temperature_c = _temperatures(args, header, rows, model)
    warn_outside_range(model, temperature_c, 'inclino survey')
    try:
        total_nT, dip_deg, declination_deg, _ = resolve_reference(args, model)
        settings = Settings(gravity_mps2=args.gravity_mps2,
                            accelerometer_range_mps2=NODE_DEFAULTS['accelerometer_range_mps2'],
                            toolface_convention=args.toolface_convention,
                            noise_std_mps2=args.noise_std_mps2,
                            bias_instability_mps2=args.bias_instability_mps2,
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
                                bias_instability_nT=args.mag_bias_instability_nT,
                                azimuth_max_std_deg=args.azimuth_max_std_deg)
    # Each row's mean with the configured bias instabilities' flicker (stillness.floored_count).
    result = run_pipeline(raw, model, settings, temperature_c, field, magnetic,
                          *station_counts(averaged, settings, magnetic))
    columns = survey_columns(result, declination_deg, total_nT is not None,
                             model.toolface_zero)
    outside = outside_fit(model, temperature_c)
    write(outputs.path(args.output), header, rows, result.codes, columns, outside)
    if field is None:
        return len(rows), None, model
    return len(rows), int(np.isfinite(columns['azimuth_deg'][1]).sum()), model


def write(path, header, rows, codes, columns, outside=None):
    """
    Write the input rows with the output columns and the status to ``path`` (``survey_table``).

    ``outside``: rows whose temperature lies outside the calibration's fitted
    range, their status ``temperature_outside_fit`` (the compensation holds
    the range's edge there).
    """
    table, renamed = survey_table(header, rows, codes, columns, outside)
    if renamed:
        print(f'inclino survey: input column(s) {", ".join(renamed)} kept as input_<name>',
              file=sys.stderr)
    if outside is not None and outside.any():
        print(f'inclino survey: {int(outside.sum())} row(s) with a temperature outside the '
              f"calibration's fitted range: status {OUTSIDE_FIT}", file=sys.stderr)
    try:
        tables.write_csv(path, table)
    except OSError as err:
        raise CommandError(f'cannot write {path}: {err}') from None
