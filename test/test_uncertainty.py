"""
The 1 sigma of every angle (issue 9, bullet 2), against Monte Carlo on the physical model.

Also its gradients against finite differences, and the default limits.

Tolerances:
- the standard deviation of N = 4000 Gaussian samples has a relative sampling error of
  1 / sqrt(2 N) = 1.1 % (1 sigma): 6 % is > 5 sigma; first order holds where the angle's
  sigma is small (< 4 deg here), its curvature adding < 1 %;
- central differences with step h err by O(h^2): 1e-6 relative at the steps used.
"""

import math

from inclino_ros.calibration.model import CalibrationModel, Installation
from inclino_ros.core.installation import inverse_installation_matrix
from inclino_ros.core.magnetics import azimuth_deg, gravity_from_specific_force, iscwsa_from_tool
from inclino_ros.core.uncertainty import (
    affine_jacobian, azimuth_gradients, inclination_std_rad, roll_pitch_covariance,
    tilt_jacobian, toolface_std_rad)
from inclino_ros.pipeline import imu_covariances, MagneticSettings, run, Settings
from inclino_ros.sim import sensor_model
import numpy as np
import pytest

G = sensor_model.STANDARD_GRAVITY_MPS2
NOISE_MPS2, NOISE_NT = 0.01, 100.0            # the node's default per-sample noise
SAMPLES = 4000
NOISY = sensor_model.Tool(accelerometer=sensor_model.Triad(noise_std=NOISE_MPS2),
                          magnetometer=sensor_model.Triad(noise_std=NOISE_NT))


def circular_std_deg(angles_deg, center_deg):
    """Return the RMS of angle - center wrapped to [-180, 180) [deg]."""
    return float(np.sqrt(np.mean(((angles_deg - center_deg + 180.0) % 360.0 - 180.0) ** 2)))


def survey(inclination_deg, toolface_deg, azimuth_deg_, tool=NOISY, axes=3, seed=0, model=None):
    """Return the pipeline's Survey of SAMPLES readings of ``tool`` at one attitude."""
    readings = sensor_model.read(tool, np.full(SAMPLES, inclination_deg), toolface_deg,
                                 azimuth_deg_, rng=seed)
    return run(readings.accel_mps2, model or CalibrationModel(axes),
               Settings(accelerometer_axes=axes, toolface_max_std_deg=180.0,
                        two_axis_max_inclination_deg=89.0),
               field_nT=readings.mag_nT if axes == 3 else None,
               magnetic_settings=MagneticSettings(azimuth_max_std_deg=180.0))


@pytest.mark.parametrize('inclination_deg', [1.0, 5.0, 30.0, 90.0])
def test_toolface_and_inclination_sigma_match_their_spread(inclination_deg):
    """Toolface 1 sigma 0.0584 deg / sin I, inclination 0.0584 deg: the spread of 4000."""
    result = survey(inclination_deg, 130.0, 40.0)
    assert circular_std_deg(result.toolface_deg, 130.0) == pytest.approx(
        np.median(result.toolface_std_deg), rel=0.06)
    assert np.std(result.inclination_deg) == pytest.approx(
        np.median(result.inclination_std_deg), rel=0.06)
    np.testing.assert_allclose(np.median(result.toolface_std_deg), math.degrees(
        NOISE_MPS2 / (G * math.sin(math.radians(inclination_deg)))), rtol=0.01)


@pytest.mark.parametrize('inclination_deg, azimuth_deg_',
                         [(3.0, 90.0), (30.0, 45.0), (90.0, 90.0), (60.0, 200.0)])
def test_azimuth_sigma_matches_its_spread(inclination_deg, azimuth_deg_):
    """The azimuth's 1 sigma (accelerometer and magnetometer noise) is its spread."""
    result = survey(inclination_deg, 300.0, azimuth_deg_).magnetic
    assert circular_std_deg(result.azimuth_deg, azimuth_deg_) == pytest.approx(
        np.median(result.azimuth_std_deg), rel=0.06)


@pytest.mark.parametrize('inclination_deg', [10.0, 45.0, 70.0])
def test_two_axis_completion_sigma_matches_its_spread(inclination_deg):
    """Two axes: the inclination's 1 sigma is noise / (g cos I) (z completed): its spread."""
    tool = sensor_model.Tool(accelerometer=sensor_model.Triad(noise_std=NOISE_MPS2),
                             accelerometer_axes=2)
    result = survey(inclination_deg, 0.0, 0.0, tool=tool, axes=2)
    expected_deg = math.degrees(NOISE_MPS2 / (G * math.cos(math.radians(inclination_deg))))
    assert np.std(result.inclination_deg) == pytest.approx(expected_deg, rel=0.06)
    np.testing.assert_allclose(np.median(result.inclination_std_deg), expected_deg, rtol=0.02)
    # imu/data: TF 0, the tilt is a pitch about y: its variance is the same.
    _, orientation = imu_covariances(result)
    np.testing.assert_allclose(np.sqrt(np.median(orientation[:, 4])),
                               math.radians(expected_deg), rtol=0.02)


