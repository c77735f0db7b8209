"""
The virtual bench (inclino_ros.sim.bench) against closed forms and the core.

Tolerances: noise-free readings are a few double-precision products of numbers of order
g, so their round-off is ~1e-15 m/s^2; 1e-12 m/s^2 is a wide margin that still catches a
wrong sign or a swapped element (errors of order g sin(0.8 deg) = 0.14 m/s^2).  Angles
through the core (C^-1, atan2) of noise-free readings come back to ~1e-14 deg: 1e-9 deg.
"""

import math

from hypothesis import given, settings
from hypothesis import strategies as st
from inclino_ros.calibration.model import CalibrationModel, Installation
from inclino_ros.core.attitude import inclination, toolface_seed000
from inclino_ros.core.installation import installation_matrix
from inclino_ros.pipeline import run, Settings
from inclino_ros.sim.bench import DEFAULT_STATIONS_DEG, Scenario, sensor_matrix, simulate
import numpy as np
import pytest

G = 9.80665
EPS_MPS2 = 1e-12
EPS_DEG = 1e-9
hyp = settings(max_examples=100, deadline=None)
install_deg = st.floats(min_value=-3.0, max_value=3.0, allow_nan=False)


def seed_eq1(gamma, beta):
    """Return C exactly as printed in seed 000 Eq. 1 (the product written out)."""
    cg, sg, cb, sb = math.cos(gamma), math.sin(gamma), math.cos(beta), math.sin(beta)
    return np.array([[cg, 0.0, -sg], [-sb * sg, cb, -sb * cg], [cb * sg, sb, cb * cg]])


def angle_diff_deg(a, b):
    """Return a - b wrapped to [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


@hyp
@given(install_deg, install_deg)
def test_sensor_matrix_is_seed_eq1_and_the_core_matrix(gamma_deg, beta_deg):
    """transforms3d's Rx(beta) Ry(-gamma) equals Eq. 1 and installation.installation_matrix."""
    gamma, beta = math.radians(gamma_deg), math.radians(beta_deg)
    c = sensor_matrix(gamma, beta)
    np.testing.assert_allclose(c, seed_eq1(gamma, beta), rtol=0, atol=1e-15)
    np.testing.assert_allclose(c, installation_matrix(gamma, beta), rtol=0, atol=1e-15)


def test_level_segment_reads_seed_eq2():
    """On the level bench the sensor reads g (-sin g, -sin b cos g, cos b cos g) (Eq. 2)."""
    sim = simulate(Scenario(noise_std_mps2=0.0))
    gamma, beta = math.radians(0.8), math.radians(-1.2)
    expected = G * np.array([-math.sin(gamma), -math.sin(beta) * math.cos(gamma),
                             math.cos(beta) * math.cos(gamma)])
    level = sim.raw_mps2[sim.segment == 0]
    assert level.shape == (600, 3)
    np.testing.assert_allclose(level, np.tile(expected, (600, 1)), rtol=0, atol=EPS_MPS2)


def test_stations_read_c_times_the_true_force():
    """Each station reads C g (sin I cos TF, sin I sin TF, cos I), C from Eq. 1 (noise free)."""
    scenario = Scenario(gamma_deg=1.5, beta_deg=0.7, noise_std_mps2=0.0)
    sim = simulate(scenario)
    c = seed_eq1(math.radians(1.5), math.radians(0.7))
    for k, (incl_deg, tf_deg) in enumerate(DEFAULT_STATIONS_DEG, start=1):
        i, a = math.radians(incl_deg), math.radians(tf_deg)
        f = G * np.array([math.sin(i) * math.cos(a), math.sin(i) * math.sin(a), math.cos(i)])
        rows = sim.raw_mps2[sim.segment == k]
        np.testing.assert_allclose(rows, np.tile(c @ f, (rows.shape[0], 1)),
                                   rtol=0, atol=EPS_MPS2)
        assert np.all(sim.inclination_deg[sim.segment == k] == incl_deg)
        assert np.all(sim.toolface_deg[sim.segment == k] == tf_deg)


@hyp
@given(install_deg, install_deg, st.floats(min_value=0.05, max_value=85.0),
       st.floats(min_value=0.0, max_value=360.0, exclude_max=True))
def test_core_inverts_the_bench(gamma_deg, beta_deg, incl_deg, tf_deg):
    """pipeline.run with the true (gamma, beta) returns the bench's I and TF (Eqs. 9, 10, 16)."""
    sim = simulate(Scenario(gamma_deg=gamma_deg, beta_deg=beta_deg, noise_std_mps2=0.0,
                            stations_deg=((incl_deg, tf_deg),), level_s=0.01, station_s=0.01,
                            rate_hz=100.0))
    model = CalibrationModel(3, Installation(gamma_deg, beta_deg, '2026-01-01T00:00:00+00:00',
                                             1, 0.0, G))
    survey = run(sim.raw_mps2, model, Settings(noise_std_mps2=1e-6))   # noise-free bench
    assert survey.inclination_deg == pytest.approx(sim.inclination_deg, abs=EPS_DEG)
    assert angle_diff_deg(survey.toolface_deg[1], tf_deg) == pytest.approx(0.0, abs=EPS_DEG)


