"""
Cross-axial magnetometer correction from one rotation of the tool (seed 002 §2.1).

While the tool turns about its own axis the axial field Bz and the total field
stay constant, so ``Bx^2 + By^2 = |B|^2 - Bz^2`` is constant (seed 002
Eqs. 15-16): undisturbed cross-axial readings lie on a circle.  Hard iron
(a fixed field of the tool) shifts that circle, soft iron and unequal axis
scales stretch it into an ellipse.  Seed 002 fits the ellipse and takes its
parameters as the correction coefficients (Eqs. 17-22, after Flook et al.
2013; the equations are lost in our copy): the standard ellipse correction is
used here (formulas.md, "Multi-station analysis").

Model: ``m = A h + c`` with ``h`` the true cross-axial field on a circle of
radius r, ``c`` the hard-iron offset and ``A`` the soft-iron/scale matrix.
The fitted ellipse ``(m - c)^T Q (m - c) = 1`` gives c and ``Q = (A A^T)^-1``;
the correction ``h_hat = W (m - c)`` with ``W = r_bar Q^(1/2)`` (symmetric,
so no turn about the tool axis is added: such a turn is unobservable from a
rotation) maps the ellipse onto a circle of radius ``r_bar = sqrt(a b)``, the
geometric mean of the semi-axes (the circle of the ellipse's area).  The scale
of A and r cannot be separated from one rotation; ``r_bar`` keeps the
cross-axial magnitude to first order in the soft iron (``r sqrt(det A)``).

Vectors are in nT, in either frame whose z is the tool axis (the node and the
calibration file use the z-up tool frame; x and y are the same in ISCWSA).
"""

from dataclasses import dataclass
import math

from inclino_ros.core.refusal import Refused
import numpy as np


class RotationFitRefused(Refused):
    """A rotation capture that cannot give a trustworthy cross-axial correction."""


@dataclass(frozen=True)
class RotationLimits:
    """
    Acceptance limits of a rotation capture.

    ``min_samples``: 5 conic parameters plus enough redundancy for the RMSE to
    mean something.  ``min_coverage_deg``: on a shorter arc the ellipse centre
    and shape trade off against each other (the fit is ill conditioned).
    ``max_axis_ratio``: a few % of soft iron is usual; beyond 1.2 the capture
    is more likely not a rotation about the tool axis (Bz changing) or a
    magnetised collar, not something to correct silently.
    ``max_relative_rmse``: radial scatter of the corrected points over the
    radius; beyond it the points do not lie on an ellipse.
    """

    min_samples: int = 20
    min_coverage_deg: float = 270.0
    max_axis_ratio: float = 1.2
    max_relative_rmse: float = 0.05


@dataclass(frozen=True)
class CrossAxialFit:
    """
    The cross-axial correction of one rotation capture.

    ``offset_nT`` (2,) is the hard iron c, ``correction`` the symmetric 2x2 W
    of ``h = W (m - c)``, ``radius_nT`` the corrected circle's radius,
    ``rmse_nT`` the RMS radial residual of the corrected samples,
    ``coverage_deg`` 360 minus the largest angular gap between samples about
    the fitted centre, ``axis_ratio`` major over minor semi-axis.
    """

    offset_nT: np.ndarray
    correction: np.ndarray
    radius_nT: float
    rmse_nT: float
    coverage_deg: float
    axis_ratio: float
    sample_count: int
    parameter_covariance: np.ndarray = None  # (6, 6) of (W row-major, c): ``rotation_covariance``


