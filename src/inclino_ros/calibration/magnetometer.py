"""
The magnetometer's own stages, from a stand (seed 001 Eq. 12) or from shots (no reference).

Both write the same two stages of the model: ``magnetometer`` (K_m, b_m:
the triad alone) and ``magnetometer_alignment`` (R: its axes turned into the
accelerometer's sensing axes).  The model applies R and then the turn of the
accelerometer's own correction (``Stand.rotation``), so R is stored free of
it: ``R = Stand.rotation^T R_found`` for the R_found a fit finds into the
accelerometer frame.  The shared mount (``installation``, ``tool_axis``)
comes after, for both triads.
"""

from dataclasses import dataclass, replace
import math

from inclino_ros.calibration.invalidation import replace_stages
from inclino_ros.calibration.model import (
    Magnetometer, MagnetometerAlignment, readings_temperature_c, Stand, ToolAxis, utc_now_iso)
from inclino_ros.calibration.stages import MagnetometerNonlinear
from inclino_ros.calibration.stand_fit import (
    group_positions, position_noise_deg, position_stood_c, stood_for_c, temperature_plateaus)
from inclino_ros.core.attitude import angle_between
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.core.installation import installation_matrix, to_tool_frame
from inclino_ros.core.magnetics import expected_field_tool_nT
from inclino_ros.core.nonlinear import fit_correction, gate
from inclino_ros.core.shots import find_roll_groups, fit_shots, ShotLimits, tilt_angles
from inclino_ros.core.stand import (
    fit_stand, plateau_numbers, plateau_stand_fit, rotation_part, StandFitRefused)
import numpy as np


def _matrix(array):
    """Return a square array as nested tuples (a stage field)."""
    return tuple(map(tuple, np.asarray(array, dtype=float).tolist()))


def split_correction(correction, accelerometer_rotation):
    """
    Return (K_m symmetric, R) with ``accelerometer_rotation R K_m^-1 = correction``.

    ``correction`` maps magnetometer readings (bias removed) into the
    accelerometer frame; its polar decomposition ``U S`` gives the triad's
    own symmetric part S = K_m^-1 and the turn U, stored without the
    accelerometer's own turn: ``R = accelerometer_rotation^T U``.
    """
    turn = rotation_part(correction)
    own = turn.T @ correction
    return np.linalg.inv(0.5 * (own + own.T)), accelerometer_rotation.T @ turn


