"""
Multi-position stand calibration of a three-axis accelerometer (seed 001 §4).

Seed 001 (Wang, Chikhotkin & Lu, Coal Geology & Exploration 44(4), 2016)
models the three accelerometer outputs as a full linear map of the true
specific force, ``A = K G`` (Eqs. 8-10): the diagonal of K holds the scale
factors, the off-diagonal terms the misalignment and cross-coupling of the
sensing axes.  K is found from a stand that sets known attitudes (Table 1,
nine positions), and every reading is corrected by ``G = K^-1 A`` (Eq. 11).
Here the model carries a bias as well, ``A = K G + b``, solved by linear least
squares; a bias-free Eq. 10 is the special case ``b = 0``.

Vectors are REP 145 specific force in the z-up tool frame of seed 000 (see
``inclino_ros.core.attitude``), shape ``(N, 3)``; readings and truth share one unit
(m/s^2 on our topics).  Without a stand, ``fit_sphere`` finds scale, bias and
non-orthogonality from ``|G| = g`` alone (no rotation: see its docstring).
"""

from dataclasses import dataclass, replace
import math

from inclino_ros.core.attitude import angle_between, as_vectors, inclination, specific_force
from inclino_ros.core.refusal import Refused
import numpy as np
from scipy.linalg import polar

#: Least stand positions: 12 unknowns (K and b), three equations per position,
#: and six is the classic six-position set (each axis up and down).
MIN_POSITIONS = 6
#: Truth vectors closer than this [deg] are one attitude visited again (a repeat).
MIN_SEPARATION_DEG = 1.0
#: Largest condition number (2-norm) of the stand design ``[G / |G|, 1]``, of
#: the fitted K, and of the sphere design: noise is amplified up to this much.
#: The six-position set gives sqrt(3); positions that leave an axis unexcited
#: (all with the same axis vertical, all at one inclination) give infinity.
MAX_CONDITION_NUMBER = 100.0
#: Least readings of a sphere fit: 9 unknowns (upper-triangular K, b) plus 3
#: redundant, so that the residual tests the fit.
MIN_SPHERE_READINGS = 12
#: No reading of a still sensor is this many times g: beyond it a fit refuses before
#: any arithmetic (squares of 1e155 overflow, and LAPACK may not return on infinities).
MAX_READING_RATIO = 10.0


class StandFitRefused(Refused):
    """Readings that cannot give a trustworthy stand or sphere calibration."""


@dataclass(frozen=True)
class _LinearSensor:
    """A fitted ``A = K G + b``: the correction and the geometry of the sensing axes."""

    scale_matrix: np.ndarray  # K (3, 3), dimensionless
    bias_mps2: np.ndarray     # b (3,), unit of the readings
    condition_number: float   # of the design matrix of the fit

    def apply(self, readings):
        """Return ``K^-1 (A - b)`` (seed 001 Eq. 11) for readings of shape (..., 3)."""
        return correct_stand(readings, self.scale_matrix, self.bias_mps2)

    @property
    def axis_scales(self):
        """Return the scale factor of each sensing axis: the norms of the rows of K."""
        return np.linalg.norm(self.scale_matrix, axis=1)

    @property
    def non_orthogonality_deg(self):
        """
        Return 90 deg minus the angles between sensing axes (x-y, x-z, y-z) [deg].

        Axis i reads ``A_i = K_i . G + b_i``: its sensing direction is row
        ``K_i`` of K.
        """
        unit = self.scale_matrix / self.axis_scales[:, None]
        pairs = ((0, 1), (0, 2), (1, 2))
        return np.array([90.0 - math.degrees(angle_between(unit[i], unit[j])) for i, j in pairs])


@dataclass(frozen=True)
class StandFit(_LinearSensor):
    """A stand calibration ``A = K G + b`` and how well it fits its positions."""

    residual_mps2: np.ndarray             # (N, 3) A - (K G + b)
    inclination_residual_deg: np.ndarray  # (N,) inclination of K^-1 (A - b) minus the true one
    rms_residual_mps2: float              # over all positions and axes
    rms_inclination_deg: float
    # (12, 12) of (K^-1 row-major, b): from the design and the pooled residual (``_fit_stand``)
    parameter_covariance: np.ndarray = None
    attitude: np.ndarray = None           # (N,) attitude number of each position (repeats share)
    repeatability_deg: np.ndarray = None  # (P,) per attitude (``repeatability``); NaN: one visit
    rms_repeatability_deg: float = math.nan  # over every repeated attitude; NaN: no repeat

    @property
    def attitudes(self):
        """Return the number of distinct attitudes among the positions."""
        return int(self.repeatability_deg.size)


@dataclass(frozen=True)
class SphereFit(_LinearSensor):
    """A reference-free calibration: upper-triangular K and b with ``|K^-1 (A - b)| = g``."""

    residual_mps2: np.ndarray  # (N,) |K^-1 (A - b)| - g
    rms_residual_mps2: float
    # (12, 12) of (K^-1 row-major, b), as StandFit's (``sphere_covariance``); the elements
    # below K^-1's diagonal are fixed at zero (no variance)
    parameter_covariance: np.ndarray = None


