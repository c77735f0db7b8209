"""
Magnetic survey quantities against the ISCWSA model, seed 001 Eq. 4 and transforms3d.

Tolerances: forward then inverse is a few dozen double operations on inputs of order
1e4..1e5 nT, so round-off is ~1e-15 relative; angles are compared to 1e-9 deg (the brief's
bound), which holds for I in [1, 179] deg where the azimuth and toolface are conditioned
no worse than 1 / sin(1 deg) ~ 57.  Field magnitudes are compared to 1e-9 relative.
"""

import math

from hypothesis import example, given, settings
from hypothesis import strategies as st
from inclino_ros.core.magnetics import (
    azimuth_deg, azimuth_sensitivity_deg, b_total_nT, dip_deg, forward, g_total,
    gravity_from_specific_force, gravity_toolface_deg, horizontal_vertical_nT, inclination_deg,
    iscwsa_from_tool, magnetic_toolface_deg, QcLimits, survey_qc, true_azimuth_deg)
import numpy as np
import pytest
from transforms3d.axangles import axangle2mat
from transforms3d.euler import euler2mat

G_STD = 9.80665
EPS_DEG = 1e-9
hyp = settings(max_examples=300, deadline=None)


def wrap_deg(a):
    """Return the angle a (deg) wrapped to [-180, 180)."""
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


def attitudes():
    """Return a strategy of (I, A, TF, g, B, D) away from vertical."""
    return st.tuples(
        st.floats(min_value=1.0, max_value=179.0),
        st.floats(min_value=0.0, max_value=360.0),
        st.floats(min_value=0.0, max_value=360.0),
        st.floats(min_value=9.7, max_value=9.9),
        st.floats(min_value=2.0e4, max_value=7.0e4),
        st.floats(min_value=-89.0, max_value=89.0))


@hyp
@given(attitudes())
@example((90.0, 0.0, 10.0, G_STD, 5.0e4, 72.0))
@example((90.0, 359.999999, 200.0, G_STD, 5.0e4, 60.0))
@example((89.999999, 1e-7, 0.0, G_STD, 5.0e4, -30.0))
@example((90.0, 90.0, 0.0, G_STD, 5.0e4, 72.0))
def test_forward_then_inverse_recovers_the_attitude_and_field(att):
    incl, azim, tf, g, b, dip = att
    G, B = forward(incl, azim, tf, g, b, dip)
    assert abs(inclination_deg(G) - incl) < EPS_DEG
    assert abs(wrap_deg(azimuth_deg(G, B) - azim)) < EPS_DEG
    assert abs(wrap_deg(gravity_toolface_deg(G) - tf)) < EPS_DEG
    assert abs(dip_deg(G, B) - dip) < EPS_DEG
    assert abs(b_total_nT(B) - b) < 1e-9 * b
    assert abs(g_total(G) - g) < 1e-9 * g
    bh, bv = horizontal_vertical_nT(G, B)
    assert np.allclose([bh, bv], [b * math.cos(math.radians(dip)),
                                  b * math.sin(math.radians(dip))], rtol=0, atol=1e-9 * b)


@hyp
@given(attitudes())
def test_forward_is_the_rotation_of_the_earth_frame_fields(att):
    """Tool-to-NED is Rz(A) Ry(I) Rz(TF - 90); the readings are R^T of the NED fields."""
    incl, azim, tf, g, b, dip = att
    rot = euler2mat(*np.radians([azim, incl, tf - 90.0]), axes='rzyz')
    d = math.radians(dip)
    G, B = forward(incl, azim, tf, g, b, dip)
    assert np.allclose(G, rot.T @ [0.0, 0.0, g], rtol=0, atol=1e-12 * g)
    assert np.allclose(B, rot.T @ [b * math.cos(d), 0.0, b * math.sin(d)], rtol=0, atol=1e-9)


def seed001_eq4_deg(gx, gy, gz, hx, hy, hz):
    """Return seed 001 Eq. 4 written out: arctan of the two terms, quadrant from their signs."""
    g = math.sqrt(gx ** 2 + gy ** 2 + gz ** 2)
    num = (gx * hy - gy * hx) * g
    den = hz * (gx ** 2 + gy ** 2) - gz * (gx * hx + gy * hy)
    a = math.degrees(math.atan(num / den))
    if den < 0.0:
        a += 180.0
    return a % 360.0


@hyp
@given(attitudes())
def test_azimuth_matches_seed001_eq4(att):
    G, B = forward(*att)
    # Eq. 4's arctan of a ratio is ill conditioned where the denominator vanishes.
    den = B[2] * (G[0] ** 2 + G[1] ** 2) - G[2] * (G[0] * B[0] + G[1] * B[1])
    if abs(den) < 1e-6 * np.linalg.norm(G) ** 2 * np.linalg.norm(B):
        return
    assert abs(wrap_deg(azimuth_deg(G, B) - seed001_eq4_deg(*G, *B))) < EPS_DEG


def test_vectorised_over_leading_axes():
    rng = np.random.default_rng(2)
    incl = rng.uniform(5.0, 175.0, (4, 5))
    azim = rng.uniform(0.0, 360.0, (4, 5))
    tf = rng.uniform(0.0, 360.0, (4, 5))
    G, B = forward(incl, azim, tf, G_STD, 4.8e4, 65.0)
    assert G.shape == B.shape == (4, 5, 3)
    assert azimuth_deg(G, B).shape == (4, 5)
    assert np.allclose(wrap_deg(azimuth_deg(G, B) - azim), 0.0, atol=EPS_DEG)
    assert np.allclose(wrap_deg(gravity_toolface_deg(G) - tf), 0.0, atol=EPS_DEG)


