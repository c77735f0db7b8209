"""
``inclino fit-magnetometer``: calibrate both triads from shots, without a stand or a reference.

Input: a CSV with the columns ``ax, ay, az`` (m/s^2, REP 145 specific
force, tool frame, z along the tool axis), ``bx, by, bz`` (nT, same frame)
and optionally ``roll_group`` (rows with the same non-empty value were
taken with the tool axis held in one direction and the tool turned about
it) and ``temperature_c``; one row per still shot.  Or a bag: the still
segments of ``--raw-topic`` and ``--mag-topic`` are found (every window of
``--still-window-s`` whose directions spread less than ``--max-still-deg``
on both triads, joined into segments of at least ``--min-still-s``) and each
becomes a shot; roll sets among them are found as in a CSV without
``roll_group`` (consecutive shots pointing one way while the tool turns).

One joint fit (``core.shots``) finds the magnetometer ellipsoid (hard iron,
full soft iron), the accelerometer's when the file has no stand stage, the
rotation between the triads (the dip is constant) and, from the roll
groups, the tool axis (seed 000's installation without a level bench).  The
file gets the stages ``magnetometer``, ``magnetometer_alignment``,
``tool_axis`` (with roll groups) and ``stand`` (method sphere, when fitted);
its other stages are kept; the installation (level bench) too, carried
into a new accelerometer frame, unless roll groups measure the tool axis.
Nothing measuring the mount (a bag has no roll groups) is said loudly, on
stderr too.  The field is scaled to
``--reference-total-nT`` (or ``--site``) if given, else to the sensor's own
mean scale.

Report (``fit_magnetometer.txt``, and ``fit_magnetometer.png`` with
``--plot``: matplotlib alone takes longer to load than the whole fit): |g|,
|B| and dip per shot before (the file's correction, raw for a new file) and
after; the azimuth and inclination spread of each roll group before and after.

Refused, exit 1 with the reason and the calibration file byte-identical: a
missing column, non-finite rows (named), too few shots, readings in uT (or
another unit) where nT are expected, a field that never changes (no
rotation), all shots in one plane, a fit that does not make |B|, |g| and
the dip constant, a roll group not turned about its axis, outliers beyond
what the shots left can spare; every failed check at once, and the figures
of the refused fit in ``fit_magnetometer_refused.txt``.  Robust: an outlier
shot is named and left out while enough good shots remain; a roll group is
weighted by its own pointing wander (reported), and one that wandered beyond
2 deg RMS is taken as free shots (named).
"""

from dataclasses import replace
import math
import sys

from inclino_ros.calibration.magnetometer import calibrate_from_shots
from inclino_ros.calibration.plausibility import check_field_unit, Implausible
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_file_arguments, finish_figure, is_bag, load_existing, new_figure, read_topic, Refused,
    report_paths, report_residuals, run_fit, save, TEMPERATURE_TOPIC, write_text)
from inclino_ros.cli.fitting import MAG_PAIRING_TOLERANCE_NT, NODE_DEFAULTS
from inclino_ros.cli.options import between, node_parameter, positive
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core import magnetics
from inclino_ros.core import stillness
from inclino_ros.core.shots import ShotFitRefused, ShotLimits
from inclino_ros.io import tables
from inclino_ros.io.report import REFUSED, Residual, USED
from inclino_ros.io.timing import pair_nearest
import numpy as np

REPORT_NAME = 'fit_magnetometer'
ACCEL_COLUMNS = ('ax', 'ay', 'az')
FIELD_COLUMNS = ('bx', 'by', 'bz')
GROUP_COLUMN = 'roll_group'


