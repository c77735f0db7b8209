"""
Reference-free calibration of both triads from still shots in many orientations.

What a hand-held survey instrument does without a stand or a reference field
(shared/notes/real-sensors.md, "Magnetometers"), here as one weighted
least-squares fit of everything at once (``scipy.optimize.least_squares``):

1. the accelerometer ellipsoid ``|T_a (a - b_a)| = g``: seed 001 Eq. 10
   without a stand (``stand.fit_sphere``), T_a upper triangular; skipped when
   the caller already has a stand calibration (then ``a`` comes corrected);
2. the magnetometer ellipsoid ``|T_m (m - o)| = F``: hard iron o and full
   soft iron T_m (seed 001 Eq. 12 without a stand), T_m symmetric;
3. the rotation R of the magnetometer's axes into the accelerometer's, from
   the constancy of the dip: ``-(T_a (a - b_a)) . (R T_m (m - o)) / (g F)``
   is ``sin D`` in every shot (formulas.md, dip);
4. with roll groups (shots taken with the tool axis held in one direction
   and the tool turned about it), the tool axis u in the accelerometer frame:
   the components of gravity and field along u are the same for every shot
   of a group.  u is seed 000's installation without a level bench: the
   level-bench reading of a vertical tool, so ``u = C e_z`` and gamma, beta
   follow from seed 000 Eqs. 11-14 (``installation.installation_angles``).

Initial values come in closed form: the algebraic ellipsoid fits of
``stand.fit_sphere``, R from the linear system ``a_i^T X m_i = c`` (the
dip constraint is linear in X = R / scale), u from the smallest eigenvector
of the within-group scatter.  The joint fit then refines them together, each
residual divided by its noise (estimated from the data), so the roll groups
and the dip also inform the ellipsoids, which 24 shots need.

What the data can observe: F only up to a scale (normalised to the
reference, or to the magnetometer's own mean scale, det K_m = 1); the frame
of the accelerometer only up to a rotation (fixed by the convention: T_a
upper triangular, i.e. z along the z sensing axis); the rotation about the
tool axis not at all (a toolface offset).  The azimuth and inclination are
free of all three.  Vectors are (N, 3), accelerations in m/s^2, fields in nT.
"""

from dataclasses import dataclass
import math

from inclino_ros.core.attitude import angle_between, as_vectors
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.core.installation import (
    installation_angles, installation_matrix, level_axis_angles)
from inclino_ros.core.refusal import Refused
from inclino_ros.core.stand import fit_sphere, rotation_part, StandFitRefused
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

#: Upper-triangular (accelerometer) and symmetric (magnetometer) entries of a 3x3 matrix.
_UPPER = np.triu_indices(3)


class ShotFitRefused(Refused):
    """Shots that cannot give a trustworthy reference-free calibration, with the reason."""


@dataclass(frozen=True)
class ShotLimits:
    """
    Acceptance limits of a reference-free calibration.

    ``min_shots``: 21 unknowns without roll groups (9 + 9 + 3), each shot
    gives three equations (|g|, |B|, dip); 12 leave 15 to test the fit.
    ``min_turn_deg``: a triad whose readings all lie within this angle of
    their mean direction was not turned.  ``min_thickness``: the readings'
    directions must leave their best plane by this fraction of their spread
    (sqrt of the smallest over the largest eigenvalue of their scatter);
    below it they lie on one circle: the tool was turned about one axis only.
    ``max_b_rms_fraction``, ``max_g_rms_fraction``, ``max_dip_rms_deg``,
    ``max_axial_rms_deg``: what the fitted model may leave in |B|, |g|, the
    dip and the axial components of a roll group; beyond, the field was not
    constant (iron near some shots) or the sensor is not linear.  MEMS noise
    (2 mg, 100 nT per shot) leaves ~0.2 %, ~0.15 deg.  ``outlier_sigma``: a
    shot with a residual this many robust standard deviations out is named.
    ``min_group_shots``, ``min_roll_deg``: a roll group needs three shots
    spread over this arc about its axis.
    """

    min_shots: int = 12
    min_turn_deg: float = 15.0
    min_thickness: float = 0.1
    max_b_rms_fraction: float = 0.01
    max_g_rms_fraction: float = 0.01
    max_dip_rms_deg: float = 0.5
    max_axial_rms_deg: float = 0.5
    outlier_sigma: float = 6.0
    min_group_shots: int = 3
    min_roll_deg: float = 90.0


