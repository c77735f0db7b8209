"""
Temperature drift of a sensor triad: scale factors (seed 001 §3, Eqs. 5-7) and biases.

Seed 001 models each axis as ``A_T = K_T G`` (Eq. 6): the scale factor K_T
of an axis varies with temperature, and is fitted by least squares as a
polynomial ``K_T = f(T) = a0 + a1 T + ... + an T^n`` (Eq. 7, T in deg C) from
readings at one fixed attitude while the tool is heated (20-100 deg C, every
10 deg C in the seed).  Readings are compensated by dividing by K_T (Eq. 6).

Choices made here:

* K_T is normalised to 1 at the reference temperature (25 deg C, the seed's
  standard temperature): ``compensate_temperature`` returns the readings as
  at 25 deg C, and the stand calibration (``inclino_ros.core.stand``, captured at
  25 deg C) keeps the scale at 25 deg C in its K.  The reference vector of
  the fit may therefore be the true specific force or the 25 deg C reading at
  the fit attitude: both give the same normalised K_T.
* ``K_T = A_T / G`` is undefined for an axis that reads about 0 at the fit
  attitude.  Each axis is fitted as ``A_i = f_i(T) G_i`` by least squares
  weighted with ``G_i`` (which is what dividing by a small G_i would ruin),
  and an axis is refused unless some sample has ``|G_i|`` at least
  MIN_AXIS_FRACTION of ``|G|``.  One attitude serves all three axes when
  each sees that much, e.g. inclination 55 deg at toolface 45 deg
  (0.58, 0.58, 0.57 g); a vertical or horizontal tool cannot, and its fit
  takes two attitudes (pass ``reference`` per sample).
* The seed models the scale factor only: a temperature-dependent bias is
  not modelled by ``fit_temperature`` (at one attitude it is absorbed into
  K_T, exactly: the fit's residual stays at the noise, and the compensation
  is wrong at every other attitude).

Bias and scale (``fit_temperature_drift``), seed 001 Eqs. 5-7 generalised.
A triad axis reads ``A_T = K_T(T) A + B_T(T)`` (Eq. 6 with an additive bias
drift B_T, 0 at the reference temperature; real MEMS parts drift 0.5-1
mg/degC in bias, real-sensors.md): with A the reading at the reference
temperature, ``K_T = 1 + sum c_k (T - T_ref)^k`` and
``B_T = sum d_k (T - T_ref)^k``.  At one attitude only ``A c_k + d_k`` is
seen; heating runs at two or more attitudes where the axis reads
differently (``MIN_AXIS_SPREAD_FRACTION``) separate them.  The unknowns (A
per attitude and axis, c_k, d_k) are fitted by Gauss-Newton on all the
readings (the model is bilinear in A and c).  Compensation:
``A = (A_T - B_T(T)) / K_T(T)`` (``compensate_temperature``).  Nothing here
depends on the unit: the same fit serves the accelerometer (m/s^2) and the
magnetometer (nT; seed 001 §3.2: "the magnetometer is compensated the same
way").

The fit's own uncertainty (``parameter_covariance``): the least-squares
covariance ``s^2 (J^T J)^-1`` of each axis's drift coefficients, from the
fit's Jacobian J at the solution and its residual variance ``s^2 = SSR / (M
- p)``, expressed in powers ``u^k``, k = 1..n, of the normalised temperature
``u = (T - T_mid) / T_half`` over the fitted range (``normalised_temperature``):
scale then bias coefficients.  The constant term is left out: it is fixed by
``K_T = 1, B_T = 0`` at the reference, so a compensation to T_s errs by
``(K_T(T) - K_T(T_s)) A + B_T(T) - B_T(T_s)``, which needs only ``u^k -
u_s^k`` (``uncertainty.temperature_compensation_covariance``).
"""

from dataclasses import dataclass, replace

from inclino_ros.core.refusal import Refused
import numpy as np
from numpy.polynomial import Polynomial
from numpy.polynomial import polynomial as poly

