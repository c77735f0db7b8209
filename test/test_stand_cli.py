"""
Seed 001 end to end: simulate --stand/--heating -> fit-stand/fit-temperature -> process.

The sensor is the physical model's (``sim.sensor_model``, what ``inclino simulate --stand
--sensor mems`` simulates): MEMS triads on a board mounted gamma 0.8, beta -1.2 deg,
i.e. a 3x3 K (scale errors ~0.4 %, misalignment ~5 mrad), biases up to 18 mg, a bias drift
~0.5 mg/degC and a scale drift ~200 ppm/degC, here with sigma = 2e-4 g = 1.96e-3 m/s^2 of
noise per axis and sample.  The stand holds 100 samples per position (nine positions,
25 deg C); the heating run, as a user now makes it, heats the tool at inclination 55 deg,
toolface 45 deg and cools it turned over (125 deg, 225 deg: every axis reads the opposite),
1601 samples over 20..100 deg C at each.  Tolerances:

- Stand K and b: at 25 deg C the triad reads K f + b with K = K_triad C(gamma, beta)
  (``sim.bench.tool_stand_truth``), seed 001's model exactly.  Each position mean has 2e-5 g
  of noise; the least-squares covariance of the nine-position design gives a K element
  1.25e-5 and a bias 6.7e-6 g at 1 sigma (test_stand.py), so 1e-4 and 5e-5 g are >= 7 sigma.
- Processed stand: the corrected specific force (/imu/data) averaged over a position's 100
  samples has 2e-5 g of noise, 1.15e-3 deg of inclination, and the fitted K and b add
  ~1.6e-3 deg: its inclination stays within 0.01 deg (> 4 sigma).  (Not the mean of the
  per-sample angles: at 0 and 180 deg an angle is a magnitude and its mean is biased by the
  Rayleigh mean 1.25 sigma / g = 0.014 deg.)
- Temperature: each axis reads A_T = (1 + s(T)) (A - b) + b + db(T) = K_T(T) A + B_T(T)
  with K_T = 1 + s and B_T = db - s b: the stage's model exactly (order 2 holds the MEMS
  drifts).  Two attitudes where the axis reads +-0.58 g tell B_T from K_T
  (``fit_temperature_drift``); 2 x 1601 readings of 2e-4 g fix B_T(100 C) to 1.2e-5 g
  and K_T(100 C) to 2.1e-5 at 1 sigma (200 noise seeds), ~0.001 deg of tilt, to which the
  stand fit adds its ~0.003 deg: random attitudes at random 20..100 deg C stay within 0.01
  deg (measured 0.0040 deg, 0.0026-0.0035 with three other heating seeds), while the drift
  left alone moves them by 3.7 deg.  Heated at ONE attitude (seed 001's run) the fit is
  K_T only and says that a bias drift cannot be seen there: right at that attitude (0.0039
  deg, what the noise leaves), 4.35 deg off at random attitudes.
- Sphere fit (60 single readings): K K^T and b to the 1e-3 and 5e-4 g the noise allows; a
  turn of the sensor about the tool axis (a roll of the board) is unobserved by it and by
  the level capture: a physical limit, its toolface offset asserted in closed form; the
  stand, which knows the toolfaces, removes it (toolface within 0.05 deg).
- Uncorrected: the simulated sensor reads the stand positions up to ~3 deg off.
Seeds are fixed; the bounds hold for any seed.  Exact round trips compare with equality.
"""

import contextlib
import csv
from dataclasses import replace
import io
import json
import os

from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.model import (
    CalibrationModel, Installation, load_model, save_model, Stand, Temperature)
from inclino_ros.cli.main import main as inclino
from inclino_ros.cli.simulate import write_bag
from inclino_ros.core.attitude import inclination
from inclino_ros.core.msa import azimuth_difference_deg
from inclino_ros.io import bag
from inclino_ros.pipeline import run, Settings
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import (
    make_tool, simulate_heating, simulate_stand, StandRun, tool_stand_truth,
    TURNED_OVER_HEATING_ATTITUDES_DEG)
import numpy as np
from numpy.polynomial import polynomial as poly
import pytest
from rosbags.typesys import get_typestore, Stores

G = 9.80665
NOISE_MPS2 = 2e-4 * G
#: What ``inclino simulate --stand --sensor mems --noise-mps2 NOISE_MPS2`` simulates.
TOOL = make_tool('mems', 0.8, -1.2, noise_mps2=NOISE_MPS2)
TOOL_K, TOOL_BIAS_MPS2 = tool_stand_truth(TOOL)
#: The MEMS triad without its bias and bias drift: only its sensitivity drifts.
SCALE_DRIFT_ONLY = replace(TOOL, accelerometer=replace(
    TOOL.accelerometer, bias=(0.0, 0.0, 0.0), bias_drift=((), (), ())))
#: The MEMS triad without its bias drift: the bias is constant, the sensitivity drifts.
NO_BIAS_DRIFT = replace(TOOL, accelerometer=replace(TOOL.accelerometer,
                                                    bias_drift=((), (), ())))
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
NOW = '2026-01-01T00:00:00+00:00'


