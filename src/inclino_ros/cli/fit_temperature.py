"""
``inclino fit-temperature``: seed 001's temperature drift K_T(T) into the calibration file.

Input: a CSV with the columns ``temperature_c, ax, ay, az`` and optionally
``ref_ax, ref_ay, ref_az`` (m/s^2), or a bag with the raw sensor on
``/imu/data_raw`` and sensor_msgs/Temperature on ``/imu/temperature``, the
temperature interpolated linearly to each Imu stamp (samples outside the
span of the temperature messages are left out): what ``inclino simulate
--heating`` writes.  The tool is held still, at one attitude (or, with the
ref columns, any), while it heats.

The reference of each reading is its ref columns, the reading of the same
attitude at 25 deg C; without them it is the mean reading within
``--reference-window-c`` (1 deg C) of 25 deg C, and a run that has none
there is refused.  Each axis is fitted as ``A_i = K_T,i(T) ref_i`` with a
polynomial of ``--order`` (``temperature.fit_temperature``, K_T = 1 at
25 deg C).  The new temperature stage replaces the old one; the stand and
installation stages are kept (K_T is a ratio of readings, independent of
them).

Refused (exit 1, the calibration file untouched): no reading near 25 deg C
and no ref columns, or a fit ``temperature`` refuses (too few distinct
temperatures for the order, 25 deg C outside the data, an axis that sees no
gravity at the attitude).
"""

from dataclasses import replace

from inclino_ros.calibration.model import Temperature, utc_now_iso
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_common_arguments, AXIS_COLUMNS, finish_figure, is_bag, load_existing, matrix_lines,
    new_figure, read_csv, read_topic, Refused, report_paths, run_fit, sample_temperatures, save,
    tool_axes, write_text)
from inclino_ros.cli.helptext import add_command
from inclino_ros.core.attitude import inclination
from inclino_ros.core.temperature import (
    AXES, fit_temperature, REFERENCE_TEMPERATURE_C, TemperatureFitRefused)
import numpy as np

REFERENCE_COLUMNS = ('ref_ax', 'ref_ay', 'ref_az')
REPORT_NAME = 'fit_temperature'


def register(subparsers):
    """Add the ``fit-temperature`` subcommand."""
    parser = add_command(
        subparsers, 'fit-temperature',
        'fit the temperature drift K_T(T) (seed 001) into a calibration file',
        'Fit how the scale of each accelerometer axis drifts with temperature (seed 001: '
        'K_T(T), a polynomial that is 1 at 25 C) and write it into the calibration file.',
        'Input: the tool held still at one attitude while it heats through 25 C: a bag with '
        'the raw sensor on /imu/data_raw and sensor_msgs/Temperature on /imu/temperature (what '
        'inclino simulate --heating writes), or a CSV with the columns temperature_c, ax, ay, '
        'az (optional ref_ax, ref_ay, ref_az: the reading at 25 C, for a run at changing '
        'attitudes). Without them the reference is the mean reading within '
        '--reference-window-c of 25 C.',
        'The temperature stage replaces the old one; the stand and level-bench stages are '
        'kept. The report, fit_temperature.png and fit_temperature.txt, goes beside the file '
        'or to --report-dir.',
        'Refused (exit 1, the file untouched): no reading near 25 C, too few distinct '
        'temperatures for --order, or an axis that sees no gravity at the attitude. Exit 2: '
        'unusable input.')
    add_common_arguments(parser)
    parser.add_argument('--order', type=int, default=2,
                        help='polynomial order of K_T(T) (default: %(default)s)')
    parser.add_argument('--reference-window-c', type=float, default=1.0,
                        help='readings within this many deg C of 25 deg C give the reference '
                             'when the input has no ref columns (default: %(default)s)')
    parser.set_defaults(func=run)


def run(args):
    """Fit, report and write the temperature stage; return the exit code."""
    return run_fit('fit-temperature', args, fit)


