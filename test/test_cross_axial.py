"""
Cross-axial ellipse correction (seed 002 §2.1) on simulated rotations.

Bounds: for N samples spread evenly round the circle with isotropic noise sigma per axis,
the least-squares centre has covariance (2 sigma^2 / N) I (each sample informs the centre
through cos and sin of its angle, sum cos^2 = N / 2), so the offsets are checked to
5 sigma sqrt(2 / N) per axis.  The radial residual of a corrected sample has standard
deviation sigma, and the RMSE of N of them is sigma within a relative 1 / sqrt(2 N) (1 sigma):
checked to 5 / sqrt(2 N).  The shape (W A, relative) is known to ~sigma / r sqrt(2 / N);
checked to 1e-4, over ten times that.
"""

import math

from inclino_ros.core.cross_axial import (
    apply_cross_axial, fit_cross_axial, fit_ellipse, RotationFitRefused, RotationLimits)
from inclino_ros.core.magnetics import azimuth_deg, forward
import numpy as np
import pytest

G_STD = 9.80665
HARD_IRON_NT = np.array([80.0, -80.0])
SOFT_IRON = np.array([[1.03, 0.015], [0.015, 0.98]])
SIGMA_NT = 10.0
N_SEED = 1323  # samples in seed 002's rotation (§3.1)


def rotation(toolface_deg, soft=SOFT_IRON, hard=HARD_IRON_NT, sigma=SIGMA_NT, seed=0):
    """Return (G, true B, measured B) of the tool turning in an east-west horizontal hole."""
    G, B = forward(88.0, 95.0, toolface_deg, G_STD, 5.0e4, 62.0)
    measured = B.copy()
    noise = np.random.default_rng(seed).normal(0.0, sigma, (len(toolface_deg), 2))
    measured[:, :2] = B[:, :2] @ soft.T + hard + noise
    return G, B, measured


def full_turn(n=N_SEED):
    """Return n toolfaces evenly round one turn."""
    return np.linspace(0.0, 360.0, n, endpoint=False)


def test_recovers_hard_iron_and_maps_the_ellipse_to_a_circle():
    _, B, measured = rotation(full_turn())
    fit = fit_cross_axial(measured)
    assert np.all(np.abs(fit.offset_nT - HARD_IRON_NT) < 5.0 * SIGMA_NT * math.sqrt(2.0 / N_SEED))
    # W undoes A up to the common scale sqrt(det A): the circle of the ellipse's area.
    scale = math.sqrt(np.linalg.det(SOFT_IRON))
    assert np.allclose(fit.correction @ SOFT_IRON, scale * np.eye(2), rtol=0, atol=1e-4)
    assert np.allclose(fit.correction, fit.correction.T)
    true_radius = np.linalg.norm(B[0, :2])
    assert fit.radius_nT == pytest.approx(scale * true_radius, rel=1e-4)
    assert abs(fit.rmse_nT / SIGMA_NT - 1.0) < 5.0 / math.sqrt(2.0 * N_SEED)
    corrected = apply_cross_axial(measured, fit)
    radial = np.linalg.norm(corrected[:, :2], axis=1) - fit.radius_nT
    assert math.sqrt(np.mean(radial ** 2)) == pytest.approx(fit.rmse_nT)
    assert np.array_equal(corrected[:, 2], measured[:, 2])
    assert fit.coverage_deg == pytest.approx(360.0, abs=1.0)
    assert fit.sample_count == N_SEED
    assert fit.axis_ratio == pytest.approx(1.06, abs=0.01)


def test_pure_hard_iron_without_noise_is_removed_exactly_and_the_azimuth_restored():
    G, B, measured = rotation(full_turn(90), soft=np.eye(2), sigma=0.0)
    fit = fit_cross_axial(measured)
    assert np.allclose(fit.offset_nT, HARD_IRON_NT, rtol=0, atol=1e-6)
    corrected = apply_cross_axial(measured, fit)
    assert np.allclose(corrected, B, rtol=0, atol=1e-6)
    error = (azimuth_deg(G, corrected) - 95.0 + 180.0) % 360.0 - 180.0
    assert np.max(np.abs(error)) < 1e-8
    # East-west, a cross-axial bias moves the azimuth by only |c| cosA / (B cosD), 0.024 deg.
    raw_error = (azimuth_deg(G, measured) - 95.0 + 180.0) % 360.0 - 180.0
    assert np.max(np.abs(raw_error)) > 0.02


def test_apply_is_vectorised_over_leading_axes():
    _, _, measured = rotation(full_turn(60))
    fit = fit_cross_axial(measured)
    stacked = measured.reshape(4, 15, 3)
    assert np.array_equal(apply_cross_axial(stacked, fit),
                          apply_cross_axial(measured, fit).reshape(4, 15, 3))


def test_a_200_deg_arc_is_refused_and_a_300_deg_arc_accepted():
    with pytest.raises(RotationFitRefused, match='covers 2'):
        fit_cross_axial(rotation(np.linspace(0.0, 200.0, 400))[2])
    fit = fit_cross_axial(rotation(np.linspace(30.0, 330.0, 400))[2])
    assert fit.coverage_deg == pytest.approx(300.0, abs=1.0)


def test_too_few_and_non_finite_samples_are_refused():
    _, _, measured = rotation(full_turn(19))
    with pytest.raises(RotationFitRefused, match='only 19 sample'):
        fit_cross_axial(measured)
    _, _, measured = rotation(full_turn(40))
    measured[7, 1] = np.nan
    with pytest.raises(RotationFitRefused, match='non-finite'):
        fit_cross_axial(measured)


def test_degenerate_captures_are_refused():
    line = np.stack([np.linspace(0.0, 1e3, 50), np.linspace(0.0, 2e3, 50)], axis=1)
    with pytest.raises(RotationFitRefused, match='degenerate'):
        fit_cross_axial(line)
    with pytest.raises(RotationFitRefused, match='degenerate'):
        fit_cross_axial(np.full((50, 2), 3e4))
    with pytest.raises(RotationFitRefused, match='axis ratio 1.5'):
        fit_cross_axial(rotation(full_turn(200), soft=np.diag([1.5, 1.0]))[2])
    with pytest.raises(RotationFitRefused, match='do not lie on an ellipse'):
        fit_cross_axial(rotation(full_turn(200), sigma=3e3)[2])
    fit = fit_cross_axial(rotation(full_turn(200), soft=np.diag([1.5, 1.0]))[2],
                          RotationLimits(max_axis_ratio=2.0))
    assert fit.axis_ratio == pytest.approx(1.5, abs=1e-3)


def test_fit_ellipse_of_an_exact_ellipse():
    angle = np.radians(np.arange(0.0, 360.0, 7.0))
    rot = np.array([[math.cos(0.4), -math.sin(0.4)], [math.sin(0.4), math.cos(0.4)]])
    points = np.stack([300.0 * np.cos(angle), 200.0 * np.sin(angle)], axis=1) @ rot.T
    centre, q = fit_ellipse(points + [1e4, -2e4])
    assert np.allclose(centre, [1e4, -2e4], rtol=0, atol=1e-6)
    expected = rot @ np.diag([300.0 ** -2, 200.0 ** -2]) @ rot.T
    assert np.allclose(q, expected, rtol=1e-9, atol=0)
