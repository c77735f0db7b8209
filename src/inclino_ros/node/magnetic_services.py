"""
The node's magnetometer services (seed 002): rotation fit, survey stations, MSA.

- ``~/capture_rotation``: records ``rotation.duration_s`` of magnetometer
  samples while the tool turns about its axis, fits the cross-axial ellipse
  (§2.1), persists and applies W and c; the MSA interference is reset, as it
  was solved on the old cross-axial correction.
- ``~/take_survey``: averages a still station (``survey.samples``; refused when
  the tool moves or the mean misses ``survey.max_sem_deg``), appends it
  to the persisted station list, answers inclination, azimuth and QC.
- ``~/solve_msa``: multi-station analysis of the stations against the
  reference field (§2.2, ``msa.method``), persists and applies the
  interference and its 1 sigma (the fit and the reference field's own,
  ``magnetic.reference_*_std_*``); ``improved`` takes the cross-axial part
  from the rotation fit, else from the classic solve, else refuses
  (``msa.improved_cross_axial``), as ``inclino msa`` does.
- ``~/clear_surveys``: empties the station list.
"""

from inclino_ros.calibration.model import NO_MAGNETIC_CORRECTION, utc_now_iso
from inclino_ros.calibration.plausibility import check_field_readings, Implausible
from inclino_ros.calibration.rotation import solve_rotation
from inclino_ros.calibration.stations import (
    msa_inputs, save_stations, solve_interference, Station, with_interference)
from inclino_ros.calibration.still_capture import (
    CaptureRefused, require_axis_still, require_still_vectors)
from inclino_ros.core.cross_axial import RotationFitRefused
from inclino_ros.core.msa import azimuth_difference_deg, MsaRefused
from inclino_ros.pipeline import capture_mean
import numpy as np
from rclpy.callback_groups import ReentrantCallbackGroup


#: The services that change the calibration (refused in field mode: ``capture.change_refusal``).
CHANGING = ('capture_rotation', 'solve_msa')


