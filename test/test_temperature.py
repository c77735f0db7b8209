"""
Seed 001 temperature model A_T = K_T G, K_T = f(T) (Eqs. 5-7), alone and before the stand K.

Tolerances:
- Noise-free: a quadratic drift fitted with order 2 is exact; Polynomial.fit works on a
  scaled domain and converts to plain coefficients, costing a few 1e-16 on K_T ~ 1, so
  coefficients (a2 ~ 1e-6 multiplies T^2 ~ 1e4) and K_T compare to 1e-12.
- Noisy: SIGMA_G = 2e-4 g per sample, 100 samples a capture (2e-5 g), one capture per
  temperature 20, 30, ..., 100 deg C at a fit attitude where every axis sees >= 0.57 g: K_T
  errs by ~3e-5 at 1 sigma, an inclination by ~2e-3 deg; with the stand's own ~1.6e-3 deg
  the largest of 400 compensated errors stays below 0.01 deg (> 4 sigma).
"""

import math

from inclino_ros.core.attitude import inclination
from inclino_ros.core.stand import fit_stand, stand_specific_force
from inclino_ros.core.temperature import (
    compensate_temperature, fit_temperature, in_range, MIN_AXIS_FRACTION,
    TemperatureFitRefused)
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

G = 9.80665
EXACT = 1e-12
SIGMA_G = 2e-4
SAMPLES = 100
#: Seed 001 heats the tool from 20 to 100 deg C and reads it every 10 deg C.
STEPS_C = np.arange(20.0, 101.0, 10.0)
#: One attitude at which every axis sees gravity: (0.58, 0.58, 0.57) g.
FIT_ATTITUDE = stand_specific_force(55.0, 45.0, G)
#: Drift of the scale factors, distinct per axis: (slope per deg C, curvature per deg C^2).
DRIFT = np.array([(3e-4, 2e-6), (-2e-4, 1e-6), (-3e-4, -2e-6)])

SENSOR_K = np.array([[1.012, 0.021, -0.030],
                     [-0.018, 0.991, 0.043],
                     [0.029, -0.044, 1.006]])
SENSOR_BIAS_MPS2 = np.array([0.15, -0.22, 0.09])
STAND_POSITIONS_DEG = np.array([
    (0.0, 0.0), (180.0, 0.0), (90.0, 0.0), (90.0, 90.0), (90.0, 180.0), (90.0, 270.0),
    (45.0, 45.0), (135.0, 165.0), (60.0, 300.0)])


def true_scale(temperature_c):
    """Return the simulated K_T(T) = 1 + a (T - 25) + c (T - 25)^2 per axis, shape (N, 3)."""
    dt = np.asarray(temperature_c, dtype=float)[..., None] - 25.0
    return 1.0 + DRIFT[:, 0] * dt + DRIFT[:, 1] * dt * dt


def true_coefficients():
    """Return true_scale expanded in powers of T: (a0, a1, a2) per axis."""
    slope, curve = DRIFT.T
    return np.stack([1.0 - 25.0 * slope + 625.0 * curve, slope - 50.0 * curve, curve], axis=1)


def capture(truth, temperature_c, rng):
    """Return mean readings of SAMPLES noisy samples of the drifting sensor at each row."""
    clean = true_scale(temperature_c) * (truth @ SENSOR_K.T + SENSOR_BIAS_MPS2)
    return clean + rng.normal(0.0, SIGMA_G * G / math.sqrt(SAMPLES), clean.shape)


