"""
``inclino process``: correct a recorded bag offline, as the node does live.

Reads sensor_msgs/Imu from a bag, runs ``pipeline.run`` on batches of
samples and writes, for every accepted sample and with its stamp and
frame_id, ``/survey`` (Vector3Stamped: x inclination_deg, y toolface_deg,
z azimuth_deg, NaN without ``--mag-topic``) and ``/imu/data`` (corrected
specific force, roll/pitch orientation and the node's covariances).
Dropped samples produce no output: before the correction non-finite,
saturated, zero (and two-axis over-g) samples, after it samples whose
G-total is off g by more than ``--g-total-tolerance-mps2`` (``dynamic``: not
gravity) and two-axis samples steeper than ``--two-axis-max-inclination-deg``
(``two_axis_range``).  When most samples are dropped the command says so on
stderr and exits 1 (the accepted ones are still written).  A toolface or
azimuth whose 1 sigma (``--noise-mps2``, ``--mag-noise-nT`` and the
calibration's own uncertainty) exceeds ``--toolface-max-std-deg`` /
``--azimuth-max-std-deg`` is NaN, counted.  With ``--temperature-topic`` the
calibration's temperature stage gets the temperature of each sample
(sensor_msgs/Temperature interpolated linearly to its stamp, the first or
last value held outside their span); without it a calibration with a
temperature stage is refused unless ``--at-reference-temperature`` (then it
compensates at its reference temperature, warned).

With ``--mag-topic`` (sensor_msgs/MagneticField, tesla, z-up tool frame)
each Imu sample is paired with the magnetometer message nearest in time
(a reading without a value, NaN as some drivers send between two
measurements, is never paired, counted ``mag_non_finite``; one no
magnetometer gives, beyond an Earth field plus interference, is dropped
first, counted ``mag_readings_dropped``);
one further than ``--max-pairing-s`` away (or none) leaves the sample
without a field: its azimuth is NaN and it is counted unpaired.  The field
(in nT) goes through the calibration's magnetic stage to ``pipeline.run``,
and ``/survey`` z is the magnetic azimuth where it is trusted (paired,
defined and passing the survey QC against the reference field: B-total,
dip, G-total), NaN elsewhere.  The reference is ``--reference-total-nT``,
``--reference-dip-deg`` or ``--site`` (WMM), else the one of the
calibration's multi-station analysis; an azimuth is never written without
one to check it against.

With ``--average-samples N`` or ``--output-rate-hz R`` (as the node's
``output.*``) OUT gets, instead of every sample, the mean of every N
accepted samples or of the accepted samples of each 1/R of stamp time: the
angles of the mean reading at the mean stamp, its covariances the standard
error of the mean (``pipeline.average``); windows of a tool that moved are
not written, and the samples of the window still open at the end are not
either (both counted).

IN may also be a continuous log: a CSV file (``*.csv``) with ``time_s`` [s,
increasing], ``ax, ay, az`` [m/s^2], optionally ``wx, wy, wz`` [rad/s] and
``temperature_c`` (then the temperature and stand stages get each row's
temperature, ``--temperature-topic`` not needed); each row is one sample,
stamped ``time_s`` (frame ``csv``).  A CSV has no magnetometer topic: for
the azimuth of a CSV use ``inclino survey``.  Temperatures outside a
multi-temperature stand's fitted range are counted on stderr.

OUT is written under a temporary name and renamed when complete; an OUT
that exists is refused unless ``--force``, and IN or the calibration file
never (``io.files.Outputs``).  A damaged IN (a read that fails or yields
fewer messages than the bag says) is an error and leaves no OUT.
"""

import os
import sys

from inclino_ros.calibration.inputs import (
    bag_temperatures, imu_count, known_temperatures, log_series)
from inclino_ros.calibration.model import (
    CalibrationFileError, missing_temperature, MissingTemperature)
from inclino_ros.cli.errors import CommandError
from inclino_ros.cli.fitting import (
    add_bias_instability_arguments, add_gravity_option, add_sensor_argument, load_calibration,
    node_option, warn_outside_range)
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.mounting import add_axes_map_arguments, settings_maps
from inclino_ros.cli.options import (
    add_force_argument, add_reference_temperature_argument, between)
