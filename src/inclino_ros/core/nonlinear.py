"""
A small smooth non-linear correction of the calibrated field, fitted from roll sets (issue 18).

After the linear calibration (ellipsoid, alignment, tool axis) a sensor whose
response is not linear (a fluxgate's or an AMR's scale changing with the
field along its axis) leaves an error that is a smooth function of each
axis's own component.  Shots of a roll set (the tool turned about one fixed
pointing direction) must read one field turned by each shot's toolface: each
set's fields turned back by their toolface and averaged, turned forward
again, give what each shot should read (the peer circuitpython-mag-cal's
target, ``fit_non_linear_quick``).  Per cross axis (x, y: a roll set keeps z
constant and cannot see its error) the difference is regressed on Gaussian
radial basis functions of that component over the field's magnitude:

    B_i <- B_i + s sum_k w_ik exp(-((B_i / s - c_k) / h)^2),  i in {x, y}

with ``RBF_CENTRES`` centres c_k over [-1, 1], width h = 1.5 / centres (the
peer's form), s the median |B| of the fit, and a ridge penalty ``RIDGE`` on w
(normalised units) that keeps an axis the roll sets barely sample near
zero.  Whether it is worth applying is judged on roll sets it was not fitted
on (``gate``): each set held out in turn.
"""

from dataclasses import dataclass
import math

from inclino_ros.core.magnetics import survey_of
import numpy as np

#: The candidate forms (Gaussian RBF centres per cross axis, ridge penalty on the weights per
#: shot, normalised units), the one with the best held-out figure taken (``gate``): chosen on
#: the 15 real instruments of test/data (sap6, mag_cal_cal_data), each roll set judged by the
#: stage fitted on the other, over 3, 4, 5 centres, ridge 0 .. 0.1 and polynomials of degree
#: 2-5: 3 centres, ridge 0.03 gave the largest summed held-out improvement (the peer's 5
#: unregularised centres made 11 of 15 worse held-out); on the simulator's cubic sensor
#: (``sim.sensor_model.Triad.cubic``) 3 centres recover little of it, 5 (ridge 0.01) most.
CANDIDATES = ((3, 0.03), (5, 0.01))
RBF_CENTRES, RIDGE = CANDIDATES[0]
#: Sigmas of the held-out improvement the gate asks for (paired, over the held-out shots).
GATE_SIGMAS = 2.0


def basis(x, centres=RBF_CENTRES):
    """Return the Gaussian RBF design (N, centres) of normalised components ``x`` (N,)."""
    offsets = np.linspace(-1.0, 1.0, centres)
    return np.exp(-(((np.asarray(x, dtype=float)[:, None] - offsets[None, :])
                     / (1.5 / centres)) ** 2))


def _toolface(gravity):
    """Return the angle [rad] of each shot's gravity across the tool axis (its roll)."""
    return np.arctan2(gravity[:, 1], gravity[:, 0])


def roll_set_targets(gravity, field, roll_sets):
    """
    Return (x, y) of the fields each roll set's shots should read: (M, 2) for their M shots.

    ``gravity``, ``field`` (N, 3) in the tool frame; ``roll_sets``: index
    arrays.  Each set's cross-axial fields turned back by their roll, averaged,
    turned forward again.
    """
    expected = []
    for shots in roll_sets:
        roll = _toolface(gravity[shots])
        c, s = np.cos(roll), np.sin(roll)
        b = field[shots]
        mean_x = np.mean(c * b[:, 0] + s * b[:, 1])
        mean_y = np.mean(-s * b[:, 0] + c * b[:, 1])
        expected.append(np.column_stack([c * mean_x - s * mean_y, s * mean_x + c * mean_y]))
    return np.vstack(expected)


@dataclass(frozen=True)
class AxisCorrection:
    """The fitted correction: weights (2, centres), scale [nT], covariance (2 centres square)."""

    weights: np.ndarray
    scale_nT: float
    covariance: np.ndarray
    rms_residual_nT: float

    def apply(self, field):
        """Return ``field`` (N, 3) [nT] with its x and y corrected (the module's equation)."""
        return apply_correction(field, self.weights, self.scale_nT)


def apply_correction(field, weights, scale_nT):
    """Return ``field`` (..., 3) with x, y corrected by RBF ``weights`` (2, centres)."""
    field = np.array(field, dtype=float)
    flat = field.reshape(-1, 3)
    weights = np.asarray(weights, dtype=float)
    for axis in (0, 1):
        flat[:, axis] += scale_nT * basis(flat[:, axis] / scale_nT, weights.shape[1]) @ \
            weights[axis]
    return flat.reshape(field.shape)


def correction_jacobian(field, weights, scale_nT):
    """Return d(corrected field) / d(weights x then y) (N, 3, 2 centres) at ``field`` (N, 3)."""
    field = np.asarray(field, dtype=float)
    centres = np.shape(weights)[1]
    jacobian = np.zeros((field.shape[0], 3, 2 * centres))
    for axis in (0, 1):
        jacobian[:, axis, axis * centres:(axis + 1) * centres] = scale_nT * basis(
            field[:, axis] / scale_nT, centres)
    return jacobian