def register(subparsers):
    """Add the ``fit-magnetometer`` subcommand."""
    parser = subparsers.add_parser(
        'fit-magnetometer',
        help='calibrate magnetometer and accelerometer from shots in many orientations '
             '(no stand, no reference)', description=__doc__.split('\n\n', 1)[1])
    add_file_arguments(parser, 'CSV file (ax, ay, az, bx, by, bz [, roll_group])')
    parser.add_argument('--gravity-mps2', type=node_parameter('gravity_mps2'),
                        default=NODE_DEFAULTS['gravity_mps2'],
                        help='local gravity [m/s^2] (default: %(default)s)')
    parser.add_argument('--plot', action='store_true',
                        help='also draw the report as fit_magnetometer.png')
    parser.add_argument('--max-dip-rms-deg', type=between(1e-6, 90.0),
                        default=ShotLimits.max_dip_rms_deg,
                        help='largest RMS of the dip the fit may leave [deg] (default: '
                             '%(default)s)')
    parser.add_argument('--max-g-rms-fraction', type=between(1e-9, 1.0),
                        default=ShotLimits.max_g_rms_fraction,
                        help='largest RMS of |g| the fit may leave, a fraction of g (default: '
                             '%(default)s)')
    parser.add_argument('--max-b-rms-fraction', type=between(1e-9, 1.0),
                        default=ShotLimits.max_b_rms_fraction,
                        help='largest RMS of |B| the fit may leave, a fraction of the field '
                             '(default: %(default)s)')
    bag = parser.add_argument_group('bag input')
    bag.add_argument('--raw-topic', default='/imu/data_raw',
                     help='sensor_msgs/Imu topic (default: %(default)s)')
    bag.add_argument('--mag-topic', default='/imu/mag',
                     help='sensor_msgs/MagneticField topic (default: %(default)s)')
    bag.add_argument('--temperature-topic', default=TEMPERATURE_TOPIC,
                     help='sensor_msgs/Temperature topic, if the bag has it (default: '
                          '%(default)s)')
    bag.add_argument('--still-window-s', type=positive, default=0.5,
                     help='window of the stillness test [s] (default: %(default)s)')
    bag.add_argument('--max-still-deg', type=between(1e-6, 90.0), default=0.5,
                     help='largest spread of the directions in a still window [deg] '
                          '(default: %(default)s)')
    bag.add_argument('--min-still-s', type=positive, default=1.0,
                     help='shortest still segment taken as a shot [s] (default: %(default)s)')
    bag.add_argument('--max-pairing-s', type=node_parameter('magnetic.max_pairing_s'),
                     default=0.05,
                     help='largest time between an Imu sample and its magnetometer message '
                          '[s] (default: %(default)s)')
    add_reference_arguments(parser.add_argument_group(
        'reference field (optional: scales |B| and checks the dip found)'))
    parser.set_defaults(func=run)


def run(args):
    """Fit, report and write the stages; return the exit code."""
    return run_fit('fit-magnetometer', args, fit)


def read_bag_shots(args, lines):
    """Return the shots of the still segments of a bag (roll groups: found by the fit)."""
    imu = read_topic(args.input, args.raw_topic)
    mag = read_topic(args.input, args.mag_topic)
    field, paired = pair_nearest(imu.stamps_ns, mag.stamps_ns, mag.field_nT,
                                 round(args.max_pairing_s * 1e9), MAG_PAIRING_TOLERANCE_NT)
    order = np.argsort(imu.stamps_ns[paired], kind='stable')
    stamps = imu.stamps_ns[paired][order]
    accel = imu.linear_acceleration_mps2[paired][order]
    field = field[paired][order]
    if stamps.size < 2:
        raise Refused(f'{args.input}: fewer than two {args.raw_topic} samples with a paired '
                      f'{args.mag_topic} reading')
    segments = stillness.still_segments(stamps, accel, field, args.still_window_s,
                                        args.max_still_deg, args.min_still_s)
    lines.append(f'{len(segments)} still segment(s) found in {args.input} '
                 f'({stamps.size} paired samples)')
    if len(segments) > tables.MAX_SHOTS:
        raise Refused(f'{len(segments)} still segments are more shots than a fit takes '
                      f'({tables.MAX_SHOTS}): take a longer --min-still-s')
    shots_a = np.array([accel[a:b].mean(axis=0) for a, b in segments]).reshape(-1, 3)
    shots_b = np.array([field[a:b].mean(axis=0) for a, b in segments]).reshape(-1, 3)
    return shots_a, shots_b, None, None


