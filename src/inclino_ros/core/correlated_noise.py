"""
The noise of a capture from the capture itself: its variance and its effective sample size.

A sensor whose first-order low-pass filter sits below its output rate
correlates neighbouring samples: its noise is an AR(1) of coefficient
``rho = exp(-2 pi f_c / f_s)`` (sim.sensor_model, "Noise in time"), and the
mean of n such samples is far noisier than sigma / sqrt(n).  For a
stationary noise of per-sample variance sigma^2 and autocorrelation rho_j
the mean of n consecutive samples has the variance (Priestley, Spectral
Analysis and Time Series, 1981, Eq. 5.3.5)::

    var(mean_n) = sigma^2 / n * F(n),   F(n) = 1 + 2 sum_(j=1)^(n-1) (1 - j/n) rho_j

so the effective sample size is ``n_eff = n / F(n)``; for rho_j = rho^j::

    F(n) = (1 + rho) / (1 - rho) - 2 rho (1 - rho^n) / (n (1 - rho)^2)

The capture is cut into segments (the still test's blocks) whose own
least-squares lines are removed, so a slow motion enters no estimate.  The
variogram of the residuals r, ``V_j = 1/2 mean (r_(i+j) - r_i)^2`` over the
pairs within one segment, would be ``sigma^2 (1 - rho^j)`` of the noise
itself; the segment's fitted line takes out part of a slow (rho near 1)
noise, so that a short segment's variogram lies below it (at rho 0.9 and
segments of 20 samples F came out at 8 for 18).  Its expectation is known
exactly: r = P x with P the projector off each segment's line (orthonormal
basis U of a constant and a slope), so ``E[r r^T] = sigma^2 P S P``, S_ab =
rho^|a - b| (``detrended_shape``), and ``E[V_j] = sigma^2 g_j(rho, m)``, g_j
half the mean of ``C_aa + C_bb - 2 C_ab`` (b = a + j) of C = P S P over a
segment of m samples.  rho and sigma^2 are the least-squares fit of that
law over the lags 1 to LAGS (the still test's noise: short lags, which a
motion left in the segments hardly reaches) or to MEAN_LAGS (the variance of
the capture's mean: long lags tell a rho near 1 from 0.9).

A rho below ``THRESHOLD / sqrt(N)`` (N the samples: two standard errors of
a white noise's lag-1 correlation) is taken as white: rho = 0 and sigma^2 the
pooled within-segment variance about the segments' means, as before (the
still test's F laws are exact again).  Segments shorter than MIN_SEGMENT
samples show no correlation: white likewise.  A 1/f (flicker) noise is no
AR(1): its slow part shows as segment means that move (the still test).
"""

from dataclasses import dataclass
import functools
import math

import numpy as np
from scipy.signal import lfilter