def test_noise_free_fit_is_exact():
    """A quadratic drift at one attitude gives its coefficients back, K_T(25 C) = 1."""
    readings = true_scale(STEPS_C) * FIT_ATTITUDE
    fit = fit_temperature(STEPS_C, readings, FIT_ATTITUDE, order=2)
    np.testing.assert_allclose(fit.coefficients, true_coefficients(), rtol=0, atol=EXACT)
    np.testing.assert_allclose(fit.scale_factor([25.0]), [[1.0, 1.0, 1.0]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(fit.scale_factor(STEPS_C), true_scale(STEPS_C), atol=EXACT)
    assert (fit.t_min_c, fit.t_max_c, fit.reference_temperature_c) == (20.0, 100.0, 25.0)
    assert fit.rms_residual.max() < EXACT
    np.testing.assert_allclose(compensate_temperature(readings, STEPS_C, fit),
                               np.tile(FIT_ATTITUDE, (9, 1)), rtol=0, atol=EXACT)


def test_weighted_fit_equals_direct_least_squares_over_two_attitudes():
    """
    Two attitudes, noisy: the fit equals lstsq of A_i = (sum a_k T^k) G_i, normalised.

    The direct design G_i T^k (T^k up to 1e4) is solved in plain powers, independent of
    Polynomial.fit's scaled domain and weights; both solve one problem: coefficients agree
    to 1e-13 (times T^2 = 1e4, 1e-9 of K_T).
    """
    rng = np.random.default_rng(3)
    vertical, horizontal = stand_specific_force(0.0, 0.0, G), stand_specific_force(90.0, 45.0, G)
    temperature_c = np.concatenate([STEPS_C, STEPS_C + 5.0])
    reference = np.vstack([np.tile(vertical, (9, 1)), np.tile(horizontal, (9, 1))])
    readings = true_scale(temperature_c) * reference + rng.normal(0.0, 2e-5 * G, reference.shape)
    fit = fit_temperature(temperature_c, readings, reference, order=2)
    for axis in range(3):
        design = reference[:, axis, None] * temperature_c[:, None] ** np.arange(3)
        direct = np.linalg.lstsq(design, readings[:, axis], rcond=None)[0]
        direct /= np.polynomial.polynomial.polyval(25.0, direct)
        np.testing.assert_allclose(fit.coefficients[axis], direct, rtol=0, atol=1e-9 / 1e4)
    np.testing.assert_allclose(fit.scale_factor(STEPS_C), true_scale(STEPS_C), atol=1e-4)


def test_drift_is_compensated_before_the_stand_k():
    """
    20-100 deg C: >= 1 deg inclination error with the stand K alone, <= 0.01 deg with K_T.

    The chain of the calibration model: A / K_T(T) (Eq. 6), then K^-1 (A - b) (Eq. 11).
    The stand is captured at 25 deg C; the heating run at FIT_ATTITUDE with the stand's
    truth as reference (its scale at 25 deg C is normalised away).
    """
    rng = np.random.default_rng(1)
    stand_truth = stand_specific_force(STAND_POSITIONS_DEG[:, 0], STAND_POSITIONS_DEG[:, 1], G)
    stand = fit_stand(capture(stand_truth, np.full(9, 25.0), rng), stand_truth)
    heating = capture(np.tile(FIT_ATTITUDE, (9, 1)), STEPS_C, rng)
    drift = fit_temperature(STEPS_C, heating, FIT_ATTITUDE, order=2)

    truth = G * Rotation.random(400, random_state=rng).apply([0.0, 0.0, 1.0])
    temperature_c = rng.uniform(20.0, 100.0, 400)
    readings = capture(truth, temperature_c, rng)
    uncompensated = stand.apply(readings)
    compensated = stand.apply(compensate_temperature(readings, temperature_c, drift))
    true_deg = np.degrees(inclination(truth))
    assert np.abs(np.degrees(inclination(uncompensated)) - true_deg).max() >= 1.0
    assert np.abs(np.degrees(inclination(compensated)) - true_deg).max() <= 0.01


def refusal(*args, **kwargs):
    """Return the reason fit_temperature gives for refusing."""
    with pytest.raises(TemperatureFitRefused) as info:
        fit_temperature(*args, **kwargs)
    return info.value.reason


def test_refuses_an_order_too_high_for_the_temperatures():
    """Nine distinct temperatures (three samples each) allow order 7, not order 8."""
    temperature_c = np.repeat(STEPS_C, 3)
    readings = true_scale(temperature_c) * FIT_ATTITUDE
    fit_temperature(temperature_c, readings, FIT_ATTITUDE, order=7)
    assert 'order 8 needs at least 10 distinct temperatures (more than its 9 coefficients), ' \
        'got 9' in refusal(temperature_c, readings, FIT_ATTITUDE, order=8)


def test_refuses_non_finite_data():
    """A NaN temperature or reading is refused."""
    temperature_c = STEPS_C.copy()
    temperature_c[4] = math.nan
    readings = true_scale(STEPS_C) * FIT_ATTITUDE
    assert 'non-finite' in refusal(temperature_c, readings, FIT_ATTITUDE, order=2)
    readings[2, 1] = math.inf
    assert 'non-finite' in refusal(STEPS_C, readings, FIT_ATTITUDE, order=2)


def test_refuses_axes_that_read_zero_at_the_fit_attitude():
    """A vertical tool gives x and y no gravity: K_T = A_T / G is undefined for them."""
    vertical = stand_specific_force(0.0, 0.0, G)
    reason = refusal(STEPS_C, true_scale(STEPS_C) * vertical, vertical, order=2)
    assert f'axis x, y reads about 0 at the fit attitude(s) (at most 0.000 of |G|, need ' \
        f'{MIN_AXIS_FRACTION})' in reason
    tilted = stand_specific_force(60.0, 0.0, G)  # y still reads 0
    assert 'axis y reads about 0' in refusal(STEPS_C, true_scale(STEPS_C) * tilted, tilted,
                                             order=2)


def test_refuses_a_reference_temperature_outside_the_data():
    """Data from 30 deg C cannot normalise K_T at 25 deg C without extrapolating."""
    steps_c = STEPS_C[1:]
    reason = refusal(steps_c, true_scale(steps_c) * FIT_ATTITUDE, FIT_ATTITUDE, order=2)
    assert 'reference temperature 25.0 C lies outside the data [30.0, 100.0] C' in reason
    fit = fit_temperature(steps_c, true_scale(steps_c) * FIT_ATTITUDE, FIT_ATTITUDE, order=2,
                          reference_temperature_c=30.0)
    assert fit.scale_factor([30.0]) == pytest.approx(np.ones((1, 3)), abs=1e-15)


def test_refuses_a_reference_of_the_wrong_sign():
    """Readings against a reference with z reversed give K_T(25) < 0: wrong frame."""
    reference = FIT_ATTITUDE * np.array([1.0, 1.0, -1.0])
    reason = refusal(STEPS_C, true_scale(STEPS_C) * FIT_ATTITUDE, reference, order=2)
    assert 'axis z: K_T(25.0 C) = -1 is not positive' in reason


def test_in_range_and_extrapolation():
    """in_range marks the fitted interval inclusive; outside it compensation extrapolates."""
    readings = true_scale(STEPS_C) * FIT_ATTITUDE
    fit = fit_temperature(STEPS_C, readings, FIT_ATTITUDE, order=2)
    assert in_range([19.9, 20.0, 60.0, 100.0, 100.1], fit).tolist() == [
        False, True, True, True, False]
    hot_c = np.array([110.0, 120.0])
    np.testing.assert_allclose(
        compensate_temperature(true_scale(hot_c) * FIT_ATTITUDE, hot_c, fit),
        np.tile(FIT_ATTITUDE, (2, 1)), atol=EXACT)


def test_wrong_shapes_are_programming_errors():
    """Mismatched temperature and reading counts raise ValueError."""
    with pytest.raises(ValueError, match='need temperature_c'):
        fit_temperature(STEPS_C[:5], true_scale(STEPS_C) * FIT_ATTITUDE, FIT_ATTITUDE, order=2)