@dataclass(frozen=True)
class ShotFit:
    """
    A reference-free calibration and what it leaves in each shot.

    ``accel_matrix`` K_a and ``accel_bias_mps2`` (None when the accelerometer
    was given corrected) give ``K_a^-1 (a - b)`` (seed 001 Eq. 11);
    ``mag_matrix`` K_m (symmetric) and ``mag_bias_nT`` give ``K_m^-1 (m - o)``;
    ``alignment`` R turns that into the accelerometer frame.  ``tool_axis``
    (unit, accelerometer frame) with ``gamma_deg``, ``beta_deg`` is None
    without roll groups.  Per shot (N,): the corrected ``g_total_mps2``,
    ``b_total_nT``, ``dip_deg``; per group: ``axial_rms_deg``, ``roll_deg``.
    """

    accel_matrix: np.ndarray
    accel_bias_mps2: np.ndarray
    mag_matrix: np.ndarray
    mag_bias_nT: np.ndarray
    alignment: np.ndarray
    dip_deg: float
    field_nT: float
    tool_axis: np.ndarray
    gamma_deg: float
    beta_deg: float
    accel_corrected_mps2: np.ndarray
    field_corrected_nT: np.ndarray
    g_total_mps2: np.ndarray
    b_total_nT: np.ndarray
    dip_per_shot_deg: np.ndarray
    dip_rms_deg: float
    groups: tuple
    axial_rms_deg: np.ndarray
    roll_deg: np.ndarray
    condition_number: float
    noise_mps2: float
    noise_nT: float
    evaluations: int


def _directions_problem(vectors, name, limits):
    """Return why the directions of ``vectors`` cannot calibrate a triad, or None."""
    unit = vectors / np.linalg.norm(vectors, axis=1)[:, None]
    mean = unit.mean(axis=0)
    largest_deg = float(np.degrees(np.max(angle_between(unit, mean))))
    if largest_deg < limits.min_turn_deg:
        return (f'the {name} readings never change (all within {largest_deg:.2f} deg of their '
                f'mean, need {limits.min_turn_deg:g}): the tool was not turned between shots')
    eigenvalues = np.linalg.eigvalsh(np.cov(unit.T))
    thickness = math.sqrt(max(eigenvalues[0], 0.0) / eigenvalues[-1])
    if thickness < limits.min_thickness:
        return (f'all {name} readings lie in one plane (thickness {thickness:.3f} of their '
                f'spread, need {limits.min_thickness:g}): the tool was turned about one axis '
                'only; add shots with the tool axis pointing in other directions')
    return None


def check_shots(accel_mps2, field_nT, limits=ShotLimits(), fit_accel=True):
    """Raise ShotFitRefused when the shots cannot be fitted: count, NaN, spread."""
    count = accel_mps2.shape[0]
    if count < limits.min_shots:
        raise ShotFitRefused(f'only {count} shot(s), need at least {limits.min_shots} '
                             '(both ellipsoids and the rotation between the triads have 21 '
                             'unknowns, three equations a shot)')
    bad = np.flatnonzero(~(np.isfinite(accel_mps2).all(axis=1)
                           & np.isfinite(field_nT).all(axis=1)))
    if bad.size:
        raise ShotFitRefused(f'non-finite readings in shot(s) {(bad + 1).tolist()}')
    triads = (('magnetometer', field_nT),) + ((('accelerometer', accel_mps2),)
                                              if fit_accel else ())
    for name, vectors in triads:
        if np.any(np.linalg.norm(vectors, axis=1) == 0.0):
            raise ShotFitRefused(f'a zero {name} reading: a dead sensor')
        problem = _directions_problem(vectors, name, limits)
        if problem:
            raise ShotFitRefused(problem)


