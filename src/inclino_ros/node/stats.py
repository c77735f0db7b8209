"""Input health for /diagnostics: samples accepted, dropped and why, rate, G-total."""

from collections import deque

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from inclino_ros.calibration.model import (
    age_seconds, missing_temperature, MissingTemperature, MOUNT_STAGES)
from inclino_ros.calibration.plausibility import field_reading_ok, temperature_ok
from inclino_ros.core.screening import count_reasons, REASONS
from inclino_ros.core.stillness import noise_check
from inclino_ros.core.temperature import in_range
from inclino_ros.io.timing import pair_nearest, pairing_tolerance
import numpy as np


class InputStats:
    """Counts of the imu/data_raw stream, totals and per diagnostics period."""

    def __init__(self):
        """Start with nothing seen."""
        self.accepted_total = 0
        self.dropped_total = [0] * len(REASONS)
        self._period_accepted = 0
        self._period_dropped = 0
        self._period_reasons = [0] * len(REASONS)
        self._period_toolface_nan = 0
        self._period_g_sum = 0.0
        self._period_start_s = None
        self.windows = None   # averaged output: [moving, dropped] windows, not published
        self.noise_warnings = {}   # name: what noise_check said (kept: said once)

    def count(self, survey):
        """Count a batch (a ``pipeline.Survey``): accepted samples, G-totals, NaN toolfaces."""
        accepted = survey.g_total_mps2.size
        self.accepted_total += accepted
        self._period_accepted += accepted
        self._period_g_sum += float(survey.g_total_mps2.sum())
        self._period_toolface_nan += int(np.isnan(survey.toolface_deg).sum())
        if survey.codes.size == accepted:   # none dropped (the usual batch): nothing to add
            return
        for code, dropped in enumerate(count_reasons(survey.codes).values()):
            self.dropped_total[code] += dropped
            self._period_reasons[code] += dropped
            self._period_dropped += dropped

    def check_noise(self, measured, configured):
        """
        Return the new warnings of a measured noise beyond the configured (``noise_check``).

        ``measured``, ``configured``: (accelerometer [m/s^2], magnetometer [nT]);
        each warning is returned once (to be logged) and kept for the diagnostics.
        """
        new = []
        for value, floor, name, unit in zip(
                measured, configured, ('accelerometer_noise_std_mps2',
                                       'magnetometer_noise_std_nT'), ('m/s^2', 'nT')):
            text = noise_check(value, floor, name, unit)
            if text is not None and name not in self.noise_warnings:
                self.noise_warnings[name] = text
                new.append(text)
        return new

    def count_windows(self, moving, dropped):
        """Count averaged windows not published: of a moving tool, and not gravity."""
        self.windows = [a + b for a, b in zip(self.windows or (0, 0), (moving, dropped))]

    def status(self, node_name, now_s, gravity_mps2, g_tolerance_mps2, publishers):
        """
        Return the input DiagnosticStatus for the period ending now; reset it.

        ``publishers``: the publishers matched to imu/data_raw now (a silent input is
        told apart from no input at all: a driver not running, a topic not remapped).
        """
        elapsed = None if self._period_start_s is None else now_s - self._period_start_s
        rate_hz = self._period_accepted / elapsed if elapsed else 0.0
        g_mean = (self._period_g_sum / self._period_accepted
                  if self._period_accepted else float('nan'))
        status = DiagnosticStatus(name=f'{node_name}: input', level=DiagnosticStatus.OK)
        if self._period_dropped > self._period_accepted:
            main = max(range(len(REASONS)), key=self._period_reasons.__getitem__)
            status.level = DiagnosticStatus.ERROR
            status.message = (
                f'most samples dropped: {self._period_dropped} of '
                f'{self._period_dropped + self._period_accepted}, '
                f'{self._period_reasons[main]} as {REASONS[main]}'
                + (' (G-total off gravity: not gravity; does the driver remove it?)'
                   if REASONS[main] == 'dynamic' else ''))
        elif self._period_accepted == 0:
            status.level = DiagnosticStatus.WARN
            status.message = (f'no samples on imu/data_raw ({publishers} publishers matched'
                              + (': is the driver running, the topic remapped?)'
                                 if not publishers else ')'))
        elif self._period_dropped:
            status.level = DiagnosticStatus.WARN
            status.message = f'{self._period_dropped} samples dropped in the last period'
        elif abs(g_mean - gravity_mps2) > g_tolerance_mps2:
            status.level = DiagnosticStatus.WARN
            status.message = f'G-total {g_mean:.4f} m/s^2 is off gravity {gravity_mps2}'
        else:
            status.message = f'{rate_hz:.1f} samples/s'
        if self.noise_warnings:   # said on every status once measured (configuration)
            status.level = max(status.level, DiagnosticStatus.WARN)
            status.message = '; '.join([status.message, *self.noise_warnings.values()])
        values = {'rate_hz': f'{rate_hz:.2f}', 'g_total_mps2': f'{g_mean:.5f}',
                  'imu_publishers': str(publishers),
                  'accepted_total': str(self.accepted_total),
                  'dropped_total': str(sum(self.dropped_total)),
                  'toolface_nan': str(self._period_toolface_nan)}
        values.update({f'dropped_{reason}': str(n)
                       for reason, n in zip(REASONS, self.dropped_total)})
        if self.windows is not None:
            values.update(windows_moving=str(self.windows[0]),
                          windows_dropped=str(self.windows[1]))
        values.update({f'noise_check_{name}': text
                       for name, text in self.noise_warnings.items()})
        status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        self._period_accepted = self._period_dropped = self._period_toolface_nan = 0
        self._period_reasons = [0] * len(REASONS)
        self._period_g_sum = 0.0
        self._period_start_s = now_s
        return status


