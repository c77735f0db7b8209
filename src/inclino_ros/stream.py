"""
A stream of raw batches corrected into outputs: one place for the node and ``inclino process``.

``correct_batch`` runs one batch through ``pipeline.run`` and builds what it
publishes (every accepted sample, or the windows an averager closes); the node
calls it for what one wake-up finds queued, ``replay`` for every batch of a
recorded bag (pairing each sample with the nearest magnetometer reading of a
``Magnetometer``, counting in a ``Summary``).

For the accepted samples (or averaged windows) of a ``pipeline.Survey``:
``survey`` (Vector3Stamped: x inclination_deg, y toolface_deg, z magnetic
azimuth_deg, NaN without a trusted azimuth) and ``imu/data`` (the corrected
specific force, the roll/pitch orientation and the covariances of
``pipeline.imu_covariances``; angular velocity not measured), plus the
scalar values of the node's ``inclination``, ``toolface`` and ``azimuth``
(true, declination added) topics; ``averaged_outputs`` those of the windows
an ``averaging.Averager`` closes.  The series are encoded to CDR by
``io.bag.encode`` (the node publishes those bytes, ``inclino process``
writes them to a bag).  No ROS here.
"""

from dataclasses import dataclass, fields
from functools import partial
import math

from inclino_ros import scalar_chain
from inclino_ros.calibration.plausibility import check_for_sensor, field_reading_ok, Implausible
from inclino_ros.calibration.store import axes_refusal, check_axes_maps
from inclino_ros.core.magnetics import true_azimuth_deg
from inclino_ros.core.screening import ACCEPTED, count_reasons, REASONS
from inclino_ros.core.temperature import in_range
from inclino_ros.io.bag import (
    BagError, concatenate, IMU, ImuSeries, MAGNETIC_FIELD, not_measured_covariance, read,
    topic_info, VECTOR3_STAMPED, Vector3Series)
from inclino_ros.io.timing import pair_nearest, pairing_tolerance
from inclino_ros.pipeline import average, imu_covariances, MagneticSettings, run, Settings
import numpy as np

#: The topics ``inclino process`` writes.
SURVEY_TOPIC = '/survey'
IMU_TOPIC = '/imu/data'
#: The keys of the bag's metadata (``custom_data``) stating the toolface zero of its survey.
TOOLFACE_ZERO_KEYS = ('inclino.toolface_zero', 'inclino.toolface_zero_meaning')
#: Azimuth counts of the summary (accepted samples; mag_non_finite: magnetometer messages).
MAGNETIC_COUNTS = ('mag_non_finite', 'mag_paired', 'mag_unpaired', 'azimuth_trusted',
                   'azimuth_untrusted', 'azimuth_imprecise', 'qc_failed', 'qc_failed_b_total',
                   'qc_failed_dip', 'qc_failed_g_total')
#: What each reason for dropping a sample means, for the loud message of a bad run.
DROP_MEANINGS = {
    'non_finite': 'NaN or Inf readings', 'saturated': 'readings at the sensor range',
    'zero': 'readings of zero magnitude (dead sensor, free fall)',
    'over_g': 'two-axis readings above g',
    'dynamic': 'G-total off gravity by more than --g-total-tolerance-mps2: not gravity (a '
               'driver that removes gravity? wrong unit?)',
    'two_axis_range': 'two-axis readings beyond --two-axis-max-inclination-deg (tool past '
                      '90 deg?)'}


@dataclass(frozen=True)
class Magnetometer:
    """A magnetometer topic read whole, and how its readings pair with the Imu samples."""

    stamps_ns: np.ndarray     # (M,) int64
    field_nT: np.ndarray      # (M, 3) sensor axes, NaN where the driver sent no value
    max_pairing_ns: int
    settings: MagneticSettings
    dropped: int              # finite readings no magnetometer gives (beyond an Earth field)
    non_finite: int           # readings holding a NaN or infinite value (a driver's gaps)

    @classmethod
    def from_series(cls, series, max_pairing_s, settings):
        """
        Return the Magnetometer of a MagneticFieldSeries (any order; tesla -> nT).

        Readings ``plausibility.field_reading_ok`` refuses are dropped (and
        counted): a sample is paired with the nearest reading that is left.
        """
        field_nT = series.field_nT
        kept = field_reading_ok(field_nT)
        finite = np.isfinite(field_nT).all(axis=1)
        return cls(series.stamps_ns[kept], field_nT[kept], round(max_pairing_s * 1e9), settings,
                   int(np.count_nonzero(finite & ~kept)), int(np.count_nonzero(~finite)))

    def field_at(self, stamps_ns):
        """Return (field_nT (N, 3), paired (N,)) of the readings nearest ``stamps_ns``."""
        return pair_nearest(stamps_ns, self.stamps_ns, self.field_nT, self.max_pairing_ns,
                            pairing_tolerance(self.settings.noise_std_nT))