#: Temperature [deg C] at which K_T is 1 (seed 001's standard 25 deg C).
REFERENCE_TEMPERATURE_C = 25.0
#: An axis needs ``|G_i| >= MIN_AXIS_FRACTION |G|`` in some sample (0.3: the
#: axis at least 17.5 deg out of the horizontal plane).
MIN_AXIS_FRACTION = 0.3
#: Largest ratio of a reading to its reference: far beyond any drift, checked first.
MAX_SCALE_RATIO = 10.0
#: Temperatures closer than this [deg C] count as one when counting distinct ones.
TEMPERATURE_RESOLUTION_C = 0.1
#: Bias and scale drift of an axis separate only when its reference readings at
#: the attitudes spread by at least this fraction of the vector's magnitude (0.5:
#: e.g. the axis at +15 and -15 deg out of the horizontal plane; two opposite
#: attitudes give up to 2).
MIN_AXIS_SPREAD_FRACTION = 0.5
#: Gauss-Newton of the bias-and-scale fit stops when a step moves K_T by less than this.
DRIFT_STEP_TOLERANCE = 1e-13
#: ...within this many steps, else refused.
MAX_DRIFT_ITERATIONS = 50
AXES = 'xyz'


class TemperatureFitRefused(Refused):
    """Data that cannot give a trustworthy temperature model."""


@dataclass(frozen=True)
class TemperatureFit:
    """
    Per-axis scale factor ``K_T(T)`` (seed 001 Eq. 7), 1 at the reference temperature.

    ``bias_coefficients`` (None: scale only) is the bias drift ``B_T(T)``,
    0 at the reference, in the unit of the readings; ``attitudes`` how many
    attitudes the fit saw; ``references`` (attitudes, 3) their readings at
    the reference temperature (bias-and-scale fit only).
    """

    coefficients: np.ndarray       # (3, order + 1): a0..an per axis, T in deg C
    t_min_c: float                 # fitted temperature range
    t_max_c: float
    reference_temperature_c: float
    rms_residual: np.ndarray       # (3,) of the fit per axis, unit of the readings
    bias_coefficients: np.ndarray = None  # (3, order + 1): B_T(T) = b0 + b1 T + ...
    attitudes: int = 1
    references: np.ndarray = None
    parameter_covariance: np.ndarray = None  # (3, p, p) in powers of u (module docstring)

    def scale_factor(self, temperature_c):
        """Return K_T per axis at each temperature, shape (N, 3)."""
        return poly.polyval(np.asarray(temperature_c, dtype=float), self.coefficients.T).T

    def bias(self, temperature_c):
        """Return the bias drift B_T per axis at each temperature, shape (N, 3) (0 if none)."""
        temperature_c = np.asarray(temperature_c, dtype=float)
        if self.bias_coefficients is None:
            return np.zeros(temperature_c.shape + (3,))
        return poly.polyval(temperature_c, self.bias_coefficients.T).T

    def referenced_to(self, temperature_c):
        """
        Return this fit normalised at ``temperature_c``: compensation to that temperature.

        With ``A_T = K_T(T) A + B_T(T)`` about the old reference, the reading
        at T_s is ``A_s = K_T(T_s) A + B_T(T_s)``, so ``A_T = K'(T) A_s + B'(T)``
        with ``K' = K_T / K_T(T_s)`` and ``B' = B_T - K' B_T(T_s)``: the same
        polynomials' order, K' = 1 and B' = 0 at T_s.
        """
        scale_s = self.scale_factor(temperature_c)                 # (3,)
        coefficients = self.coefficients / scale_s[:, None]
        bias = None
        if self.bias_coefficients is not None:
            bias = self.bias_coefficients - coefficients * self.bias(temperature_c)[:, None]
        return replace(self, coefficients=coefficients, bias_coefficients=bias,
                       reference_temperature_c=float(temperature_c))


def normalised_temperature(temperature_c, t_min_c, t_max_c):
    """Return ``u = (T - T_mid) / T_half`` of the fitted range [t_min_c, t_max_c] (in -1..1)."""
    half = 0.5 * (t_max_c - t_min_c)
    return (np.asarray(temperature_c, dtype=float) - (t_min_c + half)) / half


def _least_squares_covariance(jacobian, residual):
    """Return ``s^2 (J^T J)^-1``, ``s^2 = SSR / (M - p)``, of a least-squares solution."""
    count, params = jacobian.shape
    scale = np.linalg.norm(jacobian, axis=0)
    inverse = np.linalg.pinv((jacobian / scale).T @ (jacobian / scale)) / np.outer(scale, scale)
    inverse = 0.5 * (inverse + inverse.T)
    return inverse * float(residual @ residual) / max(count - params, 1)