def test_segments_stamps_and_truth_record():
    """Segment sizes, exact stamp spacing and the truth dictionary describe the samples."""
    scenario = Scenario(rate_hz=250.0, level_s=2.0, station_s=1.0, seed=3)
    sim = simulate(scenario)
    stations = len(DEFAULT_STATIONS_DEG)
    assert sim.stamps_ns.dtype == np.int64
    assert sim.raw_mps2.shape == (500 + 250 * stations, 3)
    assert np.all(np.diff(sim.stamps_ns) == 4_000_000)
    assert sim.stamps_ns[0] == scenario.start_ns
    assert np.bincount(sim.segment).tolist() == [500] + [250] * stations
    truth = sim.truth
    assert (truth['gamma_deg'], truth['beta_deg'], truth['seed'], truth['axes']) == \
        (0.8, -1.2, 3, 3)
    assert truth['segments'][0] == {
        'index': 0, 'kind': 'level', 'start_ns': int(sim.stamps_ns[0]),
        'end_ns': int(sim.stamps_ns[499]), 'samples': 500, 'inclination_deg': 0.0,
        'toolface_deg': None}
    last = truth['segments'][-1]
    assert (last['start_ns'], last['end_ns']) == (int(sim.stamps_ns[-250]),
                                                  int(sim.stamps_ns[-1]))
    assert np.all(np.isnan(sim.toolface_deg[sim.segment == 0]))


def test_default_stations_spread():
    """About 12 stations spanning 0.5..60 deg inclination and toolfaces all round."""
    incl = [s[0] for s in DEFAULT_STATIONS_DEG]
    tf = sorted(s[1] for s in DEFAULT_STATIONS_DEG)
    assert len(DEFAULT_STATIONS_DEG) == 12
    assert (min(incl), max(incl)) == (0.5, 60.0)
    assert tf == [30.0 * k for k in range(12)]


def test_noise_level_and_seed():
    """The noise has the asked standard deviation; a seed repeats, another seed differs."""
    clean = simulate(Scenario(noise_std_mps2=0.0)).raw_mps2
    noisy = simulate(Scenario(noise_std_mps2=0.002, seed=7)).raw_mps2
    residual = noisy - clean
    # 16200 samples: the sample std has a relative spread 1/sqrt(2 n) = 0.6 %; 5 % is > 8 sigma.
    assert residual.std() == pytest.approx(0.002, rel=0.05)
    assert abs(residual.mean()) < 5 * 0.002 / math.sqrt(residual.size)
    np.testing.assert_array_equal(noisy, simulate(Scenario(noise_std_mps2=0.002, seed=7))
                                  .raw_mps2)
    assert not np.array_equal(noisy, simulate(Scenario(noise_std_mps2=0.002, seed=8)).raw_mps2)


def test_two_axis_sensor_reads_zero_z():
    """A two-axis sensor reports z = 0.0 and the same x, y as the three-axis one."""
    three = simulate(Scenario(seed=5))
    two = simulate(Scenario(seed=5, axes=2))
    assert np.all(two.raw_mps2[:, 2] == 0.0)
    np.testing.assert_array_equal(two.raw_mps2[:, :2], three.raw_mps2[:, :2])
    assert two.truth['axes'] == 2


@pytest.mark.parametrize('changes', [{'axes': 1}, {'rate_hz': 0.0}, {'level_s': 0.001},
                                     {'noise_std_mps2': -1.0}])
def test_scenario_refuses_impossible_settings(changes):
    """A scenario that cannot be sampled is refused at construction."""
    with pytest.raises(ValueError):
        Scenario(**changes)


def test_inclination_of_the_true_force_matches_truth():
    """The true force itself (before C) has the stated inclination and seed-000 toolface."""
    sim = simulate(Scenario(gamma_deg=0.0, beta_deg=0.0, noise_std_mps2=0.0))
    tilted = sim.segment > 0
    assert np.degrees(inclination(sim.raw_mps2)) == pytest.approx(sim.inclination_deg,
                                                                  abs=EPS_DEG)
    tf = np.degrees(toolface_seed000(sim.raw_mps2[tilted]))
    assert np.abs(angle_diff_deg(tf, sim.toolface_deg[tilted])).max() < EPS_DEG
