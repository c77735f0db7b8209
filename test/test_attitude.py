"""
Inclination, toolface and orientation against closed forms, ISCWSA and transforms3d.

Tolerances: every quantity is a few double operations on inputs of order g, so round-off
is ~1e-15 relative; vectors are compared to 1e-12 m/s^2 and angles to 1e-12 rad (1e-10 deg
for degrees), three orders above round-off and far below any convention error (>= 1e-3).
"""

import math

from hypothesis import assume, given, settings
from hypothesis import strategies as st
from inclino_ros.core.attitude import (
    complete_two_axis, inclination, orientation_quaternion, roll_pitch,
    TOOLFACE_CONVENTIONS, toolface_highside, toolface_seed000)
import numpy as np
import pytest
from transforms3d.axangles import axangle2mat
from transforms3d.euler import euler2quat
from transforms3d.quaternions import quat2mat

G = 9.80665
EPS_VEC = 1e-12
EPS_ANGLE_RAD = 1e-12
hyp = settings(max_examples=200, deadline=None)

component = st.floats(min_value=-30.0, max_value=30.0, allow_nan=False)
# Away from vertical, where the toolface is defined and well conditioned.
incl_deg = st.floats(min_value=0.5, max_value=179.5)
toolface_deg = st.floats(min_value=0.0, max_value=360.0)


def wrap_deg(a):
    """Return the angle a (deg) wrapped to [-180, 180)."""
    return (a + 180.0) % 360.0 - 180.0


def seed000_force(incl, alpha, g=G):
    """Return the still-tool reading g (sin I cos a, sin I sin a, cos I) of seed 000."""
    return g * np.array([math.sin(incl) * math.cos(alpha),
                         math.sin(incl) * math.sin(alpha), math.cos(incl)])


def eq16_toolface_deg(vx, vy):
    """Return seed 000 Eq. 16 literally: asin(vy / r), quadrant from the signs, degrees."""
    a = math.degrees(math.asin(vy / math.hypot(vx, vy)))
    if vx < 0.0:
        return 180.0 - a
    if vy < 0.0:
        return 360.0 + a
    return a


def test_complete_two_axis_closed_form():
    """The axial component is g cos(phi) for phi < 90 deg; over-g gives NaN."""
    incl = np.radians([0.0, 1.0, 30.0, 89.0, 90.0])
    alpha = np.radians([0.0, 45.0, 200.0, 300.0, 90.0])
    fx, fy = G * np.sin(incl) * np.cos(alpha), G * np.sin(incl) * np.sin(alpha)
    f = complete_two_axis(fx, fy, G)
    assert f.shape == (5, 3)
    np.testing.assert_array_equal(f[:, :2], np.stack([fx, fy], axis=-1))
    # The radicand g^2 - fx^2 - fy^2 loses ~g^2 eps absolutely: sqrt(2e-14) at 90 deg.
    np.testing.assert_allclose(f[:4, 2], G * np.cos(incl[:4]), rtol=0, atol=1e-10)
    assert abs(f[4, 2]) < 2e-7
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), G, rtol=1e-14)
    over = complete_two_axis(np.array([G, 7.0, 0.0]), np.array([1e-3, 7.0, G]), G)
    assert np.isnan(over[0, 2]) and np.isnan(over[1, 2])
    assert over[2, 2] == 0.0     # exactly g cross-axial: horizontal, fz = 0, not NaN
    scalar = complete_two_axis(3.0, 4.0, 13.0)
    np.testing.assert_array_equal(scalar, [3.0, 4.0, 12.0])


@hyp
@given(st.floats(min_value=0.0, max_value=180.0), toolface_deg,
       st.floats(min_value=0.1, max_value=100.0))
def test_inclination_recovers_angle(incl_d, alpha_d, g):
    """Inclination of g(sin I cos a, sin I sin a, cos I) is I for every g, I in 0..180 deg."""
    f = seed000_force(math.radians(incl_d), math.radians(alpha_d), g)
    assert math.degrees(float(inclination(f))) == pytest.approx(incl_d, abs=1e-10)