class Summary:
    """Running statistics of a processed stream."""

    def __init__(self, gravity_mps2):
        """Start with nothing seen; G-total sums are kept about ``gravity_mps2``."""
        self.gravity_mps2 = gravity_mps2
        self.samples_in = 0
        self.dropped = dict.fromkeys(REASONS, 0)
        self.inclination_min_deg = math.inf
        self.inclination_max_deg = -math.inf
        self._inclination_sum_deg = 0.0
        self._g_offset_sum = 0.0
        self._g_offset_sum_sq = 0.0
        self.toolface_imprecise = 0
        self.magnetic = None
        self.written = 0           # messages on each output topic
        self.averaged = False      # --average-samples / --output-rate-hz
        self.windows_moving = 0    # windows of a tool that moved: not written
        self.windows_dropped = 0   # mean readings that could not be gravity
        self.samples_not_averaged = 0   # in the window still open at the end of IN

    @property
    def accepted(self):
        """Return the number of samples that produced output."""
        return self.samples_in - sum(self.dropped.values())

    def mostly_dropped(self):
        """Return the loud message of a run where most samples were dropped, else None."""
        dropped = sum(self.dropped.values())
        if dropped * 2 <= self.samples_in:
            return None
        reason = max(self.dropped, key=self.dropped.get)
        return (f'{dropped} of {self.samples_in} samples dropped, most '
                f'({self.dropped[reason]}) as {reason}: {DROP_MEANINGS[reason]}; no angle was '
                'computed from them')

    def add(self, survey):
        """Count one processed batch (a ``pipeline.Survey``)."""
        self.samples_in += survey.codes.size
        for reason, count in count_reasons(survey.codes).items():
            self.dropped[reason] += count
        if survey.inclination_deg.size:
            self.inclination_min_deg = min(self.inclination_min_deg,
                                           float(survey.inclination_deg.min()))
            self.inclination_max_deg = max(self.inclination_max_deg,
                                           float(survey.inclination_deg.max()))
            self._inclination_sum_deg += float(survey.inclination_deg.sum())
            # The pipeline makes a toolface NaN where its 1 sigma exceeds the limit.
            self.toolface_imprecise += int(np.isnan(survey.toolface_deg).sum())
            offset = survey.g_total_mps2 - self.gravity_mps2
            self._g_offset_sum += float(offset.sum())
            self._g_offset_sum_sq += float(offset @ offset)

    def add_magnetic(self, survey, paired, non_finite):
        """
        Count the azimuths of one batch: ``paired`` (N,) says which input samples had a field.

        Counts (of accepted samples): paired, unpaired, trusted, untrusted,
        and the paired ones failing QC, in all and per test; ``non_finite``
        is the number of magnetometer messages without a value (never paired).
        """
        counts = self.magnetic or dict.fromkeys(MAGNETIC_COUNTS, 0)
        counts['mag_non_finite'] = non_finite
        paired = np.asarray(paired)[survey.accepted]
        azimuth = survey.magnetic
        counts['mag_paired'] += int(paired.sum())
        counts['mag_unpaired'] += int((~paired).sum())
        counts['azimuth_trusted'] += int(azimuth.trusted.sum())
        counts['azimuth_untrusted'] += int((~azimuth.trusted).sum())
        counts['azimuth_imprecise'] += int(azimuth.imprecise.sum())
        qc = azimuth.qc
        for name, ok in (('qc_failed', qc.ok), ('qc_failed_b_total', qc.b_total_ok),
                         ('qc_failed_dip', qc.dip_ok), ('qc_failed_g_total', qc.g_total_ok)):
            counts[name] += int((paired & ~ok).sum())
        self.magnetic = counts

    def lines(self, magnetometer=None):
        """Return the summary as ``name: value`` text, with what ``magnetometer`` dropped."""
        n = self.accepted
        lines = [f'samples_in: {self.samples_in}', f'accepted: {n}']
        lines += [f'dropped_{reason}: {count}' for reason, count in self.dropped.items()]
        lines.append(f'toolface_imprecise: {self.toolface_imprecise}')
        if self.magnetic is not None:
            lines += [f'{name}: {count}' for name, count in self.magnetic.items()]
        if magnetometer is not None:
            lines.append(f'mag_readings_dropped: {magnetometer.dropped}')
        if self.averaged:
            lines += [f'windows_written: {self.written}',
                      f'windows_moving: {self.windows_moving}',
                      f'windows_dropped: {self.windows_dropped}',
                      f'samples_not_averaged: {self.samples_not_averaged}']
        if n == 0:
            return lines + ['inclination_deg: none accepted', 'g_total_mps2: none accepted']
        g_mean = self.gravity_mps2 + self._g_offset_sum / n
        g_std = (math.sqrt(max(self._g_offset_sum_sq - self._g_offset_sum ** 2 / n, 0.0)
                           / (n - 1)) if n > 1 else 0.0)
        return lines + [
            f'inclination_deg: min {self.inclination_min_deg:.6f} '
            f'mean {self._inclination_sum_deg / n:.6f} max {self.inclination_max_deg:.6f}',
            f'g_total_mps2: mean {g_mean:.6f} std {g_std:.6f}']


