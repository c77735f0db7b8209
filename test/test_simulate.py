"""
The virtual bench (inclino_ros.sim.bench): scenarios read through the physical sensor model.

Every reading must be ``sensor_model.read`` of the scenario's tool at the scenario's truth
(checked to equality), and the truth record must describe the tool and the segments.  The
closed forms (seed 000 Eqs. 1, 2; the ISCWSA forward model) check that the attitudes reach the
model as documented.

Tolerances: noise-free readings are a few double-precision products of numbers of order
g (or 5e4 nT), so their round-off is ~1e-15 m/s^2 (~1e-11 nT); 1e-12 m/s^2 and 1e-8 nT
are wide margins that still catch a wrong sign or a swapped element (errors of order
g sin(0.8 deg) = 0.14 m/s^2).  Angles through the core (C^-1, atan2) of noise-free readings
come back to ~1e-14 deg: 1e-9 deg.
"""

import contextlib
import io
import json
import math

from hypothesis import given, settings
from hypothesis import strategies as st
from inclino_ros.calibration.model import CalibrationModel, Installation
from inclino_ros.cli.main import main as inclino
from inclino_ros.core import magnetics
from inclino_ros.core.attitude import inclination, toolface_seed000
from inclino_ros.io import bag
from inclino_ros.pipeline import run, Settings
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import (
    DEFAULT_STATIONS_DEG, DEMO_TOOL, make_tool, Scenario, simulate, simulate_heating,
    simulate_stand, STAND_POSITIONS_DEG, STAND_TOOL, StandRun, tool_from_iscwsa,
    tool_stand_truth, TURNED_OVER_HEATING_ATTITUDES_DEG)
import numpy as np
import pytest

G = 9.80665
EPS_MPS2 = 1e-12
EPS_NT = 1e-8
EPS_DEG = 1e-9
hyp = settings(max_examples=100, deadline=None)
install_deg = st.floats(min_value=-3.0, max_value=3.0, allow_nan=False)
#: The demo's mount without noise: the readings are the closed forms exactly.
NOISE_FREE = make_tool('ideal', 0.8, -1.2)


def seed_eq1(gamma, beta):
    """Return C exactly as printed in seed 000 Eq. 1 (the product written out)."""
    cg, sg, cb, sb = math.cos(gamma), math.sin(gamma), math.cos(beta), math.sin(beta)
    return np.array([[cg, 0.0, -sg], [-sb * sg, cb, -sb * cg], [cb * sg, sb, cb * cg]])