def quiet(argv):
    """Run ``inclino argv`` in-process; return (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = inclino([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def noise_free(tool):
    """Return ``tool`` without accelerometer noise."""
    return replace(tool, accelerometer=replace(tool.accelerometer, noise_std=0.0))


def scale_drift_stage(tool=SCALE_DRIFT_ONLY):
    """
    Return the triad's own sensitivity 1 + s_i(T) as a model.Temperature stage.

    For a triad without bias and bias drift, that is seed 001's K_T(T) exactly.
    """
    # 1 + c1 (T - 25) + c2 (T - 25)^2 in powers of T.
    coefficients = [poly.polyadd([1.0 - 25.0 * c1 + 625.0 * c2, c1 - 50.0 * c2], [0.0, 0.0, c2])
                    for c1, c2 in tool.accelerometer.scale_drift]
    return Temperature(tuple(map(tuple, np.array(coefficients).tolist())), 20.0, 100.0, 25.0,
                       (0.0, 0.0, 0.0), 1, NOW)


def true_stand_stage():
    """Return the K and b the simulated sensor obeys at 25 deg C as a model.Stand stage."""
    return Stand(tuple(map(tuple, TOOL_K.tolist())), tuple(TOOL_BIAS_MPS2.tolist()), 'stand',
                 1.0, 0.0, 9, NOW)


def random_attitudes(count, seed):
    """Return (inclination, toolface) [deg] of ``count`` attitudes uniform over the sphere."""
    rng = np.random.default_rng(seed)
    return np.degrees(np.arccos(rng.uniform(-1.0, 1.0, count))), rng.uniform(0.0, 360.0, count)


def write_csv(path, columns):
    """Write ``{name: values}`` as a CSV file with a header row."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(zip(*(np.asarray(v).tolist() for v in columns.values())))


def stand_csv(path, attitudes_deg, readings):
    """Write stand rows: attitude and reading per row."""
    attitudes_deg = np.asarray(attitudes_deg, dtype=float)
    write_csv(path, {'inclination_deg': attitudes_deg[:, 0], 'toolface_deg': attitudes_deg[:, 1],
                     'ax': readings[:, 0], 'ay': readings[:, 1], 'az': readings[:, 2]})


def file_state(path):
    """Return the bytes and modification time of ``path``."""
    with open(path, 'rb') as stream:
        return stream.read(), os.stat(path).st_mtime_ns


def fit_both(work, stand_path, heating_path):
    """Fit the stand, then the temperature into ``work/cal.json``; return the fits' results."""
    calibration = work / 'cal.json'
    fit_stand = quiet(['fit-stand', stand_path, '--calibration', calibration])
    assert fit_stand[0] == 0, fit_stand
    stand_model = load_model(calibration)
    fit_temperature = quiet(['fit-temperature', heating_path, '--calibration', calibration])
    assert fit_temperature[0] == 0, fit_temperature
    return {'cal.json': calibration, 'fit_stand': fit_stand, 'fit_temperature': fit_temperature,
            'stand_model': stand_model, 'model': load_model(calibration)}


#: ``inclino simulate --heating-attitudes`` of the two heating attitudes.
HEATING_ATTITUDES_ARGS = [f'{v:g}' for pair in TURNED_OVER_HEATING_ATTITUDES_DEG for v in pair]


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    """
    Simulate the stand (mcap) and the heating (sqlite3) runs; fit both into one file.

    The heating run as a user now makes it: two attitudes, 55/45 deg and turned over.
    """
    work = tmp_path_factory.mktemp('seed001')
    paths = {name: work / name for name in ('stand', 'heating', 'stand.csv', 'heating.csv')}
    code, stdout, _ = quiet(['simulate', paths['stand'], '--stand', '--sensor', 'mems',
                             '--noise-mps2', NOISE_MPS2, '--samples', 100, '--csv',
                             paths['stand.csv']])
    assert code == 0 and 'wrote' in stdout
    assert quiet(['simulate', paths['heating'], '--heating', '--sensor', 'mems', '--noise-mps2',
                  NOISE_MPS2, '--heating-attitudes', *HEATING_ATTITUDES_ARGS, '--storage',
                  'sqlite3', '--csv', paths['heating.csv'], '--seed', '1'])[0] == 0
    return dict(paths, work=work, **fit_both(work, paths['stand'], paths['heating']))


@pytest.fixture(scope='module')
def drift_runs(tmp_path_factory, runs):
    """Return {name: fits} of the stand and two-attitude heating runs of each triad tried."""
    out = {'mems': runs}
    for name, tool in (('no bias drift', NO_BIAS_DRIFT), ('scale drift only', SCALE_DRIFT_ONLY)):
        work = tmp_path_factory.mktemp('drift')
        write_bag(work / 'stand', 'mcap', simulate_stand(StandRun(tool)), NOISE_MPS2, 'stand')
        write_bag(work / 'heating', 'mcap', simulate_heating(
            StandRun(tool, seed=1), TURNED_OVER_HEATING_ATTITUDES_DEG), NOISE_MPS2, 'heating')
        out[name] = fit_both(work, work / 'stand', work / 'heating')
    return out


@pytest.fixture(scope='module')
def one_attitude(tmp_path_factory, runs):
    """Seed 001's heating run (one attitude) of the MEMS tool, fitted after the same stand."""
    work = tmp_path_factory.mktemp('one_attitude')
    assert quiet(['simulate', work / 'heating', '--heating', '--sensor', 'mems', '--noise-mps2',
                  NOISE_MPS2, '--seed', '1'])[0] == 0
    save_model(work / 'cal.json', runs['stand_model'])
    fit_temperature = quiet(['fit-temperature', work / 'heating', '--calibration',
                             work / 'cal.json'])
    assert fit_temperature[0] == 0, fit_temperature
    return {'fit_temperature': fit_temperature, 'model': load_model(work / 'cal.json')}