def _sphere(vectors, radius, name):
    """Return ``stand.fit_sphere`` of one triad; ShotFitRefused naming the triad."""
    try:
        return fit_sphere(vectors, radius)
    except StandFitRefused as err:
        raise ShotFitRefused(f'{name}: {err.reason}') from None


def _initial_rotation(accel, field):
    """
    Return (R, sin D) solving ``a_i^T X m_i = c`` (linear in X and c) for a rotation.

    The homogeneous system's null vector gives X = lambda R and c; the
    rotation part of X (sign chosen for a positive determinant) starts the
    joint fit.  ShotFitRefused when the shots leave more than one solution.
    """
    design = np.column_stack([np.einsum('ni,nj->nij', accel, field).reshape(-1, 9),
                              -np.ones(accel.shape[0])])
    norms = np.linalg.norm(design, axis=0)
    _, singular, vt = np.linalg.svd(design / norms, full_matrices=False)
    if singular[-2] < 1e-6 * singular[0]:
        raise ShotFitRefused('the shots do not fix the rotation between the triads: '
                             'turn the tool through more directions')
    solution = vt[-1] / norms
    x = solution[:9].reshape(3, 3)
    if np.linalg.det(x) < 0.0:
        x, solution = -x, -solution
    scale = float(np.mean(np.linalg.svd(x, compute_uv=False)))
    product = np.linalg.norm(accel, axis=1).mean() * np.linalg.norm(field, axis=1).mean()
    return rotation_part(x), float(np.clip(-solution[9] / (scale * product), -1.0, 1.0))


def _group_axis(accel, field, labels, group_count, g, field_nT):
    """
    Return the unit u (u_z > 0) minimising the within-group spread of ``a . u`` and ``m . u``.

    The smallest eigenvector of the within-group scatter of both triads,
    each relative to its magnitude (closed form of step 4).
    """
    scatter = np.zeros((3, 3))
    for k in range(group_count):
        members = labels == k
        for vectors, scale in ((accel, g), (field, field_nT)):
            centred = (vectors[members] - vectors[members].mean(axis=0)) / scale
            scatter += centred.T @ centred
    axis = np.linalg.eigh(scatter)[1][:, 0]
    return axis if axis[2] > 0 else -axis


def tilt_angles(axis):
    """Return seed 000's (gamma, beta) [rad] of a unit tool axis u = C e_z (Eqs. 11-14)."""
    return installation_angles(*level_axis_angles(axis, 1.0))


def _roll_span_deg(vectors, axis):
    """Return 360 deg minus the largest gap of the roll angles of ``vectors`` about ``axis``."""
    reference = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    reference /= np.linalg.norm(reference)
    other = np.cross(axis, reference)
    angles = np.sort(np.degrees(np.arctan2(vectors @ other, vectors @ reference)))
    gaps = np.diff(np.append(angles, angles[0] + 360.0))
    return 360.0 - float(gaps.max())