def angle_diff_deg(a, b):
    """Return a - b wrapped to [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


def test_default_tools():
    """The demo: ideal triads, gamma 0.8, beta -1.2, 0.002 m/s^2; the stand: MEMS, same mount."""
    assert (DEMO_TOOL.mount.gamma_deg, DEMO_TOOL.mount.beta_deg, DEMO_TOOL.mount.roll_deg) == \
        (0.8, -1.2, 0.0)
    assert (DEMO_TOOL.accelerometer.noise_std, DEMO_TOOL.magnetometer.noise_std) == (0.002, 5.0)
    assert DEMO_TOOL.accelerometer.matrix == sm.IDEAL.accelerometer.matrix
    assert DEMO_TOOL.hard_iron_nT == (0.0, 0.0, 0.0)
    assert Scenario().tool == DEMO_TOOL and StandRun().tool == STAND_TOOL
    assert STAND_TOOL.accelerometer == sm.MEMS.accelerometer
    assert STAND_TOOL.mount == DEMO_TOOL.mount
    quartz = make_tool('quartz', 0.1, 0.2, 0.3, (0.4, 0.5, 0.6), noise_mps2=0.0, axes=2)
    assert quartz.mount == sm.Mount(0.1, 0.2, 0.3, (0.4, 0.5, 0.6))
    assert quartz.accelerometer.noise_std == 0.0 and quartz.accelerometer_axes == 2
    assert quartz.magnetometer == sm.QUARTZ_FLUXGATE.magnetometer   # its own noise kept


def test_interference_axes():
    """ISCWSA (80, -80, 2000) nT is (80, 80, -2000) in the z-up tool frame, and back."""
    assert tool_from_iscwsa((80.0, -80.0, 2000.0)) == (80.0, 80.0, -2000.0)
    assert Scenario().interference_tool_nT == (80.0, 80.0, -2000.0)
    np.testing.assert_array_equal(magnetics.iscwsa_from_tool([80.0, 80.0, -2000.0]),
                                  [80.0, -80.0, 2000.0])


def test_level_segment_reads_seed_eq2():
    """On the level bench the sensor reads g (-sin g, -sin b cos g, cos b cos g) (Eq. 2)."""
    sim = simulate(Scenario(tool=NOISE_FREE))
    gamma, beta = math.radians(0.8), math.radians(-1.2)
    expected = G * np.array([-math.sin(gamma), -math.sin(beta) * math.cos(gamma),
                             math.cos(beta) * math.cos(gamma)])
    level = sim.raw_mps2[sim.segment == 0]
    assert level.shape == (600, 3)
    np.testing.assert_allclose(level, np.tile(expected, (600, 1)), rtol=0, atol=EPS_MPS2)


def test_stations_read_c_times_the_true_vectors():
    """
    Each station reads C f and C (B + interference), C from Eq. 1 (ideal triads, noise free).

    f = g (sin I cos TF, sin I sin TF, cos I); B from the ISCWSA forward model at the
    station's azimuth with the high-side toolface TF + 90 deg, turned into the tool frame.
    """
    scenario = Scenario(tool=make_tool('ideal', 1.5, 0.7))
    sim = simulate(scenario)
    c = seed_eq1(math.radians(1.5), math.radians(0.7))
    azimuths = np.linspace(85.0, 95.0, len(DEFAULT_STATIONS_DEG))
    for k, ((incl_deg, tf_deg), az_deg) in enumerate(zip(DEFAULT_STATIONS_DEG, azimuths),
                                                     start=1):
        i, a = math.radians(incl_deg), math.radians(tf_deg)
        f = G * np.array([math.sin(i) * math.cos(a), math.sin(i) * math.sin(a), math.cos(i)])
        _, field = magnetics.forward(incl_deg, az_deg, tf_deg + 90.0, 1.0, 50000.0, 60.0)
        b = magnetics.iscwsa_from_tool(field) + scenario.interference_tool_nT
        rows = sim.segment == k
        np.testing.assert_allclose(sim.raw_mps2[rows], np.tile(c @ f, (rows.sum(), 1)),
                                   rtol=0, atol=EPS_MPS2)
        np.testing.assert_allclose(sim.mag_nT[rows], np.tile(c @ b, (rows.sum(), 1)),
                                   rtol=0, atol=EPS_NT)
        assert np.all(sim.inclination_deg[rows] == incl_deg)
        assert np.all(sim.toolface_deg[rows] == tf_deg)
        assert sim.azimuth_deg[rows] == pytest.approx(az_deg, abs=1e-12)


def test_every_sample_is_the_sensor_model_reading():
    """A MEMS tool and a rotation: both triads are sensor_model.read of the truth, bit for bit."""
    tool = make_tool('mems', 0.3, -0.4, 5.0, (0.1, -0.2, 0.3))
    scenario = Scenario(tool=tool, rotation_s=1.0, temperature_c=60.0, seed=9)
    sim = simulate(scenario)
    readings = sm.read(tool, sim.inclination_deg, np.nan_to_num(sim.toolface_deg),
                       np.nan_to_num(sim.azimuth_deg), 60.0, field=scenario.field,
                       interference_nT=scenario.interference_tool_nT, rng=9)
    np.testing.assert_array_equal(sim.raw_mps2, readings.accel_mps2)
    np.testing.assert_array_equal(sim.mag_nT, readings.mag_nT)
    np.testing.assert_array_equal(sim.temperature_c, 60.0)


@hyp
@given(install_deg, install_deg, st.floats(min_value=0.05, max_value=85.0),
       st.floats(min_value=0.0, max_value=360.0, exclude_max=True))
def test_core_inverts_the_bench(gamma_deg, beta_deg, incl_deg, tf_deg):
    """pipeline.run with the true (gamma, beta) returns the bench's I and TF (Eqs. 9, 10, 16)."""
    sim = simulate(Scenario(tool=make_tool('ideal', gamma_deg, beta_deg),
                            stations_deg=((incl_deg, tf_deg),), level_s=0.01, station_s=0.01,
                            rate_hz=100.0))
    model = CalibrationModel(3, Installation(gamma_deg, beta_deg, '2026-01-01T00:00:00+00:00',
                                             1, 0.0, G))
    survey = run(sim.raw_mps2, model, Settings(noise_std_mps2=1e-6))   # noise-free bench
    assert survey.inclination_deg == pytest.approx(sim.inclination_deg, abs=EPS_DEG)
    assert angle_diff_deg(survey.toolface_deg[1], tf_deg) == pytest.approx(0.0, abs=EPS_DEG)


