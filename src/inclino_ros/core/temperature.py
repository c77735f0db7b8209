"""
Temperature drift of the accelerometer scale factors (seed 001 §3, Eqs. 5-7).

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
  not modelled (at one attitude it is absorbed into K_T).
"""

from dataclasses import dataclass

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
AXES = 'xyz'


class TemperatureFitRefused(Exception):
    """Data that cannot give a trustworthy temperature model."""

    def __init__(self, reason):
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class TemperatureFit:
    """Per-axis scale factor ``K_T(T)`` (seed 001 Eq. 7), 1 at the reference temperature."""

    coefficients: np.ndarray       # (3, order + 1): a0..an per axis, T in deg C
    t_min_c: float                 # fitted temperature range
    t_max_c: float
    reference_temperature_c: float
    rms_residual_mps2: np.ndarray  # (3,) of A_i - f_i(T) G_i, unit of the readings

    def scale_factor(self, temperature_c):
        """Return K_T per axis at each temperature, shape (N, 3)."""
        return poly.polyval(np.asarray(temperature_c, dtype=float), self.coefficients.T).T


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
    temperature_c = np.asarray(temperature_c, dtype=float)
    readings = np.asarray(readings, dtype=float)
    reference = np.broadcast_to(np.asarray(reference, dtype=float), readings.shape)
    if readings.ndim != 2 or readings.shape[1] != 3 or temperature_c.shape != readings[:, 0].shape:
        raise ValueError(f'need temperature_c (M,) and readings (M, 3), not '
                         f'{temperature_c.shape} and {readings.shape}')
    if not (np.isfinite(temperature_c).all() and np.isfinite(readings).all()
            and np.isfinite(reference).all()):
        raise TemperatureFitRefused('non-finite temperature, readings or reference')
    size = np.hypot(np.hypot(readings[:, 0], readings[:, 1]), readings[:, 2])
    reference_size = np.hypot(np.hypot(reference[:, 0], reference[:, 1]), reference[:, 2])
    if not np.all((reference_size > 0.0) & (size <= MAX_SCALE_RATIO * reference_size)):
        raise TemperatureFitRefused(
            f'readings up to {size.max():.4g} for a reference of {reference_size.min():.4g}: '
            f'a scale factor beyond {MAX_SCALE_RATIO:g} is no temperature drift')
    distinct = np.unique(np.round(temperature_c / TEMPERATURE_RESOLUTION_C)).size
    if distinct < order + 2:
        raise TemperatureFitRefused(
            f'order {order} needs at least {order + 2} distinct temperatures (more than its '
            f'{order + 1} coefficients), got {distinct}')
    t_min_c, t_max_c = float(temperature_c.min()), float(temperature_c.max())
    if not t_min_c <= reference_temperature_c <= t_max_c:
        raise TemperatureFitRefused(
            f'reference temperature {reference_temperature_c} C lies outside the data '
            f'[{t_min_c}, {t_max_c}] C: K_T cannot be normalised there without extrapolating')
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
    if not (np.all(np.isfinite(fit.coefficients)) and np.all(np.isfinite(fit.rms_residual_mps2))):
        raise TemperatureFitRefused('the fit is not finite (temperatures or readings too large)')
    return fit


def _fit_axes(temperature_c, readings, reference, order, reference_temperature_c, t_min_c,
              t_max_c):
    """Return the TemperatureFit of checked, finite data (see ``fit_temperature``)."""
    coefficients, rms = [], []
    for axis in range(3):
        g_axis = reference[:, axis]
        ratio = np.divide(readings[:, axis], g_axis, out=np.zeros_like(g_axis),
                          where=g_axis != 0.0)
        # Weights |G_i| make this the least squares of A_i - f(T) G_i.
        fitted = Polynomial.fit(temperature_c, ratio, order, w=np.abs(g_axis))
        rms.append(np.sqrt(np.mean(np.square(readings[:, axis] - fitted(temperature_c) * g_axis))))
        at_reference = fitted(reference_temperature_c)
        if at_reference <= 0.0:
            raise TemperatureFitRefused(
                f'axis {AXES[axis]}: K_T({reference_temperature_c} C) = {at_reference:.4g} is '
                'not positive: readings and reference disagree in sign (wrong attitude or frame)')
        plain = (fitted / at_reference).convert().coef
        coefficients.append(np.pad(plain, (0, order + 1 - plain.size)))
    return TemperatureFit(coefficients=np.array(coefficients), t_min_c=t_min_c,
                          t_max_c=t_max_c, reference_temperature_c=reference_temperature_c,
                          rms_residual_mps2=np.array(rms))


def compensate_temperature(readings, temperature_c, fit):
    """
    Return ``A_T / K_T(T)`` per axis (seed 001 Eq. 6): readings as at the reference temperature.

    ``readings`` (N, 3), ``temperature_c`` (N,).  Outside the fitted range the
    polynomial extrapolates; ``in_range`` tells which samples are inside.
    """
    return np.asarray(readings, dtype=float) / fit.scale_factor(temperature_c)


def in_range(temperature_c, fit):
    """Return whether each temperature lies in the fitted range [t_min_c, t_max_c]."""
    temperature_c = np.asarray(temperature_c, dtype=float)
    return (temperature_c >= fit.t_min_c) & (temperature_c <= fit.t_max_c)
