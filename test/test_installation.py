"""
Seed 000 installation geometry (Eqs. 1-15) against closed forms and the paper's numbers.

Tolerances: the matrices and vectors here are a handful of double-precision operations on
numbers of order one, so their round-off is a few 1e-16; 1e-13 absolute leaves a wide
margin while still catching any wrong sign or swapped element (errors of order sin(angle)).
Angles recovered through asin/atan2 of well-conditioned arguments get 1e-12 rad.
"""

import math

from hypothesis import given, settings
from hypothesis import strategies as st
from inclino_ros.core.attitude import inclination
from inclino_ros.core.installation import (
    correct_installation, installation_angles, installation_matrix,
    inverse_installation_matrix, level_axis_angles, pseudo_inclination)
import numpy as np
import pytest
from transforms3d.axangles import axangle2mat

G = 9.80665
EPS_MATRIX = 1e-13
EPS_ANGLE_RAD = 1e-12

# Installation angles: the model accepts |angle| < 45 deg; real installations are sub-degree.
install_deg = st.floats(min_value=-44.0, max_value=44.0, allow_nan=False)
small_install_deg = st.floats(min_value=-3.0, max_value=3.0, allow_nan=False)
toolface_deg = st.floats(min_value=0.0, max_value=360.0, allow_nan=False)
hyp = settings(max_examples=200, deadline=None)


def paper_eq1_factors(gamma, beta):
    """Return the two factor matrices exactly as printed in Eq. 1."""
    cg, sg, cb, sb = math.cos(gamma), math.sin(gamma), math.cos(beta), math.sin(beta)
    about_x = np.array([[1.0, 0.0, 0.0], [0.0, cb, -sb], [0.0, sb, cb]])
    about_y = np.array([[cg, 0.0, -sg], [0.0, 1.0, 0.0], [sg, 0.0, cg]])
    return about_x, about_y


def paper_eq8(gamma, beta):
    """Return the explicit C^-1 matrix printed in Eq. 8 (and Eq. 9)."""
    cg, sg, cb, sb = math.cos(gamma), math.sin(gamma), math.cos(beta), math.sin(beta)
    return np.array([[cg, -sb * sg, sg * cb],
                     [0.0, cb, sb],
                     [-sg, -sb * cg, cb * cg]])


def angle_between(u, v):
    """Return the angle between two 3-vectors, accurate at every size (atan2 form)."""
    return math.atan2(np.linalg.norm(np.cross(u, v)), float(np.dot(u, v)))


def true_specific_force(incl, alpha, g=G):
    """Return the ideal-frame reading of a still tool (seed 000: g(sin tx, sin ty, cos phi))."""
    return g * np.array([math.sin(incl) * math.cos(alpha), math.sin(incl) * math.sin(alpha),
                         math.cos(incl)])


def test_paper_worked_example():
    """Reproduce section 4: tilts -0.0355/0.2773 deg give gamma, beta and theta as printed."""
    gamma, beta = installation_angles(math.radians(-0.0355), math.radians(0.2773))
    theta = pseudo_inclination(gamma, beta)
    # The paper prints four decimals: the values must round to exactly those.
    assert round(math.degrees(gamma), 4) == 0.0355
    assert round(math.degrees(beta), 4) == -0.2773
    assert round(math.degrees(theta), 4) == 0.2796
    # Eq. 5, the other route to theta, gives the same printed value.
    eq5 = math.asin(math.hypot(math.sin(math.radians(-0.0355)), math.sin(math.radians(0.2773))))
    assert round(math.degrees(eq5), 4) == 0.2796
    assert theta == pytest.approx(eq5, abs=EPS_ANGLE_RAD)


def test_paper_worked_example_from_raw_level_reading():
    """Feed the worked example through Eqs. 11-12 as raw bench outputs v_x1, v_y1."""
    reading = G * np.array([math.sin(math.radians(-0.0355)), math.sin(math.radians(0.2773)),
                            0.999])
    tx, ty = level_axis_angles(reading, G)
    assert math.degrees(tx) == pytest.approx(-0.0355, abs=1e-12)
    assert math.degrees(ty) == pytest.approx(0.2773, abs=1e-12)
    gamma, beta = installation_angles(tx, ty)
    assert (round(math.degrees(gamma), 4), round(math.degrees(beta), 4)) == (0.0355, -0.2773)