def test_segments_stamps_and_truth_record():
    """Segment sizes, exact stamp spacing and the truth dictionary describe the samples."""
    scenario = Scenario(rate_hz=250.0, level_s=2.0, station_s=1.0, seed=3, rotation_s=0.5)
    sim = simulate(scenario)
    stations = len(DEFAULT_STATIONS_DEG)
    assert sim.stamps_ns.dtype == np.int64
    assert sim.raw_mps2.shape == sim.mag_nT.shape == (500 + 250 * stations + 125, 3)
    assert np.all(np.diff(sim.stamps_ns) == 4_000_000)
    assert sim.stamps_ns[0] == scenario.start_ns
    assert np.bincount(sim.segment).tolist() == [500] + [250] * stations + [125]
    truth = sim.truth
    json.dumps(truth)
    assert truth['tool'] == sm.truth_dict(DEMO_TOOL)
    assert (truth['scenario'], truth['seed'], truth['rate_hz'], truth['temperature_c']) == \
        ('bench', 3, 250.0, 25.0)
    assert truth['field'] == {'total_nT': 50000.0, 'dip_deg': 60.0}
    assert (truth['interference_tool_nT'], truth['interference_iscwsa_nT']) == \
        ([80.0, 80.0, -2000.0], [80.0, -80.0, 2000.0])
    assert truth['segments'][0] == {
        'index': 0, 'kind': 'level', 'start_ns': int(sim.stamps_ns[0]),
        'end_ns': int(sim.stamps_ns[499]), 'samples': 500, 'inclination_deg': 0.0,
        'toolface_deg': None, 'azimuth_deg': None}
    last_station = truth['segments'][-2]
    assert (last_station['start_ns'], last_station['end_ns']) == \
        (int(sim.stamps_ns[-375]), int(sim.stamps_ns[-126]))
    assert last_station['azimuth_deg'] == 95.0
    rotation = truth['segments'][-1]
    assert (rotation['kind'], rotation['samples'], rotation['turns'], rotation['azimuth_deg'],
            rotation['inclination_deg'], rotation['toolface_deg']) == \
        ('rotation', 125, 2.0, 90.0, 60.0, None)
    assert np.all(np.isnan(sim.toolface_deg[sim.segment == 0]))
    assert np.all(np.isnan(sim.azimuth_deg[sim.segment == 0]))


def test_magnetic_truth_per_sample():
    """Station azimuths run 85 -> 95 deg linearly; the rotation turns its toolface twice."""
    sim = simulate(Scenario(rotation_s=2.0))
    stations = [r for r in sim.truth['segments'] if r['kind'] == 'station']
    np.testing.assert_allclose([r['azimuth_deg'] for r in stations],
                               np.linspace(85.0, 95.0, len(stations)), rtol=0, atol=1e-12)
    for record in stations:
        assert np.all(sim.azimuth_deg[sim.segment == record['index']] == record['azimuth_deg'])
    turning = sim.segment == sim.truth['segments'][-1]['index']
    toolface = sim.toolface_deg[turning]
    assert turning.sum() == 400 and toolface[0] == 0.0
    np.testing.assert_allclose(np.diff(toolface)[np.diff(toolface) > 0], 720.0 / 400,
                               rtol=0, atol=1e-9)
    assert np.all(sim.inclination_deg[turning] == 60.0)
    assert np.all(sim.azimuth_deg[turning] == 90.0)