@dataclass(frozen=True)
class Outputs:
    """What one batch publishes, topic by topic."""

    survey: Vector3Series
    imu: ImuSeries
    inclination_deg: np.ndarray
    toolface_deg: np.ndarray
    true_azimuth_deg: np.ndarray   # None without magnetometer readings


def outputs(stamps_ns, frame_ids, survey):
    """Return the Outputs of the accepted rows of ``survey``, stamped ``stamps_ns`` (M,)."""
    n = np.size(stamps_ns)
    acceleration_cov, orientation_cov = imu_covariances(survey)
    w, x, y, z = survey.orientation_wxyz.T
    magnetic = survey.magnetic
    azimuth_deg = np.full(n, np.nan) if magnetic is None else magnetic.azimuth_deg
    return Outputs(
        survey=Vector3Series(stamps_ns, frame_ids, np.stack(
            [survey.inclination_deg, survey.toolface_deg, azimuth_deg], axis=1)),
        imu=ImuSeries(
            stamps_ns, frame_ids, orientation_xyzw=np.stack([x, y, z, w], axis=1),
            orientation_covariance=orientation_cov, angular_velocity_radps=np.zeros((n, 3)),
            angular_velocity_covariance=not_measured_covariance(n),
            linear_acceleration_mps2=survey.corrected_mps2,
            linear_acceleration_covariance=acceleration_cov),
        inclination_deg=survey.inclination_deg, toolface_deg=survey.toolface_deg,
        true_azimuth_deg=None if magnetic is None else magnetic.true_azimuth_deg)


def averaged_outputs(averager, stamps_ns, frame_ids, survey, temperature_c, model, settings,
                     magnetic_settings=None):
    """
    Push the accepted samples of ``survey`` into ``averager``; return the windows it closes.

    ``stamps_ns``, ``frame_ids``: of the accepted samples; ``temperature_c``:
    None, one value, or one per input sample of the batch.  Returns (windows
    of a moving tool, windows whose mean reading was dropped by screening,
    [Outputs]): the angles of the kept windows (``pipeline.average``; with
    ``magnetic_settings``, their azimuths).
    """
    n = np.size(stamps_ns)
    if temperature_c is None:
        temperature_c = np.full(n, math.nan)
    elif np.ndim(temperature_c) == 0:
        temperature_c = np.full(n, float(temperature_c))
    else:
        temperature_c = np.asarray(temperature_c, dtype=float)[survey.accepted]
    field_nT = (np.full((n, 3), math.nan) if survey.magnetic is None
                else survey.magnetic.uncorrected_nT)
    windows = averager.push(stamps_ns, frame_ids, survey.uncorrected_mps2, temperature_c,
                            field_nT)
    if windows is None:
        return 0, 0, [], (math.nan, math.nan)
    kept, parts = average(windows, model, settings, magnetic_settings)
    noise = tuple(float(np.nanmax(values[kept])) if np.isfinite(values[kept]).any()
                  else math.nan for values in (windows.noise, windows.field_noise))
    published, dropped = [], 0
    for rows, averaged in parts:
        rows = rows[averaged.accepted]
        dropped += averaged.codes.size - rows.size
        published.append(outputs(windows.stamps_ns[rows], windows.frame_ids[rows], averaged))
    return windows.count - int(np.count_nonzero(kept)), dropped, published, noise


