"""
The processing chain end to end: level capture -> model -> pipeline.run recovers the truth.

Tolerances: in the property tests every step (C, asin in the capture, C^-1, atan2) is
exact up to round-off, a few 1e-16 relative, i.e. ~1e-14 deg; 1e-9 deg is five orders
above that yet far below any modelling error (a sign slip in gamma or beta costs up to
6 deg).  The toolface of a vector whose cross-axial part is g sin(I) carries an extra
1/sin(I) factor: above I = 0.1 deg that is < 600, still ~1e-11 deg.  The two-axis
completion sqrt(g^2 - x^2 - y^2) loses ~g eps / cos(phi_1) <= 1e-14 g at phi_1 < 85 deg.
"""

import math

from hypothesis import given, settings
from hypothesis import strategies as st
from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.model import CalibrationModel, Installation
from inclino_ros.core.installation import installation_matrix
from inclino_ros.core.screening import ACCEPTED, REASONS
from inclino_ros.pipeline import MagneticSettings, run, Settings
import numpy as np
import pytest
from transforms3d.quaternions import quat2mat

G = 9.80665
EPS_DEG = 1e-9
hyp = settings(max_examples=200, deadline=None)

install_deg = st.floats(min_value=-3.0, max_value=3.0, allow_nan=False)
toolface_deg = st.floats(min_value=0.0, max_value=360.0, exclude_max=True)
local_g = st.floats(min_value=9.78, max_value=9.83)


def truth_force(incl_deg, tf_deg, g=G):
    """Return the ideal-frame specific force g (sin I cos TF, sin I sin TF, cos I) (seed 000)."""
    i, a = math.radians(incl_deg), math.radians(tf_deg)
    return g * np.array([math.sin(i) * math.cos(a), math.sin(i) * math.sin(a), math.cos(i)])


