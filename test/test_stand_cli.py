"""
Seed 001 end to end: simulate --stand/--heating -> fit-stand/fit-temperature -> process.

Noise: every simulated sample has sigma = 2e-4 g = 1.96e-3 m/s^2 per axis; the stand holds
100 samples per position (nine positions, 25 deg C), the heating run 1601 samples from 20 to
100 deg C at inclination 55 deg, toolface 45 deg.  Tolerances:

- Stand K and b: each position mean has 2e-5 g of noise; the least-squares covariance of the
  nine-position design gives a K element 1.25e-5 and a bias 6.7e-6 g at 1 sigma
  (test_stand.py), so 1e-4 and 5e-5 g are >= 7 sigma.
- Processed stand: the corrected specific force (/imu/data) averaged over a position's 100
  samples has 2e-5 g of noise, 1.15e-3 deg of inclination, and the fitted K and b add
  ~1.6e-3 deg: its inclination stays within 0.01 deg (> 4 sigma).  (Not the mean of the
  per-sample angles: at 0 and 180 deg an angle is a magnitude and its mean is biased by the
  Rayleigh mean 1.25 sigma / g = 0.014 deg.)
- Temperature: 1601 readings of ~0.58 g per axis fix K_T to ~1e-5 (order 2); with the stand's
  own error the compensated inclination of noise-free readings at random attitudes and
  temperatures stays within 0.01 deg, while the drift alone moves it by more than 1 deg.
- Uncorrected: the simulated sensor (K = M C(0.8, -1.2 deg), b ~ 0.02 g) reads the stand
  positions up to 3.4 deg off; its K_T drifts 5 % at 100 deg C (2 deg of inclination).
Seeds are fixed; the bounds hold for any seed.  Exact round trips compare with equality.
"""

import contextlib
import csv
import io
import json
import os

from inclino_ros.calibration.model import (
    CalibrationModel, Installation, load_model, save_model, Stand, Temperature)
from inclino_ros.cli.main import main as inclino
from inclino_ros.core.attitude import inclination
from inclino_ros.core.stand import stand_specific_force
from inclino_ros.io import bag
from inclino_ros.sim.bench import SensorErrors, SensorRun, simulate_heating, simulate_stand
import numpy as np
from numpy.polynomial import polynomial as poly
import pytest
from rosbags.typesys import get_typestore, Stores
from scipy.spatial.transform import Rotation

G = 9.80665
NOISE_MPS2 = 2e-4 * G
ERRORS = SensorErrors()
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
NOW = '2026-01-01T00:00:00+00:00'


def quiet(argv):
    """Run ``inclino argv`` in-process; return (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = inclino([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def true_temperature_stage():
    """Return the simulated sensor's own K_T(T) as a model.Temperature stage."""
    # K_T = 1 + c1 (T - 25) + c2 (T - 25)^2 in powers of T.
    coefficients = [poly.polyadd([1.0 - 25.0 * c1 + 625.0 * c2, c1 - 50.0 * c2], [0.0, 0.0, c2])
                    for c1, c2 in zip(ERRORS.temperature_c1_per_c, ERRORS.temperature_c2_per_c2)]
    return Temperature(tuple(map(tuple, np.array(coefficients).tolist())), 20.0, 100.0, 25.0,
                       (0.0, 0.0, 0.0), 1, NOW)


def true_stand_stage():
    """Return the simulated sensor's own K and b as a model.Stand stage."""
    return Stand(tuple(map(tuple, ERRORS.scale_matrix.tolist())), ERRORS.bias_mps2, 'stand',
                 1.0, 0.0, 9, NOW)


def random_attitudes(count, seed):
    """Return (true specific force (N, 3), its inclination [deg]) at random attitudes."""
    f = G * Rotation.random(count, random_state=seed).apply([0.0, 0.0, 1.0])
    return f, np.degrees(inclination(f))


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


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    """Simulate the stand (mcap) and heating (sqlite3) runs; fit both into one file."""
    work = tmp_path_factory.mktemp('seed001')
    paths = {name: work / name for name in ('stand', 'heating', 'cal.json', 'stand.csv',
                                            'heating.csv')}
    code, stdout, _ = quiet(['simulate', paths['stand'], '--stand', '--noise-mps2', NOISE_MPS2,
                             '--csv', paths['stand.csv']])
    assert code == 0 and 'wrote' in stdout
    assert quiet(['simulate', paths['heating'], '--heating', '--noise-mps2', NOISE_MPS2,
                  '--storage', 'sqlite3', '--csv', paths['heating.csv'], '--seed', '1'])[0] == 0
    fit_stand = quiet(['fit-stand', paths['stand'], '--calibration', paths['cal.json']])
    assert fit_stand[0] == 0, fit_stand
    stand_model = load_model(paths['cal.json'])
    fit_temperature = quiet(['fit-temperature', paths['heating'],
                             '--calibration', paths['cal.json']])
    assert fit_temperature[0] == 0, fit_temperature
    return dict(paths, work=work, fit_stand=fit_stand, fit_temperature=fit_temperature,
                stand_model=stand_model, model=load_model(paths['cal.json']))