@hyp
@given(install_deg, install_deg)
def test_installation_matrix_is_eq1(gamma_deg, beta_deg):
    """C equals the product of Eq. 1's printed factors and is a proper rotation."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    c = installation_matrix(gamma, beta)
    about_x, about_y = paper_eq1_factors(gamma, beta)
    np.testing.assert_allclose(c, about_x @ about_y, rtol=0, atol=EPS_MATRIX)
    np.testing.assert_allclose(c @ c.T, np.eye(3), rtol=0, atol=EPS_MATRIX)
    assert np.linalg.det(c) == pytest.approx(1.0, abs=EPS_MATRIX)


@hyp
@given(install_deg, install_deg)
def test_installation_matrix_matches_transforms3d(gamma_deg, beta_deg):
    """C = Rx(beta) @ Ry(-gamma), the factors built independently by transforms3d.axangles."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    expected = axangle2mat([1.0, 0.0, 0.0], beta) @ axangle2mat([0.0, 1.0, 0.0], -gamma)
    np.testing.assert_allclose(installation_matrix(gamma, beta), expected,
                               rtol=0, atol=EPS_MATRIX)


@hyp
@given(install_deg, install_deg)
def test_inverse_is_eq8_and_transpose(gamma_deg, beta_deg):
    """Eq. 8's explicit matrix equals C^T, numpy's inverse of C, and the module's C^-1."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    c = installation_matrix(gamma, beta)
    eq8 = paper_eq8(gamma, beta)
    np.testing.assert_allclose(eq8, c.T, rtol=0, atol=EPS_MATRIX)
    np.testing.assert_allclose(eq8, np.linalg.inv(c), rtol=0, atol=EPS_MATRIX)
    np.testing.assert_allclose(inverse_installation_matrix(gamma, beta), eq8,
                               rtol=0, atol=EPS_MATRIX)


@hyp
@given(install_deg, install_deg)
def test_level_reading_eq2_gives_back_angles(gamma_deg, beta_deg):
    """The level reading C (0,0,g) is Eq. 2's vector, and Eqs. 11-14 invert it."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    level = installation_matrix(gamma, beta) @ np.array([0.0, 0.0, G])
    eq2 = G * np.array([-math.sin(gamma), -math.sin(beta) * math.cos(gamma),
                        math.cos(beta) * math.cos(gamma)])
    np.testing.assert_allclose(level, eq2, rtol=0, atol=G * EPS_MATRIX)
    # asin is well conditioned for |angle| <= 44 deg (slope <= 1/cos 44 deg = 1.4).
    got_gamma, got_beta = installation_angles(*level_axis_angles(level, G))
    assert got_gamma == pytest.approx(gamma, abs=EPS_ANGLE_RAD)
    assert got_beta == pytest.approx(beta, abs=EPS_ANGLE_RAD)