def fit(args, lines, outputs):
    """Fit the shots of ``args.input`` into ``args.calibration``; see ``run_fit``."""
    existing = load_existing(args.calibration, args.sensor_id)
    try:
        total_nT, dip_ref, _, source = resolve_reference(args)
    except ValueError as err:
        raise CommandError(str(err)) from None
    if is_bag(args.input):
        accel, field, labels, temperature_c = read_bag_shots(args, lines)
    else:
        try:
            accel, field, labels, temperature_c = tables.read_shots(
                args.input, ACCEL_COLUMNS, FIELD_COLUMNS, GROUP_COLUMN)
        except tables.TableError as err:
            raise Refused(str(err)) from None
    if accel.shape[0]:
        try:
            check_field_unit(field, 'bx, by, bz')
        except Implausible as err:
            raise Refused(err.reason) from None
    limits = replace(ShotLimits(), max_dip_rms_deg=args.max_dip_rms_deg,
                     max_b_rms_fraction=args.max_b_rms_fraction,
                     max_g_rms_fraction=args.max_g_rms_fraction)
    try:
        result = calibrate_from_shots(existing, accel, field, labels, temperature_c,
                                      args.gravity_mps2, total_nT, limits)
    except ShotFitRefused as err:
        if err.fit is not None:
            # A refused fit reports beside, not over, the report of the fit in the file.
            lines += robust_lines(err.fit, labels) + fit_table_lines(err.fit, labels)
            lines += [f'REFUSED: {reason}' for reason in err.reasons]
            write_text(outputs.path(report_paths(args, REPORT_NAME + '_refused')[1]), lines)
        raise Refused(err.reason) from None
    labels = result.roll_group
    for note in result.notes:
        if note.startswith('WARNING'):
            print(f'inclino fit-magnetometer: {note}', file=sys.stderr)
    before, after = (magnetics.survey_of(model.apply(accel, temperature_c),
                                         model.apply_magnetic(field, before='magnetic'))
                     for model in (existing, result.model))
    lines += summary_lines(result, labels, before, after, total_nT, dip_ref, source)
    report_residuals(args, lines, shot_residuals(result.fit, labels),
                     '|B| of each shot after the fit minus the fitted field')
    png, txt = report_paths(args, REPORT_NAME)
    if args.plot:
        plot_report(outputs.path(png), labels, before, after, result.fit.field_nT,
                    args.gravity_mps2)
    save(args, result.model, outputs)
    written = ['magnetometer', 'magnetometer_alignment'] + (
        ['tool_axis'] if result.fit.tool_axis is not None else []) + (
        ['stand (method sphere)'] if result.fit.accel_matrix is not None else [])
    lines += [f'wrote the stages {", ".join(written)} to {args.calibration}',
              f'report: {txt}' + (f', {png}' if args.plot else '')]
    write_text(outputs.path(txt), lines)


def circular_spread_deg(angles_deg):
    """Return the RMS deviation [deg] of angles from their circular mean."""
    mean = math.degrees(math.atan2(np.mean(np.sin(np.radians(angles_deg))),
                                   np.mean(np.cos(np.radians(angles_deg)))))
    return float(np.sqrt(np.mean(((np.asarray(angles_deg) - mean + 180.0) % 360.0 - 180.0) ** 2)))


def group_spreads(labels, survey, used):
    """Return [(azimuth spread, inclination spread)] [deg] per roll group, ``used`` shots."""
    if labels is None:
        return []
    return [(circular_spread_deg(survey['azimuth_deg'][(labels == k) & used]),
             float(np.std(survey['inclination_deg'][(labels == k) & used])))
            for k in range(int(labels.max()) + 1)]