# --- the simulated sensor -----------------------------------------------------------------

def test_model_inverts_the_simulated_sensor_exactly():
    """The model's order (A / K_T(T), then K^-1 (A - b)) undoes K_T(T) (K f + b) to round-off."""
    f, incl_deg = random_attitudes(50, 3)
    temperature_c = np.linspace(20.0, 100.0, 50)
    model = CalibrationModel(3, stand=true_stand_stage(), temperature=true_temperature_stage())
    corrected = model.apply(ERRORS.read(f, temperature_c), temperature_c)
    np.testing.assert_allclose(corrected, f, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ERRORS.temperature_scale([25.0]), [[1.0, 1.0, 1.0]], atol=0)


def test_simulated_runs_and_truth_file(runs):
    """Nine positions of 100 samples at 25 deg C; a 20 -> 100 deg C ramp; the truth file."""
    stand = simulate_stand(SensorRun(noise_std_mps2=NOISE_MPS2))
    assert stand.raw_mps2.shape == (900, 3) and np.all(stand.temperature_c == 25.0)
    assert np.bincount(stand.segment).tolist() == [0] + [100] * 9
    heating = simulate_heating(SensorRun(noise_std_mps2=NOISE_MPS2, seed=1))
    assert (heating.temperature_c[0], heating.temperature_c[-1]) == (20.0, 100.0)
    assert np.all(heating.inclination_deg == 55.0) and np.all(heating.toolface_deg == 45.0)
    with open(f'{runs["stand"]}.truth.json') as stream:
        truth = json.load(stream)
    np.testing.assert_array_equal(truth['sensor']['scale_matrix'], ERRORS.scale_matrix)
    assert truth['sensor']['bias_mps2'] == list(ERRORS.bias_mps2)
    assert truth['sensor']['temperature_c1_per_c'] == list(ERRORS.temperature_c1_per_c)
    assert truth['topics']['stand_attitude'] == '/stand/attitude'
    assert [s['inclination_deg'] for s in truth['segments']][:3] == [0.0, 180.0, 90.0]
    # Both storages read back bit for bit, the temperature too.
    for name, run in (('stand', stand), ('heating', heating)):
        raw = bag.concatenate(bag.read(runs[name], '/imu/data_raw'))
        np.testing.assert_array_equal(raw.linear_acceleration_mps2, run.raw_mps2)
        temperature = bag.concatenate(bag.read(runs[name], '/imu/temperature'))
        np.testing.assert_array_equal(temperature.temperature_c, run.temperature_c)
        np.testing.assert_array_equal(temperature.stamps_ns, run.stamps_ns)


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
    assert np.abs(np.array(stand.scale_matrix) - ERRORS.scale_matrix).max() < 1e-4
    assert np.abs(np.array(stand.bias_mps2) - ERRORS.bias_mps2).max() < 5e-5 * G
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
    assert len(errors_deg) == 9
    assert np.abs(errors_deg).max() <= 0.01
    assert np.abs(raw_errors_deg).max() >= 1.0