def fit_temperature(temperature_c, readings, reference, order,
                    reference_temperature_c=REFERENCE_TEMPERATURE_C):
    """
    Return the least-squares K_T(T) polynomials of each axis (seed 001 Eqs. 6-7).

    ``temperature_c`` (M,), ``readings`` (M, 3) of a still tool, ``reference``
    the specific force at the fit attitude, (3,) or per sample (M, 3) for
    more than one attitude.  Raises TemperatureFitRefused, with the reason,
    for: non-finite data; readings beyond MAX_SCALE_RATIO times the reference
    (checked before any arithmetic); fewer than ``order + 2`` distinct temperatures (a
    polynomial of order n has n + 1 coefficients, and one more temperature
    leaves a residual to judge the fit by); a reference temperature outside
    the data; an axis that reads about 0 at every fit attitude; an axis whose
    fitted K_T at the reference temperature is not positive; a fit that is
    not finite or fails numerically.
    """
    temperature_c, readings, _, t_min_c, t_max_c = _checked_run(
        temperature_c, readings, order, reference_temperature_c)
    reference = np.broadcast_to(np.asarray(reference, dtype=float), readings.shape)
    if not np.isfinite(reference).all():
        raise TemperatureFitRefused('non-finite temperature, readings or reference')
    size = np.hypot(np.hypot(readings[:, 0], readings[:, 1]), readings[:, 2])
    reference_size = np.hypot(np.hypot(reference[:, 0], reference[:, 1]), reference[:, 2])
    if not np.all((reference_size > 0.0) & (size <= MAX_SCALE_RATIO * reference_size)):
        raise TemperatureFitRefused(
            f'readings up to {size.max():.4g} for a reference of {reference_size.min():.4g}: '
            f'a scale factor beyond {MAX_SCALE_RATIO:g} is no temperature drift')
    fraction = np.max(np.abs(reference) / np.linalg.norm(reference, axis=1)[:, None], axis=0)
    weak = [AXES[i] for i in np.flatnonzero(fraction < MIN_AXIS_FRACTION)]
    if weak:
        raise TemperatureFitRefused(
            f'axis {", ".join(weak)} reads about 0 at the fit attitude(s) (at most '
            f'{fraction.min():.3f} of |G|, need {MIN_AXIS_FRACTION}): K_T = A_T / G is '
            'undefined there; tilt the tool so every axis sees gravity, or add an attitude')

    try:
        with np.errstate(all='ignore'):
            fit = _fit_axes(temperature_c, readings, reference, order, reference_temperature_c,
                            t_min_c, t_max_c)
    except np.linalg.LinAlgError as err:
        raise TemperatureFitRefused(f'numerical failure of the fit ({err})') from None
    if not (np.all(np.isfinite(fit.coefficients)) and np.all(np.isfinite(fit.rms_residual))):
        raise TemperatureFitRefused('the fit is not finite (temperatures or readings too large)')
    return fit


def _fit_axes(temperature_c, readings, reference, order, reference_temperature_c, t_min_c,
              t_max_c):
    """Return the TemperatureFit of checked, finite data (see ``fit_temperature``)."""
    coefficients, rms, covariance = [], [], []
    # Polynomial.fit works in u over [t_min_c, t_max_c]: the basis of parameter_covariance.
    powers = normalised_temperature(temperature_c, t_min_c, t_max_c)[:, None] ** np.arange(
        order + 1)
    for axis in range(3):
        g_axis = reference[:, axis]
        ratio = np.divide(readings[:, axis], g_axis, out=np.zeros_like(g_axis),
                          where=g_axis != 0.0)
        # Weights |G_i| make this the least squares of A_i - f(T) G_i.
        fitted = Polynomial.fit(temperature_c, ratio, order, w=np.abs(g_axis))
        residual = readings[:, axis] - fitted(temperature_c) * g_axis
        rms.append(np.sqrt(np.mean(np.square(residual))))
        at_reference = fitted(reference_temperature_c)
        # Jacobian of A_i = G_i sum p_k u^k; K_T = f / f(T_ref): its terms scale by 1 / f(T_ref).
        covariance.append(_least_squares_covariance(powers * g_axis[:, None], residual)[1:, 1:]
                          / at_reference ** 2)
        if at_reference <= 0.0:
            raise TemperatureFitRefused(
                f'axis {AXES[axis]}: K_T({reference_temperature_c} C) = {at_reference:.4g} is '
                'not positive: readings and reference disagree in sign (wrong attitude or frame)')
        plain = (fitted / at_reference).convert().coef
        coefficients.append(np.pad(plain, (0, order + 1 - plain.size)))
    return TemperatureFit(coefficients=np.array(coefficients), t_min_c=t_min_c,
                          t_max_c=t_max_c, reference_temperature_c=reference_temperature_c,
                          rms_residual=np.array(rms), parameter_covariance=np.array(covariance))


