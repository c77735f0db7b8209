"""
Level-bench capture (seed 000 section 3): angles from still samples, and every refusal.

Noise-free captures are pure round-off (asin of arguments of order 0.05): 1e-10 deg.
Noisy captures: with per-axis white noise sigma and N samples the mean reading is off by
sigma/sqrt(N) per axis, and d(gamma)/d(v_x1) = -1/(g cos gamma), d(beta)/d(v_y1) =
-1/(g cos beta cos gamma), both within 0.3 % of -1/g for angles up to 3 deg; so the angle
errors are Gaussian with standard deviation s = sigma/(g sqrt(N)) rad, and a 4 s bound is
exceeded with probability 6e-5 (the seeds are fixed, so the runs are reproducible).
"""

from dataclasses import replace
from datetime import datetime
import math

from inclino_ros.calibration.level_capture import CaptureRefused, LevelLimits, solve_level_capture
from inclino_ros.calibration.model import age_seconds
from inclino_ros.core.installation import installation_matrix
import numpy as np
import pytest

G = 9.80665
LIMITS = LevelLimits(max_tilt_deg=5.0, gravity_mps2=G, g_total_tolerance_mps2=0.3)


def level_reading(gamma_deg, beta_deg, g=G):
    """Return the noise-free level-bench reading C (0, 0, g) (seed 000 Eq. 2)."""
    return installation_matrix(math.radians(gamma_deg), math.radians(beta_deg)) @ [0.0, 0.0, g]


@pytest.mark.parametrize('gamma_deg, beta_deg, g', [
    (0.0355, -0.2773, G), (0.0, 0.0, G), (-3.0, 2.5, 9.79), (2.9, -3.0, 9.83)])
def test_noise_free_capture(gamma_deg, beta_deg, g):
    """Identical level samples give back gamma, beta exactly, with zero spread."""
    samples = np.tile(level_reading(gamma_deg, beta_deg, g), (25, 1))
    result = solve_level_capture(samples, 3, LIMITS)
    assert result.gamma_deg == pytest.approx(gamma_deg, abs=1e-10)
    assert result.beta_deg == pytest.approx(beta_deg, abs=1e-10)
    assert result.sample_count == 25
    assert result.std_deg < 1e-12      # identical rows: only the round-off of np.std's mean
    assert result.g_total_mps2 == pytest.approx(g, rel=1e-14)
    assert datetime.fromisoformat(result.captured_at).tzinfo is not None
    assert 0.0 <= age_seconds(result.captured_at) < 60.0


def test_paper_example_capture():
    """Bench outputs of section 4 (tilts -0.0355, 0.2773 deg) give gamma 0.0355, beta -0.2773."""
    vx, vy = G * math.sin(math.radians(-0.0355)), G * math.sin(math.radians(0.2773))
    samples = np.tile([vx, vy, math.sqrt(G * G - vx * vx - vy * vy)], (10, 1))
    result = solve_level_capture(samples, 3, LIMITS)
    assert (round(result.gamma_deg, 4), round(result.beta_deg, 4)) == (0.0355, -0.2773)
    assert round(result.theta_deg, 4) == 0.2796
    # A two-axis driver reports z = 0; v_g is then the configured gravity.
    two_axis = solve_level_capture(np.column_stack([samples[:, :2], np.zeros(10)]), 2, LIMITS)
    assert (round(two_axis.gamma_deg, 4), round(two_axis.beta_deg, 4)) == (0.0355, -0.2773)


@pytest.mark.parametrize('seed', range(5))
def test_noisy_capture_within_derived_bound(seed):
    """With noise sigma the angle errors stay within 4 sigma / (g sqrt N) rad."""
    rng = np.random.default_rng(seed)
    gamma_deg, beta_deg = rng.uniform(-3.0, 3.0, 2)
    sigma, n = 0.01, 400
    samples = level_reading(gamma_deg, beta_deg) + rng.normal(scale=sigma, size=(n, 3))
    result = solve_level_capture(samples, 3, LIMITS)
    bound_deg = math.degrees(4.0 * sigma / (G * math.sqrt(n)))
    assert abs(result.gamma_deg - gamma_deg) < bound_deg
    assert abs(result.beta_deg - beta_deg) < bound_deg