@dataclass(frozen=True)
class Batch:
    """What one batch of raw samples gave: its survey and the Outputs to publish."""

    survey: object          # pipeline.Survey of every input sample
    published: list         # [Outputs]: the accepted samples', or the closed windows'
    windows_moving: int     # windows of a moving tool (averaging only)
    windows_dropped: int    # windows whose mean reading was dropped by screening
    # (accelerometer [m/s^2], magnetometer [nT]) largest own per-sample noise of the kept
    # windows (averaging only; NaN: none measured)
    noise_measured: tuple = (math.nan, math.nan)


def correct_batch(raw_mps2, stamps_ns, frame_ids, model, settings, temperature_c=None,
                  field_nT=None, magnetic_settings=None, averager=None):
    """
    Return the Batch of raw samples (N, 3) stamped ``stamps_ns`` with ``frame_ids`` (N,).

    ``pipeline.run`` over the batch (``field_nT``: the paired magnetometer
    readings, NaN rows unpaired, or None), or for a few samples the same
    numbers in floats (``scalar_chain.run``); then the Outputs of the accepted
    samples, or with an ``averager`` (``core.averaging.Averager``) those of
    the windows it closes (``averaged_outputs``).
    """
    survey = None
    if scalar_chain.applies(np.shape(raw_mps2)[0], field_nT):   # the node's batches at low rates
        survey = scalar_chain.run(raw_mps2, model, settings, temperature_c)
    if survey is None:
        survey = run(raw_mps2, model, settings, temperature_c, field_nT, magnetic_settings)
    accepted = survey.accepted
    stamps_ns, frame_ids = np.asarray(stamps_ns)[accepted], np.asarray(frame_ids)[accepted]
    if averager is None:
        return Batch(survey, [outputs(stamps_ns, frame_ids, survey)], 0, 0)
    moving, dropped, published, noise = averaged_outputs(
        averager, stamps_ns, frame_ids, survey, temperature_c, model, settings,
        None if field_nT is None else magnetic_settings)
    return Batch(survey, published, moving, dropped, noise)


def replay(batches, write, model, settings, summary, temperature=None, magnetometer=None,
           averager=None, progress=None):
    """
    Correct each recorded ImuSeries of ``batches``, handing every Outputs to ``write``.

    ``temperature`` (a TemperatureSeries or None) gives each sample its
    temperature, ``magnetometer`` (a Magnetometer or None) its field;
    ``summary`` (a Summary) counts; ``progress.update(n)`` is called per batch.
    """
    for batch in batches:
        temperature_c = None if temperature is None else temperature.at(batch.stamps_ns)
        field_nT, paired, magnetic_settings = None, None, None
        if magnetometer is not None:
            field_nT, paired = magnetometer.field_at(batch.stamps_ns)
            magnetic_settings = magnetometer.settings
        result = correct_batch(batch.linear_acceleration_mps2, batch.stamps_ns,
                               batch.frame_ids, model, settings, temperature_c, field_nT,
                               magnetic_settings, averager)
        if magnetometer is not None:
            summary.add_magnetic(result.survey, paired, magnetometer.non_finite)
        summary.add(result.survey)
        summary.windows_moving += result.windows_moving
        summary.windows_dropped += result.windows_dropped
        for published in result.published:
            write(published)
            summary.written += published.inclination_deg.size
        if progress is not None:
            progress.update(batch.stamps_ns.size)


#: Status of a surveyed row whose temperature lies outside the fitted range of a temperature stage.
OUTSIDE_FIT = 'temperature_outside_fit'