def fit_temperature_drift(temperature_c, readings, attitude, order,
                          reference_temperature_c=REFERENCE_TEMPERATURE_C):
    """
    Return the least-squares bias and scale drift of each axis (module docstring).

    ``temperature_c`` (M,), ``readings`` (M, 3) of a still tool,
    ``attitude`` (M,) a label per reading (readings of one label share one
    attitude).  Raises TemperatureFitRefused, with the reason, for:
    non-finite data; fewer than ``order + 2`` distinct temperatures; a
    reference temperature outside the data; fewer than two attitudes heated
    through ``order + 1`` distinct temperatures each (one attitude cannot
    tell a bias drift from a scale drift); an axis whose readings at those
    attitudes do not spread by ``MIN_AXIS_SPREAD_FRACTION`` of the vector;
    readings beyond MAX_SCALE_RATIO times their median magnitude; a fit that
    does not converge or is not finite.
    """
    temperature_c, readings, rounded, t_min_c, t_max_c = _checked_run(
        temperature_c, readings, order, reference_temperature_c)
    size = np.hypot(np.hypot(readings[:, 0], readings[:, 1]), readings[:, 2])
    typical = float(np.median(size))
    if not np.all((typical > 0.0) & (size <= MAX_SCALE_RATIO * typical)):
        raise TemperatureFitRefused(
            f'readings up to {size.max():.4g} for a typical {typical:.4g}: a scale factor '
            f'beyond {MAX_SCALE_RATIO:g} is no temperature drift')
    try:
        with np.errstate(all='ignore'):
            fit = _drift_fit(temperature_c, readings, rounded, attitude, order,
                             reference_temperature_c, t_min_c, t_max_c)
    except np.linalg.LinAlgError as err:
        raise TemperatureFitRefused(f'numerical failure of the fit ({err})') from None
    if not (np.all(np.isfinite(fit.coefficients)) and np.all(np.isfinite(fit.bias_coefficients))
            and np.all(np.isfinite(fit.rms_residual))):
        raise TemperatureFitRefused('the fit is not finite (temperatures or readings too large)')
    return fit