# --- the simulated sensor -----------------------------------------------------------------

def test_true_stand_stage_inverts_the_sensor_at_25_c():
    """At 25 deg C the model with the tool's own K and b gives back f to round-off."""
    incl_deg, tf_deg = random_attitudes(50, 3)
    readings = sm.read(noise_free(TOOL), incl_deg, tf_deg, temperature_c=25.0)
    model = CalibrationModel(3, stand=true_stand_stage())
    np.testing.assert_allclose(model.apply(readings.accel_mps2),
                               readings.specific_force_tool_mps2, rtol=0, atol=1e-12)


def test_simulated_runs_and_truth_file(runs):
    """Nine positions of 100 samples at 25 deg C; 20 -> 100 -> 20 deg C ramps; the truth file."""
    stand = simulate_stand(StandRun(TOOL))
    assert stand.raw_mps2.shape == (900, 3) and np.all(stand.temperature_c == 25.0)
    assert np.bincount(stand.segment).tolist() == [0] + [100] * 9
    heating = simulate_heating(StandRun(TOOL, seed=1), TURNED_OVER_HEATING_ATTITUDES_DEG)
    assert heating.temperature_c[[0, 1600, 1601, 3201]].tolist() == [20.0, 100.0, 100.0, 20.0]
    assert np.bincount(heating.segment).tolist() == [0, 1601, 1601]
    assert np.all(heating.inclination_deg[:1601] == 55.0)
    assert np.all(heating.toolface_deg[1601:] == 225.0)
    with open(f'{runs["stand"]}.truth.json') as stream:
        truth = json.load(stream)
    assert truth['tool'] == json.loads(json.dumps(sm.truth_dict(TOOL)))
    assert truth['sensor'] == 'mems'
    assert truth['topics']['stand_attitude'] == '/stand/attitude'
    assert [s['inclination_deg'] for s in truth['segments']][:3] == [0.0, 180.0, 90.0]
    # Both storages read back bit for bit, the temperature too.
    for name, simulated in (('stand', stand), ('heating', heating)):
        raw = bag.concatenate(bag.read(runs[name], '/imu/data_raw'))
        np.testing.assert_array_equal(raw.linear_acceleration_mps2, simulated.raw_mps2)
        temperature = bag.concatenate(bag.read(runs[name], '/imu/temperature'))
        np.testing.assert_array_equal(temperature.temperature_c, simulated.temperature_c)
        np.testing.assert_array_equal(temperature.stamps_ns, simulated.stamps_ns)


@pytest.mark.parametrize('frame_id', ['', 'a', 'imu', 'thermometer', 'caf\u00e9'])
def test_temperature_codec_matches_rosbags_byte_for_byte(frame_id):
    """encode() gives rosbags' CDR of sensor_msgs/Temperature; decode() inverts it."""
    stamps_ns = np.array([0, 1, 1_767_225_600_123_456_789])
    values = np.array([[25.0, 0.0], [-40.5, 0.01], [151.25, 1e-3]])
    series = bag.TemperatureSeries.from_values(stamps_ns, bag.frame_id_array(frame_id, 3), values)
    types = TYPESTORE.types
    for data, stamp_ns, (temperature_c, variance) in zip(bag.encode(series), stamps_ns, values):
        header = types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=int(stamp_ns) // 10**9,
                                                       nanosec=int(stamp_ns) % 10**9),
            frame_id=frame_id)
        msg = types[bag.TEMPERATURE](header=header, temperature=temperature_c,
                                     variance=variance)
        assert data == bytes(TYPESTORE.serialize_cdr(msg, bag.TEMPERATURE))
    decoded = bag.decode(bag.encode(series), bag.TEMPERATURE)
    np.testing.assert_array_equal(decoded.values(), values)
    np.testing.assert_array_equal(decoded.stamps_ns, stamps_ns)
    assert decoded.frame_ids.tolist() == [frame_id] * 3
    # Linear in time between messages, the last value held after them.
    middle_ns = (1 + int(stamps_ns[2])) // 2
    np.testing.assert_allclose(decoded.at([0, 1, middle_ns, stamps_ns[2] + 10**9]),
                               [25.0, -40.5, (151.25 - 40.5) / 2, 151.25], rtol=0, atol=1e-9)


# --- fit-stand ----------------------------------------------------------------------------

def test_fit_stand_recovers_k_and_bias(runs):
    """K within 1e-4 per element, b within 5e-5 g; the report and the printout."""
    stand = runs['model'].stand
    assert stand.method == 'stand' and stand.positions == 9
    assert np.abs(np.array(stand.scale_matrix) - TOOL_K).max() < 1e-4
    assert np.abs(np.array(stand.bias_mps2) - TOOL_BIAS_MPS2).max() < 5e-5 * G
    assert stand.rms_inclination_deg < 0.01
    stdout = runs['fit_stand'][1]
    for text in ('K (A = K G + b)', 'bias_mps2', 'axis scales', 'non-orthogonality_deg',
                 'condition number', 'RMS inclination residual', 'residual_deg'):
        assert text in stdout
    assert len([line for line in stdout.splitlines() if line.startswith('  9 ')]) == 1
    for name in ('fit_stand.png', 'fit_stand.txt', 'fit_temperature.png',
                 'fit_temperature.txt'):
        assert (runs['work'] / name).stat().st_size > 0
    assert runs['model'].stand == runs['stand_model'].stand  # fit-temperature kept it