@hyp
@given(install_deg, install_deg)
def test_pseudo_inclination_eqs_4_5(gamma_deg, beta_deg):
    """Theta of Eq. 4 equals Eq. 5 and the angle between the sensor and tool z axes."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    theta = float(pseudo_inclination(gamma, beta))
    tx, ty = level_axis_angles(installation_matrix(gamma, beta) @ np.array([0.0, 0.0, G]), G)
    eq5 = math.asin(math.sqrt(math.sin(tx) ** 2 + math.sin(ty) ** 2))
    # Sensor z axis in the ideal frame: third row of C.
    z1 = installation_matrix(gamma, beta)[2]
    # Eq. 5's asin loses precision near 90 deg only; theta <= 62.5 deg here.
    assert theta == pytest.approx(eq5, abs=EPS_ANGLE_RAD)
    assert theta == pytest.approx(angle_between(z1, np.array([0.0, 0.0, 1.0])),
                                  abs=EPS_ANGLE_RAD)


def test_pseudo_inclination_keeps_precision_for_tiny_angles():
    """Theta of 1e-9 rad errors is resolved (a plain acos would return 0 or 2e-8)."""
    gamma, beta = 3e-9, 4e-9
    # Closed form: theta^2 = gamma^2 + beta^2 to fourth order, so theta = 5e-9 to 1e-25.
    assert float(pseudo_inclination(gamma, beta)) == pytest.approx(5e-9, rel=1e-9)


@hyp
@given(small_install_deg, small_install_deg)
def test_eq15_matrix_equals_eq8(gamma_deg, beta_deg):
    """Eq. 15's last row, written with the level tilts and theta, equals Eq. 8's last row."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    tx, ty = level_axis_angles(installation_matrix(gamma, beta) @ np.array([0.0, 0.0, G]), G)
    theta = float(pseudo_inclination(gamma, beta))
    eq15 = paper_eq8(gamma, beta)
    eq15[2] = [math.sin(tx), math.sin(ty), math.cos(theta)]
    np.testing.assert_allclose(eq15, inverse_installation_matrix(gamma, beta),
                               rtol=0, atol=EPS_MATRIX)


@hyp
@given(small_install_deg, small_install_deg,
       st.floats(min_value=5.0, max_value=85.0), toolface_deg)
def test_eq10_direct_equals_corrected_inclination(gamma_deg, beta_deg, incl_deg, alpha_deg):
    """Eq. 10 evaluated from the sensor angles equals inclination(correct_installation)."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    truth = true_specific_force(math.radians(incl_deg), math.radians(alpha_deg))
    v1 = installation_matrix(gamma, beta) @ truth
    sin_tx1, sin_ty1, cos_phi1 = v1 / G
    eq10 = math.acos(-math.sin(gamma) * sin_tx1 - math.sin(beta) * math.cos(gamma) * sin_ty1
                     + math.cos(beta) * math.cos(gamma) * cos_phi1)
    got = float(inclination(correct_installation(v1, gamma, beta)))
    # acos has slope 1/sin(phi) <= 11.5 for phi >= 5 deg: 1e-12 rad is ~1000x its round-off.
    assert got == pytest.approx(eq10, abs=EPS_ANGLE_RAD)
    assert got == pytest.approx(math.radians(incl_deg), abs=EPS_ANGLE_RAD)


@hyp
@given(small_install_deg, small_install_deg, st.floats(min_value=0.0, max_value=30.0),
       toolface_deg)
def test_eq6_bounds(gamma_deg, beta_deg, incl_deg, alpha_deg):
    """The true inclination lies within |phi_1 - theta| .. phi_1 + theta (Eq. 6)."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    v1 = installation_matrix(gamma, beta) @ true_specific_force(
        math.radians(incl_deg), math.radians(alpha_deg))
    phi1 = float(inclination(v1))
    theta = float(pseudo_inclination(gamma, beta))
    phi = float(inclination(correct_installation(v1, gamma, beta)))
    assert abs(phi1 - theta) - EPS_ANGLE_RAD <= phi <= phi1 + theta + EPS_ANGLE_RAD


def _right_angle_station(gamma, beta, phi1):
    """
    Return the up direction u (ideal frame) of a tool tilted at right angles to Z1.

    Eq. 7 is the spherical right triangle Z, Z1, u (Z0) with the right angle at Z: the tool
    tilts (plane Z, u) at right angles to the installation tilt (plane Z, Z1), and phi_1 is
    the hypotenuse.  (A right angle at u is impossible here: its hypotenuse theta would
    have to be longer than phi_1.)  u is found by bisection on its angle from Z until it
    lies phi_1 from Z1, without using Eq. 7.
    """
    z = np.array([0.0, 0.0, 1.0])
    z1 = installation_matrix(gamma, beta)[2]
    w = np.cross(z, z1)
    w /= np.linalg.norm(w)           # horizontal, at right angles to Z1's tilt direction

    def u_at(phi):
        return math.cos(phi) * z + math.sin(phi) * w

    lo, hi = 0.0, phi1               # angle(u, Z1) - phi_1 is < 0 at lo and > 0 at hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if angle_between(u_at(mid), z1) < phi1:
            lo = mid
        else:
            hi = mid
    u = u_at(0.5 * (lo + hi))
    # The dihedral angle at Z between planes (Z, Z1) and (Z, u) is 90 deg.
    assert abs(np.dot(np.cross(z, z1), np.cross(z, u))) < 1e-15
    return u