def test_default_stations_spread():
    """About 12 stations spanning 0.5..60 deg inclination and toolfaces all round."""
    incl = [s[0] for s in DEFAULT_STATIONS_DEG]
    tf = sorted(s[1] for s in DEFAULT_STATIONS_DEG)
    assert len(DEFAULT_STATIONS_DEG) == 12
    assert (min(incl), max(incl)) == (0.5, 60.0)
    assert tf == [30.0 * k for k in range(12)]


def test_noise_level_and_seed():
    """The noise has the tool's standard deviation; a seed repeats, another seed differs."""
    clean = simulate(Scenario(tool=NOISE_FREE))
    noisy = simulate(Scenario(seed=7))
    residual = noisy.raw_mps2 - clean.raw_mps2
    # 16200 samples: the sample std has a relative spread 1/sqrt(2 n) = 0.6 %; 5 % is > 8 sigma.
    assert residual.std() == pytest.approx(0.002, rel=0.05)
    assert abs(residual.mean()) < 5 * 0.002 / math.sqrt(residual.size)
    assert (noisy.mag_nT - clean.mag_nT).std() == pytest.approx(5.0, rel=0.05)
    np.testing.assert_array_equal(noisy.raw_mps2, simulate(Scenario(seed=7)).raw_mps2)
    assert not np.array_equal(noisy.raw_mps2, simulate(Scenario(seed=8)).raw_mps2)


def test_two_axis_sensor_reads_zero_z():
    """A two-axis sensor reports z = 0.0 and the same x, y as the three-axis one."""
    three = simulate(Scenario(seed=5))
    two = simulate(Scenario(tool=make_tool('ideal', 0.8, -1.2, noise_mps2=0.002,
                                           mag_noise_nT=5.0, axes=2), seed=5))
    assert np.all(two.raw_mps2[:, 2] == 0.0)
    np.testing.assert_array_equal(two.raw_mps2[:, :2], three.raw_mps2[:, :2])
    assert two.truth['tool']['accelerometer']['axes'] == 2


@pytest.mark.parametrize('changes', [{'rate_hz': 0.0}, {'level_s': 0.001},
                                     {'rotation_s': -1.0}, {'field': sm.Field(0.0, 60.0)}])
def test_scenario_refuses_impossible_settings(changes):
    """A scenario that cannot be sampled is refused at construction."""
    with pytest.raises(ValueError):
        Scenario(**changes)


@pytest.mark.parametrize('kwargs', [{'sensor': 'fluxgate'}, {'axes': 1},
                                    {'noise_mps2': -1.0}])
def test_make_tool_refuses(kwargs):
    """An unknown preset, one axis or a negative noise is refused."""
    with pytest.raises(ValueError):
        make_tool(**kwargs)


def test_inclination_of_the_true_force_matches_truth():
    """An ideal unmounted tool reads the stated inclination and seed-000 toolface."""
    sim = simulate(Scenario(tool=sm.IDEAL))
    tilted = sim.segment > 0
    assert np.degrees(inclination(sim.raw_mps2)) == pytest.approx(sim.inclination_deg,
                                                                  abs=EPS_DEG)
    tf = np.degrees(toolface_seed000(sim.raw_mps2[tilted]))
    assert np.abs(angle_diff_deg(tf, sim.toolface_deg[tilted])).max() < EPS_DEG