def stand_specific_force(inclination_deg, toolface_deg, g):
    """
    Return the true specific force of a stand position, shape (..., 3).

    ``g (sin I cos TF, sin I sin TF, cos I)`` in the z-up tool frame with the
    seed-000 toolface TF (``atan2(f_y, f_x)``), as for the level bench.  Seed
    001 Table 1 gives its GTF from +y toward +x (Eq. 2, ``atan2(G_x, G_y)``):
    its positions are ``TF = 90 deg - GTF`` here.
    """
    return specific_force(np.radians(inclination_deg), np.radians(toolface_deg), g)


def correct_stand(readings, scale_matrix, bias):
    """Return ``G = K^-1 (A - b)`` (seed 001 Eq. 11) for readings of shape (..., 3)."""
    offset = np.asarray(readings, dtype=float) - np.asarray(bias, dtype=float)
    solved = np.linalg.solve(np.asarray(scale_matrix, dtype=float), offset.reshape(-1, 3).T)
    return solved.T.reshape(offset.shape)


def fit_stand(readings, truth, min_separation_deg=MIN_SEPARATION_DEG, attitude_sigma_deg=0.0,
              mean_noise_mps2=None):
    """
    Return the least-squares ``A = K G + b`` of stand positions (seed 001 Eq. 10 + bias).

    ``readings`` (N, 3) are the mean outputs at the N positions, ``truth``
    (N, 3) the specific force the stand sets (``stand_specific_force``).
    Each row of K and b is an independent linear least-squares problem on the
    design ``[G / |G|, 1]``, solved together by ``numpy.linalg.lstsq``.

    A position may repeat an attitude (truth vectors less than
    ``min_separation_deg`` apart, ``attitude_numbers``): a real stand visits
    attitudes again.  Every visit is one more equation of the least squares (an
    attitude visited twice weighs twice; its visits average their noise), and
    the scatter of the visits is reported (``repeatability``).

    ``attitude_sigma_deg`` > 0: the positions' attitudes are known only to
    this (1 sigma per tilt axis: a tool set on its faces by hand, not a
    stand).  A tilt d of a position moves its reading across gravity by g d
    (first order) and along gravity by g d^2 / 2 only, so each position's
    residual is weighed by the inverse of its covariance
    ``s^2 I + (g sigma)^2 (I - u u^T)`` (u the direction of G, s the noise
    of the position's mean, ``mean_noise_mps2`` (N,), unknown entries NaN:
    the pooled residual of the unweighted fit stands in): generalised least
    squares (``_weighted_coefficients``).  On the six-position set the bias
    of each axis then comes from its own pair's readings along gravity, as
    in Ferraris et al. (1995); K is the same (six positions determine it).

    Raises StandFitRefused, with the reason, for: fewer than MIN_POSITIONS
    distinct attitudes; non-finite values; truth vectors not of one gravity,
    or readings beyond MAX_READING_RATIO times it (checked before any
    arithmetic); a design or a fitted K with condition number above
    MAX_CONDITION_NUMBER; a numerical failure of the solve.
    """
    readings, truth = as_vectors(readings, 'readings'), as_vectors(truth, 'truth')
    if readings.shape != truth.shape:
        raise ValueError(f'readings {readings.shape} and truth {truth.shape} differ in shape')
    count = readings.shape[0]
    _refuse_unusable(readings, MIN_POSITIONS, 'stand position(s)',
                     '(K and b have 12 unknowns; e.g. each axis up and down)')
    _refuse_non_finite(truth, 'truth')
    g_scale = float(np.median(_norms(truth)))
    if not 0.0 < g_scale < math.inf or np.any(_norms(truth) > MAX_READING_RATIO * g_scale):
        raise StandFitRefused(f'the truth vectors are not of one gravity (median |G| '
                              f'{g_scale:.4g}): every stand attitude has |G| = g')
    _refuse_beyond(readings, g_scale)
    attitude = attitude_numbers(truth, min_separation_deg)
    distinct = int(attitude.max()) + 1
    if distinct < MIN_POSITIONS:
        raise StandFitRefused(
            f'only {distinct} stand position(s) of distinct attitude ({count} with repeats), '
            f'need at least {MIN_POSITIONS} (K and b have 12 unknowns; e.g. each axis up and '
            'down)')
    try:
        fit = _fit_stand(readings, truth, g_scale)
        if attitude_sigma_deg > 0.0:
            fit = _fit_stand(readings, truth, g_scale, _attitude_weights(
                truth, fit, g_scale, attitude_sigma_deg, mean_noise_mps2))
    except np.linalg.LinAlgError as err:
        raise StandFitRefused(f'numerical failure of the fit ({err})') from None
    per_attitude, overall = repeatability(fit.apply(readings), truth, attitude)
    return replace(fit, attitude=attitude, repeatability_deg=per_attitude,
                   rms_repeatability_deg=overall)


def attitude_numbers(truth, min_separation_deg=MIN_SEPARATION_DEG):
    """
    Return the attitude number (0, 1, ...) of each truth vector (N, 3), in order of appearance.

    A vector less than ``min_separation_deg`` from an earlier one repeats its
    attitude (shares its number): the stand visited it again.
    """
    truth = as_vectors(truth, 'truth')
    near = np.degrees(angle_between(truth[:, None, :], truth[None, :, :])) < min_separation_deg
    near |= np.eye(len(truth), dtype=bool)
    owner = np.argmax(near, axis=1)          # the first position near each (itself at least)
    while np.any(owner[owner] != owner):     # a chain of repeats belongs to its first visit
        owner = owner[owner]
    number = np.unique(owner, return_inverse=True)[1]
    return number.reshape(-1).astype(int)