def test_noisy_capture_error_statistics():
    """
    Over 400 captures the error spread is sigma/(g sqrt N) and there is no bias.

    The sample standard deviation of K = 400 Gaussian errors is within 15 % of the true
    one except with probability ~1e-5 (its relative spread is 1/sqrt(2K) = 3.5 %); the
    mean is within 4 s/sqrt(K).
    """
    rng = np.random.default_rng(2012)
    sigma, n, k = 0.01, 50, 400       # standard error 0.0083 deg
    gamma_deg, beta_deg = 1.7, -2.2
    base = level_reading(gamma_deg, beta_deg)
    loose = replace(LIMITS, still=replace(LIMITS.still, max_sem_deg=0.1))
    errors = np.array([
        [(r.gamma_deg - gamma_deg), (r.beta_deg - beta_deg)]
        for r in (solve_level_capture(base + rng.normal(scale=sigma, size=(n, 3)), 3, loose)
                  for _ in range(k))])
    s_deg = math.degrees(sigma / (G * math.sqrt(n)))
    np.testing.assert_allclose(errors.std(axis=0, ddof=1), s_deg, rtol=0.15)
    assert np.all(np.abs(errors.mean(axis=0)) < 4.0 * s_deg / math.sqrt(k))


def test_reported_spread_is_per_sample_tilt_std():
    """std_deg estimates the per-sample tilt noise sigma/g (N = 2000: 1.6 % sampling error)."""
    rng = np.random.default_rng(5)
    sigma = 0.01
    samples = level_reading(0.5, 0.5) + rng.normal(scale=sigma, size=(2000, 3))
    result = solve_level_capture(samples, 3, LIMITS)
    assert result.std_deg == pytest.approx(math.degrees(sigma / G), rel=0.1)


def test_two_axis_capture_ignores_z_and_uses_configured_gravity():
    """Two axes: z is never read (NaN here); v_g is the configured gravity."""
    reading = level_reading(-1.2, 0.8)
    samples = np.tile([reading[0], reading[1], math.nan], (6, 1))
    result = solve_level_capture(samples, 2, LIMITS)
    assert result.gamma_deg == pytest.approx(-1.2, abs=1e-10)
    assert result.beta_deg == pytest.approx(0.8, abs=1e-10)
    assert result.g_total_mps2 == G
    assert result.std_deg < 1e-12


@pytest.mark.parametrize('count', [0, 1, 5])
def test_refuses_too_few_samples(count):
    """Fewer than six samples: no still test (three blocks of two) can be made."""
    samples = np.tile(level_reading(0.1, 0.1), (count, 1))
    with pytest.raises(CaptureRefused) as caught:
        solve_level_capture(samples, 3, LIMITS)
    assert str(caught.value) == f'{count} samples: a still test needs at least 6'