class TemperatureInput:
    """The latest imu/temperature reading and its health."""

    def __init__(self):
        """Start with no temperature."""
        self.value_c = None
        self.received_s = None
        self.rejected = 0
        self.withheld = 0      # outputs not published: refused without a temperature

    def missing(self, model, at_reference):
        """
        Return (refused, text) of the shared rule for the samples of now; (False, None): none.

        ``provenance.missing_temperature`` (the rule of ``inclino process`` and
        ``survey``) when no temperature has come and the model compensates
        one: refused (its reason), or with ``at_reference``
        (``temperature.at_reference``, their ``--at-reference-temperature``)
        the warning of a compensation at the reference temperature, every 1
        sigma widened by the drift over the fitted range.
        """
        if self.value_c is not None:
            return False, None
        try:
            return False, missing_temperature(
                model, 'the calibration', 'no temperature on imu/temperature', at_reference,
                option='temperature.at_reference:=true')
        except MissingTemperature as err:
            return True, f'refused: {err}: no output is published'

    def update(self, temperature_c, now_s):
        """Keep a temperature a sensor reads as the latest; count one it cannot (NaN, 1e300)."""
        if temperature_ok(temperature_c):
            self.value_c = float(temperature_c)
            self.received_s = now_s
        else:
            self.rejected += 1

    def status(self, node_name, now_s, max_age_s, stage, missing=(False, None)):
        """
        Return the temperature DiagnosticStatus.

        ``missing``: what ``missing`` says of a model with a temperature
        stage and no temperature yet: ERROR when refused, WARN when
        compensated at the reference temperature.  Otherwise with a
        temperature-dependent stage: WARN when no temperature has arrived
        (a stand's K(T) at its reference), when the latest is older than
        ``max_age_s`` (it is still used) or outside the fitted range (clamped
        to it).
        """
        status = DiagnosticStatus(name=f'{node_name}: temperature', level=DiagnosticStatus.OK)
        values = {'temperature_c': 'none' if self.value_c is None else f'{self.value_c:.2f}',
                  'rejected_implausible': str(self.rejected),
                  'withheld_no_temperature': str(self.withheld)}
        age_s = None if self.received_s is None else now_s - self.received_s
        if age_s is not None:
            values['age_s'] = f'{age_s:.1f}'
        refused, text = missing
        if stage is None:
            status.message = 'not used: the model has no temperature stage'
        elif text is not None:
            status.level = DiagnosticStatus.ERROR if refused else DiagnosticStatus.WARN
            status.message = text
        elif self.value_c is None:
            status.level = DiagnosticStatus.WARN
            status.message = (f'no temperature on imu/temperature: compensating at the '
                              f'reference {stage.reference_temperature_c:g} C')
        elif age_s > max_age_s:
            status.level = DiagnosticStatus.WARN
            status.message = (f'stale: the last temperature {self.value_c:.2f} C is '
                              f'{age_s:.1f} s old and still used')
        elif not in_range(self.value_c, stage):
            status.level = DiagnosticStatus.WARN
            status.message = (f'{self.value_c:.2f} C is outside the fitted range '
                              f'{stage.t_min_c:g} .. {stage.t_max_c:g} C: clamped to it')
        else:
            status.message = f'{self.value_c:.2f} C'
        status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        return status


#: When each magnetometer stage was made: (stage, field of its time).
STAGE_TIMES = (('magnetometer', 'fitted_at'), ('magnetometer_alignment', 'fitted_at'),
               ('installation', 'captured_at'), ('tool_axis', 'fitted_at'),
               ('magnetometer_nonlinear', 'fitted_at'), ('magnetic', 'rotation_fitted_at'),
               ('magnetic', 'msa_fitted_at'))