def test_the_default_stand_run_of_a_mems_passes_the_default_limits(tmp_path):
    """
    ``simulate --stand`` (MEMS at its own 2 mg, 500 samples a position) -> ``fit-stand``: fitted.

    Its per-sample spread, ~0.12 deg, is noise, not motion (issue 9's still test): 100
    samples a position are refused as too noisy for 0.01 deg (151 needed), not as moving.
    K and b: the 1 sigma of the nine-position design (1.25e-5 and 6.7e-6 g at 2e-4 g and 100
    samples) times 10 / sqrt(5) is 5.6e-5 and 3.0e-5 g; 3e-4 and 1.5e-4 g are 5 sigma.
    """
    code, stdout, err = quiet(['simulate', tmp_path / 'stand', '--stand'])
    assert code == 0, err
    assert 'stand run of a mems sensor' in stdout and '4500 messages' in stdout
    code, stdout, err = quiet(['fit-stand', tmp_path / 'stand', '--calibration',
                               tmp_path / 'cal.json'])
    assert code == 0, err
    stand = load_model(tmp_path / 'cal.json').stand
    k, b = tool_stand_truth(make_tool('mems', 0.8, -1.2))
    assert np.abs(np.array(stand.scale_matrix) - k).max() < 3e-4
    assert np.abs(np.array(stand.bias_mps2) - b).max() < 1.5e-4 * G
    assert stand.rms_inclination_deg < 0.05

    assert quiet(['simulate', tmp_path / 'short', '--stand', '--samples', 100])[0] == 0
    code, _, err = quiet(['fit-stand', tmp_path / 'short', '--calibration',
                          tmp_path / 'short.json'])
    assert code == 1 and 'too noisy for the target: 151 samples needed' in err, err
    assert 'moving' not in err


def test_process_applies_the_stand_stage(runs):
    """Inclination of each position's mean corrected force within 0.01 deg, raw >= 1 deg."""
    out = runs['work'] / 'stand_out'
    code, _, stderr = quiet(['process', runs['stand'], out, '--calibration', runs['cal.json'],
                             '--temperature-topic', '/imu/temperature'])
    assert code == 0, stderr
    corrected = bag.concatenate(bag.read(out, '/imu/data'))
    attitude = bag.concatenate(bag.read(runs['stand'], '/stand/attitude'))
    raw = bag.concatenate(bag.read(runs['stand'], '/imu/data_raw'))
    np.testing.assert_array_equal(corrected.stamps_ns, attitude.stamps_ns)
    errors_deg, raw_errors_deg = [], []
    for incl_deg, tf_deg in np.unique(attitude.vector[:, :2], axis=0):
        at = (attitude.vector[:, 0] == incl_deg) & (attitude.vector[:, 1] == tf_deg)
        for errors, series in ((errors_deg, corrected), (raw_errors_deg, raw)):
            mean = series.linear_acceleration_mps2[at].mean(axis=0)
            errors.append(np.degrees(inclination(mean)) - incl_deg)
    print(f'stand positions: corrected max {np.abs(errors_deg).max():.5f} deg, raw '
          f'{np.abs(raw_errors_deg).max():.2f} deg')
    assert len(errors_deg) == 9
    assert np.abs(errors_deg).max() <= 0.01
    assert np.abs(raw_errors_deg).max() >= 1.0


def test_fit_stand_from_csv_equals_bag_and_keeps_temperature(runs, tmp_path):
    """Per-sample CSV = bag; averaged CSV works; temperature kept, installation dropped."""
    calibration = tmp_path / 'cal.json'
    installation = Installation(0.8, -1.2, NOW, 100, 0.01, G)
    save_model(calibration, CalibrationModel(3, installation=installation,
                                             temperature=scale_drift_stage()))
    code, stdout, stderr = quiet(['fit-stand', runs['stand.csv'], '--calibration', calibration,
                                  '--report-dir', tmp_path / 'report'])
    assert code == 0, stderr
    assert 'installation stage dropped' in stdout and 'mounting misalignment' in stdout
    assert 'temperature stage of the file applied' in stdout
    model = load_model(calibration)
    assert model.installation is None and model.temperature == scale_drift_stage()
    # At 25 deg C K_T = 1: the same fit as from the bag, to round-off.
    np.testing.assert_allclose(model.stand.scale_matrix, runs['stand_model'].stand.scale_matrix,
                               rtol=0, atol=1e-12)
    assert (tmp_path / 'report' / 'fit_stand.png').exists()

    stand = simulate_stand(StandRun(TOOL))
    means = stand.raw_mps2.reshape(9, 100, 3).mean(axis=1)
    stand_csv(tmp_path / 'means.csv',
              [(s['inclination_deg'], s['toolface_deg']) for s in stand.truth['segments']], means)
    code, _, stderr = quiet(['fit-stand', tmp_path / 'means.csv', '--calibration',
                             tmp_path / 'new.json'])
    assert code == 0, stderr
    np.testing.assert_allclose(load_model(tmp_path / 'new.json').stand.scale_matrix,
                               runs['stand_model'].stand.scale_matrix, rtol=0, atol=1e-12)