def _drift_fit(temperature_c, readings, rounded, attitude, order, reference_temperature_c,
               t_min_c, t_max_c):
    """Return the bias and scale drift fit of checked data (``fit_temperature_drift``)."""
    labels, index = np.unique(np.asarray(attitude), return_inverse=True)
    index = index.reshape(-1)
    heated = [a for a in range(labels.size)
              if np.unique(rounded[index == a]).size >= order + 1]
    if len(heated) < 2:
        raise TemperatureFitRefused(
            f'{len(heated)} attitude(s) heated through {order + 1} distinct temperatures, '
            'need 2: at one attitude a bias drift cannot be told from a scale drift (use the '
            'scale-only fit of seed 001, or heat the tool at a second attitude)')
    means = np.stack([readings[index == a].mean(axis=0) for a in heated])
    spread = np.ptp(means, axis=0) / np.median(np.linalg.norm(means, axis=1))
    weak = [AXES[i] for i in np.flatnonzero(spread < MIN_AXIS_SPREAD_FRACTION)]
    if weak:
        raise TemperatureFitRefused(
            f'axis {", ".join(weak)} reads nearly the same at every heated attitude (spread '
            f'{spread.min():.3f} of |reading|, need {MIN_AXIS_SPREAD_FRACTION}): its bias and '
            'scale drift cannot be told apart; heat it at an attitude where it reads '
            'differently (e.g. turned over)')
    keep = np.isin(index, heated)
    dt = temperature_c[keep] - reference_temperature_c
    scale_c = max(abs(t_min_c - reference_temperature_c), abs(t_max_c - reference_temperature_c))
    powers = (dt[:, None] / scale_c) ** np.arange(1, order + 1)     # (M, n), |x| <= 1
    onehot = (index[keep][:, None] == np.array(heated)[None, :]).astype(float)
    scale, bias, references, rms, covariance = [], [], [], [], []
    # x = (T - T_ref) / scale_c = alpha u + beta: x^k in powers u^1..u^n (u^0 dropped).
    half = 0.5 * (t_max_c - t_min_c)
    x_of_u = Polynomial([(t_min_c + half - reference_temperature_c) / scale_c, half / scale_c])
    to_u = np.array([_pad_rows([(x_of_u ** k).coef], order)[0][1:]
                     for k in range(1, order + 1)]).T          # (n, n): u^j of x^k
    to_u = np.kron(np.eye(2), to_u)
    for axis in range(3):
        r, c, d, cd_covariance = _drift_axis(readings[keep, axis], onehot, powers)
        transformed = to_u @ cd_covariance @ to_u.T
        covariance.append(0.5 * (transformed + transformed.T))
        model = (onehot @ r) * (1.0 + powers @ c) + powers @ d
        rms.append(float(np.sqrt(np.mean((readings[keep, axis] - model) ** 2))))
        # (T - T_ref)^k / scale_c^k in plain powers of T.
        shift = Polynomial([-reference_temperature_c / scale_c, 1.0 / scale_c])
        scale.append((Polynomial(np.r_[1.0, c]))(shift).coef[:order + 1])
        bias.append((Polynomial(np.r_[0.0, d]))(shift).coef[:order + 1])
        references.append(r)
    return TemperatureFit(
        coefficients=_pad_rows(scale, order), t_min_c=t_min_c, t_max_c=t_max_c,
        reference_temperature_c=reference_temperature_c, rms_residual=np.array(rms),
        bias_coefficients=_pad_rows(bias, order), attitudes=len(heated),
        references=np.array(references).T, parameter_covariance=np.array(covariance))


def _checked_run(temperature_c, readings, order, reference_temperature_c):
    """
    Return (temperature_c, readings, rounded temperatures, t_min_c, t_max_c) of a heating run.

    ValueError for wrong shapes; TemperatureFitRefused for non-finite data,
    fewer than ``order + 2`` distinct temperatures (n + 1 coefficients and a
    residual to judge them by), a reference temperature outside the data.
    """
    temperature_c = np.asarray(temperature_c, dtype=float)
    readings = np.asarray(readings, dtype=float)
    if readings.ndim != 2 or readings.shape[1] != 3 or temperature_c.shape != readings[:, 0].shape:
        raise ValueError(f'need temperature_c (M,) and readings (M, 3), not '
                         f'{temperature_c.shape} and {readings.shape}')
    if not (np.isfinite(temperature_c).all() and np.isfinite(readings).all()):
        raise TemperatureFitRefused('non-finite temperature, readings or reference')
    rounded = np.round(temperature_c / TEMPERATURE_RESOLUTION_C)
    distinct = np.unique(rounded).size
    if distinct < order + 2:
        raise TemperatureFitRefused(
            f'order {order} needs at least {order + 2} distinct temperatures (more than its '
            f'{order + 1} coefficients), got {distinct}')
    t_min_c, t_max_c = float(temperature_c.min()), float(temperature_c.max())
    if not t_min_c <= reference_temperature_c <= t_max_c:
        raise TemperatureFitRefused(
            f'reference temperature {reference_temperature_c} C lies outside the data '
            f'[{t_min_c}, {t_max_c}] C: K_T cannot be normalised there without extrapolating')
    return temperature_c, readings, rounded, t_min_c, t_max_c


def _pad_rows(rows, order):
    """Return polynomial coefficient rows padded with zeros to ``order + 1`` columns."""
    return np.array([np.pad(row, (0, order + 1 - len(row))) for row in rows])