#: The fraction of the squared differences the variogram keeps (the smallest), and the
#: mean of the kept part of a chi-square of one degree of freedom, relative to its whole
#: mean: ``E[X; X <= q] / KEPT = chi2.cdf(q, 3) / KEPT``, q = chi2.ppf(KEPT, 1), since
#: x f_1(x) = f_3(x) (scipy.stats.chi2).
KEPT = 0.9
TRIMMED_MEAN = 0.6230154841346819
#: Fewest degrees of freedom given a correlated noise (a capture of a few independent
#: samples still tells a turn of millions of its sigma: F(2, 4) has finite tails).
MIN_DOF = 4.0
#: Fewest samples of a segment whose correlation is estimated (shorter: taken as white).
MIN_SEGMENT = 8
#: Significant correlation: above THRESHOLD / sqrt(N), N the capture's samples.
THRESHOLD = 2.0
#: The rho tried, to the largest (a correlation time of 100 samples: beyond, a capture
#: holds almost no independent samples), in steps of 0.001.
RHO_GRID = np.linspace(0.0, 0.99, 991)
#: Lags of the variogram fitted for the still test's noise (at most 1 / LAG_SPAN of a
#: segment): longer ones see more of a motion the segments' lines leave (a capture spanning
#: a level bench and the stations fits as a noise of rho near 1 with lags 1-25, and its
#: drift is then no longer significant: test_magnetic_cli), on the simulator at rho 0.9,
#: 500 samples: lags 1-2 spread F over 9-70 for 18.6, 1-5 over 11-29.
LAGS = 5
#: Lags fitted for the variance of a capture's mean (``estimate(..., MEAN_LAGS)``, the
#: mean's 1 sigma and n_eff of ``core.stillness``).  The law of the detrended variogram is
#: exact (``detrended_shape``), so longer lags add what tells a rho near 1 (``1 - rho^j``
#: linear in j) from 0.9 (it bends over): on the simulator at rho 0.9, 1000 samples
#: (segments of 100, 1000 captures, two components), sigma^2 F(N) / N came out above 3
#: times the truth in 7.4 % of captures with lags 1-5 (mean of its square root 1.12-1.16
#: times the truth), 1.5 % with lags 1-25 (1.02-1.04; median unchanged, 0.97-0.99).
#: Segments of 20-30 samples (captures of 200-300) keep lags 1-5 to 1-7: they hold no more.
MEAN_LAGS = 25
LAG_SPAN = 4
#: Longest segment whose detrended variogram law is computed (``detrended_shape``).
DETRENDED_MAX_SIZE = 1000


@dataclass(frozen=True)
class CorrelatedNoise:
    """A stationary AR(1) noise: per-sample variance and lag-1 correlation (``estimate``)."""

    variance: float     # sigma^2 per sample, per component
    rho: float          # lag-1 correlation (0: white)
    dof: int            # degrees of freedom of the within-segment residuals

    def inflation(self, samples):
        """Return F(n) = var(mean of n) n / sigma^2 (module docstring), n scalar or array."""
        n = np.asarray(samples, dtype=float)
        rho = self.rho
        if rho == 0.0:
            return np.ones_like(n)
        return ((1.0 + rho) / (1.0 - rho)
                - 2.0 * rho * (1.0 - rho ** n) / (n * (1.0 - rho) ** 2))

    def effective_samples(self, samples):
        """Return n_eff = n / F(n): the white-noise samples a mean of n is worth."""
        return np.asarray(samples, dtype=float) / self.inflation(samples)

    def mean_variance(self, samples):
        """Return the variance of the mean of ``samples`` consecutive samples."""
        return self.variance * self.inflation(samples) / np.asarray(samples, dtype=float)


def _residuals(values, segments, sizes, degree):
    """Return ``values`` less each segment's least-squares polynomial of ``degree`` (0 or 1)."""
    design = [np.ones(len(segments))]
    if degree:
        position = np.arange(len(segments), dtype=float)
        design.append(position - (np.bincount(segments, weights=position) / sizes)[segments])
    residual = values.copy()
    for column in design:   # orthogonal within each segment: one projection each
        norm = np.bincount(segments, weights=column * column)
        for j in range(values.shape[1]):
            weight = np.bincount(segments, weights=column * values[:, j]) / norm
            residual[:, j] -= weight[segments] * column
    return residual


def _variogram(residual, segments, lag):
    """
    Return 1/2 the mean squared difference of residuals ``lag`` apart in one segment.

    Robust: the mean of the smallest KEPT of the squared differences over
    its Gaussian value (``TRIMMED_MEAN`` times the whole mean), so that jumps
    (a knock, a turn the still test is to see) do not pass for noise.
    """
    same = segments[lag:] == segments[:-lag]
    squared = np.sort((residual[lag:][same] - residual[:-lag][same]).ravel() ** 2)
    kept = squared[:max(int(KEPT * squared.size), 1)]
    return 0.5 * float(np.mean(kept)) / TRIMMED_MEAN


