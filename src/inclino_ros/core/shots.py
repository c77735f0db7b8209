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
and the dip also inform the ellipsoids, which 24 shots need.  The residuals of one
shot share its readings' noise (|g| and the axial component of gravity both hold
the noise along gravity): each shot's are whitened by their covariance
(``_Model.set_whitening``), which makes the fit maximum likelihood to first order.

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
#: The tool axis of a fit without roll groups: the accelerometer's z sensing axis.
_Z = np.array([0.0, 0.0, 1.0])
#: Most refits of the robust loop (outliers left out, wandering groups freed); each settles in 2-4.
_MAX_ROUNDS = 20


class ShotFitRefused(Refused):
    """
    Shots that cannot give a trustworthy reference-free calibration, with the reason.

    ``reasons``: every failed check (``reason`` joins them); ``fit``: the
    ShotFit that failed them (its figures for the refusal's report), or None
    when the shots could not be fitted at all.
    """

    def __init__(self, reason, fit=None, reasons=None):
        super().__init__(reason)
        self.reasons = tuple(reasons or (reason,))
        self.fit = fit


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
    ``max_b_rms_fraction``, ``max_g_rms_fraction``, ``max_dip_rms_deg``:
    what the fitted model may leave in |B|, |g| and the dip; beyond, the
    field was not constant (iron near some shots) or the sensor is not
    linear.  MEMS noise (2 mg, 100 nT per shot) leaves ~0.2 %, ~0.15 deg.
    ``outlier_sigma``: a shot with a residual this many robust standard
    deviations out is an outlier: named, left out of the fit (weight 0) and
    the fit repeated, while ``min_shots`` and ``min_group_shots`` remain.
    ``max_axial_rms_deg``: a roll group whose components along the tool axis
    vary more than this (the hand let the pointing wander) no longer holds
    one direction: its shots count as free shots (named), it measures no tool
    axis.  Below it a group is weighted by its own spread (a hand-held real
    set wanders 0.1-0.7 deg RMS).  ``min_group_shots``, ``min_roll_deg``: a
    roll group needs three shots spread over this arc about its axis.
    ``max_pointing_deg``: consecutive shots whose tool axes point within this
    angle of their mean are one roll set (``find_roll_groups``; a hand-held
    set wanders 0.1-0.7 deg RMS, an outlier shot 5).  ``max_mount_tilt_deg``:
    the largest angle between the sensors' z axis and the tool axis the
    finder allows for: before the tool axis is known, a roll set's z axes lie
    on a cone of that half-angle about its direction, so its first pass joins
    shots within ``max_pointing_deg`` plus twice this (15 real hand-held
    instruments: 1.2-3.6 deg).
    """

    min_shots: int = 12
    min_turn_deg: float = 15.0
    min_thickness: float = 0.1
    max_b_rms_fraction: float = 0.01
    max_g_rms_fraction: float = 0.01
    max_dip_rms_deg: float = 0.5
    max_axial_rms_deg: float = 2.0
    outlier_sigma: float = 6.0
    min_group_shots: int = 3
    min_roll_deg: float = 90.0
    max_pointing_deg: float = 5.0
    max_mount_tilt_deg: float = 5.0


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
    ``b_total_nT``, ``dip_deg`` (outliers too) and ``used`` (False: an
    outlier, left out); per group of the input: ``axial_rms_deg`` (the
    pointing's wander), ``roll_deg`` (NaN for a group not fitted).
    ``groups``: the input groups fitted as roll groups; ``outliers``:
    (shot index, robust sigma) left out, in order; ``freed_groups``:
    (group index, why) taken as free shots.  ``parameter_covariance``: of the
    parameters a calibration file stores (``_stored_parameters``: K_a^-1 and b_a
    when fitted, R K_m^-1 and b_m, the tool axis's gamma and beta), from the
    fit's Jacobian and residuals (issue 19 item 2).
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
    used: np.ndarray
    outliers: tuple
    freed_groups: tuple
    parameter_covariance: np.ndarray = None


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


def pointing(accel, field, axis=_Z):
    """
    Return the tool frame's unit ``axis`` (default z) in NED (N, 3) of shots in the tool frame.

    Down is against the specific force, east ``down x B``, north ``east x
    down``; the axis's components on them are its NED components.
    """
    down = -accel / np.linalg.norm(accel, axis=1)[:, None]
    east = np.cross(down, field)
    east /= np.linalg.norm(east, axis=1)[:, None]
    north = np.cross(east, down)
    return np.column_stack([north @ axis, east @ axis, down @ axis])


def find_roll_groups(accel, field, limits=ShotLimits()):
    """
    Return roll-group labels (N,) of shots taken in order: -1 for a free shot.

    Consecutive shots whose tool axes (``pointing``) lie within a tolerance
    of their running mean are one run; a run of ``limits.min_group_shots``
    or more turned over ``limits.min_roll_deg`` or more about the axis
    (``_roll_span_of``, as the fit checks it) is a roll group.  ``accel``,
    ``field``: corrected, in one frame whose z is within
    ``limits.max_mount_tilt_deg`` of the tool axis (a fit without roll
    groups).  Two passes: the sensors' z axis traces a cone of the mount
    tilt about a roll set's direction, so the first pass allows
    ``max_pointing_deg`` plus twice the tilt; the tool axis of the runs it
    finds (``_group_axis``, the same for every set) then points each set's
    shots within their wander, and the second pass, with that axis, allows
    ``max_pointing_deg``.
    """
    labels = _roll_runs(accel, field, _Z,
                        limits.max_pointing_deg + 2.0 * limits.max_mount_tilt_deg, limits)
    if labels.max(initial=-1) < 0:
        return labels
    axis = _group_axis(accel, field, labels, int(labels.max()) + 1,
                       float(np.mean(np.linalg.norm(accel, axis=1))),
                       float(np.mean(np.linalg.norm(field, axis=1))))
    return _roll_runs(accel, field, axis, limits.max_pointing_deg, limits)


def _roll_runs(accel, field, axis, tolerance_deg, limits):
    """Return the labels of ``find_roll_groups``'s runs of ``axis`` within ``tolerance_deg``."""
    axes = pointing(accel, field, axis)
    labels = np.full(len(axes), -1)
    start, group = 0, 0
    for end in range(1, len(axes) + 1):
        if end < len(axes):
            mean = axes[start:end].sum(axis=0)
            if math.degrees(float(angle_between(axes[end], mean))) <= tolerance_deg:
                continue
        if (end - start >= limits.min_group_shots and _roll_span_of(
                accel[start:end], field[start:end], axis) >= limits.min_roll_deg):
            labels[start:end] = group
            group += 1
        start = end
    return labels