def stored_coefficient_covariance(covariance, turn):
    """
    Return the covariance of K_m(T), b_m(T)'s coefficients as stored, from the fit's.

    ``covariance``: of the fitted K(T), b(T)'s coefficients, power by power
    (``stand.coefficient_covariance``); the stage stores each K term times
    the constant ``turn`` (``fit_field_stand``): row-major,
    ``vec(X turn) = (I kron turn^T) vec(X)``, b unchanged.
    """
    block = np.eye(12)
    block[:9, :9] = np.kron(np.eye(3), turn.T)
    change = np.kron(np.eye(np.shape(covariance)[0] // 12), block)
    return change @ covariance @ change.T


def accelerometer_rotation(stand):
    """Return the turn of the accelerometer's own correction (identity without a stand stage)."""
    return np.eye(3) if stand is None else stand.rotation


@dataclass(frozen=True)
class FieldStandFit:
    """Seed 001 Eq. 12 fitted to stand positions: the two stages and the residual per position."""

    magnetometer: Magnetometer
    alignment: MagnetometerAlignment
    residual_deg: np.ndarray   # (P,) angle between the corrected and the expected field
    rms_residual_deg: float
    plateaus: object = None    # core.stand.TemperatureStandFit of a multi-temperature stand
    plateau_rms_deg: np.ndarray = None  # (plateaus,) RMS of residual_deg per plateau


def fit_field_stand(fields_nT, attitudes_deg, reference_total_nT, reference_dip_deg, stand,
                    max_rms_deg, temperatures_c=None):
    """
    Return the FieldStandFit of the magnetometer at stand positions, or raise StandFitRefused.

    ``fields_nT`` (P, 3): mean raw readings per position; ``attitudes_deg``
    (P, 3): inclination, seed-000 toolface and magnetic azimuth of each; the
    truth is the reference field seen from the tool
    (``magnetics.expected_field_tool_nT``) and the fit ``stand.fit_stand``,
    the accelerometer's (Eq. 12 is Eq. 10 against another truth), with its
    refusals.  ``stand`` is the accelerometer's new stand stage: the fitted
    K_m maps the readings into the tool frame, which is its frame.  Refused
    too when the RMS angle between corrected and expected fields over the
    positions exceeds ``max_rms_deg``.  ``temperatures_c`` (P,): what each
    position's readings stood for (``provenance.readings_temperature_c``;
    None or None entries: unknown), their mean recorded by both stages.

    Positions at two or more temperature plateaus (``stand_fit.temperature_plateaus``,
    the accelerometer's rule) give K_m(T), b_m(T) (``stand.fit_stand_plateaus``): the
    stage's polynomials are those of the fit times the constant turn the
    alignment takes out at the plateaus' centre, so that the chain
    (``Stand.rotation`` R K_m(T)^-1) is the fitted correction at every T.
    """
    fields_nT = np.asarray(fields_nT, dtype=float).reshape(-1, 3)
    attitudes_deg = np.asarray(attitudes_deg, dtype=float).reshape(-1, 3)
    truth = expected_field_tool_nT(attitudes_deg[:, 0], attitudes_deg[:, 1],
                                   attitudes_deg[:, 2], reference_total_nT, reference_dip_deg)
    try:
        plateaus = temperature_plateaus(fields_nT, truth, temperatures_c)
        if plateaus is None:
            fit = fit_stand(fields_nT, truth)
            corrected = fit.apply(fields_nT)
        else:
            fit = plateau_stand_fit(plateaus, fields_nT, truth, temperatures_c)
            corrected = plateaus.apply(fields_nT, np.asarray(temperatures_c, dtype=float))
    except StandFitRefused as err:
        raise StandFitRefused(f'magnetometer: {err.reason}') from None
    residual_deg = np.degrees(angle_between(corrected, truth))
    rms_deg = float(np.sqrt(np.mean(residual_deg ** 2)))
    if rms_deg > max_rms_deg:
        worst = int(np.argmax(residual_deg))
        raise StandFitRefused(
            f'the magnetometer fit does not reproduce its positions: the corrected field is '
            f'{rms_deg:.4f} deg RMS from the expected one (limit {max_rms_deg} deg; worst: '
            f'position {worst + 1}, {residual_deg[worst]:.4f} deg): a wrong azimuth, a wrong '
            'reference field, or iron near the stand')
    k_m, rotation = split_correction(np.linalg.inv(fit.scale_matrix),
                                     accelerometer_rotation(stand))
    now = utc_now_iso()
    rms_nT = float(np.sqrt(np.mean(np.sum((corrected - truth) ** 2, axis=1))))
    polynomial, plateau_rms_deg = {}, None
    # The fit's own error: one temperature, the stand fit's covariance; K_m(T), that of its
    # coefficients as stored (``stored_coefficient_covariance``).
    covariance = ({} if fit.parameter_covariance is None else
                  {'parameter_covariance': _matrix(fit.parameter_covariance),
                   'covariance_stages': ('magnetometer',)})
    temperature_c = stood_for_c(temperatures_c)
    if plateaus is not None:
        turn = accelerometer_rotation(stand) @ rotation
        scale = plateaus.scale_coefficients @ turn
        scale[0] = k_m
        covariance = {'parameter_covariance': _matrix(stored_coefficient_covariance(
            plateaus.parameter_covariance, turn)), 'covariance_stages': ('magnetometer',)}
        polynomial = {'scale_coefficients': tuple(map(_matrix, scale)),
                      'bias_coefficients_nT': tuple(map(tuple, plateaus.bias_coefficients
                                                        .tolist())),
                      't_min_c': plateaus.range_c[0], 't_max_c': plateaus.range_c[1]}
        temperature_c = plateaus.centre_c
        number = plateau_numbers(temperatures_c)
        plateau_rms_deg = np.sqrt(np.bincount(number, weights=residual_deg ** 2)
                                  / np.bincount(number))
    return FieldStandFit(
        magnetometer=Magnetometer(
            scale_matrix=_matrix(k_m), bias_nT=tuple(fit.bias_mps2.tolist()), method='stand',
            condition_number=float(fit.condition_number), rms_residual_nT=rms_nT,
            field_nT=float(reference_total_nT), positions=int(fields_nT.shape[0]),
            fitted_at=now, temperature_c=temperature_c,
            **covariance, **polynomial),
        alignment=MagnetometerAlignment(
            rotation=_matrix(rotation), method='stand', dip_deg=None, dip_rms_deg=None,
            shots=int(fields_nT.shape[0]), fitted_at=now, temperature_c=temperature_c),
        residual_deg=residual_deg, rms_residual_deg=rms_deg, plateaus=plateaus,
        plateau_rms_deg=plateau_rms_deg)


def fit_field_positions(existing, fields_nT, attitude_deg, times_s, temperature_c, stand,
                        reference, max_rms_deg, still):
    """
    Return (FieldStandFit, positions) of a stand's magnetometer samples (``fit_field_stand``).

    ``fields_nT`` (N, 3) with ``attitude_deg``, ``times_s`` and
    ``temperature_c`` (None: unknown) per sample; samples without a paired
    reading (NaN) are left out, the others go through ``existing``'s
    magnetometer stages before ``magnetometer`` and are grouped by attitude
    as the accelerometer's (``stand_fit.group_positions``); each position's
    noise is judged by the ``still`` limits (``position_noise_deg``:
    CaptureRefused) and stood for ``position_stood_c``.  ``reference``:
    (total_nT, dip_deg).  StandFitRefused as ``fit_field_stand`` refuses.
    """
    paired = np.isfinite(fields_nT).all(axis=1)
    temperature_c = None if temperature_c is None else temperature_c[paired]
    fields_nT = existing.apply_magnetic(fields_nT[paired], temperature_c, before='magnetometer')
    times_s = None if times_s is None else times_s[paired]
    positions, means, counts, position = group_positions(fields_nT, attitude_deg[paired], times_s)
    stood_c = position_stood_c(existing.magnetometer_temperature, temperature_c, position,
                               counts)
    position_noise_deg(fields_nT, times_s, position, len(means), still, ' (magnetometer)')
    return fit_field_stand(means, positions, *reference, stand, max_rms_deg, stood_c), len(means)


def mean_temperature_c(temperature_c):
    """Return the mean of the finite temperatures [deg C] given, None when there is none."""
    if temperature_c is None:
        return None
    finite = np.asarray(temperature_c, dtype=float)
    finite = finite[np.isfinite(finite)]
    return float(finite.mean()) if finite.size else None


#: What a shot calibration says when nothing measured the mount (issue 18).
MOUNT_WARNING = (
    'WARNING: the mount is NOT calibrated: no roll groups and no installation (level-bench) '
    'stage; the tool axis is taken as the accelerometer z sensing axis, and a mount tilt of '
    '1 deg gives up to 1.2 deg inclination and several deg azimuth error that no sigma '
    'shows: give roll groups (roll_group column) or run inclino fit-level')


def installation_in_new_frame(installation, accel_matrix, accel_bias_mps2):
    """
    Return ``installation`` in the frame of a new accelerometer correction ``K^-1 (a - b)``.

    The installation is the level-bench reading of a vertical tool (seed 000
    Eqs. 11-14), taken with the previous correction (none: the raw triad):
    ``v = |v| C e_z``.  Corrected by the new stage it reads ``K^-1 (v - b)``,
    whose direction is the tool axis in the new frame: its gamma, beta.
    """
    reading = installation.g_total_mps2 * installation_matrix(
        math.radians(installation.gamma_deg), math.radians(installation.beta_deg))[:, 2]
    corrected = np.linalg.solve(accel_matrix, reading - np.asarray(accel_bias_mps2))
    gamma, beta = (math.degrees(float(v)) for v in
                   tilt_angles(corrected / np.linalg.norm(corrected)))
    return replace(installation, gamma_deg=gamma, beta_deg=beta,
                   g_total_mps2=float(np.linalg.norm(corrected)))


@dataclass(frozen=True)
class ShotCalibration:
    """
    A reference-free calibration: the new model, the fit, and what changed (text lines).

    ``roll_group``: the labels the fit used (given, or found; None: none).
    ``gate``: the held-out verdict on the non-linear stage (``core.nonlinear.Gate``;
    None: not judged, ``nonlinear='off'``).
    """

    model: object
    fit: object
    notes: tuple
    roll_group: object = None
    gate: object = None


#: What ``calibrate_from_shots`` does with the non-linear stage: ``auto`` (fitted from the
#: roll sets and kept when the held-out gate says it helps), ``off``, ``on`` (kept whatever
#: the gate says, when there is at least one roll set).
NONLINEAR_CHOICES = ('auto', 'off', 'on')


def nonlinear_stage(model, accel_mps2, field_nT, roll_sets, temperature_c, choice, fitted_at,
                    temperature_of_fields_c):
    """
    Return (MagnetometerNonlinear or None, Gate or None, note) of ``model``'s roll sets.

    The roll sets' corrected gravity and tool-frame fields (``model`` up to
    the stage) are judged by ``core.nonlinear.gate`` (each set held out in
    turn); the stage is fitted on all of them when the gate enables it (or
    ``choice`` is ``on``).
    """
    if choice == 'off':
        return None, None, 'non-linear stage: off (--non-linear off)'
    gravity = model.apply(accel_mps2, temperature_c)
    fields = model.apply_magnetic(field_nT, temperature_c, before='magnetometer_nonlinear')
    verdict = gate(gravity, fields, roll_sets)
    keep = verdict.enabled or (choice == 'on' and len(roll_sets) >= 1)
    if not keep:
        return None, verdict, f'non-linear stage: OFF (linear kept): {verdict.reason}'
    correction = fit_correction(gravity, fields, roll_sets, verdict.centres, verdict.ridge)
    stage = MagnetometerNonlinear(
        weights=_matrix(correction.weights), scale_nT=correction.scale_nT,
        rms_residual_nT=correction.rms_residual_nT, roll_sets=len(roll_sets),
        shots=int(sum(len(s) for s in roll_sets)),
        **{f'held_out_{key}_deg': value if math.isfinite(value) else None for key, value in (
            ('before', verdict.before_deg), ('after', verdict.after_deg),
            ('noise', verdict.noise_deg))}, fitted_at=fitted_at,
        parameter_covariance=_matrix(correction.covariance),
        temperature_c=temperature_of_fields_c)
    forced = '' if verdict.enabled else ' (forced: --non-linear on)'
    return stage, verdict, f'non-linear stage: ON{forced}: {verdict.reason}'


def calibrate_from_shots(existing, accel_mps2, field_nT, roll_group=None, temperature_c=None,
                         gravity_mps2=STANDARD_GRAVITY_MPS2, reference_total_nT=None,
                         limits=ShotLimits(), nonlinear='auto'):
    """
    Return the ShotCalibration of shots (``core.shots.fit_shots``) on top of ``existing``.

    The accelerometer is fitted too unless ``existing`` has a stand stage (then
    its readings are corrected by it and its frame kept, with the
    installation).  With roll groups the tool axis is measured (after the
    installation stage) and becomes the ``tool_axis`` stage; a new
    accelerometer frame then drops the installation.  Without roll groups an
    installation is kept, carried into a new accelerometer frame
    (``installation_in_new_frame``), and a model with no mount stage at all
    gets MOUNT_WARNING in its notes.  Every other stage is kept, but a high-side mark
    captured through a stand or mount this fit replaces (``invalidation.replace_stages``,
    noted).  Raises
    ShotFitRefused with the reason.  Without ``roll_group`` the roll sets among
    shots taken in order are found (``core.shots.find_roll_groups``) and the
    fit repeated with them.  Then the non-linear stage (``nonlinear_stage``,
    ``nonlinear`` one of NONLINEAR_CHOICES) from the roll sets' shots the fit
    used; a non-linear stage of ``existing`` is replaced (or dropped).
    """
    fit_accel = existing.stand is None
    accel = existing.apply(accel_mps2, temperature_c,
                           before='stand' if fit_accel else 'installation')
    field = existing.apply_magnetic(field_nT, temperature_c, before='magnetometer')
    # What each triad's readings stood for: every new stage records it.
    measured_c = mean_temperature_c(temperature_c)
    accel_c = readings_temperature_c(existing.temperature, measured_c)
    field_c = readings_temperature_c(existing.magnetometer_temperature, measured_c)
    fit = fit_shots(accel, field, roll_group, gravity_mps2, reference_total_nT, fit_accel, limits)
    notes = []
    if roll_group is None:   # a bag, or a file without the column: roll sets in the shots?
        found = find_roll_groups(fit.accel_corrected_mps2, fit.field_corrected_nT, limits)
        if found.max(initial=-1) >= 0:
            fit = fit_shots(accel, field, found, gravity_mps2, reference_total_nT, fit_accel,
                            limits)
            roll_group = found
            notes.append(f'{found.max() + 1} roll group(s) found in the order of the shots '
                         '(consecutive shots pointing within '
                         f'{limits.max_pointing_deg:g} deg, turned about that axis): '
                         + ', '.join(f'shots {np.flatnonzero(found == k)[0] + 1}-'
                                     f'{np.flatnonzero(found == k)[-1] + 1}'
                                     for k in range(found.max() + 1)))
    now = utc_now_iso()
    stand = existing.stand
    installation = existing.installation
    if fit_accel:
        stand = Stand(scale_matrix=_matrix(fit.accel_matrix),
                      bias_mps2=tuple(fit.accel_bias_mps2.tolist()), method='sphere',
                      condition_number=float(fit.condition_number), rms_inclination_deg=None,
                      positions=int(fit.used.sum()), fitted_at=now, temperature_c=accel_c)
        notes.append('accelerometer fitted too (no stand stage in the file): stand stage, '
                     'method sphere')
        if installation is not None and fit.tool_axis is not None:
            installation = None
            notes.append("installation stage dropped: the roll groups' tool axis replaces it "
                         "(it was measured in the accelerometer's previous frame)")
        elif installation is not None:
            installation = installation_in_new_frame(installation, fit.accel_matrix,
                                                     fit.accel_bias_mps2)
            notes.append('installation stage kept (no roll groups to measure the mount): its '
                         "level-bench reading carried into the accelerometer's new frame, "
                         f'gamma_deg={installation.gamma_deg:.4f} '
                         f'beta_deg={installation.beta_deg:.4f}')
    else:
        notes.append("accelerometer stand stage of the file kept (its frame is the tool's)")
    tool_axis = existing.tool_axis
    covariance = np.array(fit.parameter_covariance)
    if fit.tool_axis is not None:
        def after_installation(angles):
            axis = installation_matrix(*angles)[:, 2]
            if installation is not None:
                axis = to_tool_frame(axis, installation.inverse_matrix)
            return np.array(tilt_angles(axis), dtype=float)
        fitted_angles = np.radians([fit.gamma_deg, fit.beta_deg])
        gamma, beta = np.degrees(after_installation(fitted_angles))
        # The covariance of the tool axis's angles as stored (after the installation).
        turn = np.eye(covariance.shape[0])
        turn[-2:, -2:] = np.column_stack([
            (after_installation(fitted_angles + h) - after_installation(fitted_angles - h))
            / 2e-6 for h in np.eye(2) * 1e-6])
        covariance = turn @ covariance @ turn.T
        in_groups = np.isin(np.asarray(roll_group), fit.groups) & fit.used
        tool_axis = ToolAxis(gamma_deg=float(gamma), beta_deg=float(beta),
                             roll_groups=len(fit.groups),
                             shots=int(np.sum(in_groups)),
                             axial_rms_deg=float(np.sqrt(np.mean(
                                 fit.axial_rms_deg[list(fit.groups)] ** 2))),
                             fitted_at=now, temperature_c=accel_c)
    elif fit_accel and tool_axis is not None:
        tool_axis = None
        notes.append("tool_axis stage dropped: it was measured in the accelerometer's "
                     'previous frame')
    k_m, rotation = split_correction(fit.alignment @ np.linalg.inv(fit.mag_matrix),
                                     accelerometer_rotation(stand))
    covered = (('stand',) if fit_accel else ()) + ('magnetometer',) + (
        ('tool_axis',) if fit.tool_axis is not None else ())
    magnetometer = Magnetometer(
        scale_matrix=_matrix(k_m), bias_nT=tuple(fit.mag_bias_nT.tolist()), method='ellipsoid',
        condition_number=float(fit.condition_number),
        rms_residual_nT=float(np.sqrt(np.mean((fit.b_total_nT[fit.used] - fit.field_nT) ** 2))),
        field_nT=float(fit.field_nT), positions=int(fit.used.sum()), fitted_at=now,
        temperature_c=field_c, parameter_covariance=_matrix(covariance),
        covariance_stages=covered)
    alignment = MagnetometerAlignment(
        rotation=_matrix(rotation), method='dip', dip_deg=float(fit.dip_deg),
        dip_rms_deg=float(fit.dip_rms_deg), shots=int(fit.used.sum()), fitted_at=now,
        temperature_c=field_c)
    if installation is None and tool_axis is None:
        notes.append(MOUNT_WARNING)
    if existing.magnetic is not None:
        notes.append('magnetic (seed 002) stage kept: it was fitted on the previous '
                     'magnetometer correction; fit the rotation and MSA again')
    model, dropped = replace_stages(existing, stand=stand, installation=installation,
                                    tool_axis=tool_axis, magnetometer=magnetometer,
                                    magnetometer_alignment=alignment, magnetometer_nonlinear=None)
    notes.extend(dropped)
    labels = np.asarray(-1 if roll_group is None else roll_group)
    roll_sets = [np.flatnonzero((labels == k) & fit.used) for k in fit.groups]
    stage, verdict, note = nonlinear_stage(model, accel_mps2, field_nT, roll_sets, temperature_c,
                                           nonlinear, now, field_c)
    notes.append(note)
    model = replace(model, magnetometer_nonlinear=stage)
    return ShotCalibration(model=model, fit=fit, notes=tuple(notes), roll_group=roll_group,
                           gate=verdict)