def sphere_fit(tmp_path, tool):
    """Write 60 single readings of ``tool`` at random attitudes; fit-stand --method sphere."""
    incl_deg, tf_deg = random_attitudes(60, 5)
    readings = sm.read(tool, incl_deg, tf_deg, rng=5).accel_mps2
    write_csv(tmp_path / 'sphere.csv', dict(zip(('ax', 'ay', 'az'), readings.T)))
    code, stdout, stderr = quiet(['fit-stand', tmp_path / 'sphere.csv', '--method', 'sphere',
                                  '--calibration', tmp_path / 'cal.json'])
    assert code == 0, stderr
    return stdout, load_model(tmp_path / 'cal.json')


def test_fit_stand_sphere(tmp_path):
    """Sphere fit of 60 random still readings: K K^T and b of the sensor; level bench next."""
    stdout, model = sphere_fit(tmp_path, TOOL)
    assert 'calibrate the level bench' in stdout
    k = np.array(model.stand.scale_matrix)
    assert model.stand.method == 'sphere' and model.stand.rms_inclination_deg is None
    assert np.allclose(np.tril(k, -1), 0.0)
    assert np.abs(k @ k.T - TOOL_K @ TOOL_K.T).max() < 1e-3
    assert np.abs(np.array(model.stand.bias_mps2) - TOOL_BIAS_MPS2).max() < 5e-4 * G


#: A roll of the board about the tool axis [deg], and the MEMS tool so rolled.
ROLL_DEG = 2.0
ROLLED = make_tool('mems', 0.8, -1.2, ROLL_DEG, noise_mps2=NOISE_MPS2)
#: Toolface bound [deg] at inclinations >= 10 deg (tests of the rolled board, budgets there).
TOOLFACE_DEG = 0.05


def rolled_errors(model):
    """Return the inclination error and the toolface error at I >= 10 deg of ``ROLLED`` [deg]."""
    incl_deg, tf_deg = random_attitudes(400, 7)
    tilted = incl_deg >= 10.0
    survey = run(sm.read(noise_free(ROLLED), incl_deg, tf_deg).accel_mps2, model, Settings())
    return (survey.inclination_deg - incl_deg,
            azimuth_difference_deg(survey.toolface_deg[tilted], tf_deg[tilted]))


def test_stand_calibration_gives_the_toolface_of_a_rolled_board(tmp_path):
    """
    A MEMS board rolled 2 deg: simulate --stand, fit-stand: I and toolface true.

    The stand knows each position's toolface: K = K_triad C R_z(-roll) holds the roll.  Budget:
    K elements ~1.25e-5 and b ~6.7e-6 g (1 sigma, module docstring) put ~2e-5 g on the
    corrected cross-axial force, i.e. 2e-5 / sin(10 deg) rad = 0.007 deg of toolface at the
    lowest inclination: TOOLFACE_DEG = 0.05 deg is 7 sigma there (measured, seeds 0-4: at
    most 0.009 deg), the inclination bound 0.01 deg as for the unrolled tool.
    """
    stand, calibration = tmp_path / 'stand', tmp_path / 'cal.json'
    assert quiet(['simulate', stand, '--stand', '--sensor', 'mems', '--roll-deg', ROLL_DEG,
                  '--noise-mps2', NOISE_MPS2, '--samples', 100])[0] == 0
    with open(f'{stand}.truth.json') as stream:
        assert json.load(stream)['tool'] == json.loads(json.dumps(sm.truth_dict(ROLLED)))
    code, _, stderr = quiet(['fit-stand', stand, '--calibration', calibration])
    assert code == 0, stderr
    inclination_error, tf_error = rolled_errors(load_model(calibration))
    print(f'stand, roll {ROLL_DEG} deg: toolface error {tf_error.min():.4f} .. '
          f'{tf_error.max():.4f} deg, inclination {np.abs(inclination_error).max():.4f} deg')
    assert np.abs(inclination_error).max() <= 0.01
    assert np.abs(tf_error).max() <= TOOLFACE_DEG


def unobserved_toolface_offset_deg(tool):
    """
    Return the toolface offset [deg] a sphere fit and a level capture leave on ``tool``.

    Closed form from the physical model.  The triad reads K f + b with K = K_triad C (the
    mount with its roll, ``tool_stand_truth``); the sphere fit sees K K^T only and takes the
    upper-triangular K_s of it (positive diagonal), so it leaves the rotation M = K_s^-1 K.
    The level capture then finds the seed-000 mount (gamma', beta') that reads M e_z standing
    vertical (the sensor model's level reading g (-sin gamma, -sin beta cos gamma, ...)) and
    turns it back; what remains, Mount(gamma', beta') M, is a turn about the tool axis by the
    offset.  For ideal triads it is -roll; a MEMS triad adds the turn of its y sensing axis
    about z, which the sphere's convention cannot see either (~-0.24 deg).
    """
    k, _ = tool_stand_truth(tool)
    flip = np.eye(3)[::-1]
    k_sphere = flip @ np.linalg.cholesky(flip @ k @ k.T @ flip) @ flip
    rotation = np.linalg.solve(k_sphere, k)
    up_x, up_y, _ = rotation[:, 2]
    gamma = -np.arcsin(up_x)
    beta = -np.arcsin(up_y / np.cos(gamma))
    left = sm.Mount(np.degrees(gamma), np.degrees(beta)).tool_from_board() @ rotation
    np.testing.assert_allclose(left[:, 2], (0.0, 0.0, 1.0), rtol=0, atol=1e-12)
    return float(np.degrees(np.arctan2(left[1, 0], left[0, 0])))