def test_inclination_precise_near_vertical():
    """A 1e-9 rad tilt is resolved, where acos(fz/g) returns exactly 0."""
    f = seed000_force(1e-9, 0.3)
    assert math.acos(f[2] / G) == 0.0
    assert float(inclination(f)) == pytest.approx(1e-9, rel=1e-12)


@hyp
@given(component, component, component)
def test_inclination_is_eq10_acos_form(fx, fy, fz):
    """Inclination equals Eq. 10's acos(cos phi) with cos phi = fz / |f| away from 0/180."""
    f = np.array([fx, fy, fz])
    norm = np.linalg.norm(f)
    # acos is ill-conditioned near 0 and 180 deg; the atan2 form is checked above.
    assume(norm > 1e-3 and math.hypot(fx, fy) > 1e-2 * norm)
    assert float(inclination(f)) == pytest.approx(math.acos(fz / norm), abs=1e-10)


@hyp
@given(component, component, component)
def test_toolface_seed000_is_eq16(fx, fy, fz):
    """Toolface_seed000 is Eq. 16 with its sign-based quadrant, in [0, 360)."""
    assume(math.hypot(fx, fy) > 1e-6)   # undefined at vertical
    got = math.degrees(float(toolface_seed000(np.array([fx, fy, fz]))))
    assert 0.0 <= got < 360.0
    # Eq. 16's asin is ill-conditioned near +-90 deg (slope 1/cos): compare loosely there.
    tol = 1e-9 if abs(fy) < 0.99 * math.hypot(fx, fy) else 1e-5
    assert abs(wrap_deg(got - eq16_toolface_deg(fx, fy))) < tol


def test_toolface_cardinal_directions():
    """High side along +x, +y, -x, -y gives 0, 90, 180, 270 deg (seed 000), +90 (ISCWSA)."""
    f = np.array([[1.0, 0.0, 5.0], [0.0, 1.0, 5.0], [-1.0, 0.0, 5.0], [0.0, -1.0, 5.0]])
    np.testing.assert_allclose(np.degrees(toolface_seed000(f)), [0.0, 90.0, 180.0, 270.0],
                               atol=1e-12)
    np.testing.assert_allclose(np.degrees(toolface_highside(f)), [90.0, 180.0, 270.0, 0.0],
                               atol=1e-12)
    assert TOOLFACE_CONVENTIONS == {'seed000': toolface_seed000,
                                    'iscwsa_highside': toolface_highside}


def test_toolface_just_below_zero_wraps_to_zero_not_360():
    """A high side 1e-17 rad below +x is 0, never the out-of-range 360 deg."""
    # np.mod(-1e-17, 2 pi) rounds to exactly 2 pi; the true value differs from 0 by 1e-17.
    seed = toolface_seed000(np.array([[1.0, -1e-17, 0.0], [1.0, -0.0, 0.0]]))
    high = toolface_highside(np.array([[-1e-17, -1.0, 0.0], [-0.0, -1.0, 0.0]]))
    for value in np.concatenate([seed, high]):
        assert 0.0 <= value < 2.0 * math.pi
        assert value == pytest.approx(0.0, abs=1e-15)


@hyp
@given(component, component, component)
def test_highside_is_seed000_plus_90(fx, fy, fz):
    """ISCWSA high-side toolface = seed 000 toolface + 90 deg (mod 360)."""
    assume(math.hypot(fx, fy) > 1e-6)
    f = np.array([fx, fy, fz])
    high = math.degrees(float(toolface_highside(f)))
    assert 0.0 <= high < 360.0
    assert abs(wrap_deg(high - math.degrees(float(toolface_seed000(f))) - 90.0)) < 1e-10