@functools.lru_cache(maxsize=64)
def detrended_shape(size, lags):
    """
    Return g (len(RHO_GRID), len(lags)): E[V_j] / sigma^2 of a segment of ``size`` detrended.

    Module docstring: C = P S P with P = I - U U^T, so C_ab = S_ab - U_a G_b -
    G_a U_b + U_a M U_b with G = S U (the AR(1) filter run both ways over U)
    and M = U^T S U; ``lags`` a tuple of positive lags below ``size``.  Beyond
    DETRENDED_MAX_SIZE samples the line takes out less than 1e-4 of any V_j
    (rho <= 0.99, lags <= 5): ``1 - rho^j``.
    """
    lags = np.asarray(lags)
    if size > DETRENDED_MAX_SIZE:
        return 1.0 - RHO_GRID[:, None] ** lags[None, :]
    position = np.arange(size, dtype=float)
    basis = np.linalg.qr(np.stack([np.ones(size), position - position.mean()], axis=1))[0]
    shape = np.empty((RHO_GRID.size, lags.size))
    for row, rho in enumerate(RHO_GRID):
        # G = S U: sum_a rho^|a - b| U_a, the causal and anticausal AR(1) sums less U.
        forward = lfilter([1.0], [1.0, -rho], basis, axis=0)
        backward = lfilter([1.0], [1.0, -rho], basis[::-1], axis=0)[::-1]
        g = forward + backward - basis
        m = basis.T @ g
        diagonal = (1.0 - 2.0 * np.sum(basis * g, axis=1)
                    + np.einsum('ak,kl,al->a', basis, m, basis))
        for column, lag in enumerate(lags):
            a, b = basis[:-lag], basis[lag:]
            cross = (rho ** lag - np.sum(a * g[lag:], axis=1) - np.sum(g[:-lag] * b, axis=1)
                     + np.einsum('ak,kl,al->a', a, m, b))
            shape[row, column] = 0.5 * np.mean(diagonal[:-lag] + diagonal[lag:] - 2.0 * cross)
    return shape


def estimate(values, segments, max_lag=LAGS):
    """
    Return the CorrelatedNoise of ``values`` (N,) or (N, k) within ``segments``.

    ``segments`` (N,) integers 0 .. S-1, each a run of consecutive samples
    (the still test's blocks) of at least two samples.  ``dof``: the
    within-segment residuals' degrees of freedom, ``k (N - S)``.  ``max_lag``:
    the longest lag fitted (LAGS or MEAN_LAGS; at most 1 / LAG_SPAN of a segment).
    """
    return estimate_spans(values, segments, (max_lag,))[0]