def test_sphere_fit_and_level_capture_leave_the_roll_as_a_toolface_offset(tmp_path):
    """
    A MEMS board rolled 2 deg: sphere fit, then a level capture: the toolface is off by the roll.

    A physical limit, not a defect: neither a sphere fit (|G| = g) nor a level capture (seed
    000 Eq. 2) sees a turn about the tool axis, so the toolface keeps the closed-form offset
    ``unobserved_toolface_offset_deg``: -roll, plus the triad's own turn about z.  Asserted
    within TOOLFACE_DEG at every attitude (I >= 10 deg): the sphere fit's K to ~5e-4 (K K^T
    within 1e-3, test_fit_stand_sphere) and the 100-sample level capture to 2e-5 rad leave
    ~0.03 deg (measured: -2.257 .. -2.204 deg for the closed form's -2.240).  Inclination is
    not affected by the turn: within the same 0.05 deg.  Only a stand (the test above) or a
    marked high side removes the offset.
    """
    _, model = sphere_fit(tmp_path, ROLLED)
    level = sm.read(ROLLED, np.zeros(100), 0.0, rng=6).accel_mps2
    installation = solve_level_capture(model.apply(level), 3, LevelLimits(
        max_tilt_deg=5.0, gravity_mps2=G, g_total_tolerance_mps2=0.05))
    inclination_error, tf_error = rolled_errors(replace(model, installation=installation))
    offset_deg = unobserved_toolface_offset_deg(ROLLED)
    print(f'sphere + level, roll {ROLL_DEG} deg: toolface error {tf_error.min():.3f} .. '
          f'{tf_error.max():.3f} deg (closed form {offset_deg:.3f}), inclination '
          f'{np.abs(inclination_error).max():.4f} deg')
    # The roll's share of the offset is exactly -roll; the rest is the triad's own.
    unrolled = replace(ROLLED, mount=replace(ROLLED.mount, roll_deg=0.0))
    roll_share_deg = offset_deg - unobserved_toolface_offset_deg(unrolled)
    assert roll_share_deg == pytest.approx(-ROLL_DEG, abs=1e-9)
    assert np.abs(inclination_error).max() <= 0.05
    assert np.abs(tf_error - offset_deg).max() <= TOOLFACE_DEG


# --- fit-temperature ----------------------------------------------------------------------

@pytest.mark.parametrize('sensor', ['mems', 'no bias drift', 'scale drift only'])
def test_fit_temperature_compensates(drift_runs, sensor):
    """
    Two heating attitudes, then random attitudes at 20..100 deg C: <= 0.01 deg (docstring).

    The drift left alone (the stand stage only) moves them by >= 0.25 deg.
    """
    fits = drift_runs[sensor]
    tool = {'mems': TOOL, 'no bias drift': NO_BIAS_DRIFT,
            'scale drift only': SCALE_DRIFT_ONLY}[sensor]
    stage = fits['model'].temperature
    assert (stage.t_min_c, stage.t_max_c, stage.samples, stage.attitudes) == \
        (20.0, 100.0, 3202, 2)
    assert stage.bias_coefficients_mps2 is not None
    assert '2 attitudes heated: bias and scale drift' in fits['fit_temperature'][1]
    assert 'stand stage kept' in fits['fit_temperature'][1]
    incl_deg, tf_deg = random_attitudes(400, 11)
    temperature_c = np.random.default_rng(11).uniform(20.0, 100.0, 400)
    readings = sm.read(noise_free(tool), incl_deg, tf_deg, temperature_c=temperature_c)
    compensated = np.degrees(inclination(fits['model'].apply(readings.accel_mps2,
                                                             temperature_c))) - incl_deg
    drifting = np.degrees(inclination(fits['stand_model'].apply(readings.accel_mps2))) - incl_deg
    print(f'{sensor}: compensated max {np.abs(compensated).max():.4f} deg, stand stage alone '
          f'{np.abs(drifting).max():.3f} deg')
    assert np.abs(drifting).max() >= 0.25
    assert np.abs(compensated).max() <= 0.01


def test_fit_temperature_finds_the_drifts(drift_runs):
    """
    K_T(T) = 1 + s(T) within 1e-4, B_T(T) = db(T) - s(T) b within 6e-5 g: ~5 sigma (docstring).

    The model's own drifts; the triad whose sensitivity alone drifts has B_T = 0.  Over 200
    noise seeds the largest errors over 20..100 deg C were 6.8e-5 and 4.3e-5 g.
    """
    grid_c = np.linspace(20.0, 100.0, 81)
    for sensor, tool in (('mems', TOOL), ('scale drift only', SCALE_DRIFT_ONLY)):
        stage = drift_runs[sensor]['model'].temperature
        triad = tool.accelerometer
        scale = sum(np.outer((grid_c - 25.0) ** (k + 1), [row[k] if k < len(row) else 0.0
                                                          for row in triad.scale_drift])
                    for k in range(2))
        bias_drift = sum(np.outer((grid_c - 25.0) ** (k + 1), [row[k] if k < len(row) else 0.0
                                                               for row in triad.bias_drift])
                         for k in range(2))
        assert np.abs(stage.fit.scale_factor(grid_c) - (1.0 + scale)).max() < 1e-4
        expected_bias = bias_drift - scale * np.array(triad.bias)
        error_g = np.abs(stage.fit.bias(grid_c) - expected_bias).max() / G
        print(f'{sensor}: B_T within {error_g:.2e} g of the model, at most '
              f'{np.abs(expected_bias).max() / G:.2e} g')
        assert error_g < 6e-5