def test_stand_reads_k_f_plus_b_at_the_reference_temperature():
    """
    At 25 deg C a MEMS triad on the mount reads K_triad C f + b: ``tool_stand_truth``.

    That is seed 001's stand model, which the physics obeys at T_ref (no drift acts).
    """
    tool = make_tool('mems', 0.8, -1.2, noise_mps2=0.0)
    stand = simulate_stand(StandRun(tool=tool), samples=3)
    k, b = tool_stand_truth(tool)
    angles = np.repeat(np.array(STAND_POSITIONS_DEG), 3, axis=0)
    i, a = np.radians(angles[:, 0]), np.radians(angles[:, 1])
    f = G * np.column_stack([np.sin(i) * np.cos(a), np.sin(i) * np.sin(a), np.cos(i)])
    np.testing.assert_allclose(stand.raw_mps2, f @ k.T + b, rtol=0, atol=EPS_MPS2)
    np.testing.assert_allclose(k, np.array(sm.MEMS.accelerometer.matrix) @ seed_eq1(
        math.radians(0.8), math.radians(-1.2)), rtol=0, atol=1e-15)
    assert np.bincount(stand.segment).tolist() == [0] + [3] * 9
    assert stand.truth['scenario'] == 'position' and stand.truth['temperature_c'] == 25.0
    assert stand.truth['tool'] == sm.truth_dict(tool)


def test_heating_ramp():
    """The heating run holds 55/45 deg while 20 -> 100 deg C; the readings drift with T."""
    heating = simulate_heating(StandRun(tool=make_tool('mems', noise_mps2=0.0)), samples=81)
    np.testing.assert_array_equal(heating.temperature_c, np.linspace(20.0, 100.0, 81))
    assert np.all(heating.inclination_deg == 55.0) and np.all(heating.toolface_deg == 45.0)
    assert (heating.truth['t_start_c'], heating.truth['t_end_c']) == (20.0, 100.0)
    at_25 = heating.raw_mps2[heating.temperature_c == 25.0][0]
    drift = heating.raw_mps2[-1] - at_25
    # MEMS: bias drift ~0.5 mg/degC and scale drift ~2e-4/degC over 75 degC: tens of mg.
    assert np.abs(drift).max() > 0.02 * G


def test_heating_at_two_attitudes():
    """
    Heated at 55/45 deg, turned over to 125/225 deg and cooled: every reading is the model's.

    The temperature runs 20 -> 100 -> 20 deg C without a jump; each axis reads the opposite
    sign at the second attitude (what lets fit-temperature tell a bias from a scale drift).
    """
    tool = make_tool('mems', 0.8, -1.2)
    heating = simulate_heating(StandRun(tool=tool, seed=4), TURNED_OVER_HEATING_ATTITUDES_DEG,
                               samples=81)
    ramp = np.linspace(20.0, 100.0, 81)
    np.testing.assert_array_equal(heating.temperature_c, np.r_[ramp, ramp[::-1]])
    assert np.bincount(heating.segment).tolist() == [0, 81, 81]
    assert [(s['inclination_deg'], s['toolface_deg']) for s in heating.truth['segments']] == \
        [(55.0, 45.0), (125.0, 225.0)]
    first = heating.segment == 1
    assert np.all(heating.inclination_deg[first] == 55.0)
    assert np.all(heating.toolface_deg[~first] == 225.0)
    readings = sm.read(tool, heating.inclination_deg, heating.toolface_deg, 0.0,
                       heating.temperature_c, field=sm.Field(), rng=4)
    np.testing.assert_array_equal(heating.raw_mps2, readings.accel_mps2)
    assert np.all(np.sign(heating.raw_mps2[first]) == -np.sign(heating.raw_mps2[~first]))
    with pytest.raises(ValueError, match='pairs'):
        simulate_heating(StandRun(tool=tool), ((55.0,),))