class _Model:
    """The joint model: parameter vector layout, corrected vectors, weighted residuals."""

    def __init__(self, accel, field, labels, group_count, g, field_nT, fit_accel):
        self.accel, self.field, self.labels = accel, field, labels
        self.groups, self.g, self.field_nT, self.fit_accel = group_count, g, field_nT, fit_accel
        self.sigma_a, self.sigma_m = 1e-3, 1e-3  # relative noise, set from the data

    def pack(self, t_a, b_a, t_m, o_m, rotation, sin_dip, tilt, c_a, c_m):
        parts = ([t_a[_UPPER], b_a / self.g] if self.fit_accel else []) + [
            t_m[_UPPER], o_m / self.field_nT,
            Rotation.from_matrix(rotation).as_rotvec(), [sin_dip]]
        if self.groups:
            parts += [tilt, c_a / self.g, c_m / self.field_nT]
        return np.concatenate([np.ravel(p) for p in parts])

    def unpack(self, x):
        values, i = {}, 0
        if self.fit_accel:
            t_a = np.zeros((3, 3))
            t_a[_UPPER] = x[0:6]
            values.update(t_a=t_a, b_a=x[6:9] * self.g)
            i = 9
        t_m = np.zeros((3, 3))
        t_m[_UPPER] = x[i:i + 6]
        t_m = t_m + np.triu(t_m, 1).T
        values.update(t_m=t_m, o_m=x[i + 6:i + 9] * self.field_nT,
                      rotation=Rotation.from_rotvec(x[i + 9:i + 12]).as_matrix(),
                      sin_dip=x[i + 12])
        i += 13
        if self.groups:
            n = self.groups
            values.update(tilt=x[i:i + 2], c_a=x[i + 2:i + 2 + n] * self.g,
                          c_m=x[i + 2 + n:i + 2 + 2 * n] * self.field_nT)
        return values

    def vectors(self, values):
        """Return the corrected (accel, field) of every shot, both in the accelerometer frame."""
        accel = ((self.accel - values['b_a']) @ values['t_a'].T if self.fit_accel
                 else self.accel)
        field = (self.field - values['o_m']) @ (values['rotation'] @ values['t_m']).T
        return accel, field

    def errors(self, x):
        """Return the relative residual families: |g|, |B|, dip, group accel, group field."""
        values = self.unpack(x)
        accel, field = self.vectors(values)
        g_total = np.linalg.norm(accel, axis=1)
        b_total = np.linalg.norm(field, axis=1)
        sin_dip = -np.einsum('ij,ij->i', accel, field) / (g_total * b_total)
        families = {'g': g_total / self.g - 1.0, 'b': b_total / self.field_nT - 1.0,
                    'dip': sin_dip - values['sin_dip']}
        if self.groups:
            axis = installation_matrix(*values['tilt'])[:, 2]
            grouped = self.labels >= 0
            label = self.labels[grouped]
            families['axial_g'] = (accel[grouped] @ axis - values['c_a'][label]) / self.g
            families['axial_b'] = (field[grouped] @ axis - values['c_m'][label]) / self.field_nT
        return families

    def weights(self, cos_dip):
        return {'g': self.sigma_a, 'b': self.sigma_m, 'axial_g': self.sigma_a,
                'axial_b': self.sigma_m,
                'dip': max(cos_dip, 0.05) * math.hypot(self.sigma_a, self.sigma_m)}

    def residuals(self, x, cos_dip):
        weights = self.weights(cos_dip)
        families = self.errors(x)
        if not self.fit_accel:
            del families['g']  # the given accelerometer is not refitted
        return np.concatenate([value / weights[name] for name, value in families.items()])