def repeatability(corrected, truth, attitude):
    """
    Return (per attitude, overall) repeatability [deg] of the visits of each attitude.

    The error of a visit is the difference of unit vectors ``corrected/|corrected|
    - truth/|truth|`` (its angle from the truth, in radians, with its direction);
    an attitude's repeatability is the sample standard deviation of its
    visits' errors, ``sqrt(sum |e - mean e|^2 / (n - 1))``, as an angle (NaN for
    an attitude visited once); the overall figure pools every repeated
    attitude, ``sqrt(sum of squares / sum (n - 1))`` (NaN without a repeat).
    Comparing errors, not readings, lets two visits of one attitude stand a
    little apart (0.012 deg on a real stand) without that counting as scatter.
    """
    corrected, truth = as_vectors(corrected, 'corrected'), as_vectors(truth, 'truth')
    attitude = np.asarray(attitude, dtype=int).reshape(-1)
    error = (corrected / np.linalg.norm(corrected, axis=1)[:, None]
             - truth / np.linalg.norm(truth, axis=1)[:, None])
    counts = np.bincount(attitude).astype(float)
    mean = np.stack([np.bincount(attitude, weights=error[:, axis]) for axis in range(3)],
                    axis=1) / counts[:, None]
    squares = np.bincount(attitude, weights=np.sum((error - mean[attitude]) ** 2, axis=1))
    repeated = counts > 1
    per_attitude = np.full(counts.size, math.nan)
    per_attitude[repeated] = np.degrees(np.sqrt(squares[repeated] / (counts[repeated] - 1)))
    freedom = np.sum(counts[repeated] - 1)
    overall = (math.degrees(math.sqrt(np.sum(squares[repeated]) / freedom)) if freedom
               else math.nan)
    return per_attitude, overall


def _attitude_weights(truth, fit, g_scale, attitude_sigma_deg, mean_noise_mps2):
    """
    Return (N, 3, 3) inverse covariances of the positions' readings (``fit_stand``).

    ``s^2 I + (g sigma)^2 (I - u u^T)``: s the noise of each position's mean
    (``mean_noise_mps2``; NaN or None: the unweighted ``fit``'s pooled
    residual), sigma the attitude's uncertainty [rad] per tilt axis.
    """
    count = truth.shape[0]
    pooled = float(np.sum(fit.residual_mps2 ** 2)) / max(3 * (count - 4), 1)
    noise = np.full(count, np.nan) if mean_noise_mps2 is None else np.array(
        mean_noise_mps2, dtype=float).reshape(count)
    noise = np.where(np.isfinite(noise) & (noise > 0.0), noise ** 2, pooled)
    unit = truth / np.linalg.norm(truth, axis=1)[:, None]
    across = np.eye(3) - unit[:, :, None] * unit[:, None, :]
    tilt = (g_scale * math.radians(attitude_sigma_deg)) ** 2
    return np.linalg.inv(noise[:, None, None] * np.eye(3) + tilt * across)


def _weighted_coefficients(design, readings, weights):
    """
    Return (coefficients (4, 3), their (12, 12) covariance) of ``A_i = C^T x_i``, weighted.

    Generalised least squares: each position's residual weighed by
    ``weights`` (N, 3, 3), its inverse covariance; the parameters ordered
    axis by axis (``C[:, 0], C[:, 1], C[:, 2]``), their covariance ``N^-1``
    times the reduced chi-square (as the unweighted fit scales by its pooled
    residual).  Solved whitened (``W = L L^T``: least squares of ``L^T J`` by
    QR, ``N^-1 = R^-1 R^-T``), not by the normal equations: a mean's noise
    along gravity and a face's tilt across it weigh ~1e8 apart, whose normal
    matrix would square that condition (K off by 1e-8 from rounding alone).
    """
    count = design.shape[0]
    jacobian = np.einsum('ab,nj->nabj', np.eye(3), design).reshape(count, 3, 12)
    root = np.linalg.cholesky(weights)
    whitened = np.einsum('nba,nbj->naj', root, jacobian).reshape(3 * count, 12)
    target = np.einsum('nba,nb->na', root, readings).reshape(3 * count)
    theta = np.linalg.lstsq(whitened, target, rcond=None)[0]
    residual = target - whitened @ theta
    freedom = max(3 * count - 12, 1)
    spread = np.linalg.inv(np.linalg.qr(whitened, mode='r'))
    covariance = spread @ spread.T * float(residual @ residual) / freedom
    return theta.reshape(3, 4).T, covariance