def fit_correction(gravity, field, roll_sets, centres=RBF_CENTRES, ridge=RIDGE):
    """
    Return the AxisCorrection fitted to ``roll_sets`` (ridge least squares per cross axis).

    The covariance of each axis's weights: the residual variance times the
    inverse normal matrix (ridge included), the two axes independent.
    """
    gravity, field = np.asarray(gravity, dtype=float), np.asarray(field, dtype=float)
    shots = np.concatenate([np.asarray(s) for s in roll_sets])
    scale = float(np.median(np.linalg.norm(field[shots], axis=1)))
    expected = roll_set_targets(gravity, field, roll_sets)
    weights = np.zeros((2, centres))
    covariance = np.zeros((2 * centres, 2 * centres))
    residuals = []
    for axis in (0, 1):
        design = basis(field[shots, axis] / scale, centres)
        target = (expected[:, axis] - field[shots, axis]) / scale
        normal = design.T @ design + ridge * len(shots) * np.eye(centres)
        weights[axis] = np.linalg.solve(normal, design.T @ target)
        residual = target - design @ weights[axis]
        residuals.append(residual)
        dof = max(len(shots) - centres, 1)
        inverse = np.linalg.inv(normal)
        covariance[axis * centres:(axis + 1) * centres, axis * centres:(axis + 1) * centres] = (
            np.sum(residual ** 2) / dof * inverse @ design.T @ design @ inverse)
    rms_nT = scale * float(np.sqrt(np.mean(np.square(np.concatenate(residuals)))))
    return AxisCorrection(weights=weights, scale_nT=scale, covariance=covariance,
                          rms_residual_nT=rms_nT)


def roll_set_deviations_deg(gravity, field, shots):
    """Return the azimuth deviations [deg] of a roll set's shots about their circular mean."""
    azimuth = np.radians(survey_of(gravity[shots], field[shots])['azimuth_deg'])
    mean = math.atan2(np.mean(np.sin(azimuth)), np.mean(np.cos(azimuth)))
    return np.degrees((azimuth - mean + math.pi) % (2.0 * math.pi) - math.pi)


@dataclass(frozen=True)
class Gate:
    """
    The held-out verdict on the correction: figures [deg] and the decision.

    ``before_deg``, ``after_deg``: RMS azimuth deviation of every roll set
    about its circular mean, each set corrected by the stage fitted on the
    OTHER sets (NaN: not judged), of the candidate form (``centres``,
    ``ridge``) with the lowest ``after_deg``; ``noise_deg``: 1 sigma of
    their difference (paired over the held-out shots); ``enabled`` when the
    improvement exceeds ``GATE_SIGMAS`` of it; ``reason``: why, in words.
    """

    before_deg: float
    after_deg: float
    noise_deg: float
    enabled: bool
    reason: str
    roll_sets: int
    centres: int = RBF_CENTRES
    ridge: float = RIDGE


def held_out_deg(gravity, field, roll_sets, centres, ridge):
    """Return (before, after) azimuth deviations [deg] of each set held out in turn, pooled."""
    before, after = [], []
    for k, held in enumerate(roll_sets):
        correction = fit_correction(gravity, field, roll_sets[:k] + roll_sets[k + 1:],
                                    centres, ridge)
        before.append(roll_set_deviations_deg(gravity, field, held))
        after.append(roll_set_deviations_deg(gravity, correction.apply(field), held))
    return np.concatenate(before), np.concatenate(after)


def gate(gravity, field, roll_sets, candidates=CANDIDATES, sigmas=GATE_SIGMAS):
    """
    Return the Gate of the correction on ``roll_sets``: each held out in turn.

    Every candidate form is judged so; the best held-out one is the verdict.
    Needs at least 2 roll sets (one set cannot judge a correction fitted on
    itself): with fewer, not enabled, the figures NaN.
    """
    roll_sets = [np.asarray(s) for s in roll_sets]
    if len(roll_sets) < 2:
        return Gate(math.nan, math.nan, math.nan, False,
                    f'{len(roll_sets)} roll set(s): at least 2 are needed to fit it on some and '
                    'judge it on another', len(roll_sets))
    judged = [(held_out_deg(gravity, field, roll_sets, *form), form) for form in candidates]
    (before, after), (centres, ridge) = min(judged, key=lambda j: np.mean(j[0][1] ** 2))
    before, after = before ** 2, after ** 2
    rms_before, rms_after = math.sqrt(before.mean()), math.sqrt(after.mean())
    # The difference of the mean squares, its standard error over the held-out shots, in deg.
    total = rms_before + rms_after
    noise = (float(np.std(before - after, ddof=1) / math.sqrt(before.size) / total)
             if total > 0.0 and before.size > 1 else math.inf)
    enabled = rms_before - rms_after > sigmas * noise
    reason = (f'held-out roll-set azimuth RMS {rms_before:.3f} -> {rms_after:.3f} deg '
              f'(1 sigma of the difference {noise:.3f} deg, {len(roll_sets)} roll sets each '
              f'held out in turn, {centres} RBF per axis): '
              + ('improved by more than ' if enabled else 'not improved by more than ')
              + f'{sigmas:g} sigma')
    return Gate(rms_before, rms_after, noise, bool(enabled), reason, len(roll_sets), centres,
                ridge)
