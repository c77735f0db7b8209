"""
The noise of a capture from its own samples (``core.correlated_noise``) against closed forms.

The truth is the physical simulator's AR(1) noise (``sim.sensor_model``, ``noise_rho``).
"""

from inclino_ros.core import stillness
from inclino_ros.core.correlated_noise import CorrelatedNoise, estimate
from inclino_ros.sim import sensor_model
import numpy as np
import pytest


@pytest.mark.parametrize('rho', [0.3, 0.73, 0.95])
def test_inflation_is_the_sum_of_the_correlations(rho):
    """F(n) in closed form equals 1 + 2 sum (1 - j/n) rho^j written out (round-off)."""
    noise = CorrelatedNoise(variance=2.0, rho=rho, dof=100)
    for n in (1, 2, 7, 50, 1000):
        lags = np.arange(1, n)
        expected = 1.0 + 2.0 * np.sum((1.0 - lags / n) * rho ** lags)
        assert noise.inflation(n) == pytest.approx(expected, rel=1e-12)
        assert noise.mean_variance(n) == pytest.approx(2.0 * expected / n, rel=1e-12)
    assert CorrelatedNoise(variance=2.0, rho=0.0, dof=100).inflation(50) == 1.0


@pytest.mark.parametrize('rho,variance_tolerance', [(0.0, 0.05), (0.5, 0.06), (0.9, 0.28)])
def test_estimate_recovers_the_simulated_noise(rho, variance_tolerance):
    """
    A 20000-sample record of AR(1) noise in 10 segments: rho and sigma^2 recovered.

    Tolerances: 5 times the spread measured over 50 records (sigma 1, two components):
    rho 1 sigma 0.006, sigma^2 relative 0.9 / 1.1 / 5.5 % at rho 0 / 0.5 / 0.9; white
    noise read as white in all 50 (rho 0: the still test's exact F laws).  A turn within
    the segments (their lines are removed) changes nothing.
    """
    triad = sensor_model.Triad(noise_std=1.0, noise_rho=rho)
    values = triad.read(np.zeros((20000, 3)), 25.0, rng=4)[:, :2]
    segments = np.repeat(np.arange(10), 2000)
    noise = estimate(values, segments)
    assert noise.rho == pytest.approx(rho, abs=0.03)
    assert noise.variance == pytest.approx(1.0, rel=variance_tolerance)
    if rho == 0.0:
        assert noise.rho == 0.0
    turning = estimate(values + np.linspace(0.0, 50.0, 20000)[:, None], segments)
    assert turning.rho == pytest.approx(noise.rho, abs=1e-3)


def test_mean_variance_of_a_long_capture_has_no_heavy_upper_tail():
    """
    1000 captures of 1000 samples, AR(1) rho 0.9: the still test's variance of the mean.

    The estimate's median lies at the truth; it is above 3 times the truth in at most 3 % of
    captures and below a third of it in at most 1 %.  A variance of the correlated dof
    (``correlated_noise.dof``: 26 here) exceeds 3 times its value with probability ~1e-6;
    the estimate measured 1.4-1.5 % (seeds 7, 8), the bound 3 % lies 4 binomial sigma
    above.  With lags 1-5 (main) 7.4 % of captures were above 3 times the truth (rho read
    at the grid's end): the 1 sigma of a 10 s MEMS capture over-covered (issue 19).
    ``stillness.assess`` fits it over lags 1-25 (``MEAN_LAGS``), its 10 blocks of 100.
    """
    draws, samples, rho = 1000, 1000, 0.9
    triad = sensor_model.Triad(noise_std=1.0, noise_rho=rho)
    values = triad.read(np.zeros((draws * samples, 3)), 25.0, rng=7, records=draws)
    truth = CorrelatedNoise(variance=1.0, rho=rho, dof=1).mean_variance(samples)
    sem = np.radians([stillness.assess(capture).sem_deg
                      for capture in values[:, :2].reshape(draws, samples, 2)])
    ratio = sem ** 2 / truth
    assert 0.9 <= np.median(ratio) <= 1.1, np.median(ratio)
    assert np.mean(ratio > 3.0) <= 0.03, np.mean(ratio > 3.0)
    assert np.mean(ratio < 1.0 / 3.0) <= 0.01, np.mean(ratio < 1.0 / 3.0)