def _fit_stand(readings, truth, g_scale, weights=None):
    """
    Return the StandFit of checked, finite readings and truth (see ``fit_stand``).

    ``weights`` (N, 3, 3): inverse covariances of the positions' readings
    (``_attitude_weights``); None: each reading's axes alike and independent.
    """
    count = readings.shape[0]
    design = np.column_stack([truth / g_scale, np.ones(count)])
    condition = _condition_number(design)
    if condition > MAX_CONDITION_NUMBER:
        raise StandFitRefused(
            f'ill-posed position set: the design [G/|G|, 1] has rank '
            f'{np.linalg.matrix_rank(design)} of 4 and condition number {condition:.3g} '
            f'(limit {MAX_CONDITION_NUMBER:g}); the positions must turn every axis both '
            'up and down (not all with one axis vertical, not all at one inclination)')
    if weights is None:
        coefficients = np.linalg.lstsq(design, readings, rcond=None)[0]
    else:
        coefficients, by_axis = _weighted_coefficients(design, readings, weights)
    scale_matrix = coefficients[:3].T / g_scale
    _refuse_singular(scale_matrix)
    bias = coefficients[3]

    residual = readings - design @ coefficients
    # Each row's coefficients (K_i * g_scale, b_i) have s^2 (X^T X)^-1, s^2 the residual's
    # mean square per degree of freedom pooled over the axes (weighted: N^-1 scaled by the
    # reduced chi-square, every pair of axes); to (K^-1, b) through
    # dK^-1 = -K^-1 dK K^-1 (row-major: -K^-1 kron K^-T).
    units = np.array([1.0 / g_scale] * 3 + [1.0])
    order = [index for axis in range(3) for index in (3 * axis, 3 * axis + 1, 3 * axis + 2,
                                                      9 + axis)]
    rows = np.zeros((12, 12))
    if weights is None:
        pooled = float(np.sum(residual ** 2)) / max(3 * (count - 4), 1)
        unscaled = np.linalg.pinv(design.T @ design)
        for axis in range(3):
            index = order[4 * axis:4 * axis + 4]
            rows[np.ix_(index, index)] = pooled * unscaled * units[:, None] * units[None, :]
    else:
        scaled = np.tile(units, 3)
        rows[np.ix_(order, order)] = by_axis * scaled[:, None] * scaled[None, :]
    inverse = np.linalg.inv(scale_matrix)
    turn = np.eye(12)
    turn[:9, :9] = -np.kron(inverse, inverse.T)
    inclination_residual_deg = np.degrees(
        inclination(correct_stand(readings, scale_matrix, bias)) - inclination(truth))
    return StandFit(
        scale_matrix=scale_matrix, bias_mps2=bias, condition_number=condition,
        residual_mps2=residual, inclination_residual_deg=inclination_residual_deg,
        rms_residual_mps2=_rms(residual), rms_inclination_deg=_rms(inclination_residual_deg),
        parameter_covariance=turn @ rows @ turn.T)


def fit_sphere(readings, g):
    """
    Return the reference-free fit of readings of a still sensor in many attitudes.

    With no stand the only truth is ``|G| = g``, so the readings lie on the
    ellipsoid ``|K^-1 (A - b)| = g``.  It fixes K only up to a rotation:
    ``K Q`` fits as well as K for every rotation Q.  K is therefore returned
    upper triangular (positive diagonal): then ``A_z = K_zz G_z``, i.e. the
    corrected frame has its z axis along the z sensing axis and its y axis in
    the plane of the y and z sensing axes.  The six numbers are the three
    scales and three non-orthogonalities; the rotation of that frame against
    the tool is what seed 000's level bench measures next (its roll about z,
    unobservable from gravity, only offsets the toolface).

    Linear algebraic fit: ``u^T M u + l . u = 1`` with ``u = A / g`` gives
    the centre ``c = -M^-1 l / 2``, ``M / (1 + c^T M c) = R^T R`` (Cholesky,
    R upper triangular) and ``K = R^-1``, ``b = g c``; ``u`` is taken about
    the readings' mean (added back to c), which keeps the design well
    conditioned when the centre lies far from zero.  Its bias from noise
    is of order (noise / g)^2, negligible for a still, averaged capture.

    Raises StandFitRefused for fewer than MIN_SPHERE_READINGS readings,
    non-finite ones or ones beyond MAX_READING_RATIO g (checked before any
    arithmetic), readings not spread over the sphere (design condition number
    above MAX_CONDITION_NUMBER), readings on no ellipsoid and a numerical
    failure of the solve.
    """
    readings = as_vectors(readings, 'readings')
    _refuse_unusable(readings, MIN_SPHERE_READINGS, 'reading(s)',
                     'for a sphere fit (9 unknowns: upper-triangular K and b)')
    if not 0.0 < g < math.inf:
        raise ValueError(f'g must be a positive finite number, not {g!r}')
    _refuse_beyond(readings, g)
    try:
        return _fit_sphere(readings, g)
    except np.linalg.LinAlgError as err:
        raise StandFitRefused(f'numerical failure of the fit ({err})') from None