class MagneticServices:
    """~/capture_rotation, ~/take_survey, ~/solve_msa, ~/clear_surveys."""

    def __init__(self, node, collector, stations):
        """Create the services on ``node``, capturing with ``collector``; ``stations`` loaded."""
        self.node = node
        self.collector = collector
        self.stations = stations
        group = ReentrantCallbackGroup()
        for name, callback in (('capture_rotation', self.capture_rotation),
                               ('take_survey', self.take_survey),
                               ('solve_msa', self.solve_msa),
                               ('clear_surveys', self.clear_surveys)):
            collector.create_service(name, callback, group, changes=name in CHANGING)

    def _stage(self):
        return self.node.model.magnetic or NO_MAGNETIC_CORRECTION

    async def capture_rotation(self, request, response):
        """Fit the cross-axial ellipse of a rotation capture (seed 002 §2.1) and apply it."""
        node = self.node
        try:
            captured = await self.collector.collect(
                'rotation', duration_s=node.param('rotation.duration_s'))
            require_axis_still(node.model.apply(captured.raw, captured.temperatures_c),
                               captured.times_s, node.calibration.still_limits('survey'))
            solution = solve_rotation(node.model, captured.field_nT, captured.temperatures_c)
            fit = solution.fit
            self.collector.commit(solution.model)
        except (CaptureRefused, RotationFitRefused, Implausible) as err:
            return self.collector.refuse(response, str(err))
        return self.collector.answer(response, (
            f'rotation fit of {fit.sample_count} samples: hard iron '
            f'({fit.offset_nT[0]:.1f}, {fit.offset_nT[1]:.1f}) nT, axis ratio '
            f'{fit.axis_ratio:.4f}, RMSE {fit.rmse_nT:.1f} nT, coverage {fit.coverage_deg:.0f} '
            'deg; MSA interference reset (solve again with ~/solve_msa)'))

    async def take_survey(self, request, response):
        """Average a still station, store it, and answer its inclination, azimuth and QC."""
        node = self.node
        kept = f'{len(self.stations)} stations kept'
        try:
            captured = await self.collector.collect('survey')
        except CaptureRefused as err:
            return self.collector.refuse(response, str(err), kept)
        paired = np.isfinite(captured.field_nT).all(axis=1)
        if paired.sum() < 2:
            return self.collector.refuse(
                response, f'only {paired.sum()} of {paired.size} samples had a paired imu/mag '
                'reading', kept)
        field_nT = captured.field_nT[paired].mean(axis=0)
        try:
            check_field_readings(field_nT[None], "the station's field")
        except Implausible as err:
            return self.collector.refuse(response, err.reason, kept)
        try:
            require_still_vectors(captured.raw[paired], captured.times_s[paired],
                                  node.calibration.still_limits('survey'))
        except CaptureRefused as err:
            return self.collector.refuse(response, str(err), kept)
        temperatures_c = (None if captured.temperatures_c is None
                          else captured.temperatures_c[paired].mean())
        # The station's 1 sigma from its own noise (correlated noise too, issue 19 item 4).
        survey = capture_mean(captured.raw[paired], captured.times_s[paired], node.model,
                              node.settings, temperatures_c, captured.field_nT[paired],
                              node.magnetic_settings)
        if not survey.accepted.all():
            return self.collector.refuse(response, 'the averaged station is not a valid '
                                         'reading', kept)
        station = Station(
            # In the frame of the field: before the toolface mark (seed 002 comes first).
            specific_force_mps2=tuple(node.model.before_mark(survey.corrected_mps2)[0].tolist()),
            field_nT=tuple(field_nT.tolist()),
            samples=int(paired.sum()), captured_at=utc_now_iso(),
            temperature_c=captured.temperature_c)
        try:
            save_stations(node.stations_file, self.stations + [station])
        except OSError as err:
            return self.collector.refuse(response, f'cannot write {node.stations_file}: {err}',
                                         kept)
        self.stations.append(station)
        magnetic = survey.magnetic
        qc = 'not checked (no reference field)' if magnetic.qc is None else (
            f'B-total {magnetic.qc.b_total_delta_nT[0]:+.0f} nT, dip '
            f'{magnetic.qc.dip_delta_deg[0]:+.3f} deg off the reference: '
            f'{"pass" if magnetic.qc.ok[0] else "FAIL"}')
        return self.collector.answer(response, (
            f'station {len(self.stations)} from {station.samples} samples: inclination_deg='
            f'{survey.inclination_deg[0]:.3f} azimuth_deg={magnetic.azimuth_deg[0]:.3f} '
            f'(1 sigma {magnetic.azimuth_std_deg[0]:.3f}) '
            f'b_total_nT={magnetic.b_total_nT[0]:.0f} dip_deg={magnetic.dip_deg[0]:.3f}; '
            f'QC {qc}; stored in {node.stations_file}'), saved=False)

    def solve_msa(self, request, response):
        """Solve the multi-station analysis (seed 002 §2.2), persist and apply it."""
        node = self.node
        settings = node.magnetic_settings
        method = node.param('msa.method')
        if settings.reference_total_nT <= 0:
            return self.collector.refuse(response, 'MSA needs the reference field: set '
                                         'magnetic.reference_total_nT and reference_dip_deg')
        gravity, field = msa_inputs(self.stations, node.model)
        reference = (settings.reference_total_nT, settings.reference_dip_deg)
        reference_std = (node.param('magnetic.reference_total_std_nT'),
                         node.param('magnetic.reference_dip_std_deg'))
        try:
            result, source = solve_interference(
                method, gravity, field, reference, reference_std,
                rotation_fitted_at=self._stage().rotation_fitted_at,
                azimuth_max_std_deg=settings.azimuth_max_std_deg)
            source = '' if source is None else f'; {source}'
            self.collector.commit(with_interference(node.model, result, reference))
        except (MsaRefused, CaptureRefused) as err:
            return self.collector.refuse(response, str(err))
        change = np.abs(azimuth_difference_deg(result.azimuth_deg, result.azimuth_raw_deg))
        eps = ', '.join(f'{v:.1f} +- {s:.1f}' for v, s in zip(result.eps_nT, result.eps_std_nT))
        return self.collector.answer(response, (
            f'{method} MSA of {len(self.stations)} stations: interference (x, y, z) = '
            f'({eps}) nT (ISCWSA axes; 1 sigma from the fit and the reference field, '
            f'{reference_std[0]:g} nT and {reference_std[1]:g} deg){source}; station azimuth '
            f'1 sigma up to {np.nanmax(result.azimuth_std_deg):.3f} deg; V '
            f'{result.v_before_nT2:.3g} -> {result.v_after_nT2:.3g} nT^2, azimuths moved by up '
            f'to {np.nanmax(change):.3f} deg'))

    def clear_surveys(self, request, response):
        """Forget the stations (and empty their file)."""
        count = len(self.stations)
        try:
            save_stations(self.node.stations_file, [])
        except OSError as err:
            return self.collector.refuse(
                response, f'cannot write {self.node.stations_file}: {err}',
                f'{count} stations kept')
        self.stations.clear()
        return self.collector.answer(response, f'cleared {count} stations', saved=False)