def angle_diff_deg(a, b):
    """Return a - b wrapped to [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


def calibrate(gamma_deg, beta_deg, axes, g):
    """Run a noise-free level capture of a sensor mounted with (gamma, beta); return the model."""
    level = installation_matrix(math.radians(gamma_deg), math.radians(beta_deg)) @ [0, 0, g]
    if axes == 2:
        level = np.array([level[0], level[1], 0.0])
    limits = LevelLimits(max_tilt_deg=5.0, gravity_mps2=g, g_total_tolerance_mps2=0.3)
    installation = solve_level_capture(np.tile(level, (6, 1)), axes, limits)
    # The capture itself recovers the mounting (asin of arguments <= 0.05: round-off only).
    assert installation.gamma_deg == pytest.approx(gamma_deg, abs=1e-12)
    assert installation.beta_deg == pytest.approx(beta_deg, abs=1e-12)
    return CalibrationModel(accelerometer_axes=axes, installation=installation)


@hyp
@given(install_deg, install_deg, st.floats(min_value=0.0, max_value=90.0), toolface_deg,
       local_g)
def test_three_axis_chain_recovers_truth(gamma_deg, beta_deg, incl_deg, tf_deg, g):
    """A misaligned 3-axis sensor, calibrated on the bench, reports the true I and toolface."""
    model = calibrate(gamma_deg, beta_deg, 3, g)
    truth = truth_force(incl_deg, tf_deg, g)
    reading = installation_matrix(math.radians(gamma_deg), math.radians(beta_deg)) @ truth
    survey = run(reading[None, :], model, Settings(gravity_mps2=g, noise_std_mps2=1e-6,
                                                   accelerometer_range_mps2=2.0 * g))
    assert survey.codes.tolist() == [ACCEPTED]
    np.testing.assert_allclose(survey.corrected_mps2[0], truth, rtol=0, atol=1e-12 * g)
    assert survey.inclination_deg[0] == pytest.approx(incl_deg, abs=EPS_DEG)
    assert survey.g_total_mps2[0] == pytest.approx(g, rel=1e-14)
    if incl_deg >= 0.1:
        assert abs(angle_diff_deg(survey.toolface_deg[0], tf_deg)) < EPS_DEG
    # The orientation turns the world's up (0, 0, g) into the true tool-frame reading.
    np.testing.assert_allclose(quat2mat(survey.orientation_wxyz[0]).T @ [0.0, 0.0, g], truth,
                               rtol=0, atol=1e-12 * g)


@hyp
@given(install_deg, install_deg, st.floats(min_value=0.0, max_value=79.999), toolface_deg)
def test_two_axis_chain_recovers_truth(gamma_deg, beta_deg, incl_deg, tf_deg):
    """A misaligned 2-axis sensor (z completed from g) reports the true I below 80 deg."""
    model = calibrate(gamma_deg, beta_deg, 2, G)
    reading = installation_matrix(math.radians(gamma_deg), math.radians(beta_deg)) @ \
        truth_force(incl_deg, tf_deg)
    raw = np.array([[reading[0], reading[1], 0.0]])      # the driver has no z
    survey = run(raw, model, Settings(accelerometer_axes=2, noise_std_mps2=1e-6,
                                      two_axis_max_inclination_deg=80.0))
    assert survey.codes.tolist() == [ACCEPTED]
    assert survey.inclination_deg[0] == pytest.approx(incl_deg, abs=EPS_DEG)
    if incl_deg >= 0.1:
        assert abs(angle_diff_deg(survey.toolface_deg[0], tf_deg)) < EPS_DEG


@hyp
@given(install_deg, install_deg, st.floats(min_value=0.5, max_value=90.0), toolface_deg)
def test_iscwsa_convention_in_chain(gamma_deg, beta_deg, incl_deg, tf_deg):
    """The ISCWSA high-side convention reports the seed-000 toolface + 90 deg."""
    model = calibrate(gamma_deg, beta_deg, 3, G)
    reading = installation_matrix(math.radians(gamma_deg), math.radians(beta_deg)) @ \
        truth_force(incl_deg, tf_deg)
    survey = run(reading, model, Settings(toolface_convention='iscwsa_highside',
                                          noise_std_mps2=1e-6))
    assert abs(angle_diff_deg(survey.toolface_deg[0], tf_deg + 90.0)) < EPS_DEG


def test_paper_installation_vertical_tool():
    """Uncorrected, a vertical tool reads the false tilt theta = 0.2796 deg; corrected, 0."""
    installation = Installation(gamma_deg=0.0355, beta_deg=-0.2773,
                                captured_at='2026-03-01T10:20:30+00:00', sample_count=100,
                                std_deg=0.01, g_total_mps2=G)
    reading = installation_matrix(math.radians(0.0355), math.radians(-0.2773)) @ [0, 0, G]
    raw_survey = run(reading, CalibrationModel(accelerometer_axes=3), Settings())
    assert round(raw_survey.inclination_deg[0], 4) == 0.2796
    corrected = run(reading, CalibrationModel(accelerometer_axes=3, installation=installation),
                    Settings())
    assert corrected.inclination_deg[0] < 1e-12
    assert np.isnan(corrected.toolface_deg[0])       # vertical: its 1 sigma is unbounded


def test_dropped_samples_give_no_rows_and_keep_order():
    """Rejected samples vanish from the outputs; accepted ones keep their input order."""
    good = [truth_force(1.0, 10.0), truth_force(2.0, 200.0), truth_force(3.0, 300.0)]
    raw = np.array([good[0], [math.nan, 0.0, G], good[1], [0.0, 3.0 * G, 0.0],
                    [0.0, 0.0, 0.0], good[2], [math.inf, math.inf, math.inf]])
    survey = run(raw, CalibrationModel(accelerometer_axes=3), Settings())
    assert survey.codes.tolist() == [ACCEPTED, REASONS.index('non_finite'), ACCEPTED,
                                     REASONS.index('saturated'), REASONS.index('zero'),
                                     ACCEPTED, REASONS.index('non_finite')]
    assert survey.accepted.tolist() == [True, False, True, False, False, True, False]
    np.testing.assert_allclose(survey.corrected_mps2, good, rtol=0, atol=0)
    np.testing.assert_allclose(survey.inclination_deg, [1.0, 2.0, 3.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(survey.toolface_deg, [10.0, 200.0, 300.0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(survey.g_total_mps2, G, rtol=1e-15)
    assert survey.orientation_wxyz.shape == (3, 4)


def test_two_axis_drops_over_g_and_ignores_z():
    """Two axes: over-g readings are dropped; z (NaN here) never matters."""
    a = truth_force(5.0, 45.0)
    b = truth_force(20.0, 135.0)
    raw = np.array([[a[0], a[1], math.nan], [8.0, 8.0, 0.0], [b[0], b[1], -1e9]])
    survey = run(raw, CalibrationModel(accelerometer_axes=2), Settings(accelerometer_axes=2))
    assert survey.codes.tolist() == [ACCEPTED, REASONS.index('over_g'), ACCEPTED]
    # complete_two_axis: z = sqrt(g^2 - x^2 - y^2) = g cos I; round-off only.
    np.testing.assert_allclose(survey.corrected_mps2, [a, b], rtol=0, atol=1e-13)
    np.testing.assert_allclose(survey.inclination_deg, [5.0, 20.0], rtol=0, atol=1e-10)


def test_toolface_nan_where_its_sigma_exceeds_the_limit():
    """
    Toolface is NaN where its 1 sigma, noise / (g sin I) rad (no calibration), is above the limit.

    Default noise 0.01 m/s^2: 0.0584 / sin I deg, i.e. 669, 167, 6.7 and 2.2 deg at
    0.005, 0.02, 0.5 and 1.5 deg; the default limit 5 deg keeps only the last.
    """
    inclinations_deg = np.array([0.0, 0.005, 0.02, 0.5, 1.5])
    raw = np.array([truth_force(i, 77.0) for i in inclinations_deg])
    model = CalibrationModel(accelerometer_axes=3)
    survey = run(raw, model, Settings())
    expected_deg = np.degrees(0.01 / (G * np.sin(np.radians(inclinations_deg[1:]))))
    np.testing.assert_allclose(survey.toolface_std_deg[1:], expected_deg, rtol=1e-9)
    assert survey.toolface_std_deg[0] == math.inf
    assert np.isnan(survey.toolface_deg[:4]).all()
    assert survey.toolface_deg[4] == pytest.approx(77.0, abs=1e-9)
    np.testing.assert_allclose(survey.inclination_deg, inclinations_deg, rtol=0, atol=1e-12)
    quiet = run(raw, model, Settings(noise_std_mps2=1e-4))     # 100x less noise
    assert np.isnan(quiet.toolface_deg[:2]).all()
    np.testing.assert_allclose(quiet.toolface_deg[2:], 77.0, rtol=0, atol=1e-9)
    # A limit equal to a sample's own sigma: that sample keeps its toolface.
    at = run(raw, model, Settings(toolface_max_std_deg=survey.toolface_std_deg[3]))
    assert np.isnan(at.toolface_deg[:3]).all()
    np.testing.assert_allclose(at.toolface_deg[3:], 77.0, rtol=0, atol=1e-9)


def test_empty_and_single_sample_batches():
    """An empty batch gives empty outputs; a bare 3-vector is a batch of one."""
    model = CalibrationModel(accelerometer_axes=3)
    empty = run(np.zeros((0, 3)), model, Settings())
    assert empty.codes.shape == (0,) and empty.corrected_mps2.shape == (0, 3)
    assert empty.inclination_deg.shape == empty.toolface_deg.shape == (0,)
    assert empty.orientation_wxyz.shape == (0, 4)
    one = run(truth_force(30.0, 60.0), model, Settings())
    assert one.inclination_deg == pytest.approx([30.0], abs=1e-12)
    assert one.toolface_deg == pytest.approx([60.0], abs=1e-10)


@pytest.mark.parametrize('kwargs, message', [
    ({'accelerometer_axes': 1}, 'accelerometer_axes must be 2 or 3, not 1'),
    ({'accelerometer_axes': 4}, 'accelerometer_axes must be 2 or 3, not 4'),
    ({'accelerometer_axes': '3'}, 'accelerometer_axes must be 2 or 3, not 3'),
    ({'toolface_convention': 'highside'},
     "toolface_convention must be one of ['iscwsa_highside', 'seed000'], not 'highside'"),
    ({'toolface_convention': 'SEED000'}, "not 'SEED000'"),
])
def test_settings_refuse_bad_values(kwargs, message):
    """Settings refuses axes other than 2 or 3 and unknown toolface conventions."""
    with pytest.raises(ValueError) as caught:
        Settings(**kwargs)
    assert message in str(caught.value)


def test_settings_defaults():
    """The defaults are the node's parameters' (node.parameters)."""
    from inclino_ros.node.parameters import PARAMETERS
    defaults = {p.name: p.default for p in PARAMETERS}
    s = Settings()
    assert (s.accelerometer_axes, s.gravity_mps2, s.accelerometer_range_mps2,
            s.toolface_convention, s.noise_std_mps2, s.toolface_max_std_deg,
            s.g_total_tolerance_mps2, s.two_axis_max_inclination_deg) == tuple(
        defaults[name] for name in (
            'accelerometer_axes', 'gravity_mps2', 'accelerometer_range_mps2',
            'toolface_convention', 'accelerometer_noise_std_mps2', 'toolface_max_std_deg',
            'g_total_tolerance_mps2', 'two_axis_max_inclination_deg'))
    m = MagneticSettings()
    assert (m.noise_std_nT, m.azimuth_max_std_deg) == (
        defaults['magnetometer_noise_std_nT'], defaults['magnetic.azimuth_max_std_deg'])
    assert Settings(accelerometer_axes=2, toolface_convention='iscwsa_highside')


def test_azimuth_is_not_trusted_near_vertical_or_without_a_field():
    """A vertical tool or a dead magnetometer gives a NaN azimuth, never a number."""
    from inclino_ros.core.magnetics import forward, iscwsa_from_tool
    settings = MagneticSettings()   # 0.2 deg: 1 sigma ~16 deg at the default noise
    rows = []
    for inclination_deg in (0.2, 30.0):
        gravity, field = forward(inclination_deg, 100.0, 40.0, G, 50000.0, 60.0)
        rows.append((-iscwsa_from_tool(gravity), iscwsa_from_tool(field)))
    force = np.array([r[0] for r in rows] + [rows[1][0]])
    field = np.array([r[1] for r in rows] + [np.zeros(3)])
    survey = run(force, CalibrationModel(3), Settings(), field_nT=field,
                 magnetic_settings=settings)
    azimuth = survey.magnetic.azimuth_deg
    assert np.isnan(azimuth[0]) and np.isnan(azimuth[2])
    assert azimuth[1] == pytest.approx(100.0, abs=1e-9)
    assert survey.magnetic.true_azimuth_deg[1] == pytest.approx(100.0, abs=1e-9)