def _drift_axis(y, onehot, powers):
    """
    Return (r (A,), c (n,), d (n,), covariance of (c, d)) of ``y = r_a (1 + P c) + P d``.

    Gauss-Newton.  Start: c = 0, r and d linear least squares; then full
    Gauss-Newton steps on all three (Jacobian columns onehot (1 + P c), r_a P,
    P); the covariance is ``s^2 (J^T J)^-1`` at the solution (r marginalised).
    """
    n = powers.shape[1]
    c = np.zeros(n)
    start = np.linalg.lstsq(np.hstack([onehot, powers]), y, rcond=None)[0]
    r, d = start[:onehot.shape[1]], start[onehot.shape[1]:]
    for _ in range(MAX_DRIFT_ITERATIONS):
        r_a = onehot @ r
        k_t = 1.0 + powers @ c
        residual = y - (r_a * k_t + powers @ d)
        jacobian = np.hstack([onehot * k_t[:, None], r_a[:, None] * powers, powers])
        scale = np.linalg.norm(jacobian, axis=0)
        step = np.linalg.lstsq(jacobian / scale, residual, rcond=None)[0] / scale
        r = r + step[:r.size]
        c = c + step[r.size:r.size + n]
        d = d + step[r.size + n:]
        if np.max(np.abs(step[r.size:r.size + n])) < DRIFT_STEP_TOLERANCE:
            covariance = _least_squares_covariance(jacobian, residual - jacobian @ step)
            return r, c, d, covariance[r.size:, r.size:]
    raise TemperatureFitRefused('the bias-and-scale fit does not converge')


def compensate_temperature(readings, temperature_c, fit):
    """
    Return ``(A_T - B_T(T)) / K_T(T)`` per axis: readings as at the reference temperature.

    Seed 001 Eq. 6 with the bias drift B_T of ``fit_temperature_drift`` (0
    for a scale-only fit).  ``readings`` (N, 3), ``temperature_c`` (N,).
    Outside the fitted range the polynomials extrapolate; ``in_range`` tells
    which samples are inside.
    """
    return ((np.asarray(readings, dtype=float) - fit.bias(temperature_c))
            / fit.scale_factor(temperature_c))


#: Temperatures of the fitted range at which ``unknown_temperature_covariance`` looks.
UNKNOWN_TEMPERATURE_POINTS = 33


def unknown_temperature_covariance(readings, fit):
    """
    Return the covariance (M, 3, 3) of readings compensated without knowing their temperature.

    Without a temperature a reading is compensated at the reference
    temperature; at T it would be ``A(T) = compensate_temperature(A_T, T)``,
    so the error is ``e(T) = A(T_ref) - A(T)``.  T anywhere in the fitted
    range (``UNKNOWN_TEMPERATURE_POINTS`` evenly spaced, ends included):
    the second moment ``E[e e^T]`` over the range gives the error's shape
    (a drift common to all axes moves no angle), scaled so that its trace is
    the largest ``|e(T)|^2``: the 1 sigma is the drift over the fitted range.
    ``readings`` (M, 3) uncompensated, in the unit of the fit.
    """
    readings = np.asarray(readings, dtype=float).reshape(-1, 3)
    grid = np.linspace(fit.t_min_c, fit.t_max_c, UNKNOWN_TEMPERATURE_POINTS)
    count = readings.shape[0]
    at_reference = compensate_temperature(
        readings, np.full(count, fit.reference_temperature_c), fit)
    errors = np.stack([at_reference - compensate_temperature(readings, np.full(count, t), fit)
                       for t in grid])                                    # (G, M, 3)
    moment = np.einsum('gmi,gmj->mij', errors, errors) / grid.size
    trace = np.trace(moment, axis1=1, axis2=2)
    worst = np.max(np.einsum('gmi,gmi->gm', errors, errors), axis=0)
    scale = np.divide(worst, trace, out=np.zeros_like(worst), where=trace > 0.0)
    return moment * scale[:, None, None]


def in_range(temperature_c, fit):
    """Return whether each temperature lies in the fitted range [t_min_c, t_max_c]."""
    temperature_c = np.asarray(temperature_c, dtype=float)
    return (temperature_c >= fit.t_min_c) & (temperature_c <= fit.t_max_c)