def _roll_span_of(accel, field, axis):
    """
    Return the roll span [deg] of shots about ``axis``: ``_roll_span_deg`` of one triad.

    The triad whose vectors lie further from the axis (their cross-axial part,
    relative to its largest) tells the roll: gravity unless the axis is near
    vertical, the field unless it is near the field's direction.
    """
    across = [v - np.outer(v @ axis, axis) for v in (accel, field)]
    triad = max(across, key=lambda v: np.mean(np.linalg.norm(v, axis=1)
                                              / np.linalg.norm(v, axis=1).max()
                                              if v.size else 0.0))
    return _roll_span_deg(triad, axis)


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
        # Each roll group's own spread along the axis (hand-held wander), set from the data.
        self.group_a, self.group_m = np.full(group_count, 1e-3), np.full(group_count, 1e-3)

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

    def set_whitening(self, x):
        """
        Set each shot's whitening of its residuals (``residuals``) at the fit ``x``.

        A shot's residuals (|g|, |B|, dip, and in a roll group its axial
        components) are functions of its two readings' noise, ``sigma_a`` and
        ``sigma_m`` per axis relative to g and F: to first order ``r = J_a e_a +
        J_m e_m`` with the rows ``(a^, 0, -P_a m^, u, 0)`` and ``(0, m^, -P_m a^,
        0, u)`` (a^, m^ the unit corrected vectors, ``P_a m^ = m^ - (a^ . m^)
        a^``, u the tool axis), so they are correlated (|g| and the axial
        component of gravity share the noise along gravity).  Their covariance
        ``sigma_a^2 J_a J_a^T + sigma_m^2 J_m J_m^T``, plus a roll group's wander
        beyond the shot noise on its axial components (and a floor of 0.05 of
        the dip's noise, a dip near 90 deg), is whitened by its Cholesky factor:
        the weighted least squares is then the maximum likelihood of the shots
        to first order (issue 19 item 10), not that of independent families.
        """
        values = self.unpack(x)
        accel, field = self.vectors(values)
        a_hat = accel / np.linalg.norm(accel, axis=1)[:, None]
        m_hat = field / np.linalg.norm(field, axis=1)[:, None]
        count = accel.shape[0]
        axis = (installation_matrix(*values['tilt'])[:, 2] if self.groups
                else np.zeros(3))
        j_a, j_m = np.zeros((count, 5, 3)), np.zeros((count, 5, 3))
        j_a[:, 0], j_m[:, 1] = a_hat, m_hat
        cosine = np.einsum('ij,ij->i', a_hat, m_hat)[:, None]
        j_a[:, 2], j_m[:, 2] = -(m_hat - cosine * a_hat), -(a_hat - cosine * m_hat)
        j_a[:, 3], j_m[:, 4] = axis, axis
        covariance = (self.sigma_a ** 2 * j_a @ j_a.transpose(0, 2, 1)
                      + self.sigma_m ** 2 * j_m @ j_m.transpose(0, 2, 1))
        floor = (0.05 * math.hypot(self.sigma_a, self.sigma_m)) ** 2
        covariance[:, 2, 2] = np.maximum(covariance[:, 2, 2], floor)
        grouped = self.labels >= 0
        label = self.labels[grouped]
        covariance[grouped, 3, 3] += self.group_a[label] ** 2 - self.sigma_a ** 2
        covariance[grouped, 4, 4] += self.group_m[label] ** 2 - self.sigma_m ** 2
        present = np.ones((count, 5), dtype=bool)
        present[:, 0] = self.fit_accel
        present[~grouped, 3:] = False
        # An absent residual: unit variance, no correlation (it stays zero).
        covariance[~present] = 0.0
        covariance.transpose(0, 2, 1)[~present] = 0.0
        index = np.nonzero(~present)
        covariance[index[0], index[1], index[1]] = 1.0
        self.whiten = np.linalg.inv(np.linalg.cholesky(covariance))
        self.present = present

    def set_noise(self, families):
        """
        Set the noise of each residual family from what a fit left (``errors``).

        The shot noise from |g| and |B|; a roll group's axial weight from its own
        spread, never below the shot noise: a group whose pointing wandered
        counts for what it holds.
        """
        # The |g| and |B| residuals are left by an ellipsoid of 9 parameters each: their
        # mean square over N - 9 degrees of freedom, not N, is the noise's.
        count = families['b'].size
        unbiased = math.sqrt(count / max(count - 9, 1))
        self.sigma_a = max(_rms(families['g']) * unbiased if self.fit_accel else
                           _rms(families.get('axial_g', [])) or 1e-4, 1e-9)
        self.sigma_m = max(_rms(families['b']) * unbiased, 1e-9)
        label = self.labels[self.labels >= 0]
        for k in range(self.groups):
            self.group_a[k] = max(self.sigma_a, _rms(families['axial_g'][label == k]))
            self.group_m[k] = max(self.sigma_m, _rms(families['axial_b'][label == k]))

    def residuals(self, x):
        """Return every shot's residuals whitened (``set_whitening``), the absent ones left out."""
        families = self.errors(x)
        stacked = np.zeros(self.present.shape)
        stacked[:, 0] = families['g']
        stacked[:, 1] = families['b']
        stacked[:, 2] = families['dip']
        grouped = self.labels >= 0
        if self.groups:
            stacked[grouped, 3] = families['axial_g']
            stacked[grouped, 4] = families['axial_b']
        stacked[~self.present] = 0.0
        return np.einsum('nij,nj->ni', self.whiten, stacked)[self.present]