def magnetometer_stage_values(model, now=None):
    """Return diagnostics values of the magnetometer's stages: names, times and ages [s]."""
    names = [f'{name} (shared)' if name in MOUNT_STAGES else name
             for name in model.magnetometer_stages]
    values = {'magnetometer_stages': ', '.join(names) or 'none: raw readings'}
    for stage_name, field in STAGE_TIMES:
        stage = getattr(model, stage_name)
        moment = None if stage is None else getattr(stage, field)
        if moment is not None:
            key = f'{stage_name}_{field}' if stage_name == 'magnetic' else stage_name
            values[f'{key}'] = moment
            values[f'{key}_age_s'] = f'{age_seconds(moment, now):.0f}'
    if model.magnetometer is not None:
        values['magnetometer_method'] = model.magnetometer.method
    if model.magnetometer_alignment is not None:
        values['magnetometer_alignment_deg'] = f'{model.magnetometer_alignment.angle_deg:.4f}'
    return values


class MagneticInput:
    """Recent imu/mag readings, and how the azimuths of the last period fared."""

    def __init__(self, keep=256):
        """Start with no magnetometer; keep the latest ``keep`` readings for pairing."""
        self.recent = deque(maxlen=keep)
        self.rejected = 0
        self._period = {'trusted': 0, 'unpaired': 0, 'imprecise': 0, 'untrusted': 0}
        self._last = None

    @property
    def stamp_ns(self):
        """Return the stamp of the latest reading, None before the first."""
        return self.recent[-1][0] if self.recent else None

    def update(self, series):
        """
        Keep the readings of a MagneticFieldSeries (in nT) to pair with; count those refused.

        Refused: a non-finite one, and one beyond an Earth field plus
        interference (``plausibility.field_reading_ok``).
        """
        field_nT = series.field_nT
        ok = field_reading_ok(field_nT)
        self.recent.extend(zip(series.stamps_ns[ok].tolist(), map(tuple, field_nT[ok])))
        self.rejected += int(ok.size - np.count_nonzero(ok))

    def paired(self, stamps_ns, max_pairing_s, noise_std_nT):
        """Return (N, 3) fields [nT] paired with ``stamps_ns`` (NaN rows: none of its attitude)."""
        stamps, fields = zip(*self.recent)
        return pair_nearest(stamps_ns, stamps, fields, round(max_pairing_s * 1e9),
                            pairing_tolerance(noise_std_nT))[0]

    def count(self, azimuth_survey):
        """Count the azimuth outcomes of an AzimuthSurvey's rows (unpaired: a NaN field)."""
        trusted = azimuth_survey.trusted
        if trusted.size == 0:
            return
        paired = np.isfinite(azimuth_survey.uncorrected_nT).all(axis=1)
        imprecise = azimuth_survey.imprecise
        self._period['trusted'] += int(trusted.sum())
        self._period['unpaired'] += int((~trusted & ~paired).sum())
        self._period['imprecise'] += int((~trusted & paired & imprecise).sum())
        self._period['untrusted'] += int((~trusted & paired & ~imprecise).sum())
        self._last = (azimuth_survey, trusted.size - 1)

    def status(self, node_name, settings, model_stage, stations, model=None, now=None):
        """
        Return the magnetics DiagnosticStatus for the period; reset the period.

        With ``model``: the magnetometer's stages in the order applied
        (``magnetometer_stages``, the shared mount marked), each one's time and
        age in seconds, the alignment's angle.
        """
        status = DiagnosticStatus(name=f'{node_name}: magnetics', level=DiagnosticStatus.OK)
        values = {key: str(n) for key, n in self._period.items()}
        if model is not None:
            values.update(magnetometer_stage_values(model, now))
        values.update(rejected_implausible=str(self.rejected), stations_held=str(stations),
                      reference_total_nT=f'{settings.reference_total_nT:g}',
                      reference_dip_deg=f'{settings.reference_dip_deg:g}',
                      rotation_fitted_at=str(model_stage and model_stage.rotation_fitted_at),
                      msa_method=str(model_stage and model_stage.msa_method))
        if self._last is not None:
            last, row = self._last
            values.update(b_total_nT=f'{last.b_total_nT[row]:.0f}',
                          dip_deg=f'{last.dip_deg[row]:.3f}',
                          azimuth_std_deg=f'{last.azimuth_std_deg[row]:.3f}')
            if last.qc is not None:
                values.update(b_total_delta_nT=f'{last.qc.b_total_delta_nT[row]:+.0f}',
                              dip_delta_deg=f'{last.qc.dip_delta_deg[row]:+.3f}')
        if self.stamp_ns is None:
            status.message = 'no imu/mag: azimuth not computed (NaN)'
        elif self._period['unpaired'] or self._period['untrusted'] or self._period['imprecise']:
            status.level = DiagnosticStatus.WARN
            status.message = (f'{self._period["unpaired"]} samples without a paired imu/mag '
                              f'reading, {self._period["imprecise"]} with a 1 sigma above '
                              f'magnetic.azimuth_max_std_deg and {self._period["untrusted"]} '
                              'failing QC: their azimuth is NaN')
        elif settings.reference_total_nT <= 0:
            status.level = DiagnosticStatus.WARN
            status.message = 'no reference field: azimuth QC not checked'
        else:
            status.message = f'{self._period["trusted"]} trusted azimuths'
        status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        self._period = dict.fromkeys(self._period, 0)
        return status