def survey_columns(result, declination_deg, with_qc, toolface_zero):
    """
    Return ``{name: (accepted mask, values of the accepted rows)}`` of a surveyed table.

    The angles, totals and their 1 sigma of a ``pipeline.Survey`` (``inclino
    survey``) and ``toolface_zero`` (``CalibrationModel.toolface_zero``);
    with a field the azimuth, dip, the true azimuth with ``declination_deg``
    and, ``with_qc`` (a reference field), the survey QC.
    """
    accepted = result.accepted
    azimuth = result.magnetic
    if azimuth is None:    # no magnetometer: no azimuth, no field QC
        values = {'inclination_deg': result.inclination_deg,
                  'toolface_deg': result.toolface_deg, 'g_total_mps2': result.g_total_mps2,
                  'inclination_std_deg': result.inclination_std_deg,
                  'toolface_std_deg': result.toolface_std_deg,
                  'toolface_zero': [toolface_zero] * int(np.count_nonzero(accepted))}
        return {name: (accepted, value) for name, value in values.items()}
    values = {'inclination_deg': result.inclination_deg, 'toolface_deg': result.toolface_deg,
              'azimuth_deg': azimuth.defined_azimuth_deg, 'g_total_mps2': result.g_total_mps2,
              'b_total_nT': azimuth.b_total_nT, 'dip_deg': azimuth.dip_deg,
              'inclination_std_deg': result.inclination_std_deg,
              'toolface_std_deg': result.toolface_std_deg,
              'azimuth_std_deg': azimuth.azimuth_std_deg,
              'g_total_std_mps2': azimuth.g_total_std_mps2,
              'b_total_std_nT': azimuth.b_total_std_nT, 'dip_std_deg': azimuth.dip_std_deg}
    values['toolface_zero'] = [toolface_zero] * int(np.count_nonzero(accepted))
    if declination_deg is not None:
        values['true_azimuth_deg'] = true_azimuth_deg(azimuth.defined_azimuth_deg,
                                                      declination_deg)
    if with_qc:
        qc = azimuth.qc
        values.update(b_total_delta_nT=qc.b_total_delta_nT, dip_delta_deg=qc.dip_delta_deg,
                      g_total_delta_mps2=qc.g_total_delta, qc_b_total=qc.b_total_ok,
                      qc_dip=qc.dip_ok, qc_g_total=qc.g_total_ok, qc_ok=qc.ok)
    return {name: (accepted, value) for name, value in values.items()}


def outside_fit(model, temperature_c):
    """Return which rows lie outside the fitted range of a temperature stage (None: none)."""
    if temperature_c is None:
        return None
    outside = np.zeros(temperature_c.shape, dtype=bool)
    for stage in (model.temperature, model.magnetometer_temperature):
        if stage is not None:
            outside |= ~in_range(temperature_c, stage)
    return outside


def row_status(codes, outside=None):
    """
    Return each row's status: ``ok``, the drop reason (``screening.REASONS``) or OUTSIDE_FIT.

    ``outside``: rows whose temperature lies outside the calibration's fitted
    range (``outside_fit``): an accepted one is OUTSIDE_FIT (the compensation
    holds the range's edge there).
    """
    status = ['ok' if code == ACCEPTED else REASONS[code] for code in codes]
    if outside is not None and outside.any():
        status = [OUTSIDE_FIT if far and text == 'ok' else text
                  for text, far in zip(status, outside)]
    return status


def survey_table(header, rows, codes, columns, outside=None):
    """
    Return (the CSV columns, the input columns renamed) of a survey (``inclino survey``).

    The input rows (``header``, ``rows``: text cells) first, an input column
    named as an output one kept as ``input_<name>``; then the output
    ``columns`` (``survey_columns``: NaN in the rows not accepted) and each
    row's status (``row_status`` with ``outside``).
    """
    names = list(columns) + ['status']
    renamed = [f'input_{name}' if name in names else name for name in header]
    full = {}
    for name, (accepted, values) in columns.items():
        column = np.full(len(rows), math.nan, dtype=object)
        column[accepted] = list(values)
        full[name] = column
    table = ([(name, [row[k] for row in rows]) for k, name in enumerate(renamed)]
             + [(name, full[name]) for name in columns]
             + [('status', row_status(codes, outside))])
    return table, [name for name, new in zip(header, renamed) if name != new]