def fit_shots(accel_mps2, field_nT, roll_group=None, g=STANDARD_GRAVITY_MPS2,
              reference_total_nT=None, fit_accel=True, limits=ShotLimits()):
    """
    Return the ShotFit of still shots of both triads, or raise ShotFitRefused.

    ``accel_mps2``: (N, 3) raw (``fit_accel``) or already corrected
    accelerometer readings; ``field_nT``: (N, 3) raw magnetometer readings;
    ``roll_group``: (N,) integer labels, -1 for a shot in no group (None:
    no groups); ``reference_total_nT``: the field to scale the magnetometer
    to (None: its own mean scale, det K_m = 1).  Refused, with the reason:
    too few shots, non-finite ones, a triad not turned or turned about one
    axis only, a roll group too small or not turned about its axis, a fit
    that leaves |B|, |g|, the dip or a group's axial components varying
    beyond ``limits``, and outlier shots (named, 1-based).
    """
    accel = as_vectors(accel_mps2, 'accel_mps2')
    field = as_vectors(field_nT, 'field_nT')
    count = accel.shape[0]
    if field.shape[0] != count:
        raise ValueError('accel_mps2 and field_nT need one row per shot each')
    check_shots(accel, field, limits, fit_accel)
    labels = (np.full(count, -1) if roll_group is None
              else np.asarray(roll_group, dtype=int).reshape(count))
    group_count = int(labels.max()) + 1 if labels.size and labels.max() >= 0 else 0
    for k in range(group_count):
        size = int(np.sum(labels == k))
        if size < limits.min_group_shots:
            raise ShotFitRefused(f'roll group {k + 1} has {size} shot(s), need at least '
                                 f'{limits.min_group_shots}')

    # Closed-form start: both ellipsoids, the rotation between them, the tool axis.
    if fit_accel:
        sphere_a = _sphere(accel, g, 'accelerometer')
        t_a, b_a = np.linalg.inv(sphere_a.scale_matrix), sphere_a.bias_mps2
        corrected_a = sphere_a.apply(accel)
    else:
        t_a, b_a, corrected_a = np.eye(3), np.zeros(3), accel
    first = float(np.median(np.linalg.norm(field, axis=1)))
    sphere_m = _sphere(field, first, 'magnetometer')
    own_scale = first * np.cbrt(np.linalg.det(sphere_m.scale_matrix))
    field_total = own_scale if reference_total_nT is None else float(reference_total_nT)
    t_m = np.linalg.inv(sphere_m.scale_matrix) * (field_total / first)
    rotation0 = rotation_part(t_m)
    t_m = rotation0.T @ t_m  # symmetric: the soft iron adds no turn of its own
    t_m = 0.5 * (t_m + t_m.T)
    corrected_m = (field - sphere_m.bias_mps2) @ t_m.T
    rotation, sin_dip = _initial_rotation(corrected_a, corrected_m)
    model = _Model(accel, field, labels, group_count, g, field_total, fit_accel)
    tilt, c_a, c_m = np.zeros(2), np.zeros(group_count), np.zeros(group_count)
    if group_count:
        aligned_m = corrected_m @ rotation.T
        axis = _group_axis(corrected_a, aligned_m, labels, group_count, g, field_total)
        tilt = np.array(tilt_angles(axis))
        c_a = np.array([np.mean(corrected_a[labels == k] @ axis) for k in range(group_count)])
        c_m = np.array([np.mean(aligned_m[labels == k] @ axis) for k in range(group_count)])
    x0 = model.pack(t_a, b_a, t_m, sphere_m.bias_mps2, rotation, sin_dip, tilt, c_a, c_m)
    model.sigma_a = max(sphere_a.rms_residual_mps2 / g if fit_accel else 1e-4, 1e-9)
    model.sigma_m = max(sphere_m.rms_residual_mps2 / first, 1e-9)

    # Joint fit, twice: the second with the noise the first one leaves.
    evaluations = 0
    x = x0
    for _ in range(2):
        cos_dip = math.sqrt(max(1.0 - model.unpack(x)['sin_dip'] ** 2, 0.0))
        result = least_squares(model.residuals, x, args=(cos_dip,), method='lm',
                               x_scale='jac')
        x, evaluations = result.x, evaluations + result.nfev
        families = model.errors(x)
        model.sigma_a = max(_rms(np.concatenate(
            [families.get('g', []), families.get('axial_g', [])])) or 1e-4, 1e-9)
        model.sigma_m = max(_rms(np.concatenate(
            [families['b'], families.get('axial_b', [])])), 1e-9)
    values = model.unpack(x)
    _refuse_outliers(model.errors(x), labels, limits)
    return _result(model, values, families, labels, group_count, sphere_m, limits, evaluations)


def _rms(values):
    """Return the root mean square of ``values`` (0 for none)."""
    values = np.asarray(values, dtype=float)
    return float(np.sqrt(np.mean(values ** 2))) if values.size else 0.0


def _refuse_outliers(families, labels, limits):
    """Raise ShotFitRefused naming the shots whose residual is an outlier in any family."""
    grouped = np.flatnonzero(labels >= 0)
    worst = np.zeros(labels.size)
    for name, values in families.items():
        scale = max(1.4826 * float(np.median(np.abs(values))), 1e-7)
        shots = grouped if name.startswith('axial') else np.arange(labels.size)
        np.maximum.at(worst, shots, np.abs(values) / scale)
    outliers = np.flatnonzero(worst > limits.outlier_sigma)
    if outliers.size:
        named = ', '.join(f'{i + 1} ({worst[i]:.0f} sigma)' for i in outliers)
        raise ShotFitRefused(f'outlier shot(s) {named}: their readings disagree with the '
                             f'others beyond {limits.outlier_sigma:g} robust sigma (the tool '
                             'moved, or iron was near); retake or drop them')