def _fit_sphere(readings, g):
    """Return the SphereFit of checked, finite readings (see ``fit_sphere``)."""
    count = readings.shape[0]
    # Centred on the readings' mean: the algebraic design of readings whose centre lies far
    # from zero (a magnetometer's hard iron as large as the field, on real instruments) is
    # ill-conditioned however well they spread; the ellipsoid is found about the mean and
    # moved back.
    offset = np.mean(readings, axis=0) / g
    u = readings / g - offset
    x, y, z = u.T
    design = np.column_stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z, x, y, z])
    condition = _condition_number(design)
    if condition > MAX_CONDITION_NUMBER:
        raise StandFitRefused(
            f'readings do not spread over the sphere: the ellipsoid design has condition '
            f'number {condition:.3g} (limit {MAX_CONDITION_NUMBER:g}); tilt the tool through '
            'attitudes that turn every axis both up and down')
    p = np.linalg.lstsq(design, np.ones(count), rcond=None)[0]
    quadratic = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    centre = -0.5 * np.linalg.solve(quadratic, p[6:])
    try:
        upper = np.linalg.cholesky(quadratic / (1.0 + centre @ quadratic @ centre)).T
    except np.linalg.LinAlgError:
        raise StandFitRefused('the readings lie on no ellipsoid (the fitted quadric is not '
                              'positive definite): not a still accelerometer?') from None
    scale_matrix = np.linalg.inv(upper)
    _refuse_singular(scale_matrix)
    bias = g * (centre + offset)
    residual = np.linalg.norm(correct_stand(readings, scale_matrix, bias), axis=1) - g
    return SphereFit(scale_matrix=scale_matrix, bias_mps2=bias, condition_number=condition,
                     residual_mps2=residual, rms_residual_mps2=_rms(residual),
                     parameter_covariance=sphere_covariance(readings, upper, bias, residual))


#: Row-major indices of an upper-triangular 3x3 matrix's free elements.
_UPPER = [3 * row + column for row in range(3) for column in range(row, 3)]


def sphere_covariance(readings, inverse, bias, residual):
    """
    Return the (12, 12) covariance of (K^-1 row-major, b) of a sphere fit (Gauss-Newton).

    The fit minimises r_i = |K^-1 (A_i - b)| - g over the six free elements of
    the upper-triangular K^-1 and b (its algebraic solution is the
    least-squares one to first order): with u_i = K^-1 (A_i - b) / |...|,
    dr_i / dK^-1_jk = u_ij (A_i - b)_k and dr_i / db = -K^-T u_i; the
    covariance is s^2 (J^T J)^-1, s^2 = sum r^2 / (N - 9).  ``inverse``:
    K^-1 (upper triangular).
    """
    centred = readings - bias
    corrected = centred @ inverse.T
    unit = corrected / np.linalg.norm(corrected, axis=1, keepdims=True)
    jacobian = np.column_stack([
        (unit[:, :, None] * centred[:, None, :]).reshape(-1, 9)[:, _UPPER],
        -unit @ inverse])
    count = readings.shape[0]
    free = np.linalg.pinv(jacobian.T @ jacobian) * (
        float(np.sum(residual ** 2)) / max(count - 9, 1))
    index = _UPPER + [9, 10, 11]
    covariance = np.zeros((12, 12))
    covariance[np.ix_(index, index)] = free
    return covariance


def consecutive_poses(readings, min_samples=6, jump_ratio=10.0, min_jump_deg=1.0):
    """
    Return the pose number of each reading (N,) when they are samples of still poses, or None.

    Readings in the order taken, the samples of each still pose together (a
    log's still samples, the motion between them cut out): consecutive
    samples of one pose turn by their noise, a change of pose by much more.
    A pose ends where the direction jumps by more than ``jump_ratio`` times
    the median turn between consecutive readings (and ``min_jump_deg``).
    None when the readings are not such samples: fewer than
    MIN_SPHERE_READINGS poses of at least ``min_samples`` samples holding at
    least half the readings (single readings in many attitudes).  Poses of
    fewer samples are numbered -1 (left out).
    """
    readings = as_vectors(readings, 'readings')
    if readings.shape[0] < MIN_SPHERE_READINGS * min_samples:
        return None
    turn_deg = np.degrees(angle_between(readings[1:], readings[:-1]))
    jump = turn_deg > max(min_jump_deg, jump_ratio * float(np.median(turn_deg)))
    pose = np.concatenate([[0], np.cumsum(jump)])
    counts = np.bincount(pose)
    kept = counts >= min_samples
    if kept.sum() < MIN_SPHERE_READINGS or counts[kept].sum() < 0.5 * readings.shape[0]:
        return None
    number = np.full(counts.size, -1)
    number[kept] = np.arange(kept.sum())
    return number[pose]


def rotation_part(matrix):
    """
    Return the rotation nearest ``matrix`` (3x3): the orthogonal factor of its polar decomposition.

    ``matrix = U P`` with U a rotation and P symmetric positive definite
    (``scipy.linalg.polar``).  For a correction ``K^-1`` it is the turn the
    correction gives the sensing axes, free of their scales and of the
    symmetric part of their non-orthogonality.  ValueError for a reflection
    (a determinant that is not positive).
    """
    matrix = np.asarray(matrix, dtype=float)
    if not np.linalg.det(matrix) > 0.0:
        raise ValueError('the matrix mirrors (determinant not positive): no rotation part')
    return polar(matrix)[0]


def _refuse_unusable(readings, minimum, what, why):
    """Refuse (StandFitRefused) fewer than ``minimum`` readings, or any not finite."""
    if readings.shape[0] < minimum:
        raise StandFitRefused(f'only {readings.shape[0]} {what}, need at least {minimum} {why}')
    _refuse_non_finite(readings, 'readings')