from inclino_ros.cli.reference import add_reference_arguments, resolve_reference
from inclino_ros.core.averaging import Averager
from inclino_ros.io.bag import BagWriter, CHUNK_SIZE, STORAGES
from inclino_ros.io.files import Outputs
from inclino_ros.stream import (
    IMU_TOPIC, recorded_magnetometer, replay_recording, replay_settings, Summary, SURVEY_TOPIC)
from tqdm import tqdm


def register(subparsers):
    """Add the ``process`` subcommand."""
    parser = add_command(
        subparsers, 'process', 'correct a recorded bag with a calibration file',
        'Correct a recorded bag with a calibration file, as the running node would, and '
        'write the corrected angles to a new bag.',
        'IN holds the raw accelerometer (sensor_msgs/Imu on --topic, m/s^2, the up axis '
        'reading +g at rest). OUT gets, for every sample that can give an angle and with its '
        'stamp, /survey (x inclination, y gravity toolface, z magnetic azimuth, degrees) and '
        '/imu/data (the corrected acceleration, roll and pitch). Samples that cannot (NaN, '
        'saturated, zero) are dropped and counted in the summary.',
        'With --temperature-topic the temperature stage of the calibration gets the '
        'temperature of each sample (interpolated in time); without it a calibration with a '
        'temperature stage is refused, unless --at-reference-temperature (compensated at its '
        'reference temperature, warned).',
        'With --mag-topic (sensor_msgs/MagneticField, tesla) each sample takes the '
        'magnetometer reading nearest in time (readings without a value skipped); none within '
        '--max-pairing-s leaves its azimuth empty (NaN). An azimuth is written only where it '
        'is trusted: the corrected field agrees with the reference field (total, dip, and '
        'G-total) of --reference-total-nT and --reference-dip-deg, of --site, or of the '
        'multi-station analysis in the calibration file; with no reference there is none.',
        'Exit 0 done, 1 no sample accepted (nothing written), 2 unusable input.')
    parser.add_argument('input', metavar='IN',
                        help='input bag (mcap or sqlite3), or a CSV log (*.csv: time_s, ax, '
                             'ay, az; optional wx, wy, wz, temperature_c)')
    parser.add_argument('output', metavar='OUT', help='output bag to create')
    parser.add_argument('--calibration', required=True, metavar='FILE',
                        help='calibration file (as written by the node or inclino calibrate)')
    add_sensor_argument(parser)
    parser.add_argument('--topic', default='/imu/data_raw',
                        help='sensor_msgs/Imu topic to read (default: %(default)s)')
    parser.add_argument('--temperature-topic', metavar='TOPIC',
                        help='sensor_msgs/Temperature topic of IN feeding the temperature '
                             'stage (default: none)')
    parser.add_argument('--storage', choices=sorted(STORAGES), default='mcap',
                        help='storage format of OUT (default: %(default)s)')
    add_force_argument(parser)
    add_reference_temperature_argument(parser)
    node_option(parser, '--toolface-convention', 'toolface_convention',
                'gravity toolface definition')
    parser.add_argument('--axes', type=int, choices=(2, 3),
                        help='accelerometer axes (default: those of the calibration file)')
    add_gravity_option(parser)
    node_option(parser, '--range-mps2', 'accelerometer_range_mps2',
                'sensor full scale [m/s^2]; samples at or beyond are dropped')
    node_option(parser, '--noise-mps2', 'accelerometer_noise_std_mps2',
                'accelerometer noise per sample, 1 sigma [m/s^2]: the 1 sigma of the angles and '
                'the /imu/data covariances', dest='noise_std_mps2', metavar='NOISE_MPS2')
    add_limit_arguments(parser)
    node_option(parser, '--g-total-tolerance-mps2', 'g_total_tolerance_mps2',
                'three axes: a sample whose corrected G-total is further from g is not gravity '
                'and dropped')
    node_option(parser, '--two-axis-max-inclination-deg', 'two_axis_max_inclination_deg',
                'two axes: a steeper sample is dropped')
    parser.add_argument('--chunk-size', type=between(1, 1_000_000, int), default=CHUNK_SIZE,
                        help='samples processed per batch (default: %(default)s)')
    averaging = parser.add_mutually_exclusive_group()
    node_option(averaging, '--average-samples', 'output.average_samples',
                'write the mean of every N accepted samples (the angles of the mean reading, '
                'the standard error in the covariances) instead of every sample',
                metavar='N')
    node_option(averaging, '--output-rate-hz', 'output.rate_hz',
                'write the mean of the accepted samples of each 1/rate of stamp time instead '
                'of every sample')
    add_axes_map_arguments(parser, 'accelerometer', 'magnetometer')
    magnetic = parser.add_argument_group('magnetic azimuth (seed 002)')
    magnetic.add_argument('--mag-topic', metavar='TOPIC',
                          help='sensor_msgs/MagneticField topic of IN (tesla, tool frame): '
                               'adds the azimuth on /survey z (default: none, z NaN)')
    node_option(magnetic, '--max-pairing-s', 'magnetic.max_pairing_s',
                'largest time between an Imu sample and its magnetometer message [s]; beyond it '
                'the azimuth is NaN', metavar='S')
    node_option(magnetic, '--mag-noise-nT', 'magnetometer_noise_std_nT',
                'magnetometer noise per sample, 1 sigma [nT]')
    add_bias_instability_arguments(parser, magnetic)
    add_reference_arguments(magnetic)
    parser.set_defaults(func=run)