def test_noisy_still_tool_is_refused_as_noisy_not_moving():
    """
    Samples alternating +-0.5 deg about y have a stable mean: too noisy, not moving.

    Their noise is 0.5 deg (within blocks of two: exactly a sqrt(2)/sqrt(2)), the standard
    error 0.5 / sqrt(10) deg; 0.01 deg needs 10 (0.5 / sqrt(10) / 0.01)^2 = 2500 samples.
    """
    a, n = math.radians(0.5), 10
    signs = np.tile([1.0, -1.0], n // 2)
    samples = G * np.column_stack([signs * math.sin(a), np.zeros(n), np.full(n, math.cos(a))])
    with pytest.raises(CaptureRefused) as caught:
        solve_level_capture(samples, 3, LIMITS)
    assert str(caught.value).startswith('too noisy for the target: 2500 samples needed')
    assert 'level_capture.max_sem_deg 0.01 deg' in str(caught.value)
    # The same samples pass with a target above their standard error (the mean is level).
    loose = replace(LIMITS, still=replace(LIMITS.still, max_sem_deg=0.5 / math.sqrt(n) + 1e-6))
    result = solve_level_capture(samples, 3, loose)
    assert result.std_deg == pytest.approx(0.5, rel=1e-9)
    assert abs(result.gamma_deg) < 1e-12 and abs(result.beta_deg) < 1e-12


def test_refuses_drifting_tool():
    """A noise-free tilt of 0.1 deg/s at 100 Hz: drift 0.1 deg/s > 0.02, named in deg/s."""
    times_s = np.arange(50) / 100.0
    samples = np.array([level_reading(0.1 * t, 0.0) for t in times_s])
    with pytest.raises(CaptureRefused, match=r'^tool is moving \(drift 0\.1000 deg/s'):
        solve_level_capture(samples, 3, LIMITS, times_s)


@pytest.mark.parametrize('scale', [1.05, 0.95, 9.80665])   # 5 % off, and g-units read as m/s^2
def test_refuses_implausible_g_total(scale):
    """A mean magnitude off gravity by more than the tolerance is refused (3 axes)."""
    samples = np.tile(level_reading(0.2, -0.3) * scale, (6, 1))
    g_total = G * scale
    with pytest.raises(CaptureRefused) as caught:
        solve_level_capture(samples, 3, LIMITS)
    assert str(caught.value) == (
        f'implausible G-total {g_total:.4f} m/s^2: expected {G} +/- 0.3 m/s^2 '
        '(sensor scale or units wrong?)')


def test_accepts_g_total_within_tolerance():
    """0.29 m/s^2 off gravity passes with a 0.3 tolerance, and is reported."""
    samples = np.tile(level_reading(0.2, -0.3, G + 0.29), (6, 1))
    result = solve_level_capture(samples, 3, LIMITS)
    assert result.g_total_mps2 == pytest.approx(G + 0.29, rel=1e-14)
    assert result.gamma_deg == pytest.approx(0.2, abs=1e-10)


def test_refuses_tilted_bench():
    """Gamma = beta = 4 deg: theta = acos(cos^2 4 deg) = 5.655 deg > max_tilt_deg 5."""
    theta_deg = math.degrees(math.acos(math.cos(math.radians(4.0)) ** 2))
    samples = np.tile(level_reading(4.0, 4.0), (6, 1))
    with pytest.raises(CaptureRefused) as caught:
        solve_level_capture(samples, 3, LIMITS)
    assert str(caught.value) == (
        f'bench is not level: tilt {theta_deg:.3f} deg exceeds level_capture.max_tilt_deg '
        '5.0 deg')
    assert f'{theta_deg:.3f}' == '5.655'
    # 3.5 deg each (theta 4.95 deg) passes.
    result = solve_level_capture(np.tile(level_reading(3.5, 3.5), (6, 1)), 3, LIMITS)
    assert result.theta_deg == pytest.approx(
        math.degrees(math.acos(math.cos(math.radians(3.5)) ** 2)), abs=1e-9)


def test_refusal_order():
    """Moving is reported before G-total, G-total before the tilt."""
    moving_and_scaled = np.array([level_reading(0.2 * k, 0.0) for k in range(10)]) * 1.1
    with pytest.raises(CaptureRefused, match='^tool is moving'):
        solve_level_capture(moving_and_scaled, 3, LIMITS)
    scaled_and_tilted = np.tile(level_reading(6.0, 0.0) * 1.1, (6, 1))
    with pytest.raises(CaptureRefused, match='^implausible G-total'):
        solve_level_capture(scaled_and_tilted, 3, LIMITS)