def run_cli(argv):
    """Run ``inclino simulate argv`` in-process quietly; return (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = inclino(['simulate', *[str(a) for a in argv]])
    return code, out.getvalue(), err.getvalue()


def test_cli_options_reach_the_tool(tmp_path):
    """--sensor, the mount, --magnetometer-deg and the noise make the tool of the truth file."""
    path = tmp_path / 'sim'
    code, out, err = run_cli([path, '--sensor', 'mems', '--gamma-deg', 0.3, '--beta-deg', -0.4,
                              '--roll-deg', 5, '--magnetometer-deg', 0.1, -0.2, 0.3,
                              '--noise-mps2', 0.01, '--magnetic', '--interference-nT', 10, 20,
                              30, '--seed', 9, '--level-s', 0.5, '--station-s', 0.1])
    assert code == 0, err
    assert 'mems sensor' in out and 'roll 5 deg' in out
    truth = json.loads((tmp_path / 'sim.truth.json').read_text())
    tool = make_tool('mems', 0.3, -0.4, 5.0, (0.1, -0.2, 0.3), noise_mps2=0.01)
    assert truth['tool'] == json.loads(json.dumps(sm.truth_dict(tool)))
    assert truth['interference_tool_nT'] == [10.0, -20.0, -30.0]
    assert truth['magnetic']['topic'] == '/imu/mag'
    expected = simulate(Scenario(tool=tool, interference_tool_nT=(10.0, -20.0, -30.0), seed=9,
                                 level_s=0.5, station_s=0.1))
    assert [s['samples'] for s in truth['segments']] == \
        [s['samples'] for s in expected.truth['segments']]


def test_demo_takes_the_noise_from_the_truth_file(tmp_path):
    """``inclino demo`` tells the node the noise ``inclino simulate`` recorded (0.002 m/s^2)."""
    from inclino_ros.cli.demo import accelerometer_noise_mps2
    assert run_cli([tmp_path / 'bench', '--level-s', 0.1, '--station-s', 0.1])[0] == 0
    truth = json.loads((tmp_path / 'bench.truth.json').read_text())
    assert accelerometer_noise_mps2(truth) == 0.002


def test_cli_heating_attitudes(tmp_path):
    """--heating-attitudes: the bag, the truth file and the CSV's attitude column."""
    path = tmp_path / 'heating'
    code, out, err = run_cli([path, '--heating', '--sensor', 'mems', '--heating-attitudes', 55,
                              45, 125, 225, '--samples', 41, '--seed', 3, '--csv',
                              tmp_path / 'heating.csv'])
    assert code == 0, err
    assert 'attitudes 55/45, 125/225 deg' in out and '82 messages' in out
    expected = simulate_heating(StandRun(tool=make_tool('mems', 0.8, -1.2), seed=3),
                                TURNED_OVER_HEATING_ATTITUDES_DEG, samples=41)
    raw = bag.concatenate(bag.read(path, '/imu/data_raw'))
    np.testing.assert_array_equal(raw.linear_acceleration_mps2, expected.raw_mps2)
    temperature = bag.concatenate(bag.read(path, '/imu/temperature'))
    np.testing.assert_array_equal(temperature.temperature_c, expected.temperature_c)
    truth = json.loads((tmp_path / 'heating.truth.json').read_text())
    assert [s['toolface_deg'] for s in truth['segments']] == [45.0, 225.0]
    rows = np.genfromtxt(tmp_path / 'heating.csv', delimiter=',', names=True)
    np.testing.assert_array_equal(rows['attitude'], expected.segment)
    np.testing.assert_array_equal(rows['temperature_c'], expected.temperature_c)


@pytest.mark.parametrize('argv, message', [
    (['--stand', '--magnetic'], '--magnetic goes with the bench scenario'),
    (['--stand', '--heating-attitudes', '55', '45'], '--heating-attitudes goes with --heating'),
    (['--heating', '--heating-attitudes', '55', '45', '125'], 'INCLINATION TOOLFACE pairs'),
    (['--heating', '--axes', '2'], 'three-axis sensor'),
    # Impossible numbers are usage errors where argparse reads them (issue 10).
    (['--stand', '--samples', '0'], 'argument --samples: 0 is not between'),
    (['--noise-mps2', '-1'], 'argument --noise-mps2: -1 is not between'),
    (['--rate-hz', '0'], 'argument --rate-hz: 0 is not between'),
    (['--magnetic', '--reference-total-nT', '0'], 'argument --reference-total-nT: 0 is not'),
    (['--rate-hz', '100000', '--station-s', '86400'], 'at most 1000000'),
])
def test_cli_refuses_impossible_settings(tmp_path, argv, message):
    """Impossible combinations exit 2 with the reason and write nothing."""
    code, _, err = run_cli([tmp_path / 'sim', *argv])
    assert code == 2 and message in err, err
    assert not (tmp_path / 'sim').exists()