def fit_ellipse(points):
    """
    Return (centre, Q) of the direct least-squares ellipse through ``points``.

    Fitzgibbon, Pilu & Fisher, "Direct least square fitting of ellipses", IEEE
    PAMI 21(5), 1999, in the numerically stable form of Halir & Flusser (WSCG
    1998): the conic ``a x^2 + b xy + c y^2 + d x + e y + f = 0`` minimising the
    algebraic residual under ``4ac - b^2 = 1``.  The points are centred and
    scaled first (by the largest value, then by their spread: no square
    overflows or underflows).  The ellipse is ``(p - centre)^T Q (p - centre) = 1``.
    Raises RotationFitRefused when no ellipse fits (e.g. collinear points,
    all zero, a numerical failure), never another error.
    """
    points = np.asarray(points, dtype=float)
    # Scaled by the largest value first, so no square below overflows or vanishes.
    largest = np.max(np.abs(points), initial=0.0)
    if not 0.0 < largest < math.inf:
        raise RotationFitRefused('degenerate fit: the samples are all zero or not finite')
    unit = points / largest
    mean = unit.mean(axis=0)
    scale = math.sqrt(np.mean(np.sum((unit - mean) ** 2, axis=1)))
    if not scale > 1e-12:
        raise RotationFitRefused('degenerate fit: all samples are the same point')
    try:
        centre, q = _direct_ellipse((unit - mean) / scale)
    except (np.linalg.LinAlgError, ValueError, FloatingPointError) as err:
        raise RotationFitRefused(f'degenerate fit: numerical failure ({err})') from None
    with np.errstate(over='ignore', under='ignore'):
        size = largest * scale  # a numpy float: overflows to inf, never raises
        centre, q = largest * (mean + scale * centre), q / size / size
    if not (np.all(np.isfinite(centre)) and np.all(np.isfinite(q))):
        raise RotationFitRefused('degenerate fit: the fitted ellipse is not finite')
    return centre, q


def _direct_ellipse(points):
    """Return (centre, Q) of the ellipse through centred, unit-scaled points (``fit_ellipse``)."""
    x, y = points.T
    quadratic = np.stack([x * x, x * y, y * y], axis=1)
    linear = np.stack([x, y, np.ones_like(x)], axis=1)
    s1, s2, s3 = quadratic.T @ quadratic, quadratic.T @ linear, linear.T @ linear
    try:
        t = -np.linalg.solve(s3, s2.T)
    except np.linalg.LinAlgError:
        raise RotationFitRefused('degenerate fit: the samples are collinear') from None
    reduced = s1 + s2 @ t
    # C1^-1 reduced, C1 = [[0, 0, 2], [0, -1, 0], [2, 0, 0]] (the constraint matrix).
    reduced = np.stack([reduced[2] / 2.0, -reduced[1], reduced[0] / 2.0])
    if not np.all(np.isfinite(reduced)):
        raise RotationFitRefused('degenerate fit: the samples give no finite conic')
    _, vectors = np.linalg.eig(reduced)
    vectors = np.real(vectors)
    constraint = 4.0 * vectors[0] * vectors[2] - vectors[1] ** 2
    if not np.any(constraint > 0.0):
        raise RotationFitRefused('degenerate fit: the samples do not lie on an ellipse')
    a, b, c = vectors[:, np.argmax(constraint)]
    d, e, f = t @ np.array([a, b, c])
    conic = np.array([[a, b / 2.0], [b / 2.0, c]])
    centre = np.linalg.solve(conic, [-d / 2.0, -e / 2.0])
    level = -(f + centre @ np.array([d, e]) / 2.0)
    q = conic / level
    if not (np.all(np.isfinite(q)) and np.all(np.linalg.eigvalsh(q) > 0.0)):
        raise RotationFitRefused('degenerate fit: the fitted conic is not a real ellipse')
    return centre, q


def _coverage_deg(points):
    """Return 360 deg minus the largest angular gap between the (centred) points."""
    angles = np.sort(np.degrees(np.arctan2(points[:, 1], points[:, 0])))
    gaps = np.diff(np.append(angles, angles[0] + 360.0))
    return 360.0 - float(gaps.max())