def test_fit_stand_from_csv_equals_bag_and_keeps_temperature(runs, tmp_path):
    """Per-sample CSV = bag; averaged CSV works; temperature kept, installation dropped."""
    calibration = tmp_path / 'cal.json'
    installation = Installation(0.8, -1.2, NOW, 100, 0.01, G)
    save_model(calibration, CalibrationModel(3, installation=installation,
                                             temperature=true_temperature_stage()))
    code, stdout, stderr = quiet(['fit-stand', runs['stand.csv'], '--calibration', calibration,
                                  '--report-dir', tmp_path / 'report'])
    assert code == 0, stderr
    assert 'installation stage dropped' in stdout and 'mounting misalignment' in stdout
    assert 'temperature stage of the file applied' in stdout
    model = load_model(calibration)
    assert model.installation is None and model.temperature == true_temperature_stage()
    # At 25 deg C K_T = 1: the same fit as from the bag, to round-off.
    np.testing.assert_allclose(model.stand.scale_matrix, runs['stand_model'].stand.scale_matrix,
                               rtol=0, atol=1e-12)
    assert (tmp_path / 'report' / 'fit_stand.png').exists()

    stand = simulate_stand(SensorRun(noise_std_mps2=NOISE_MPS2))
    means = stand.raw_mps2.reshape(9, 100, 3).mean(axis=1)
    stand_csv(tmp_path / 'means.csv',
              [(s['inclination_deg'], s['toolface_deg']) for s in stand.truth['segments']], means)
    code, _, stderr = quiet(['fit-stand', tmp_path / 'means.csv', '--calibration',
                             tmp_path / 'new.json'])
    assert code == 0, stderr
    np.testing.assert_allclose(load_model(tmp_path / 'new.json').stand.scale_matrix,
                               runs['stand_model'].stand.scale_matrix, rtol=0, atol=1e-12)


def test_fit_stand_sphere(tmp_path):
    """Sphere fit of 60 random still readings: K K^T and b of the sensor; level bench next."""
    f, _ = random_attitudes(60, 5)
    rng = np.random.default_rng(5)
    readings = ERRORS.read(f, 25.0) + rng.normal(0.0, NOISE_MPS2, f.shape)
    write_csv(tmp_path / 'sphere.csv', dict(zip(('ax', 'ay', 'az'), readings.T)))
    code, stdout, stderr = quiet(['fit-stand', tmp_path / 'sphere.csv', '--method', 'sphere',
                                  '--calibration', tmp_path / 'cal.json'])
    assert code == 0, stderr
    assert 'calibrate the level bench' in stdout
    stand = load_model(tmp_path / 'cal.json').stand
    k = np.array(stand.scale_matrix)
    assert stand.method == 'sphere' and stand.rms_inclination_deg is None
    assert np.allclose(np.tril(k, -1), 0.0)
    true_k = ERRORS.scale_matrix
    assert np.abs(k @ k.T - true_k @ true_k.T).max() < 1e-3
    assert np.abs(np.array(stand.bias_mps2) - ERRORS.bias_mps2).max() < 5e-4 * G


# --- fit-temperature ----------------------------------------------------------------------

def test_fit_temperature_compensates(runs):
    """Random attitudes at 20..100 deg C: <= 0.01 deg with K_T(T), >= 1 deg without."""
    model = runs['model']
    stage = model.temperature
    assert (stage.t_min_c, stage.t_max_c, stage.samples) == (20.0, 100.0, 1601)
    grid_c = np.linspace(20.0, 100.0, 81)
    assert np.abs(stage.fit.scale_factor(grid_c) - ERRORS.temperature_scale(grid_c)).max() \
        < 1e-4
    f, incl_deg = random_attitudes(400, 11)
    temperature_c = np.random.default_rng(11).uniform(20.0, 100.0, 400)
    readings = ERRORS.read(f, temperature_c)
    compensated = np.degrees(inclination(model.apply(readings, temperature_c))) - incl_deg
    drifting = np.degrees(inclination(runs['stand_model'].apply(readings))) - incl_deg
    assert np.abs(compensated).max() <= 0.01
    assert np.abs(drifting).max() >= 1.0
    assert 'stand stage kept' in runs['fit_temperature'][1]


def test_process_with_temperature_topic(runs, tmp_path):
    """A noise-free heating bag: every sample within 0.01 deg with the topic, >= 1 deg without."""
    heating = tmp_path / 'heating'
    assert quiet(['simulate', heating, '--heating', '--noise-mps2', 0])[0] == 0
    errors = {}
    for name, extra in (('with', ['--temperature-topic', '/imu/temperature']), ('without', [])):
        code, _, stderr = quiet(['process', heating, tmp_path / name, '--calibration',
                                 runs['cal.json'], *extra])
        assert code == 0, stderr
        errors[name] = bag.concatenate(bag.read(tmp_path / name, '/survey')).vector[:, 0] - 55.0
    assert 'no --temperature-topic' in stderr
    assert np.abs(errors['with']).max() <= 0.01
    assert np.abs(errors['without']).max() >= 1.0