def add_limit_arguments(parser):
    """Add --toolface-max-std-deg and --azimuth-max-std-deg (``process`` and ``msa``)."""
    node_option(parser, '--toolface-max-std-deg', 'toolface_max_std_deg',
                'a toolface of larger 1 sigma is NaN')
    node_option(parser, '--azimuth-max-std-deg', 'magnetic.azimuth_max_std_deg',
                'an azimuth of larger 1 sigma is NaN')


def run(args):
    """
    Process IN into OUT; return 0, 1 if most samples dropped or none accepted.

    An unusable input or OUT raises (``main`` reports it, exit code 2); OUT
    is written under a temporary name and renamed only when complete.
    """
    try:
        with Outputs(inputs=[args.input, args.calibration], force=args.force) as outputs:
            output = outputs.path(args.output)
            log = read_log(args) if is_csv(args.input) else None
            model, settings, count, temperature = _prepare(args, log)
            if temperature is not None:
                warn_outside_range(model, temperature.temperature_c, 'inclino process')
            magnetometer = _magnetometer(args, model)
            averager = (Averager(args.average_samples, args.output_rate_hz)
                        if args.average_samples > 1 or args.output_rate_hz > 0 else None)
            with BagWriter(output, args.storage) as out:
                summary = process(args.input, args.topic, out, model, settings,
                                  args.chunk_size, count, temperature, magnetometer, averager,
                                  None if log is None else log[0])
            if summary.accepted == 0:
                raise _NothingAccepted()   # an empty OUT is not left behind
    except _NothingAccepted:
        print('\n'.join(summary.lines(magnetometer)))
        loud = summary.mostly_dropped()
        if loud is not None:
            print(f'inclino process: ERROR: {loud}', file=sys.stderr)
        print(f'inclino process: no sample of {args.topic} was accepted: {args.output} not '
              'written', file=sys.stderr)
        return 1
    print(f'wrote {args.output} ({args.storage}): {summary.written} messages on each of '
          f'{SURVEY_TOPIC} and {IMU_TOPIC}')
    print('\n'.join(summary.lines(magnetometer)))
    # 'board': the toolface written is the sensor board's, not the tool's (issue 19 item 6);
    # the bag's metadata says so too (stream.TOOLFACE_ZERO_KEYS).
    print('\n'.join(model.toolface_zero_lines))
    loud = summary.mostly_dropped()
    if loud is not None:
        print(f'inclino process: ERROR: {loud}', file=sys.stderr)
        return 1
    return 0


class _NothingAccepted(Exception):
    """No sample was accepted: the output is discarded (``Outputs`` removes it)."""


def read_log(args):
    """Return (ImuSeries, TemperatureSeries or None) of IN, a CSV log (``inputs.log_series``)."""
    log = log_series(args.input)
    if args.mag_topic is not None:
        raise CommandError(f'{args.input} is a CSV log: it has no --mag-topic (for the '
                           'azimuth of a CSV use inclino survey)')
    return log


def is_csv(path):
    """Return whether IN names a CSV log (a file ending in .csv) rather than a bag."""
    return os.path.isfile(path) and path.lower().endswith('.csv')