def fit_cross_axial(samples_nT, limits=RotationLimits()):
    """
    Return the CrossAxialFit of a rotation capture, or raise RotationFitRefused.

    ``samples_nT``: shape (N, 2) or (N, 3) (only x and y are used), the
    magnetometer readings while the tool turns about its axis at one depth.
    Checks, in order: enough samples, all finite, an ellipse fits, its axis
    ratio, the angular coverage of the corrected samples about the centre, the
    radial RMSE.  Raises nothing else, whatever the numbers (the units and
    magnitudes of a magnetometer are checked by its callers,
    ``calibration.plausibility.check_field_readings``).
    """
    samples = np.asarray(samples_nT, dtype=float)[:, :2]
    count = samples.shape[0]
    if count < limits.min_samples:
        raise RotationFitRefused(
            f'only {count} sample(s) in the rotation, need at least {limits.min_samples}')
    if not np.all(np.isfinite(samples)):
        raise RotationFitRefused('the rotation holds non-finite readings')
    offset, q = fit_ellipse(samples)
    eigenvalues, eigenvectors = np.linalg.eigh(q)
    semi_axes = 1.0 / np.sqrt(eigenvalues)
    axis_ratio = float(semi_axes.max() / semi_axes.min())
    if axis_ratio > limits.max_axis_ratio:
        raise RotationFitRefused(
            f'degenerate fit: axis ratio {axis_ratio:.3f} exceeds {limits.max_axis_ratio}')
    radius = float(math.sqrt(semi_axes.prod()))
    correction = radius * (eigenvectors * np.sqrt(eigenvalues)) @ eigenvectors.T
    corrected = (samples - offset) @ correction.T
    coverage = _coverage_deg(corrected)
    if coverage < limits.min_coverage_deg:
        raise RotationFitRefused(
            f'the rotation covers {coverage:.1f} deg about the fitted centre, '
            f'need at least {limits.min_coverage_deg} deg')
    rmse = float(np.sqrt(np.mean((np.linalg.norm(corrected, axis=1) - radius) ** 2)))
    if not (math.isfinite(radius) and math.isfinite(rmse) and np.all(np.isfinite(correction))):
        raise RotationFitRefused('degenerate fit: the correction is not finite')
    if not rmse <= limits.max_relative_rmse * radius:
        raise RotationFitRefused(
            f'the samples do not lie on an ellipse: radial RMSE {rmse:.1f} nT exceeds '
            f'{limits.max_relative_rmse} of the radius {radius:.1f} nT')
    return CrossAxialFit(offset_nT=offset, correction=correction, radius_nT=radius,
                         rmse_nT=rmse, coverage_deg=coverage, axis_ratio=axis_ratio,
                         sample_count=count, parameter_covariance=rotation_covariance(
                             samples, offset, correction, radius))


def _correction_of(parameters):
    """
    Return (W, c, r) of p = (u, v, c_x, c_y, r): ``W = expm([[u, v], [v, -u]])``.

    Every symmetric W of determinant 1 (the fit's: ``r_bar^2 = a b``) is such
    an exponential: ``cosh(k) I + sinh(k) / k S``, k = hypot(u, v).
    """
    u, v, cx, cy, radius = parameters
    k = math.hypot(u, v)
    ratio = math.sinh(k) / k if k > 1e-12 else 1.0
    return (math.cosh(k) * np.eye(2) + ratio * np.array([[u, v], [v, -u]]),
            np.array([cx, cy]), radius)


def rotation_covariance(samples, offset, correction, radius):
    """
    Return the (6, 6) covariance of (W row-major, c) of a fitted rotation (ML, first order).

    The geometric residual ``|W (m - c)| - r`` of every sample against p =
    (u, v, c, r) (``_correction_of``, W's logarithm from its eigenvectors): its
    Jacobian J by central differences, ``s^2 (J^T J)^-1`` with s^2 the mean
    square residual per degree of freedom, carried to (W, c) the same way.
    """
    values, vectors = np.linalg.eigh(correction)
    logarithm = (vectors * np.log(values)) @ vectors.T
    start = np.array([logarithm[0, 0], logarithm[0, 1], offset[0], offset[1], radius])
    steps = np.array([1e-6, 1e-6, 1e-6 * radius, 1e-6 * radius, 1e-6 * radius])

    def residuals(parameters):
        w, c, r = _correction_of(parameters)
        return np.linalg.norm((samples - c) @ w.T, axis=1) - r

    def stored(parameters):
        w, c, _ = _correction_of(parameters)
        return np.concatenate([w.ravel(), c])

    def jacobian(function):
        return np.column_stack([(function(start + h) - function(start - h)) / (2.0 * h[i])
                                for i, h in enumerate(np.diag(steps))])

    jac = jacobian(residuals)
    freedom = max(samples.shape[0] - 5, 1)
    covariance = np.linalg.pinv(jac.T @ jac) * float(np.sum(residuals(start) ** 2)) / freedom
    turn = jacobian(stored)
    result = turn @ covariance @ turn.T
    return 0.5 * (result + result.T)


def apply_cross_axial(B, fit):
    """
    Return B (..., 3) [nT] with x and y corrected: ``W (m - c)``; z untouched.

    The axial component is left to the multi-station analysis (seed 002 §2.2).
    """
    B = np.array(B, dtype=float)
    B[..., :2] = (B[..., :2] - fit.offset_nT) @ fit.correction.T
    return B