def _result(model, values, families, labels, group_count, sphere_m, limits, evaluations):
    """Check the fit's quality against ``limits``; return the ShotFit."""
    accel, field = model.vectors(values)
    g_total, b_total = np.linalg.norm(accel, axis=1), np.linalg.norm(field, axis=1)
    dip = np.degrees(np.arcsin(np.clip(-np.einsum('ij,ij->i', accel, field)
                                       / (g_total * b_total), -1.0, 1.0)))
    dip_deg = math.degrees(math.asin(float(np.clip(values['sin_dip'], -1.0, 1.0))))
    checks = [('|B|', _rms(families['b']), limits.max_b_rms_fraction, 'fraction'),
              ('the dip', _rms(dip - dip_deg), limits.max_dip_rms_deg, 'deg')]
    if model.fit_accel:
        checks.append(('|g|', _rms(families['g']), limits.max_g_rms_fraction, 'fraction'))
    for what, rms, limit, unit in checks:
        if rms > limit:
            raise ShotFitRefused(
                f'the fit does not make {what} constant: RMS {rms:.4g} {unit} left, limit '
                f'{limit:g} (the field changed between shots, e.g. iron nearby, or a triad '
                'is not linear)')
    axis, gamma, beta = None, None, None
    axial_rms, roll = np.zeros(0), np.zeros(0)
    if group_count:
        gamma, beta = (float(v) for v in values['tilt'])
        axis = installation_matrix(gamma, beta)[:, 2]
        axial_rms = np.zeros(group_count)
        roll = np.zeros(group_count)
        grouped = labels[labels >= 0]
        for k in range(group_count):
            members = labels == k
            axial_rms[k] = math.degrees(_rms(np.concatenate(
                [families['axial_g'][grouped == k], families['axial_b'][grouped == k]])))
            across = [v[members] - np.outer(v[members] @ axis, axis) for v in (accel, field)]
            triad = max(across, key=lambda v: np.mean(np.linalg.norm(v, axis=1)
                                                      / np.linalg.norm(v, axis=1).max()
                                                      if v.size else 0.0))
            roll[k] = _roll_span_deg(triad, axis)
            if roll[k] < limits.min_roll_deg:
                raise ShotFitRefused(
                    f'roll group {k + 1} turns the tool over {roll[k]:.0f} deg about its axis, '
                    f'need {limits.min_roll_deg:g}: spread its shots around the axis')
            if axial_rms[k] > limits.max_axial_rms_deg:
                raise ShotFitRefused(
                    f'roll group {k + 1}: the components along the tool axis vary by '
                    f'{axial_rms[k]:.3f} deg RMS (limit {limits.max_axial_rms_deg:g}): the tool '
                    'axis was not held in one direction')
        gamma, beta = math.degrees(gamma), math.degrees(beta)
    accel_matrix = np.linalg.inv(values['t_a']) if model.fit_accel else None
    return ShotFit(
        accel_matrix=accel_matrix, accel_bias_mps2=values['b_a'] if model.fit_accel else None,
        mag_matrix=np.linalg.inv(values['t_m']), mag_bias_nT=values['o_m'],
        alignment=values['rotation'], dip_deg=dip_deg, field_nT=model.field_nT,
        tool_axis=axis, gamma_deg=gamma, beta_deg=beta, accel_corrected_mps2=accel,
        field_corrected_nT=field, g_total_mps2=g_total, b_total_nT=b_total,
        dip_per_shot_deg=dip, dip_rms_deg=_rms(dip - dip_deg),
        groups=tuple(range(group_count)), axial_rms_deg=axial_rms, roll_deg=roll,
        condition_number=sphere_m.condition_number, noise_mps2=model.sigma_a * model.g,
        noise_nT=model.sigma_m * model.field_nT, evaluations=evaluations)