def _prepare(args, log=None):
    """
    Return (model, settings, message count, TemperatureSeries or None) or raise CommandError.

    ``log``: the (ImuSeries, TemperatureSeries or None) of a CSV log, else None (a bag).
    """
    model = load_calibration(args.calibration, args.sensor_id)
    if not model.calibrated:
        print(f'inclino process: warning: {args.calibration} holds no accelerometer '
              'correction (no level-bench, stand or temperature stage): the inclination and '
              'toolface written are the raw ones' + (
                  ', and the azimuth uses the raw gravity direction (calibrate the level bench '
                  'first: inclino fit-level or inclino calibrate)'
                  if model.magnetic is not None else ''), file=sys.stderr)
    for note in model.uncertainty_notes:
        print(f'inclino process: warning: {args.calibration}: {note}', file=sys.stderr)
    try:
        settings = replay_settings(
            model, args.calibration, '--range-mps2', accelerometer_axes=args.axes,
            gravity_mps2=args.gravity_mps2, accelerometer_range_mps2=args.range_mps2,
            toolface_convention=args.toolface_convention, noise_std_mps2=args.noise_std_mps2,
            bias_instability_mps2=args.bias_instability_mps2,
            toolface_max_std_deg=args.toolface_max_std_deg,
            g_total_tolerance_mps2=args.g_total_tolerance_mps2,
            two_axis_max_inclination_deg=args.two_axis_max_inclination_deg,
            **settings_maps(args))
    except (ValueError, CalibrationFileError) as err:
        raise CommandError(str(err)) from None
    if log is not None:
        imu, series = log
        if series is None:
            refuse_missing_temperature(args, model, f'{args.input} has no temperature_c column')
        return model, settings, imu.stamps_ns.size, None if series is None else \
            known_temperatures(series, args.temperature_topic or 'temperature_c', args.input)
    count = imu_count(args.input, args.topic)
    if args.temperature_topic is None:
        refuse_missing_temperature(args, model, 'no --temperature-topic was given')
        return model, settings, count, None
    return model, settings, count, bag_temperatures(args.input, args.temperature_topic)


def refuse_missing_temperature(args, model, missing):
    """
    Refuse input without temperatures for a model compensating them (CommandError).

    ``--at-reference-temperature``: warn on stderr and go on at the reference
    temperature instead (``provenance.missing_temperature``, the rule of
    ``inclino survey`` too).
    """
    try:
        warning = missing_temperature(model, args.calibration, missing,
                                      args.at_reference_temperature)
    except MissingTemperature as err:
        raise CommandError(str(err)) from None
    if warning is not None:
        print(f'inclino {args.command}: {warning}', file=sys.stderr)


def _magnetometer(args, model):
    """Return the Magnetometer of --mag-topic or None (``stream.recorded_magnetometer``)."""
    if args.mag_topic is None:
        return None
    try:
        *reference, source = resolve_reference(args, model)
        magnetometer = recorded_magnetometer(args.input, args.mag_topic, args.max_pairing_s,
                                             reference, args.mag_noise_nT,
                                             args.azimuth_max_std_deg,
                                             args.mag_bias_instability_nT)
    except ValueError as err:
        raise CommandError(str(err)) from None
    if model.magnetic is None:
        print(f'inclino process: warning: {args.calibration} has no magnetic stage: the '
              'azimuth is of the raw magnetometer', file=sys.stderr)
    settings = magnetometer.settings
    print(f'reference field: {settings.reference_total_nT:.1f} nT, dip '
          f'{settings.reference_dip_deg:.3f} deg, declination {settings.declination_deg:.3f} '
          f'deg ({source}); /survey z is the magnetic azimuth', file=sys.stderr)
    return magnetometer


def process(in_path, topic, out, model, settings, chunk_size, count=None, temperature=None,
            magnetometer=None, averager=None, imu=None):
    """
    Correct ``topic`` of the bag ``in_path`` into the open BagWriter ``out``.

    ``stream.replay_recording`` with a progress bar of ``count`` messages on
    stderr; returns the Summary.
    """
    summary = Summary(settings.gravity_mps2)
    with tqdm(total=count, unit='msg', desc='inclino process', file=sys.stderr) as progress:
        try:
            return replay_recording(in_path, topic, out, model, settings, chunk_size, summary,
                                    temperature, magnetometer, averager, imu, progress)
        except KeyboardInterrupt:
            raise KeyboardInterrupt(f'after {summary.samples_in} of {count} messages') from None