def estimate_spans(values, segments, max_lags):
    """
    Return ``estimate(values, segments, max_lag)`` for each of ``max_lags``, as a tuple.

    The residuals and the variogram are computed once, to the longest lag;
    each span fits its own first lags of it.
    """
    segments = np.asarray(segments)
    values = np.asarray(values, dtype=float).reshape(len(segments), -1)
    count, k = values.shape
    sizes = np.bincount(segments).astype(float)
    dof = k * (count - sizes.size)
    white = CorrelatedNoise(
        variance=float(np.sum(_residuals(values, segments, sizes, 0) ** 2)) / dof, rho=0.0,
        dof=dof)
    if sizes.min() < MIN_SEGMENT or white.variance == 0.0:
        return tuple(white for _ in max_lags)
    residual = _residuals(values, segments, sizes, 1)
    spans = [max(min(max_lag, int(sizes.min()) // LAG_SPAN), 2) for max_lag in max_lags]
    variogram = np.array([_variogram(residual, segments, lag) for lag in range(1, max(spans) + 1)])
    size = int(np.median(sizes))
    return tuple(_fitted(variogram[:span], size, count, white) for span in spans)


def _fitted(variogram, size, count, white):
    """
    Return the AR(1) CorrelatedNoise whose detrended variogram law fits ``variogram``.

    Least squares of V_j = sigma^2 g_j(rho, m), j = 1 .. len(variogram), over
    a grid of rho (sigma^2 is linear), for segments of ``size`` samples;
    ``white`` where rho is not significant over the ``count`` samples.
    """
    shape = detrended_shape(size, tuple(range(1, len(variogram) + 1)))
    variance = (shape @ variogram) / np.sum(shape * shape, axis=1)
    best = int(np.argmin(np.sum((variogram - variance[:, None] * shape) ** 2, axis=1)))
    if not RHO_GRID[best] > THRESHOLD / math.sqrt(count):
        return white
    return CorrelatedNoise(variance=float(variance[best]), rho=float(RHO_GRID[best]),
                           dof=white.dof)


def dof(noise, samples):
    """
    Return the degrees of freedom of a CorrelatedNoise's variance of a mean of ``samples``.

    White: the within-segment residuals' (the F laws of ``core.stillness`` are
    exact).  Correlated: ``dof / (4 F(N))``, from the spread measured on the
    simulator (AR(1), 2 components, 300 captures each): the estimate of F
    has a relative 1 sigma of ~0.4 at rho 0.9 and 500 samples, ~0.3 at 1000,
    i.e. ``2 / 0.4^2 = 12`` and 22 degrees of freedom, where ``dof / (4 F)``
    gives 13 and 26 (``dof / (2 F)`` refused 1 still capture in 300 at rho
    0.9 and 500 samples, ``dof / F`` 2).  At least MIN_DOF.
    """
    if noise.rho == 0.0:
        return noise.dof
    return max(noise.dof / (4.0 * float(noise.inflation(samples))), MIN_DOF)


#: The slowest flicker a capture's mean is exposed to has this many times the capture's
#: length as its period (``flicker_mean_factor``): a capture of ~10 s whose bias was last
#: calibrated ~1 day before (c grows as sqrt(ln R / pi): 0.90 at R = 32, 2.0 at 1e6).
FLICKER_BAND_RATIO = 1.0e4


def flicker_mean_factor(band_ratio=FLICKER_BAND_RATIO):
    """
    Return c of a mean's 1 sigma ``c B`` from flicker noise of bias instability B.

    Flicker (1/f) noise of IEEE Std 952's bias instability B has the one-sided
    power spectral density ``S(f) = B^2 / (pi f)``.  The mean over a capture of
    length T passes it through ``|H(f)|^2 = (sin(pi f T) / (pi f T))^2``; the
    error of the mean against the sensor's bias is the flicker of every
    frequency above ``f_lo = 1 / (R T)``, R = ``band_ratio`` (slower flicker is
    a bias a calibration took up)::

        var = int_(f_lo)^inf B^2 / (pi f) |H(f)|^2 df
            = B^2 / pi int_(pi / R)^inf sin^2 x / x^3 dx       (x = pi f T)
            = B^2 / pi (ln(R / (2 pi)) + 3/2 - gamma) + O(R^-2)

    (gamma: Euler's constant; the integral is ``-ln x0 + 3/2 - gamma - ln 2``
    for small x0, checked by quadrature to 1e-4 at R >= 16).  So ``c =
    sqrt((ln(R / (2 pi)) + 3/2 - gamma) / pi)``, independent of T and of the
    sample rate (a flat Allan floor: the mean of any length is as far off).
    At the default R = 1e4: c = 1.625.  The simulator (``sim.sensor_model``,
    flicker synthesised in bins k / (L T), k >= 1, over FLICKER_SPAN times the
    record of L captures) is the integral from ``f_lo e^-gamma`` (the harmonic
    sum's gamma): a capture read alone (L = 16 records of itself, R = 16 e^gamma
    = 28.5) is off by 0.88 B (measured, 3000 captures); bench_coverage gives
    each capture its own record over ``flicker_span`` = R e^-gamma records, R =
    FLICKER_BAND_RATIO (the band this c assumes).  Its Allan floor
    ``0.664 B`` is what the capture itself shows; the rest (periods beyond the
    capture) only a configured B can say.
    """
    return math.sqrt((math.log(band_ratio / (2.0 * math.pi)) + 1.5 - np.euler_gamma) / math.pi)