def test_one_attitude_fit_says_what_it_cannot_see(one_attitude):
    """
    Heated at one attitude (seed 001): K_T only, and the summary says a bias drift is unseen.

    K_T absorbs the MEMS bias drift at that attitude (its readings compensated within the 0.01
    deg the two-attitude fit reaches everywhere) and leaves degrees at others (measured 4.3).
    """
    out = one_attitude['fit_temperature'][1]
    assert 'ONE attitude' in out and 'bias drift cannot be seen' in out
    model = one_attitude['model']
    assert model.temperature.attitudes == 1 and model.temperature.bias_coefficients_mps2 is None
    temperature_c = np.random.default_rng(11).uniform(20.0, 100.0, 400)
    own = sm.read(noise_free(TOOL), 55.0, 45.0, temperature_c=temperature_c)
    own_error = np.degrees(inclination(model.apply(own.accel_mps2, temperature_c))) - 55.0
    incl_deg, tf_deg = random_attitudes(400, 11)
    readings = sm.read(noise_free(TOOL), incl_deg, tf_deg, temperature_c=temperature_c)
    error = np.degrees(inclination(model.apply(readings.accel_mps2, temperature_c))) - incl_deg
    print(f'one attitude: {np.abs(own_error).max():.4f} deg there, {np.abs(error).max():.2f} '
          'deg at random attitudes')
    assert np.abs(own_error).max() <= 0.01
    assert np.abs(error).max() >= 1.0


def test_process_with_temperature_topic(runs, tmp_path):
    """
    A noise-free heating bag: every sample within 0.01 deg with the topic, >= 1 deg without.

    Without the topic the temperature stage is refused (issue 21: as survey), unless
    --at-reference-temperature, warned.

    Seed 001's one-attitude run processed with the two-attitude calibration: this checks the
    topic's use (random attitudes: test_fit_temperature_compensates).
    """
    heating = tmp_path / 'heating'
    assert quiet(['simulate', heating, '--heating', '--sensor', 'mems', '--noise-mps2', 0])[0] == 0
    code, _, stderr = quiet(['process', heating, tmp_path / 'refused', '--calibration',
                             runs['cal.json']])
    assert code == 2 and 'no --temperature-topic was given but' in stderr
    assert '--at-reference-temperature' in stderr and not (tmp_path / 'refused').exists()
    errors = {}
    for name, extra in (('with', ['--temperature-topic', '/imu/temperature']),
                        ('without', ['--at-reference-temperature'])):
        code, _, stderr = quiet(['process', heating, tmp_path / name, '--calibration',
                                 runs['cal.json'], *extra])
        assert code == 0, stderr
        errors[name] = bag.concatenate(bag.read(tmp_path / name, '/survey')).vector[:, 0] - 55.0
    assert 'warning: no --temperature-topic was given' in stderr
    assert 'temperature 25 deg C' in stderr
    assert np.abs(errors['with']).max() <= 0.01
    assert np.abs(errors['without']).max() >= 1.0


def test_fit_temperature_csv(runs, tmp_path):
    """The heating CSV (attitude column) gives the bag's fit; ref columns give K_T."""
    code, stdout, stderr = quiet(['fit-temperature', runs['heating.csv'], '--calibration',
                                  tmp_path / 'cal.json'])
    assert code == 0, stderr
    assert '2 attitudes heated' in stdout
    stage = load_model(tmp_path / 'cal.json').temperature
    for name in ('coefficients', 'bias_coefficients_mps2'):
        np.testing.assert_allclose(getattr(stage, name), getattr(runs['model'].temperature, name),
                                   rtol=0, atol=1e-12)

    # A triad whose sensitivity alone drifts: A(T) / A(25) is its 1 + s(T) exactly.
    temperature_c = np.repeat(np.arange(20.0, 101.0, 10.0), 2)
    incl_deg, tf_deg = np.tile([55.0, 120.0], 9), np.tile([45.0, 200.0], 9)
    tool = noise_free(SCALE_DRIFT_ONLY)
    reference = sm.read(tool, incl_deg, tf_deg, temperature_c=25.0).accel_mps2
    readings = sm.read(tool, incl_deg, tf_deg, temperature_c=temperature_c).accel_mps2
    write_csv(tmp_path / 'ref.csv', {
        'temperature_c': temperature_c, 'ax': readings[:, 0], 'ay': readings[:, 1],
        'az': readings[:, 2], 'ref_ax': reference[:, 0], 'ref_ay': reference[:, 1],
        'ref_az': reference[:, 2]})
    code, _, stderr = quiet(['fit-temperature', tmp_path / 'ref.csv', '--calibration',
                             tmp_path / 'ref.json'])
    assert code == 0, stderr
    np.testing.assert_allclose(load_model(tmp_path / 'ref.json').temperature.coefficients,
                               scale_drift_stage().coefficients, rtol=0, atol=1e-12)


# --- refusals -----------------------------------------------------------------------------