def test_gradients_are_the_derivatives():
    """Azimuth, inclination, toolface, roll and pitch gradients against central differences."""
    rng = np.random.default_rng(1)
    readings = sensor_model.read(sensor_model.IDEAL, rng.uniform(5.0, 175.0, 50),
                                 rng.uniform(0.0, 360.0, 50), rng.uniform(0.0, 360.0, 50))
    G_ = gravity_from_specific_force(readings.specific_force_tool_mps2)
    B = iscwsa_from_tool(readings.earth_field_tool_nT)
    grad_g, grad_b = azimuth_gradients(G_, B)
    for vector, grad, step in ((G_, grad_g, 1e-4), (B, grad_b, 1e-1)):
        for axis in range(3):
            delta = np.zeros(3)
            delta[axis] = step
            plus = azimuth_deg(G_ + delta, B) if vector is G_ else azimuth_deg(G_, B + delta)
            minus = azimuth_deg(G_ - delta, B) if vector is G_ else azimuth_deg(G_, B - delta)
            numeric = np.radians((plus - minus + 180.0) % 360.0 - 180.0) / (2 * step)
            np.testing.assert_allclose(grad[:, axis], numeric, rtol=1e-5, atol=1e-12)
    # Inclination, toolface, roll, pitch: with C = I their variances are |grad|^2.
    f = readings.specific_force_tool_mps2
    identity = np.broadcast_to(np.eye(3), (50, 3, 3))
    h = np.hypot(f[:, 0], f[:, 1])
    np.testing.assert_allclose(inclination_std_rad(f, identity), 1.0 / G, rtol=1e-12)
    np.testing.assert_allclose(toolface_std_rad(f, identity), 1.0 / h, rtol=1e-12)
    rp = roll_pitch_covariance(f, identity)
    np.testing.assert_allclose(rp[:, 0, 0], 1.0 / (f[:, 1] ** 2 + f[:, 2] ** 2), rtol=1e-12)
    np.testing.assert_allclose(rp[:, 1, 1], 1.0 / G ** 2, rtol=1e-12)


def test_the_calibration_own_sigma_enters():
    """A level capture's 1 sigma (std / sqrt N) adds tilt^2 and tilt^2 / sin^2 I."""
    installation = Installation(0.0, 0.0, '2026-01-01T00:00:00+00:00', 100, 0.1, G)
    tilt = math.radians(0.1) / 10.0
    f = sensor_model.true_specific_force([2.0], [10.0])
    result = run(f, CalibrationModel(3, installation=installation),
                 Settings(noise_std_mps2=1e-6))
    np.testing.assert_allclose(result.toolface_std_deg, math.degrees(
        math.hypot(1e-6 / G, tilt) / math.sin(math.radians(2.0))), rtol=1e-6)
    np.testing.assert_allclose(result.inclination_std_deg, math.degrees(
        math.hypot(1e-6 / G, tilt)), rtol=1e-6)


def test_default_limits_publish_only_what_is_meaningful():
    """
    Default noise: toolface NaN below ~0.7 deg (5 deg limit), azimuth below ~3.3 deg (1 deg).

    Formerly the toolface was published from 0.01 deg (spread 102 deg at 0.02, 39 at 0.1,
    6.7 at 0.5) and the azimuth from 0.5 deg (6.3 deg spread).
    """
    for inclination_deg, toolface_kept, azimuth_kept in ((0.02, 0.0, 0.0), (0.1, 0.0, 0.0),
                                                         (0.5, 0.0, 0.0), (1.5, 1.0, 0.0),
                                                         (2.0, 1.0, 0.0), (6.0, 1.0, 1.0)):
        readings = sensor_model.read(NOISY, np.full(SAMPLES, inclination_deg), 50.0, 90.0,
                                     rng=2)
        result = run(readings.accel_mps2, CalibrationModel(3), Settings(),
                     field_nT=readings.mag_nT, magnetic_settings=MagneticSettings())
        assert np.isfinite(result.toolface_deg).mean() == pytest.approx(toolface_kept, abs=0.01)
        assert np.isfinite(result.magnetic.azimuth_deg).mean() == pytest.approx(azimuth_kept,
                                                                                abs=0.01)


def test_parameter_jacobians_against_finite_differences():
    """The fits' Jacobians (issue 19 item 2) against central differences of the stages."""
    rng = np.random.default_rng(4)
    vectors = rng.normal(size=(5, 3)) * 30000.0
    matrix, offset = np.eye(3) + 0.01 * rng.normal(size=(3, 3)), rng.normal(size=3) * 300.0

    def affine(p):
        return (vectors - p[9:]) @ p[:9].reshape(3, 3).T

    start = np.concatenate([matrix.ravel(), offset])
    numeric = np.stack([(affine(start + h) - affine(start - h)) / 2e-3
                        for h in np.eye(12) * 1e-3], axis=2)
    assert np.allclose(affine_jacobian(vectors - offset, matrix), numeric, rtol=1e-9, atol=1e-6)
    gamma, beta = 0.3, -0.7

    def turned(angles):
        return vectors @ inverse_installation_matrix(*angles).T

    numeric = np.stack([(turned(np.add((gamma, beta), h)) - turned(np.subtract((gamma, beta), h)))
                        / 2e-6 for h in np.eye(2) * 1e-6], axis=2)
    assert np.allclose(tilt_jacobian(vectors, gamma, beta), numeric, rtol=1e-6, atol=1e-4)