def robust_lines(fit, labels):
    """Return the lines naming the outlier shots left out and the roll groups taken as free."""
    lines = [f'outlier shot {shot + 1}'
             + ('' if labels is None or labels[shot] < 0 else f' (roll group {labels[shot] + 1})')
             + f': {sigma:.1f} robust sigma from the others, left out of the fit (the tool '
             'moved, or iron was near)' for shot, sigma in fit.outliers]
    lines += [f'roll group {group + 1} taken as free shots (no tool axis from it): {why}'
              for group, why in fit.freed_groups]
    lines += [f'roll group {k + 1}: pointing wander {fit.axial_rms_deg[k]:.3f} deg RMS along '
              'the tool axis (its weight in the fit)' for k in fit.groups]
    return lines


def shot_residuals(fit, labels):
    """
    Return the Residual rows of each shot: its |B| after the fit minus the fitted field [nT].

    Against the noise the fit found per shot (``noise_nT``); an outlier shot
    left out of the fit is refused, with how many robust sigma it stood off.
    """
    outliers, rows = dict(fit.outliers), []
    for i, b_total_nT in enumerate(fit.b_total_nT):
        group = '' if labels is None or labels[i] < 0 else f' (roll group {labels[i] + 1})'
        note = '' if fit.used[i] else (f'outlier, {outliers.get(i, float("nan")):.1f} robust '
                                       'sigma from the others: left out')
        rows.append(Residual(f'shot {i + 1}{group}', float(b_total_nT - fit.field_nT),
                             float(fit.noise_nT), 'nT', USED if fit.used[i] else REFUSED, note))
    return rows


def fit_table_lines(fit, labels):
    """Return the per-shot |g|, |B| and dip the fit leaves (a refused fit's figures)."""
    lines = [f'{"shot":>4} {"group":>5} {"|g| [m/s^2]":>12} {"|B| [nT]":>10} {"dip [deg]":>10}']
    for i in range(len(fit.b_total_nT)):
        group = '' if labels is None or labels[i] < 0 else str(labels[i] + 1)
        lines.append(f'{i + 1:>4} {group:>5} {fit.g_total_mps2[i]:12.5f} '
                     f'{fit.b_total_nT[i]:10.1f} {fit.dip_per_shot_deg[i]:10.4f}'
                     + ('' if fit.used[i] else '  outlier, left out'))
    return lines