def stand_rows(case):
    """Return (attitudes_deg, readings) of a stand CSV that ``case`` makes unusable."""
    stand = simulate_stand(StandRun(TOOL))
    attitudes = np.column_stack([stand.inclination_deg, stand.toolface_deg])
    readings = stand.raw_mps2.copy()
    if case == 'too few positions':
        keep = stand.segment <= 5
        return attitudes[keep], readings[keep]
    if case == 'moving':
        moving = stand.segment == 7
        readings[moving] = sm.read(noise_free(TOOL), 45.0 + np.linspace(-1.0, 1.0, 100),
                                   45.0).accel_mps2
        return attitudes, readings
    wrong = attitudes[:, 0] == 45.0   # 'wrong attitude': the stand read 0.3 deg off
    attitudes[wrong, 0] = 45.3
    return attitudes, readings


def refused_fit(case, tmp_path):
    """Return the command (without --calibration) of a fit that ``case`` makes refuse."""
    path = tmp_path / 'input.csv'
    if case in ('no 25 C', 'few temperatures'):
        heating = simulate_heating(StandRun(TOOL))
        keep = (heating.temperature_c >= 40.0 if case == 'no 25 C' else
                np.isin(heating.temperature_c, [20.0, 25.0, 30.0]))
        write_csv(path, {'temperature_c': heating.temperature_c[keep],
                         **dict(zip(('ax', 'ay', 'az'), heating.raw_mps2[keep].T))})
        return ['fit-temperature', path]
    stand_csv(path, *stand_rows(case))
    return ['fit-stand', path]


@pytest.mark.parametrize('case, reason', [
    ('too few positions', 'only 5 stand position'),
    ('moving', 'position 7: tool is moving'),
    ('wrong attitude', 'exceeds --max-rms-deg'),
    ('no 25 C', 'no reading within 1.0 deg C of 25.0'),
    ('few temperatures', 'needs at least 4 distinct temperatures'),
])
def test_refusals_leave_the_file(runs, tmp_path, case, reason):
    """A refused fit exits 1 with the reason and leaves the calibration file as it was."""
    calibration = tmp_path / 'cal.json'
    save_model(calibration, runs['model'])
    before = file_state(calibration)
    code, _, stderr = quiet([*refused_fit(case, tmp_path), '--calibration', calibration])
    assert code == 1 and reason in stderr and 'left unchanged' in stderr, stderr
    assert file_state(calibration) == before
    if case == 'wrong attitude':  # fitted, so reported, beside the accepted fit's report
        assert 'REFUSED' in (tmp_path / 'fit_stand_refused.txt').read_text()
        assert (tmp_path / 'fit_stand_refused.png').exists()
        assert not (tmp_path / 'fit_stand.png').exists()


def test_unusable_inputs_exit_2(runs, tmp_path):
    """A corrupt calibration file, a missing column or topic: exit 2, nothing written."""
    corrupt = tmp_path / 'corrupt.json'
    corrupt.write_text('{"format": ')
    code, _, stderr = quiet(['fit-stand', runs['stand'], '--calibration', corrupt])
    assert code == 2 and 'not valid JSON' in stderr
    assert corrupt.read_text() == '{"format": '
    write_csv(tmp_path / 'no_temperature.csv', {'ax': [1.0], 'ay': [2.0], 'az': [9.0]})
    code, _, stderr = quiet(['fit-temperature', tmp_path / 'no_temperature.csv',
                             '--calibration', tmp_path / 'new.json'])
    assert code == 2 and 'lacks the column(s) temperature_c' in stderr
    code, _, stderr = quiet(['fit-temperature', runs['stand'], '--calibration',
                             tmp_path / 'new.json', '--temperature-topic', '/none'])
    assert code == 2 and 'no topic /none' in stderr
    assert not (tmp_path / 'new.json').exists()


def test_seed001_fits_of_a_mounted_board(runs, tmp_path):
    """
    Stand and heating runs of a board with -Y+X+Z axes: with the map, the same corrections.

    The stand stage is the same (tool axes); the temperature stage is fitted per sensor axis
    (issue 19 item 7: its rows are the sensor's, y and x swapped) and compensates tool-axis
    readings as the unmounted board's does.
    """
    maps = ('--accelerometer-axes-map', '-Y+X+Z')
    # The runs fixture's simulate options, so that only the axes map differs.
    for name, mode, extra in (('stand', '--stand', ('--samples', 100)),
                              ('heating', '--heating', ('--heating-attitudes',
                                                        *HEATING_ATTITUDES_ARGS, '--storage',
                                                        'sqlite3', '--seed', '1'))):
        code, _, err = quiet(['simulate', tmp_path / name, mode, '--sensor', 'mems',
                              '--noise-mps2', NOISE_MPS2, *extra, *maps])
        assert code == 0, err
    for command, name in (('fit-stand', 'stand'), ('fit-temperature', 'heating')):
        code, _, err = quiet([command, tmp_path / name, '--calibration', tmp_path / 'cal.json',
                              *maps])
        assert code == 0, err
    mounted = load_model(tmp_path / 'cal.json')
    np.testing.assert_allclose(mounted.stand.scale_matrix, runs['model'].stand.scale_matrix,
                               atol=1e-12)
    assert mounted.temperature.axes_map == '-Y+X+Z'
    readings = np.array([[3.0, -5.0, 7.0], [-6.0, 2.0, 7.5], [0.5, 9.0, -1.0]])
    for temperature_c in (20.0, 60.0, 100.0):
        np.testing.assert_allclose(mounted.temperature.apply(readings, temperature_c),
                                   runs['model'].temperature.apply(readings, temperature_c),
                                   atol=1e-9)