def fit(args, lines):
    """Fit the temperature stage of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    if args.order < 1:
        raise CommandError('--order must be at least 1')
    existing = load_existing(args.calibration)
    temperature_c, readings, reference = load_input(args)
    readings, reference = tool_axes(args, readings), tool_axes(args, reference)
    if reference is None:
        near = np.abs(temperature_c - REFERENCE_TEMPERATURE_C) <= args.reference_window_c
        if not near.any():
            raise Refused(
                f'no reading within {args.reference_window_c} deg C of '
                f'{REFERENCE_TEMPERATURE_C} deg C (data {temperature_c.min():.2f} .. '
                f'{temperature_c.max():.2f} deg C) to take the reference from; heat through '
                '25 deg C or give ref_ax, ref_ay, ref_az columns')
        reference = readings[near].mean(axis=0)
        lines.append(f'reference: mean of {near.sum()} readings within '
                     f'{args.reference_window_c} deg C of {REFERENCE_TEMPERATURE_C} deg C: '
                     + ' '.join(f'{v:.6f}' for v in reference) + ' m/s^2')
    try:
        result = fit_temperature(temperature_c, readings, reference, args.order)
    except TemperatureFitRefused as err:
        raise Refused(err.reason) from None
    stage = Temperature(
        coefficients=tuple(map(tuple, result.coefficients.tolist())),
        t_min_c=result.t_min_c, t_max_c=result.t_max_c,
        reference_temperature_c=result.reference_temperature_c,
        rms_residual_mps2=tuple(result.rms_residual_mps2.tolist()),
        samples=int(temperature_c.size), fitted_at=utc_now_iso())
    model = replace(existing, temperature=stage)
    uncompensated = replace(existing, temperature=None)
    baseline_deg = np.degrees(inclination(uncompensated.apply(
        np.broadcast_to(reference, readings.shape))))
    before_deg = np.degrees(inclination(uncompensated.apply(readings))) - baseline_deg
    after_deg = np.degrees(inclination(model.apply(readings, temperature_c))) - baseline_deg

    lines += matrix_lines(f'K_T(T) = a0 + a1 T + ... (rows {", ".join(AXES)}; a0 a1 ...)',
                          result.coefficients, '14.6e')
    ends_c = (result.t_min_c, result.reference_temperature_c, result.t_max_c)
    lines += [f'K_T at {", ".join(f"{t:.1f}" for t in ends_c)} deg C:'] + [
        f'  {axis}: ' + ' '.join(f'{v:.6f}' for v in values)
        for axis, values in zip(AXES, result.scale_factor(ends_c).T)]
    lines += [f'fitted {result.t_min_c:.2f} .. {result.t_max_c:.2f} deg C, '
              f'{temperature_c.size} readings; RMS residual per axis: '
              + ' '.join(f'{v:.3g}' for v in result.rms_residual_mps2) + ' m/s^2',
              f'inclination error over the run (vs the reference): largest '
              f'{np.abs(before_deg).max():.4f} deg uncompensated, '
              f'{np.abs(after_deg).max():.4f} deg compensated']
    png, txt = report_paths(args, REPORT_NAME)
    plot(png, temperature_c, readings / reference, result, before_deg, after_deg)
    lines.append(f'report: {png}')
    save(args.calibration, model)
    kept = [name for name in ('stand', 'installation') if getattr(model, name) is not None]
    lines.append(f'wrote {args.calibration}: temperature stage (order {args.order})'
                 + (f', {" and ".join(kept)} stage kept' if kept else ''))
    write_text(txt, lines)


def load_input(args):
    """Return (temperature_c (N,), readings (N, 3), reference (N, 3) or None)."""
    if not is_bag(args.input):
        table = read_csv(args.input, ('temperature_c',) + AXIS_COLUMNS,
                         optional=REFERENCE_COLUMNS)
        given = [name for name in REFERENCE_COLUMNS if name in table]
        if given and len(given) != 3:
            raise CommandError(f'{args.input} has {", ".join(given)}: give all of '
                               f'{", ".join(REFERENCE_COLUMNS)} or none')
        readings = np.column_stack([table[name] for name in AXIS_COLUMNS])
        reference = (np.column_stack([table[name] for name in REFERENCE_COLUMNS])
                     if given else None)
        return table['temperature_c'], readings, reference
    imu = read_topic(args.input, args.raw_topic)
    temperature_c, inside = sample_temperatures(imu, args.input, args.temperature_topic)
    if not inside.any():
        raise CommandError(f'no sample of {args.raw_topic} lies within the time span of '
                           f'{args.temperature_topic}')
    return temperature_c[inside], imu.linear_acceleration_mps2[inside], None


def plot(path, temperature_c, ratio, result, before_deg, after_deg):
    """Plot K_T points and curves per axis, and the inclination error before/after."""
    pyplot, fig, axes = new_figure(2, 'inclino fit-temperature: scale factor drift K_T(T)')
    grid_c = np.linspace(result.t_min_c, result.t_max_c, 200)
    fitted = result.scale_factor(temperature_c)
    # The points A/ref are K_T up to a constant per axis (1 at 25 deg C only for a
    # 25 deg C reference): scale them onto the curve by least squares.
    points = ratio / (np.sum(ratio * fitted, axis=0) / np.sum(fitted * fitted, axis=0))
    for axis, color in zip(range(3), ('tab:red', 'tab:green', 'tab:blue')):
        axes[0].plot(temperature_c, points[:, axis], '.', color=color, markersize=2, alpha=0.4)
        axes[0].plot(grid_c, result.scale_factor(grid_c)[:, axis], color=color,
                     label=f'{AXES[axis]}: K_T fit (points: A / ref)')
    axes[0].set_ylabel('K_T [1]')
    axes[1].plot(temperature_c, before_deg, '.', color='tab:red', markersize=2,
                 label=f'uncompensated, largest {np.abs(before_deg).max():.3f} deg')
    axes[1].plot(temperature_c, after_deg, '.', color='tab:green', markersize=2,
                 label=f'compensated A / K_T(T), largest {np.abs(after_deg).max():.4f} deg')
    axes[1].set_ylabel('inclination error [deg]')
    for ax in axes:
        ax.set_xlabel('temperature [deg C]')
    finish_figure(pyplot, fig, axes, path)