def fit_shots(accel_mps2, field_nT, roll_group=None, g=STANDARD_GRAVITY_MPS2,
              reference_total_nT=None, fit_accel=True, limits=ShotLimits()):
    """
    Return the ShotFit of still shots of both triads, or raise ShotFitRefused.

    ``accel_mps2``: (N, 3) raw (``fit_accel``) or already corrected
    accelerometer readings; ``field_nT``: (N, 3) raw magnetometer readings;
    ``roll_group``: (N,) integer labels, -1 for a shot in no group (None:
    no groups); ``reference_total_nT``: the field to scale the magnetometer
    to (None: its own mean scale, det K_m = 1).

    Robust: the shots beyond ``limits.outlier_sigma`` of a fit are left out
    and the fit repeated until the shots left out no longer change (a shot a
    worse one had pushed out comes back); a roll group whose
    pointing wandered beyond ``limits.max_axial_rms_deg`` is taken as free
    shots; both are named in the ShotFit.  Refused, with the reason: too few
    shots, non-finite ones, a triad not turned or turned about one axis
    only, a roll group too small; and, every failed check at once with the
    fit that failed them: too few good shots left, a group not turned about
    its axis, |B|, |g| or the dip left varying beyond ``limits``.
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
    used = np.ones(count, dtype=bool)
    kept = list(range(group_count))
    freed, evaluations = [], 0
    for _ in range(_MAX_ROUNDS):
        fitted = _joint_fit(accel[used], field[used], _renumber(labels[used], kept), g,
                            reference_total_nT, fit_accel)
        evaluations += fitted[-1]
        model, x = fitted[0], fitted[1]
        # Every shot against this fit, in robust sigma of the shots used: an outlier is out,
        # a shot a worse one had pushed out comes back.
        whole = _Model(accel, field, _renumber(labels, kept), len(kept), g, model.field_nT,
                       fit_accel)
        sigma = _shot_sigma(whole.errors(x), whole.labels, used)
        good = sigma <= limits.outlier_sigma
        if good.sum() < limits.min_shots:   # keep the best min_shots: the checks will say
            good[np.argsort(sigma)[:limits.min_shots]] = True
        if not np.array_equal(good, used):
            used = good
            for k in [k for k in kept if np.sum(used & (labels == k)) < limits.min_group_shots]:
                kept.remove(k)
                freed.append((k, f'fewer than {limits.min_group_shots} good shots left'))
            continue
        wander = _group_wander_deg(model, x)
        if wander.size and wander.max() > limits.max_axial_rms_deg:
            group = kept[int(np.argmax(wander))]
            freed.append((group, f'its pointing wandered {wander.max():.3f} deg RMS (more than '
                                 f'{limits.max_axial_rms_deg:g}): not held in one direction'))
            kept.remove(group)
            continue
        break
    bad = np.flatnonzero(~used)
    outliers = [(int(i), float(sigma[i])) for i in bad[np.argsort(-sigma[bad])]]
    return _result(fitted, accel, field, labels, (kept, used, outliers, freed), limits,
                   evaluations)


def _renumber(labels, kept):
    """Return ``labels`` with the groups of ``kept`` numbered 0, 1, ... and every other -1."""
    out = np.full(labels.shape, -1)
    for new, old in enumerate(kept):
        out[labels == old] = new
    return out


def _joint_fit(accel, field, labels, g, reference_total_nT, fit_accel):
    """
    Return (model, x, sphere_m, covariance, evaluations): closed-form start, then the joint fit.

    ``covariance``: of x, ``s^2 (J^T J)^-1`` from the last fit's Jacobian J of
    the weighted residuals and their mean square s^2 per degree of freedom.
    """
    group_count = int(labels.max()) + 1 if labels.size and labels.max() >= 0 else 0
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
    x = model.pack(t_a, b_a, t_m, sphere_m.bias_mps2, rotation, sin_dip, tilt, c_a, c_m)
    model.sigma_a = max(sphere_a.rms_residual_mps2 / g if fit_accel else 1e-4, 1e-9)
    model.sigma_m = max(sphere_m.rms_residual_mps2 / first, 1e-9)
    model.group_a[:], model.group_m[:] = model.sigma_a, model.sigma_m
    # Joint fit, three times: each with the noise (and group spread) the one before left.
    evaluations = 0
    for _ in range(3):
        model.set_whitening(x)
        result = least_squares(model.residuals, x, method='lm',
                               x_scale='jac')
        x, evaluations = result.x, evaluations + result.nfev
        model.set_noise(model.errors(x))
    return model, x, sphere_m, _covariance(result), evaluations


def _covariance(result):
    """Return ``s^2 (J^T J)^-1`` of a ``least_squares`` result (pseudo-inverse: no refusal)."""
    jacobian = result.jac
    freedom = max(jacobian.shape[0] - jacobian.shape[1], 1)
    return np.linalg.pinv(jacobian.T @ jacobian) * (2.0 * result.cost / freedom)


def _stored_parameters(model, x):
    """
    Return the parameters a calibration file stores of the fit ``x`` (the covariance's order).

    The accelerometer's ``K_a^-1`` (row-major) and ``b_a`` (``fit_accel``), the
    map ``R K_m^-1`` taking magnetometer readings (bias removed) into the
    accelerometer frame (row-major) and ``b_m``, then the tool axis's gamma,
    beta [rad] (roll groups).
    """
    values = model.unpack(x)
    parts = [values['t_a'].ravel(), values['b_a']] if model.fit_accel else []
    parts += [(values['rotation'] @ values['t_m']).ravel(), values['o_m']]
    if model.groups:
        parts.append(values['tilt'])
    return np.concatenate(parts)


def stored_covariance(model, x, covariance):
    """Return the covariance of ``_stored_parameters`` from that of x (central differences)."""
    step = np.maximum(np.sqrt(np.clip(np.diag(covariance), 0.0, None)), 1e-9) * 1e-3
    jacobian = np.column_stack([
        (_stored_parameters(model, x + h) - _stored_parameters(model, x - h)) / (2.0 * h[i])
        for i, h in enumerate(np.diag(step))])
    stored = jacobian @ covariance @ jacobian.T
    return 0.5 * (stored + stored.T)


def _rms(values):
    """Return the root mean square of ``values`` (0 for none)."""
    values = np.asarray(values, dtype=float)
    return float(np.sqrt(np.mean(values ** 2))) if values.size else 0.0


def _shot_sigma(families, labels, used):
    """
    Return per shot its largest residual in robust standard deviations of any family.

    The robust standard deviation of a family is 1.4826 times the median
    absolute residual (MAD) of the ``used`` shots.
    """
    grouped = np.flatnonzero(labels >= 0)
    worst = np.zeros(labels.size)
    for name, values in families.items():
        shots = grouped if name.startswith('axial') else np.arange(labels.size)
        scale = max(1.4826 * float(np.median(np.abs(values[used[shots]]))), 1e-7)
        np.maximum.at(worst, shots, np.abs(values) / scale)
    return worst


def _group_wander_deg(model, x):
    """Return per roll group of ``model`` the RMS of its axial components [deg] (the wander)."""
    if not model.groups:
        return np.zeros(0)
    families = model.errors(x)
    label = model.labels[model.labels >= 0]
    return np.array([math.degrees(_rms(np.concatenate(
        [families['axial_g'][label == k], families['axial_b'][label == k]])))
        for k in range(model.groups)])


def _result(fitted, accel_all, field_all, labels, robust, limits, evaluations):
    """
    Check the fit's quality against ``limits``; return the ShotFit or refuse, every check.

    ``robust``: (kept groups, used shots, outliers, freed groups) of ``fit_shots``.
    """
    model, x, sphere_m, covariance, _ = fitted
    kept, used, outliers, freed = robust
    values = model.unpack(x)
    families = model.errors(x)
    # Every shot through the fitted model (the outliers too, for the report).
    whole = _Model(accel_all, field_all, _renumber(labels, kept), len(kept), model.g,
                   model.field_nT, model.fit_accel)
    accel, field = whole.vectors(values)
    g_total, b_total = np.linalg.norm(accel, axis=1), np.linalg.norm(field, axis=1)
    dip = np.degrees(np.arcsin(np.clip(-np.einsum('ij,ij->i', accel, field)
                                       / (g_total * b_total), -1.0, 1.0)))
    dip_deg = math.degrees(math.asin(float(np.clip(values['sin_dip'], -1.0, 1.0))))
    problems = []
    sigma = _shot_sigma(families, model.labels, np.ones(model.labels.size, dtype=bool))
    if np.any(sigma > limits.outlier_sigma):
        named = ', '.join(f'{i + 1} ({s:.0f} sigma)' for i, s in
                          zip(np.flatnonzero(used)[sigma > limits.outlier_sigma],
                              sigma[sigma > limits.outlier_sigma]))
        problems.append(f'outlier shot(s) {named} beyond {limits.outlier_sigma:g} robust sigma '
                        f'remain after {len(outliers)} left out: only {int(used.sum())} shots '
                        f'left, the fit needs {limits.min_shots}')
    checks = [('|B|', _rms(families['b']), limits.max_b_rms_fraction, 'fraction'),
              ('the dip', _rms(dip[used] - dip_deg), limits.max_dip_rms_deg, 'deg')]
    if model.fit_accel:
        checks.append(('|g|', _rms(families['g']), limits.max_g_rms_fraction, 'fraction'))
    for what, rms, limit, unit in checks:
        if rms > limit:
            problems.append(f'the fit does not make {what} constant: RMS {rms:.4g} {unit} '
                            f'left, limit {limit:g}')
    axis, gamma, beta = None, None, None
    group_count = int(labels.max()) + 1 if labels.size and labels.max() >= 0 else 0
    axial_rms, roll = np.full(group_count, np.nan), np.full(group_count, np.nan)
    if kept:
        gamma, beta = (float(v) for v in values['tilt'])
        axis = installation_matrix(gamma, beta)[:, 2]
        gamma, beta = math.degrees(gamma), math.degrees(beta)
    for k in range(group_count):
        members = (labels == k) & used
        if axis is not None:
            axial_rms[k] = math.degrees(_rms(np.concatenate(
                [(v[members] @ axis - np.mean(v[members] @ axis)) / scale
                 for v, scale in ((accel, model.g), (field, model.field_nT))])))
        if k not in kept:
            continue
        roll[k] = _roll_span_of(accel[members], field[members], axis)
        if roll[k] < limits.min_roll_deg:
            problems.append(f'roll group {k + 1} turns the tool over {roll[k]:.0f} deg about '
                            f'its axis, need {limits.min_roll_deg:g}: spread its shots around '
                            'the axis')
    fit = ShotFit(
        accel_matrix=np.linalg.inv(values['t_a']) if model.fit_accel else None,
        accel_bias_mps2=values['b_a'] if model.fit_accel else None,
        mag_matrix=np.linalg.inv(values['t_m']), mag_bias_nT=values['o_m'],
        alignment=values['rotation'], dip_deg=dip_deg, field_nT=model.field_nT,
        tool_axis=axis, gamma_deg=gamma, beta_deg=beta, accel_corrected_mps2=accel,
        field_corrected_nT=field, g_total_mps2=g_total, b_total_nT=b_total,
        dip_per_shot_deg=dip, dip_rms_deg=_rms(dip[used] - dip_deg),
        groups=tuple(kept), axial_rms_deg=axial_rms, roll_deg=roll,
        condition_number=sphere_m.condition_number, noise_mps2=model.sigma_a * model.g,
        noise_nT=model.sigma_m * model.field_nT, evaluations=evaluations,
        used=used, outliers=tuple(outliers), freed_groups=tuple(freed),
        parameter_covariance=stored_covariance(model, x, covariance))
    if problems:
        raise ShotFitRefused('; '.join(problems) + ' (the field changed between shots, e.g. '
                             'iron nearby, the tool moved during shots, or a triad is not '
                             'linear)', fit=fit, reasons=problems)
    return fit


def circular_mean_deg(angles_deg):
    """Return the circular mean [deg] of angles: the direction of their mean unit vector."""
    return math.degrees(math.atan2(np.mean(np.sin(np.radians(angles_deg))),
                                   np.mean(np.cos(np.radians(angles_deg)))))


def circular_spread_deg(angles_deg):
    """Return the RMS deviation [deg] of angles from their circular mean."""
    mean = circular_mean_deg(angles_deg)
    return float(np.sqrt(np.mean(((np.asarray(angles_deg) - mean + 180.0) % 360.0 - 180.0) ** 2)))


def group_spreads(labels, survey, used):
    """
    Return [(azimuth spread, inclination spread)] [deg] per roll group, ``used`` shots only.

    ``labels`` (N,) each shot's roll group (-1 none; None: no groups),
    ``survey`` the shots' ``magnetics.survey_of``: the azimuth's circular
    spread (``circular_spread_deg``) and the inclination's standard deviation.
    """
    if labels is None:
        return []
    return [(circular_spread_deg(survey['azimuth_deg'][(labels == k) & used]),
             float(np.std(survey['inclination_deg'][(labels == k) & used])))
            for k in range(int(labels.max()) + 1)]