def summary_lines(result, labels, before, after, total_nT, dip_ref, source):
    """Return the text summary of a shot calibration."""
    fit = result.fit
    model = result.model
    lines = [f'{len(fit.b_total_nT)} shots, {len(fit.groups)} roll group(s); joint fit in '
             f'{fit.evaluations} evaluations; noise found: {fit.noise_mps2:.3g} m/s^2, '
             f'{fit.noise_nT:.3g} nT per shot']
    lines += list(result.notes) + robust_lines(fit, labels)
    lines.append(f'field scaled to {fit.field_nT:.1f} nT '
                 + (f'(reference, {source})' if total_nT is not None
                    else "(the magnetometer's own mean scale: no reference given)"))
    lines.append(f'dip found {fit.dip_deg:.4f} deg, RMS over the shots {fit.dip_rms_deg:.4f} deg'
                 + ('' if dip_ref is None else
                    f'; reference {dip_ref:.4f} deg ({fit.dip_deg - dip_ref:+.4f})'))
    k_m, bias = model.magnetometer.arrays
    lines.append('magnetometer K_m: ' + '; '.join(' '.join(f'{v:.6f}' for v in row)
                                                  for row in k_m)
                 + '  bias/hard iron nT: ' + ' '.join(f'{v:.1f}' for v in bias))
    lines.append(f'magnetometer axes turned {model.magnetometer_alignment.angle_deg:.4f} deg '
                 "into the accelerometer's")
    if model.tool_axis is not None:
        axis = model.tool_axis
        lines.append(f'tool axis from the roll groups: gamma_deg={axis.gamma_deg:.4f} '
                     f'beta_deg={axis.beta_deg:.4f} (axial RMS left {axis.axial_rms_deg:.4f} deg)')
    lines.append(f'{"shot":>4} {"group":>5} {"|g| before":>11} {"after":>9} {"|B| before":>11} '
                 f'{"after":>9} {"dip before":>10} {"after":>8}')
    for i in range(len(fit.b_total_nT)):
        group = '' if labels is None or labels[i] < 0 else str(labels[i] + 1)
        lines.append(f'{i + 1:>4} {group:>5} {before["g_total_mps2"][i]:11.5f} '
                     f'{after["g_total_mps2"][i]:9.5f} {before["b_total_nT"][i]:11.1f} '
                     f'{after["b_total_nT"][i]:9.1f} {before["dip_deg"][i]:10.4f} '
                     f'{after["dip_deg"][i]:8.4f}' + ('' if fit.used[i] else '  outlier'))
    for what, key in (('|g| [m/s^2]', 'g_total_mps2'), ('|B| [nT]', 'b_total_nT'),
                      ('dip [deg]', 'dip_deg')):
        lines.append(f'spread (std) of {what} over the shots used: before '
                     f'{np.std(before[key][fit.used]):.5g}, '
                     f'after {np.std(after[key][fit.used]):.5g}')
    for k, ((az0, inc0), (az1, inc1)) in enumerate(zip(group_spreads(labels, before, fit.used),
                                                       group_spreads(labels, after, fit.used))):
        lines.append(f'roll group {k + 1}: azimuth spread {az0:.4f} -> {az1:.4f} deg RMS, '
                     f'inclination spread {inc0:.4f} -> {inc1:.4f} deg'
                     + (f', turned over {fit.roll_deg[k]:.0f} deg' if k in fit.groups
                        else ' (free shots)'))
    return lines


def plot_report(path, labels, before, after, field_nT, g):
    """Plot |g|, |B|, dip per shot and the azimuth of the roll-group shots, before and after."""
    pyplot, fig, axes = new_figure(4, 'inclino fit-magnetometer: shots before and after')
    shot = np.arange(1, len(after['b_total_nT']) + 1)
    for ax, key, unit, centre in ((axes[0], 'g_total_mps2', 'm/s^2', g),
                                  (axes[1], 'b_total_nT', 'nT', field_nT),
                                  (axes[2], 'dip_deg', 'deg', None)):
        for survey, colour, name in ((before, 'tab:red', 'before'), (after, 'tab:green', 'after')):
            values = survey[key] - (np.mean(survey[key]) if centre is None else centre)
            ax.plot(shot, values, 'o', color=colour, markersize=4, label=name)
        ax.set_ylabel(f'{key} - {"mean" if centre is None else "nominal"} [{unit}]')
    if labels is not None:
        for survey, colour, name in ((before, 'tab:red', 'before'), (after, 'tab:green', 'after')):
            values = np.full(shot.size, np.nan)
            for k in range(int(labels.max()) + 1):
                members = labels == k
                azimuth = survey['azimuth_deg'][members]
                mean = math.degrees(math.atan2(np.mean(np.sin(np.radians(azimuth))),
                                               np.mean(np.cos(np.radians(azimuth)))))
                values[members] = (azimuth - mean + 180.0) % 360.0 - 180.0
            axes[3].plot(shot, values, 'o', color=colour, markersize=4, label=name)
    axes[3].set_ylabel('roll-group azimuth - group mean [deg]')
    axes[3].set_xlabel('shot')
    for ax in axes:
        ax.axhline(0.0, color='black', linewidth=0.8)
    finish_figure(pyplot, fig, axes, path)