def test_eq7_paper_example():
    """Beta = gamma = 1 deg, phi_1 = 2 deg, tilts at right angles: true phi ~1.414 deg (Eq. 7)."""
    gamma = beta = math.radians(1.0)
    phi1 = math.radians(2.0)
    theta = float(pseudo_inclination(gamma, beta))
    assert round(math.degrees(theta), 3) == 1.414          # "theta = 1.414 deg"
    u = _right_angle_station(gamma, beta, phi1)
    v1 = installation_matrix(gamma, beta) @ (G * u)
    # The sensor indeed reads phi_1 = 2 deg (bisection to 1e-16 rad, atan2 angles) ...
    assert float(inclination(v1)) == pytest.approx(phi1, abs=EPS_ANGLE_RAD)
    phi = float(inclination(correct_installation(v1, gamma, beta)))
    # ... the correction agrees with Eq. 7 (cos phi_1 = cos phi cos theta) and with the
    # paper's "about 1.414 deg", a measured error of about 30 % of phi_1.
    eq7 = math.acos(math.cos(phi1) / (math.cos(beta) * math.cos(gamma)))
    assert phi == pytest.approx(eq7, abs=1e-10)       # acos slope 1/sin(1.4 deg) = 41
    assert round(math.degrees(phi), 3) == 1.414
    assert (phi1 - phi) / phi1 == pytest.approx(0.30, abs=0.01)
    # Eq. 6 extremes: the paper prints [0.581, 3.414] deg; phi_1 + theta = 3.414 deg matches,
    # while phi_1 - theta = 0.586 deg (the printed 0.581 looks like a typo).
    assert round(math.degrees(phi1 + theta), 3) == 3.414
    assert round(math.degrees(phi1 - theta), 3) == 0.586


@hyp
@given(install_deg, install_deg,
       st.floats(min_value=0.0, max_value=180.0), toolface_deg)
def test_correct_installation_inverts_c(gamma_deg, beta_deg, incl_deg, alpha_deg):
    """Correcting C f gives back f (Eq. 9 undoes Eq. 1)."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    f = true_specific_force(math.radians(incl_deg), math.radians(alpha_deg))
    v1 = installation_matrix(gamma, beta) @ f
    np.testing.assert_allclose(correct_installation(v1, gamma, beta), f,
                               rtol=0, atol=G * EPS_MATRIX)


def test_vectorised_over_samples_and_angles():
    """Batches of readings and per-sample angles give the per-sample results, in shape."""
    rng = np.random.default_rng(7)
    gammas = np.radians(rng.uniform(-3.0, 3.0, 5))
    betas = np.radians(rng.uniform(-3.0, 3.0, 5))
    readings = rng.normal(size=(5, 3))
    stacked = installation_matrix(gammas, betas)
    assert stacked.shape == (5, 3, 3)
    one_angle = correct_installation(readings, gammas[0], betas[0])
    per_sample = correct_installation(readings, gammas, betas)
    assert one_angle.shape == per_sample.shape == (5, 3)
    for i in range(5):
        np.testing.assert_allclose(stacked[i], installation_matrix(gammas[i], betas[i]),
                                   rtol=0, atol=0)
        np.testing.assert_allclose(one_angle[i],
                                   installation_matrix(gammas[0], betas[0]).T @ readings[i],
                                   rtol=0, atol=EPS_MATRIX)
        np.testing.assert_allclose(per_sample[i],
                                   installation_matrix(gammas[i], betas[i]).T @ readings[i],
                                   rtol=0, atol=EPS_MATRIX)
    tx, ty = level_axis_angles(G * np.array([[0.5, 0.0, 0.0], [0.0, -0.5, 0.0]]), G)
    np.testing.assert_allclose(np.degrees(tx), [30.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(np.degrees(ty), [0.0, -30.0], atol=1e-12)