def _refuse_non_finite(values, name):
    """Raise StandFitRefused naming the positions (1-based) with non-finite values."""
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if bad.size:
        raise StandFitRefused(f'non-finite {name} at position(s) {(bad + 1).tolist()}')


def _norms(vectors):
    """Return |v| of each row, computed without overflow (``hypot``)."""
    return np.hypot(np.hypot(vectors[:, 0], vectors[:, 1]), vectors[:, 2])


def _refuse_beyond(readings, g):
    """Raise StandFitRefused naming the readings (1-based) beyond MAX_READING_RATIO g."""
    bad = np.flatnonzero(_norms(readings) > MAX_READING_RATIO * g)
    if bad.size:
        raise StandFitRefused(
            f'reading(s) {(bad + 1)[:10].tolist()} exceed {MAX_READING_RATIO:g} times g '
            f'(largest |A| {_norms(readings).max():.4g}): not a still sensor, or another unit')


def _condition_number(matrix):
    """Return the 2-norm condition number, infinity for a rank-deficient matrix."""
    singular = np.linalg.svd(matrix, compute_uv=False)
    return math.inf if singular[-1] == 0.0 else float(singular[0] / singular[-1])


def _refuse_singular(scale_matrix):
    """Raise StandFitRefused when K is too ill-conditioned to invert (Eq. 11)."""
    condition = _condition_number(scale_matrix)
    if condition > MAX_CONDITION_NUMBER:
        raise StandFitRefused(
            f'the fitted K has condition number {condition:.3g} (limit '
            f'{MAX_CONDITION_NUMBER:g}): an axis does not respond or two axes sense one '
            'direction')


def _rms(values):
    """Return the root mean square of all elements."""
    return float(np.sqrt(np.mean(np.square(values))))


#: Stand positions whose temperatures lie closer than this [deg C] are one plateau.
PLATEAU_GAP_C = 2.0


@dataclass(frozen=True)
class TemperatureStandFit:
    """
    A stand calibration at two or more temperature plateaus: K(T), b(T), element by element.

    Each plateau is fitted alone (``fit_stand``: its own K and b, with their
    residual); every element of K and b is then a polynomial of T, in powers of
    ``(T - centre_c)``, of the lowest ``order`` (at most plateaus - 1) whose
    values at the plateaus agree with the plateau fits within their noise
    (``fit_stand_plateaus``).  Valid over ``range_c`` only.
    """

    plateaus_c: np.ndarray           # (P,) mean temperature of each plateau
    fits: tuple                      # the StandFit of each plateau
    order: int
    centre_c: float
    scale_coefficients: np.ndarray   # (order + 1, 3, 3), powers of (T - centre_c)
    bias_coefficients: np.ndarray    # (order + 1, 3)
    element_sigma: np.ndarray        # (P, 12) 1 sigma of K and b of each plateau fit
    chi_square: tuple                # per order tried: (order, chi-square, degrees of freedom)
    # (12 (order + 1), 12 (order + 1)) of the coefficients, power by power: K row-major (9)
    # then b (3) of (T - centre_c)^0, then of ^1, ... (``coefficient_covariance``)
    parameter_covariance: np.ndarray = None

    @property
    def range_c(self):
        """Return (lowest, highest) plateau temperature: the range the fit holds."""
        return float(self.plateaus_c.min()), float(self.plateaus_c.max())

    def at(self, temperature_c):
        """Return (K, b) at the temperature(s) ``temperature_c``: shapes (..., 3, 3), (..., 3)."""
        powers = np.power.outer(np.asarray(temperature_c, dtype=float) - self.centre_c,
                                np.arange(self.order + 1))
        return (np.tensordot(powers, self.scale_coefficients, axes=1),
                np.tensordot(powers, self.bias_coefficients, axes=1))

    def sigma_at(self, temperature_c):
        """
        Return the 1 sigma of K(T), b(T)'s 12 elements (K row-major, b) at ``temperature_c``.

        The coefficients' ``parameter_covariance`` through the powers of
        ``T - centre_c``: ``sqrt(diag(P C P^T))``, ``P = powers kron I_12``.
        """
        powers = np.power.outer(float(temperature_c) - self.centre_c, np.arange(self.order + 1))
        change = np.kron(powers[None, :], np.eye(12))
        return np.sqrt(np.diag(change @ self.parameter_covariance @ change.T))

    def apply(self, readings, temperature_c):
        """Return ``K(T)^-1 (A - b(T))`` of readings (N, 3) at their temperatures (N,)."""
        readings = as_vectors(readings, 'readings')
        scale, bias = self.at(np.broadcast_to(temperature_c, readings.shape[:1]))
        return np.linalg.solve(scale, (readings - bias)[..., None])[..., 0]


def plateau_numbers(temperatures_c, gap_c=PLATEAU_GAP_C):
    """Return the plateau number (0, 1, ... by temperature) of each position's temperature."""
    temperatures_c = np.asarray(temperatures_c, dtype=float).reshape(-1)
    order = np.argsort(temperatures_c, kind='stable')
    steps = np.diff(temperatures_c[order]) > gap_c
    number = np.empty(temperatures_c.size, dtype=int)
    number[order] = np.concatenate([[0], np.cumsum(steps)])
    return number