def replay_settings(model, path, range_option, **settings):
    """
    Return the pipeline Settings a recording is corrected with by ``model`` (the file ``path``).

    ``settings``: those of ``pipeline.Settings`` (``accelerometer_axes``
    None: the model's).  ValueError (CalibrationFileError for the maps) when
    they disagree with the model: another number of axes
    (``store.axes_refusal``), a model implausible for the sensor's range
    (``plausibility.check_for_sensor``; ``range_option`` names what sets the
    range), readings turned by other axes maps than it was fitted in
    (``store.check_axes_maps``).
    """
    settings['accelerometer_axes'] = settings['accelerometer_axes'] or model.accelerometer_axes
    reason = axes_refusal(model, settings['accelerometer_axes'], path)
    if reason is not None:
        raise ValueError(reason)
    try:
        check_for_sensor(model, settings['accelerometer_range_mps2'])
    except Implausible as err:
        raise ValueError(f'{path}: {err} ({range_option})') from None
    settings = Settings(**settings)
    check_axes_maps(model, (settings.accelerometer_axes_map, settings.magnetometer_axes_map),
                    path)
    return settings


def recorded_magnetometer(path, topic, max_pairing_s, reference, noise_std_nT,
                          azimuth_max_std_deg, bias_instability_nT=0.0):
    """
    Return the Magnetometer of the MagneticField ``topic`` of the bag ``path``.

    ``reference``: (total_nT, dip_deg, declination_deg or None) each azimuth
    is checked against (ValueError without total and dip: no azimuth is
    written unchecked); BagError unless the topic holds MagneticField
    messages.  ``noise_std_nT``, ``azimuth_max_std_deg``, ``bias_instability_nT``:
    those of ``MagneticSettings``.
    """
    total_nT, dip_deg, declination_deg = reference
    if total_nT is None or dip_deg is None:
        raise ValueError('--mag-topic needs the reference field to check each azimuth '
                         'against: --reference-total-nT and --reference-dip-deg, or --site '
                         '(the calibration holds no multi-station analysis to take it from)')
    msgtype, count = topic_info(path, topic)
    if msgtype != MAGNETIC_FIELD or count == 0:
        raise BagError(f'{topic} in {path} holds {count} {msgtype} messages, not '
                       f'{MAGNETIC_FIELD} ones')
    settings = MagneticSettings(reference_total_nT=total_nT, reference_dip_deg=dip_deg,
                                declination_deg=declination_deg or 0.0, noise_std_nT=noise_std_nT,
                                azimuth_max_std_deg=azimuth_max_std_deg,
                                bias_instability_nT=bias_instability_nT)
    return Magnetometer.from_series(concatenate(read(path, topic)), max_pairing_s, settings)


def replay_recording(in_path, topic, out, model, settings, chunk_size, summary, temperature=None,
                     magnetometer=None, averager=None, imu=None, progress=None):
    """
    Correct ``topic`` of the bag ``in_path`` into the open BagWriter ``out`` (``replay``).

    Writes SURVEY_TOPIC and IMU_TOPIC, and the toolface zero of ``model`` in the
    bag's metadata (TOOLFACE_ZERO_KEYS).  ``temperature`` (a TemperatureSeries
    or None) gives each sample its temperature, ``magnetometer`` (a
    Magnetometer or None) its field; with an ``averager``
    (``core.averaging.Averager``) the windows it closes are written instead
    of the samples.  ``imu``: the ImuSeries of a CSV log, read instead of
    ``topic`` of the bag.  Counts in ``summary`` (a Summary), returned.
    """
    out.add_topic(SURVEY_TOPIC, VECTOR3_STAMPED)
    out.add_topic(IMU_TOPIC, IMU)
    for key, value in zip(TOOLFACE_ZERO_KEYS, (model.toolface_zero, model.toolface_zero_meaning)):
        out.set_custom_data(key, value)
    batches = (read(in_path, topic, chunk_size) if imu is None else
               (ImuSeries(*(getattr(imu, f.name)[start:start + chunk_size] for f in fields(imu)))
                for start in range(0, imu.stamps_ns.size, chunk_size)))
    replay(batches, partial(_write_recorded, out), model, settings, summary, temperature,
           magnetometer, averager, progress)
    if averager is not None:
        summary.averaged, summary.samples_not_averaged = True, averager.pending
    return summary


def _write_recorded(out, published):
    """Write one Outputs (``outputs``) to SURVEY_TOPIC and IMU_TOPIC of the BagWriter ``out``."""
    out.write_series({SURVEY_TOPIC: published.survey, IMU_TOPIC: published.imu})