@hyp
@given(incl_deg, toolface_deg, st.floats(min_value=9.7, max_value=9.9))
def test_iscwsa_forward_model(incl_d, tf_d, g):
    """
    G from the ISCWSA forward model, mapped to the z-up tool frame, gives back I and TF.

    ISCWSA frame: z toward the bit, sensors report gravity G (+g on z when vertical).
    Tool frame: z up, specific force f = -G_tool.  The ISCWSA frame is the tool frame turned
    180 deg about x, so G_iscwsa = Rx(180) G_tool = -Rx(180) f, built here with transforms3d.
    """
    i, tf = math.radians(incl_d), math.radians(tf_d)
    gx, gy, gz = -g * math.sin(i) * math.sin(tf), -g * math.sin(i) * math.cos(tf), \
        g * math.cos(i)
    g_iscwsa = np.array([gx, gy, gz])
    f = -axangle2mat([1.0, 0.0, 0.0], math.pi).T @ g_iscwsa
    # The shortcut of the notes, f = (-Gx, Gy, Gz).
    np.testing.assert_allclose(f, [-gx, gy, gz], rtol=0, atol=EPS_VEC)
    # ISCWSA inverse on G itself.
    assert math.atan2(math.hypot(gx, gy), gz) == pytest.approx(i, abs=EPS_ANGLE_RAD)
    gtf = math.degrees(math.atan2(-gx, -gy)) % 360.0
    assert abs(wrap_deg(gtf - tf_d)) < 1e-9
    # The module on the tool-frame vector.
    assert float(inclination(f)) == pytest.approx(i, abs=EPS_ANGLE_RAD)
    assert abs(wrap_deg(math.degrees(float(toolface_highside(f))) - tf_d)) < 1e-9
    assert abs(wrap_deg(math.degrees(float(toolface_seed000(f))) + 90.0 - tf_d)) < 1e-9


def test_iscwsa_vertical_tool_reads_plus_g_on_z():
    """A vertical tool: ISCWSA G = (0, 0, +g) and REP 145 f = (0, 0, +g) in the z-up frame."""
    f = np.array([0.0, 0.0, G])
    g_iscwsa = -axangle2mat([1.0, 0.0, 0.0], math.pi) @ f
    np.testing.assert_allclose(g_iscwsa, [0.0, 0.0, G], rtol=0, atol=EPS_VEC)
    assert float(inclination(f)) == 0.0


@hyp
@given(component, component, component)
def test_orientation_quaternion_matches_transforms3d(fx, fy, fz):
    """The quaternion equals euler2quat(roll, pitch, 0, 'sxyz'), and R^T (0,0,|f|) = f."""
    f = np.array([fx, fy, fz])
    norm = np.linalg.norm(f)
    assume(norm > 1e-3)
    roll, pitch = roll_pitch(f)
    q = orientation_quaternion(f)
    np.testing.assert_allclose(q, euler2quat(float(roll), float(pitch), 0.0, 'sxyz'),
                               rtol=0, atol=1e-15)
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(quat2mat(q).T @ np.array([0.0, 0.0, norm]), f,
                               rtol=0, atol=EPS_VEC * max(norm, 1.0))


def test_roll_pitch_closed_form():
    """Roll and pitch of simple tilts: 30 deg about x, 30 deg about y."""
    # Tool rolled +30 deg about x (R = Rx(30)): f = Rx(30)^T (0,0,g) = g(0, sin30, cos30).
    roll, pitch = roll_pitch(G * np.array([0.0, 0.5, math.sqrt(0.75)]))
    assert (math.degrees(roll), math.degrees(pitch)) == pytest.approx((30.0, 0.0), abs=1e-12)
    # Pitched +30 deg about y: f = Ry(30)^T (0,0,g) = g(-sin30, 0, cos30).
    roll, pitch = roll_pitch(G * np.array([-0.5, 0.0, math.sqrt(0.75)]))
    assert (math.degrees(roll), math.degrees(pitch)) == pytest.approx((0.0, 30.0), abs=1e-12)


def test_vectorised_shapes():
    """Every function maps (N, 3) to (N,) or (N, 4), row by row."""
    rng = np.random.default_rng(3)
    f = rng.normal(size=(6, 3))
    incl, tf0, tf1, q = (inclination(f), toolface_seed000(f), toolface_highside(f),
                         orientation_quaternion(f))
    assert incl.shape == tf0.shape == tf1.shape == (6,) and q.shape == (6, 4)
    for k in range(6):
        assert incl[k] == inclination(f[k])
        assert tf0[k] == toolface_seed000(f[k])
        assert tf1[k] == toolface_highside(f[k])
        np.testing.assert_array_equal(q[k], orientation_quaternion(f[k]))