def fit_stand_plateaus(readings, truth, temperatures_c, gap_c=PLATEAU_GAP_C,
                       significance=0.05):
    """
    Return the TemperatureStandFit of stand positions at two or more temperature plateaus.

    ``readings``, ``truth`` (N, 3) as ``fit_stand``; ``temperatures_c`` (N,)
    each position's temperature: positions closer than ``gap_c`` in
    temperature form one plateau, each fitted by ``fit_stand`` (its
    refusals, named with the plateau).  The 12 elements of K and b of each
    plateau carry the covariance of their fit with the residual noise pooled
    over the plateaus (``pooled_covariances``: one sensor's noise, measured
    with every plateau's degrees of freedom).  Order k = 0, 1, ..., P - 1 of
    the polynomial in T is tried in turn (each element by weighted least
    squares over the plateaus); the first whose residuals' generalised
    chi-square per degree of freedom (``_lack_of_fit_ratio``, the elements'
    correlation within a plateau fit kept) stays below the ``1 -
    significance`` quantile of F(its freedom, the pooled noise's) is taken
    (P - 1 interpolates and always passes).  0.05 rather than stricter: a
    drift the test misses is in no 1 sigma but the Birge ratio's, while a
    needless higher order costs only variance, which the covariance carries.
    A per-element chi-square with
    each plateau's own noise (5 degrees of freedom an axis of nine positions,
    its mean square taken over 9) chose orders 0-4 about equally on a
    temperature-independent sensor.  The coefficients carry their covariance
    from the plateau fits' (``coefficient_covariance``).  Raises
    StandFitRefused for fewer than two plateaus.
    """
    from scipy.stats import f as fisher

    readings, truth = as_vectors(readings, 'readings'), as_vectors(truth, 'truth')
    plateau = plateau_numbers(temperatures_c, gap_c)
    temperatures_c = np.asarray(temperatures_c, dtype=float).reshape(-1)
    count = int(plateau.max()) + 1
    if count < 2:
        raise StandFitRefused(
            f'the positions stand at one temperature plateau ({temperatures_c.min():.1f} .. '
            f'{temperatures_c.max():.1f} C): a temperature-dependent stand needs two or more '
            f'plateaus more than {gap_c:g} C apart')
    fits, values, centres, covariances, squares = [], [], [], [], []
    for number in range(count):
        mine = plateau == number
        try:
            fit = fit_stand(readings[mine], truth[mine])
        except StandFitRefused as err:
            raise StandFitRefused(f'plateau {number + 1} '
                                  f'({temperatures_c[mine].mean():.1f} C): {err.reason}') from None
        values.append(np.concatenate([fit.scale_matrix.ravel(), fit.bias_mps2]))
        covariances.append(scale_bias_covariance(fit))
        squares.append((float(np.sum(fit.residual_mps2 ** 2)), 3 * (mine.sum() - 4)))
        fits.append(fit)
        centres.append(temperatures_c[mine].mean())
    values, centres = np.array(values), np.array(centres)
    covariances = pooled_covariances(np.array(covariances), squares)
    noise_freedom = max(sum(freedom for _, freedom in squares), 1)
    # At least 1e-12 of the element's value, so that an exact fit does not divide by zero.
    sigma = np.maximum(np.sqrt(np.diagonal(covariances, axis1=1, axis2=2)),
                       1e-12 * np.abs(values).max(axis=0) + 1e-300)
    centre = float(centres.mean())
    tried = []
    for order in range(count):
        design = np.power.outer(centres - centre, np.arange(order + 1))
        estimator = np.empty((12, order + 1, count))   # coefficients = estimator @ values
        for element in range(12):
            weights = 1.0 / sigma[:, element]
            estimator[element] = np.linalg.pinv(design * weights[:, None]) * weights[None, :]
        coefficients = np.einsum('ekp,pe->ke', estimator, values)
        freedom = 12 * (count - order - 1)
        if freedom == 0:
            tried.append((order, 0.0, 0))
            break
        ratio = _lack_of_fit_ratio(estimator, covariances, design, values)
        tried.append((order, ratio * freedom, freedom))
        if ratio <= fisher.ppf(1.0 - significance, freedom, noise_freedom):
            break
    return TemperatureStandFit(
        plateaus_c=centres, fits=tuple(fits), order=order, centre_c=centre,
        scale_coefficients=coefficients[:, :9].reshape(-1, 3, 3),
        bias_coefficients=coefficients[:, 9:], element_sigma=sigma, chi_square=tuple(tried),
        parameter_covariance=coefficient_covariance(estimator, covariances, design, values))


def scale_bias_covariance(fit):
    """
    Return the (12, 12) covariance of (K row-major, b) of a StandFit.

    Its ``parameter_covariance`` is of (K^-1, b); ``dK = -K dK^-1 K``
    (row-major: ``-K kron K^T``) turns it back.
    """
    turn = np.eye(12)
    turn[:9, :9] = -np.kron(fit.scale_matrix, fit.scale_matrix.T)
    return turn @ fit.parameter_covariance @ turn.T