def test_fit_temperature_csv(runs, tmp_path):
    """The heating CSV gives the bag's fit; ref columns (the 25 deg C reading) give K_T."""
    code, _, stderr = quiet(['fit-temperature', runs['heating.csv'], '--calibration',
                             tmp_path / 'cal.json'])
    assert code == 0, stderr
    np.testing.assert_allclose(load_model(tmp_path / 'cal.json').temperature.coefficients,
                               runs['model'].temperature.coefficients, rtol=0, atol=1e-12)

    temperature_c = np.repeat(np.arange(20.0, 101.0, 10.0), 2)
    f = stand_specific_force(np.tile([55.0, 120.0], 9), np.tile([45.0, 200.0], 9), G)
    reference = ERRORS.read(f, 25.0)
    readings = ERRORS.read(f, temperature_c)
    write_csv(tmp_path / 'ref.csv', {
        'temperature_c': temperature_c, 'ax': readings[:, 0], 'ay': readings[:, 1],
        'az': readings[:, 2], 'ref_ax': reference[:, 0], 'ref_ay': reference[:, 1],
        'ref_az': reference[:, 2]})
    code, _, stderr = quiet(['fit-temperature', tmp_path / 'ref.csv', '--calibration',
                             tmp_path / 'ref.json'])
    assert code == 0, stderr
    np.testing.assert_allclose(load_model(tmp_path / 'ref.json').temperature.coefficients,
                               true_temperature_stage().coefficients, rtol=0, atol=1e-12)


# --- refusals -----------------------------------------------------------------------------

def stand_rows(case):
    """Return (attitudes_deg, readings) of a stand CSV that ``case`` makes unusable."""
    stand = simulate_stand(SensorRun(noise_std_mps2=NOISE_MPS2))
    attitudes = np.column_stack([stand.inclination_deg, stand.toolface_deg])
    readings = stand.raw_mps2.copy()
    if case == 'too few positions':
        keep = stand.segment <= 5
        return attitudes[keep], readings[keep]
    if case == 'repeated attitude':
        extra = simulate_stand(SensorRun(noise_std_mps2=NOISE_MPS2), ((90.0, 0.5),))
        return (np.vstack([attitudes, [(90.0, 0.5)] * 100]),
                np.vstack([readings, extra.raw_mps2]))
    if case == 'moving':
        sweep = np.radians(np.linspace(-1.0, 1.0, 100))
        moving = stand.segment == 7
        readings[moving] = ERRORS.read(stand_specific_force(
            45.0 + np.degrees(sweep), 45.0, G), 25.0)
        return attitudes, readings
    wrong = attitudes[:, 0] == 45.0   # 'wrong attitude': the stand read 0.3 deg off
    attitudes[wrong, 0] = 45.3
    return attitudes, readings


def refused_fit(case, tmp_path):
    """Return the command (without --calibration) of a fit that ``case`` makes refuse."""
    path = tmp_path / 'input.csv'
    if case in ('no 25 C', 'few temperatures'):
        heating = simulate_heating(SensorRun(noise_std_mps2=NOISE_MPS2))
        keep = (heating.temperature_c >= 40.0 if case == 'no 25 C' else
                np.isin(heating.temperature_c, [20.0, 25.0, 30.0]))
        write_csv(path, {'temperature_c': heating.temperature_c[keep],
                         **dict(zip(('ax', 'ay', 'az'), heating.raw_mps2[keep].T))})
        return ['fit-temperature', path]
    stand_csv(path, *stand_rows(case))
    return ['fit-stand', path]


@pytest.mark.parametrize('case, reason', [
    ('too few positions', 'only 5 stand position'),
    ('repeated attitude', 'are one attitude'),
    ('moving', 'tool moving at position(s) [7]'),
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
    """Stand and heating runs of a board with -Y+X+Z axes: with the map, the same stages."""
    maps = ('--accelerometer-axes-map', '-Y+X+Z')
    for name, mode, extra in (('stand', '--stand', ()),
                              ('heating', '--heating', ('--storage', 'sqlite3', '--seed', '1'))):
        code, _, err = quiet(['simulate', tmp_path / name, mode, '--noise-mps2', NOISE_MPS2,
                              *extra, *maps])
        assert code == 0, err
    for command, name in (('fit-stand', 'stand'), ('fit-temperature', 'heating')):
        code, _, err = quiet([command, tmp_path / name, '--calibration', tmp_path / 'cal.json',
                              *maps])
        assert code == 0, err
    mounted = load_model(tmp_path / 'cal.json')
    np.testing.assert_allclose(mounted.stand.scale_matrix, runs['model'].stand.scale_matrix,
                               atol=1e-12)
    np.testing.assert_allclose(mounted.temperature.coefficients,
                               runs['model'].temperature.coefficients, atol=1e-12)