def test_sensitivity_example_of_formulas_md():
    """I=90, A=90, B=50 uT, D=72: 220 nT on Bz moves the azimuth by 0.82 deg."""
    assert azimuth_sensitivity_deg(90.0, 90.0, 72.0, 5.0e4, 220.0) == pytest.approx(
        -0.816, abs=5e-4)


@pytest.mark.parametrize('incl, azim, dip', [(90.0, 90.0, 72.0), (60.0, 250.0, 55.0),
                                             (30.0, 10.0, -40.0), (90.0, 0.0, 72.0)])
def test_sensitivity_matches_a_finite_difference_of_azimuth(incl, azim, dip):
    G, B = forward(incl, azim, 33.0, G_STD, 5.0e4, dip)
    for delta in (1.0, 220.0):
        shifted = B + [0.0, 0.0, delta]
        measured = wrap_deg(azimuth_deg(G, shifted) - azimuth_deg(G, B))
        predicted = azimuth_sensitivity_deg(incl, azim, dip, 5.0e4, delta)
        # Second-order remainder: (dBz / (B cosD))^2 rad, 0.01 deg at 220 nT and D = 72.
        bound = math.degrees((delta / (5.0e4 * math.cos(math.radians(dip)))) ** 2) + 1e-9
        assert abs(measured - predicted) <= bound


def test_tool_to_iscwsa_is_a_half_turn_about_x():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(50, 3))
    assert np.allclose(iscwsa_from_tool(v), v @ axangle2mat([1.0, 0.0, 0.0], math.pi).T,
                       atol=1e-15)
    assert np.array_equal(iscwsa_from_tool(iscwsa_from_tool(v)), v)


def test_gravity_from_specific_force_points_down_the_hole():
    # A tool standing vertical, bit down: the z-up axis reads +g of specific force.
    G = gravity_from_specific_force([0.0, 0.0, G_STD])
    assert np.allclose(G, [0.0, 0.0, G_STD])
    assert inclination_deg(G) == 0.0
    # Lying on its side, x up (seed 000 toolface 0): high side along +x of the tool, which
    # is ISCWSA +x too, so the high-side toolface is atan2(-Gx, -Gy) = atan2(g, 0) = 90 deg.
    G = gravity_from_specific_force([G_STD, 0.0, 0.0])
    assert inclination_deg(G) == pytest.approx(90.0)
    assert gravity_toolface_deg(G) == pytest.approx(90.0)


def test_magnetic_toolface_is_gtf_plus_azimuth_near_vertical_and_dip_free_inclined():
    G, B = forward(1e-6, 40.0, 100.0, G_STD, 5.0e4, 70.0)
    assert magnetic_toolface_deg(G, B) == pytest.approx(140.0, abs=1e-6)
    incl, azim, tf = np.radians([50.0, 120.0, 200.0])
    G, B = forward(50.0, 120.0, 200.0, G_STD, 5.0e4, 70.0)
    hx = math.cos(incl) * math.cos(azim) * math.sin(tf) + math.sin(azim) * math.cos(tf)
    hy = math.cos(incl) * math.cos(azim) * math.cos(tf) - math.sin(azim) * math.sin(tf)
    assert magnetic_toolface_deg(G, B) == pytest.approx(
        math.degrees(math.atan2(hx, hy)) % 360.0, abs=1e-9)


def test_true_azimuth_adds_declination_and_removes_convergence():
    assert true_azimuth_deg(350.0, 15.0) == pytest.approx(5.0)
    assert true_azimuth_deg(10.0, -4.0, 8.0) == pytest.approx(358.0)
    assert true_azimuth_deg(-1e-15, 0.0) == 0.0


def test_nan_angles_stay_nan():
    """An undefined angle (no paired reading, a vertical tool) is NaN, never 0 deg."""
    assert np.isnan(true_azimuth_deg(np.nan, 3.0))
    np.testing.assert_array_equal(np.isnan(true_azimuth_deg([np.nan, 10.0], 0.0)), [True, False])
    G, B = forward(50.0, 120.0, 200.0, G_STD, 5.0e4, 70.0)
    assert np.isnan(azimuth_deg(G, np.full(3, np.nan)))
    assert np.isnan(gravity_toolface_deg(np.full(3, np.nan)))


def test_survey_qc_flags_each_test_at_its_limit():
    G, B = forward(np.full(4, 60.0), 80.0, 30.0, G_STD, 5.0e4, 70.0)
    B = B * np.array([1.0, 1.0, 1.0, 1.01])[:, None]             # sample 3: +500 nT
    G = G * np.array([1.0, 1.0, 1.003, 1.0])[:, None]            # sample 2: +0.029 m/s^2
    B[1] = forward(60.0, 80.0, 30.0, G_STD, 5.0e4, 70.3)[1]      # sample 1: dip +0.3
    qc = survey_qc(G, B, 5.0e4, 70.0, G_STD, QcLimits())
    assert qc.b_total_ok.tolist() == [True, True, True, False]
    assert qc.dip_ok.tolist() == [True, False, True, True]
    assert qc.g_total_ok.tolist() == [True, True, False, True]
    assert qc.ok.tolist() == [True, False, False, False]
    assert qc.b_total_delta_nT[3] == pytest.approx(500.0)
    assert qc.dip_delta_deg[1] == pytest.approx(0.3)
    nan_qc = survey_qc(np.full(3, np.nan), B[0], 5.0e4, 70.0, G_STD)
    assert not nan_qc.ok