def pooled_covariances(covariances, squares):
    """
    Return each plateau fit's (12, 12) covariance with the noise pooled over the plateaus.

    ``covariances`` (P, 12, 12) of (K row-major, b), each scaled by its own
    residual mean square; ``squares`` (P, 2): each plateau fit's sum of
    squared residuals and degrees of freedom.  Every C_p takes their pooled
    mean square for its own (the plateaus measure one sensor's noise, as one
    stand fit pools its axes: nine positions leave a plateau 15 degrees of
    freedom, whose Student t puts 0.936 within 2 sigma, three pool 45: 0.949).
    """
    squares = np.array(squares, dtype=float)
    own = squares[:, 0] / np.maximum(squares[:, 1], 1.0)
    pooled = squares[:, 0].sum() / max(squares[:, 1].sum(), 1.0)
    return covariances * np.where(own > 0, pooled / np.where(own > 0, own, 1.0),
                                  0.0)[:, None, None]


def coefficient_covariance(estimator, covariances, design=None, values=None):
    """
    Return the (12 (n + 1), 12 (n + 1)) covariance of K(T), b(T)'s coefficients, power by power.

    The coefficients of element e are ``estimator[e] @ v_e`` (``estimator``
    (12, n + 1, P): the weighted least squares over the plateaus), v_e that
    element of the P plateau fits, independent fits of covariances
    ``covariances`` (P, 12, 12) of (K row-major, b) each (``pooled_covariances``):
    so ``cov(c_ke, c_lf) = sum_p E_e[k, p] C_p[e, f] E_f[l, p]`` (the sandwich
    of the estimator used: the elements' correlation within a plateau fit
    kept, which the per-element weights leave out).

    A polynomial of lower order than the plateaus allow (``design`` (P, n + 1)
    of the plateaus' powers, n + 1 < P) leaves residuals against the plateau
    fits' ``values`` (P, 12): their chi-square under their own covariance
    (generalised: the residuals' covariance ``(I - H) V (I - H)^T``, of rank
    12 (P - n - 1)) per degree of freedom, when above 1, scales the
    covariance (a Birge ratio): a drift the order left out, unseen under the
    test's significance, still shows in it.
    """
    terms, count = estimator.shape[1:]
    joint = np.einsum('ekp,pef,flp->kelf', estimator, covariances, estimator)
    joint = joint.reshape(12 * terms, 12 * terms)
    if design is not None and terms < count:
        joint = joint * max(1.0, _lack_of_fit_ratio(estimator, covariances, design, values))
    return 0.5 * (joint + joint.T)


def _lack_of_fit_ratio(estimator, covariances, design, values):
    """Return the chi-square per degree of freedom of the plateaus' polynomial residuals."""
    terms, count = estimator.shape[1:]
    # Every element and plateau at once: v (P 12,), theta = E v (terms 12,), fitted X theta.
    element = np.arange(12)
    whole = np.zeros((terms, 12, count, 12))
    whole[:, element, :, element] = estimator
    whole = whole.reshape(12 * terms, 12 * count)
    powers = np.kron(design, np.eye(12))                     # (P 12, terms 12)
    residual_map = np.eye(12 * count) - powers @ whole
    stacked = np.zeros((count, 12, count, 12))
    stacked[np.arange(count), :, np.arange(count), :] = covariances
    spread = residual_map @ stacked.reshape(12 * count, 12 * count) @ residual_map.T
    residual = residual_map @ np.asarray(values, dtype=float).reshape(-1)
    # Each element in its own 1 sigma (K's and a bias in nT lie 1e5 apart), so that the
    # pseudo-inverse cuts the residuals' null space only.
    unit = np.sqrt(np.diag(spread))
    unit = np.where(unit > 0.0, unit, 1.0)
    scaled = residual / unit
    inverse = np.linalg.pinv(spread / np.outer(unit, unit), rcond=1e-9, hermitian=True)
    return float(scaled @ inverse @ scaled / (12 * (count - terms)))


def plateau_stand_fit(plateaus, readings, truth, temperatures_c):
    """
    Return the StandFit view of a TemperatureStandFit over all its positions.

    K and b at the plateaus' centre; each position's residual against K(T),
    b(T) at its own temperature; the attitudes (plateaus visit the same ones:
    repeats) and their repeatability as ``fit_stand`` reports them.
    """
    readings, truth = as_vectors(readings, 'readings'), as_vectors(truth, 'truth')
    temperatures_c = np.asarray(temperatures_c, dtype=float).reshape(-1)
    scale, bias = plateaus.at(temperatures_c)
    residual = readings - (np.einsum('nij,nj->ni', scale, truth) + bias)
    corrected = plateaus.apply(readings, temperatures_c)
    inclination_residual_deg = np.degrees(inclination(corrected) - inclination(truth))
    attitude = attitude_numbers(truth)
    per_attitude, overall = repeatability(corrected, truth, attitude)
    centre_scale, centre_bias = plateaus.at(plateaus.centre_c)
    return StandFit(
        scale_matrix=centre_scale, bias_mps2=centre_bias,
        condition_number=max(fit.condition_number for fit in plateaus.fits),
        residual_mps2=residual, inclination_residual_deg=inclination_residual_deg,
        rms_residual_mps2=_rms(residual), rms_inclination_deg=_rms(inclination_residual_deg),
        attitude=attitude, repeatability_deg=per_attitude, rms_repeatability_deg=overall)
