"""
Bags end to end: simulate -> bag -> calibrate -> ``inclino process`` -> bag -> truth.

Tolerances of the noisy end-to-end checks (default scenario of ``inclino simulate``: the
physical sensor model's ideal triads on a board mounted gamma 0.8, beta -1.2 deg, noise
sigma_n = 0.002 m/s^2 per axis, g = 9.80665 m/s^2, N_L = 600 level samples, 400 samples per
station; the mount and the noise are its only errors):

- One sample's inclination error is the noise component along the tilt direction over g,
  sigma_I = sigma_n / g = 2.04e-4 rad = 0.0117 deg (at I = 0 it is the 2-D norm of the
  cross-axial noise over g, Rayleigh with the same sigma).  6 sigma is exceeded with
  probability 2e-9 (Gaussian) or exp(-18) = 1.5e-8 (Rayleigh) per sample, < 1e-4 over all.
- gamma and beta come from the mean of N_L level samples: each is off by at most
  6 sigma_I / sqrt(N_L) = 0.0029 deg, and so is the tilt the correction leaves.
- Per sample: |I - I_true| <= 6 sigma_I (1 + 1/sqrt(N_L)) = 0.073 deg.  Uncorrected, the
  level bench alone reads the false tilt theta = acos(cos 0.8 cos 1.2) = 1.44 deg (Eq. 4).
- Station means (tilted stations, I >= 0.5 deg >> sigma_I, so the error is linear in the
  noise): 6 sigma_I (1/sqrt(400) + 1/sqrt(N_L)) = 0.0064 deg; the toolface error is the
  same cross-axial error over sin I.
- Two-axis sensor: z = sqrt(g^2 - x^2 - y^2) turns a radial error dh into dI = dh / (g cos I),
  so the per-sample bound is 6 sigma_I (1 / cos I_max + 1/sqrt(N_L)) = 0.143 deg at 60 deg.
The seeds are fixed, so the runs are reproducible; the bounds hold for any seed.
Exact round trips (stamps, float64 values) are compared with equality.
"""

import contextlib
import io
import json
import math
import os
from pathlib import Path
import subprocess

from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.model import CalibrationModel, save_model
from inclino_ros.cli.main import main as inclino
from inclino_ros.core.attitude import inclination, toolface_seed000
from inclino_ros.core.installation import installation_matrix
from inclino_ros.io import bag
from inclino_ros.sim.bench import Scenario, simulate
import numpy as np
import pytest
from ros_harness import installed_script
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore, Stores
from transforms3d.quaternions import quat2mat

G = 9.80665
NOISE_MPS2 = 0.002
SIGMA_I_DEG = math.degrees(NOISE_MPS2 / G)
LEVEL_SAMPLES = 600
STATION_SAMPLES = 400
CALIBRATION_DEG = 6 * SIGMA_I_DEG / math.sqrt(LEVEL_SAMPLES)
SAMPLE_TOL_DEG = 6 * SIGMA_I_DEG + CALIBRATION_DEG
MEAN_TOL_DEG = 6 * SIGMA_I_DEG / math.sqrt(STATION_SAMPLES) + CALIBRATION_DEG
THETA_DEG = math.degrees(math.acos(math.cos(math.radians(0.8)) * math.cos(math.radians(1.2))))
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
LIMITS = LevelLimits(max_tilt_deg=5.0, gravity_mps2=G, g_total_tolerance_mps2=0.05)


def quiet(argv):
    """Run ``inclino argv`` in-process; return (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = inclino(argv)
    return code, out.getvalue(), err.getvalue()


def summary_values(stdout):
    """Return the ``name: value`` lines of a process summary as a dict of strings."""
    return dict(line.split(': ', 1) for line in stdout.splitlines() if ': ' in line)


def angle_diff_deg(a, b):
    """Return a - b wrapped to [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


def calibrate_from_level(bag_path, calibration_path, axes=3):
    """Write the calibration of the level segment of a simulated bag (seed 000 Eqs. 11-14)."""
    with open(f'{bag_path}.truth.json') as stream:
        level = json.load(stream)['segments'][0]
    raw = bag.concatenate(bag.read(bag_path, '/imu/data_raw'))
    selected = (raw.stamps_ns >= level['start_ns']) & (raw.stamps_ns <= level['end_ns'])
    installation = solve_level_capture(raw.linear_acceleration_mps2[selected], axes, LIMITS)
    save_model(calibration_path, CalibrationModel(accelerometer_axes=axes,
                                                  installation=installation))
    return installation


@pytest.fixture(scope='module')
def run_3axis(tmp_path_factory):
    """Simulate (mcap), calibrate from the level segment and process; return the paths."""
    work = tmp_path_factory.mktemp('run3')
    sim_bag, out_bag, calibration = (str(work / n) for n in ('sim', 'out', 'cal.json'))
    assert quiet(['simulate', sim_bag])[0] == 0
    installation = calibrate_from_level(sim_bag, calibration)
    code, stdout, stderr = quiet(['process', sim_bag, out_bag, '--calibration', calibration,
                                  '--noise-mps2', str(NOISE_MPS2)])
    assert code == 0, stderr
    return {'sim': sim_bag, 'out': out_bag, 'calibration': calibration,
            'installation': installation, 'stdout': stdout, 'stderr': stderr}


# --- CDR codec against rosbags ------------------------------------------------------------

def rosbags_imu(stamp_ns, frame_id, values):
    """Return a rosbags Imu message with the 37 post-header float64s ``values``."""
    types = TYPESTORE.types
    vector3, quaternion = types['geometry_msgs/msg/Vector3'], types['geometry_msgs/msg/Quaternion']
    header = types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=stamp_ns // 10**9,
                                                   nanosec=stamp_ns % 10**9),
        frame_id=frame_id)
    return types['sensor_msgs/msg/Imu'](
        header=header, orientation=quaternion(*values[0:4]),
        orientation_covariance=values[4:13], angular_velocity=vector3(*values[13:16]),
        angular_velocity_covariance=values[16:25], linear_acceleration=vector3(*values[25:28]),
        linear_acceleration_covariance=values[28:37])


@pytest.mark.parametrize('frame_id', ['', 'a', 'imu', 'imu_link', 'inclinometer', 'x' * 21,
                                      'caf\u00e9'])
def test_codec_matches_rosbags_byte_for_byte(frame_id):
    """encode() gives rosbags' CDR for every alignment of the frame_id; decode() inverts it."""
    rng = np.random.default_rng(len(frame_id))
    stamps_ns = np.array([0, 1, 1_767_225_600_123_456_789, -1_500_000_000])
    values = rng.normal(size=(4, 37))
    series = bag.ImuSeries.from_values(stamps_ns, bag.frame_id_array(frame_id, 4), values)
    encoded = bag.encode(series)
    for i in range(4):
        expected = TYPESTORE.serialize_cdr(
            rosbags_imu(int(stamps_ns[i]), frame_id, values[i]), bag.IMU)
        assert encoded[i] == bytes(expected)
    decoded = bag.decode(encoded, bag.IMU)
    np.testing.assert_array_equal(decoded.stamps_ns, stamps_ns)
    np.testing.assert_array_equal(decoded.values(), values)
    assert decoded.frame_ids.tolist() == [frame_id] * 4

    vectors = bag.Vector3Series(stamps_ns, bag.frame_id_array(frame_id, 4), values[:, :3])
    for data, value in zip(bag.encode(vectors), values[:, :3]):
        msg = TYPESTORE.deserialize_cdr(data, bag.VECTOR3_STAMPED)
        assert msg.header.frame_id == frame_id
        assert (msg.vector.x, msg.vector.y, msg.vector.z) == tuple(value)


@pytest.mark.parametrize('frame_id', ['', 'mag', 'imu_link', 'magnetometer'])
def test_magnetic_field_codec_matches_rosbags(frame_id):
    """Encode MagneticField (tesla, 9 covariances) as rosbags' CDR, byte for byte; decode back."""
    rng = np.random.default_rng(len(frame_id))
    stamps_ns = np.array([0, 7, 1_767_225_600_123_456_789])
    field_nT = rng.normal(0.0, 3e4, size=(3, 3))
    series = bag.magnetometer(stamps_ns, frame_id, field_nT, noise_std_nT=5.0)
    types = TYPESTORE.types
    for i, data in enumerate(bag.encode(series)):
        stamp_ns = int(stamps_ns[i])
        header = types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=stamp_ns // 10**9,
                                                       nanosec=stamp_ns % 10**9),
            frame_id=frame_id)
        msg = types[bag.MAGNETIC_FIELD](
            header=header,
            magnetic_field=types['geometry_msgs/msg/Vector3'](*series.magnetic_field_T[i]),
            magnetic_field_covariance=series.covariance_T2[i])
        assert data == bytes(TYPESTORE.serialize_cdr(msg, bag.MAGNETIC_FIELD))
    decoded = bag.decode(bag.encode(series), bag.MAGNETIC_FIELD)
    np.testing.assert_array_equal(decoded.stamps_ns, stamps_ns)
    np.testing.assert_array_equal(decoded.values(), series.values())
    np.testing.assert_allclose(decoded.field_nT, field_nT, rtol=1e-15)
    np.testing.assert_allclose(decoded.covariance_T2[:, [0, 4, 8]], 25e-18, rtol=1e-15)
    assert np.all(decoded.covariance_T2[:, [1, 2, 3, 5, 6, 7]] == 0.0)
    assert decoded.frame_ids.tolist() == [frame_id] * 3


def test_decode_mixed_frames_and_nonzero_padding():
    """Messages of different frame_ids and sizes decode in order; padding bytes are ignored."""
    frame_ids = np.array(['a', 'base_link', 'a', '', 'imu'])
    values = np.arange(15.0).reshape(5, 3)
    encoded = bag.encode(bag.Vector3Series(np.arange(5), frame_ids, values))
    padded = bytearray(encoded[0])  # 'a' + NUL at 16..17, padding 18..19, doubles from 20
    padded[18:20] = b'\xff\xff'
    encoded[0] = bytes(padded)
    decoded = bag.decode(encoded, bag.VECTOR3_STAMPED)
    assert decoded.frame_ids.tolist() == frame_ids.tolist()
    np.testing.assert_array_equal(decoded.vector, values)
    np.testing.assert_array_equal(decoded.stamps_ns, np.arange(5))


def test_decode_refuses_big_endian_and_truncated():
    """Big-endian CDR and a truncated message raise BagError, never wrong numbers."""
    big_endian = TYPESTORE.serialize_cdr(rosbags_imu(5, 'imu', np.ones(37)), bag.IMU,
                                         little_endian=False)
    with pytest.raises(bag.BagError, match='little-endian'):
        bag.decode([bytes(big_endian)], bag.IMU)
    with pytest.raises(bag.BagError, match='too short'):
        bag.decode([b'\x00\x01\x00\x00' + bytes(20)], bag.IMU)


# --- simulate -> bag -> read back ---------------------------------------------------------

@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_simulated_bag_reads_back_exactly(tmp_path, storage):
    """Stamps, readings, covariances and truth come back bit for bit, by both readers."""
    path = str(tmp_path / 'sim')
    code, stdout, _ = quiet(['simulate', path, '--storage', storage, '--seed', '4'])
    assert code == 0 and f'wrote {path} ({storage}): 5400 messages' in stdout
    sim = simulate(Scenario(seed=4))
    assert bag.topic_info(path, '/imu/data_raw') == (bag.IMU, 5400)
    raw = bag.concatenate(bag.read(path, '/imu/data_raw', chunk_size=777))
    np.testing.assert_array_equal(raw.stamps_ns, sim.stamps_ns)
    np.testing.assert_array_equal(raw.linear_acceleration_mps2, sim.raw_mps2)
    assert set(raw.frame_ids.tolist()) == {'inclinometer'}
    assert np.all(raw.orientation_covariance[:, 0] == -1.0)
    assert np.all(raw.angular_velocity_covariance[:, 0] == -1.0)
    np.testing.assert_array_equal(raw.linear_acceleration_covariance[:, [0, 4, 8]],
                                  np.full((5400, 3), NOISE_MPS2 ** 2))
    truth = bag.concatenate(bag.read(path, '/truth/survey'))
    np.testing.assert_array_equal(truth.stamps_ns, sim.stamps_ns)
    np.testing.assert_array_equal(truth.vector[:, 0], sim.inclination_deg)
    np.testing.assert_array_equal(truth.vector[:, 1], sim.toolface_deg)
    assert np.all(np.isnan(truth.vector[:, 2]))

    # An independent reader: rosbags' own deserializer, log time = header stamp.
    with Reader(path) as reader:
        connections = [c for c in reader.connections if c.topic == '/imu/data_raw']
        for i, (connection, log_ns, data) in enumerate(reader.messages(connections)):
            msg = TYPESTORE.deserialize_cdr(data, connection.msgtype)
            stamp_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            acc = msg.linear_acceleration
            assert log_ns == stamp_ns == sim.stamps_ns[i]
            assert (acc.x, acc.y, acc.z) == tuple(sim.raw_mps2[i])
    assert i == 5399

    with open(f'{path}.truth.json') as stream:
        sidecar = json.load(stream)
    tool = sidecar['tool']
    assert (tool['mount']['gamma_deg'], tool['mount']['beta_deg'], sidecar['seed'],
            tool['accelerometer']['axes'], sidecar['rate_hz'],
            tool['accelerometer']['noise_std']) == (0.8, -1.2, 4, 3, 200.0, 0.002)
    assert sidecar['sensor'] == 'ideal' and tool == json.loads(json.dumps(sim.truth['tool']))
    assert sidecar['segments'] == sim.truth['segments']


def test_read_names_the_topics_there_are(run_3axis):
    """Asking for a topic the bag lacks names the ones it has."""
    with pytest.raises(bag.BagError, match=r'/imu/data_raw \(sensor_msgs/msg/Imu\)'):
        next(bag.read(run_3axis['sim'], '/imu/missing'))
    with pytest.raises(bag.BagError, match='cannot read the bag'):
        bag.topic_info(run_3axis['sim'] + '.nope', '/imu/data_raw')


# --- calibration and process --------------------------------------------------------------

def test_level_segment_recovers_gamma_beta(run_3axis):
    """The level capture of the simulated bag finds the simulated mounting (Eqs. 13, 14)."""
    installation = run_3axis['installation']
    assert abs(installation.gamma_deg - 0.8) <= CALIBRATION_DEG
    assert abs(installation.beta_deg - (-1.2)) <= CALIBRATION_DEG


def test_process_corrects_inclination_and_toolface(run_3axis):
    """Corrected angles match the truth within the noise bound; raw ones miss by theta."""
    raw = bag.concatenate(bag.read(run_3axis['sim'], '/imu/data_raw'))
    truth = bag.concatenate(bag.read(run_3axis['sim'], '/truth/survey'))
    survey = bag.concatenate(bag.read(run_3axis['out'], '/survey'))
    np.testing.assert_array_equal(survey.stamps_ns, truth.stamps_ns)
    assert set(survey.frame_ids.tolist()) == {'inclinometer'}
    assert np.all(np.isnan(survey.vector[:, 2]))

    error_deg = survey.vector[:, 0] - truth.vector[:, 0]
    raw_error_deg = np.degrees(inclination(raw.linear_acceleration_mps2)) - truth.vector[:, 0]
    assert np.abs(error_deg).max() <= SAMPLE_TOL_DEG
    assert np.abs(raw_error_deg).max() >= THETA_DEG - SAMPLE_TOL_DEG
    assert np.abs(raw_error_deg).max() > 15 * SAMPLE_TOL_DEG

    sim = simulate(Scenario())
    raw_tf_deg = np.degrees(toolface_seed000(raw.linear_acceleration_mps2))
    for k in range(1, sim.segment.max() + 1):
        rows = sim.segment == k
        incl_deg = sim.inclination_deg[rows][0]
        assert abs(error_deg[rows].mean()) <= MEAN_TOL_DEG
        tf_error_deg = angle_diff_deg(survey.vector[rows, 1], truth.vector[rows, 1])
        tf_tol_deg = math.degrees(math.radians(MEAN_TOL_DEG) / math.sin(math.radians(incl_deg)))
        assert abs(tf_error_deg.mean()) <= tf_tol_deg, k
        if incl_deg == 0.5:  # below theta the raw toolface is meaningless
            raw_tf_error_deg = angle_diff_deg(raw_tf_deg[rows], truth.vector[rows, 1])
            assert abs(raw_tf_error_deg.mean()) > 10 * tf_tol_deg


def test_process_imu_data_orientation_and_covariances(run_3axis):
    """imu/data: corrected force, quaternion fields in x, y, z, w order, node covariances."""
    out = bag.concatenate(bag.read(run_3axis['out'], '/imu/data'))
    survey = bag.concatenate(bag.read(run_3axis['out'], '/survey'))
    np.testing.assert_array_equal(out.stamps_ns, survey.stamps_ns)
    f = out.linear_acceleration_mps2
    np.testing.assert_allclose(np.degrees(inclination(f)), survey.vector[:, 0],
                               rtol=0, atol=1e-9)
    x, y, z, w = out.orientation_xyzw.T
    # At rest the world's up axis, seen in the tool frame, is f / |f|: R^T e_z (R tool->world).
    for i in range(0, f.shape[0], 97):
        rotation = quat2mat((w[i], x[i], y[i], z[i]))
        np.testing.assert_allclose(rotation.T @ [0.0, 0.0, 1.0], f[i] / np.linalg.norm(f[i]),
                                   rtol=0, atol=1e-12)
    installation = run_3axis['installation']
    # First order, isotropic noise: var roll = s^2 / (f_y^2 + f_z^2), var pitch = s^2 / |f|^2,
    # uncorrelated; plus the level capture's own variance std^2 / N on both.
    calibration_var = math.radians(installation.std_deg) ** 2 / installation.sample_count
    roll_var = NOISE_MPS2 ** 2 / (f[:, 1] ** 2 + f[:, 2] ** 2) + calibration_var
    pitch_var = NOISE_MPS2 ** 2 / np.sum(f ** 2, axis=1) + calibration_var
    np.testing.assert_allclose(out.orientation_covariance[:, 0], roll_var, rtol=1e-9)
    np.testing.assert_allclose(out.orientation_covariance[:, 4], pitch_var, rtol=1e-9)
    np.testing.assert_allclose(out.orientation_covariance[:, [1, 3]], 0.0,
                               atol=1e-9 * pitch_var.min())
    assert np.all(out.orientation_covariance[:, 8] == math.pi ** 2 / 3)
    # The installation correction turns isotropic noise into itself.
    np.testing.assert_allclose(out.linear_acceleration_covariance[:, [0, 4, 8]], NOISE_MPS2 ** 2,
                               rtol=1e-12)
    np.testing.assert_allclose(out.linear_acceleration_covariance[:, [1, 2, 3, 5, 6, 7]], 0.0,
                               atol=1e-15 * NOISE_MPS2 ** 2)
    assert np.all(out.angular_velocity_covariance[:, 0] == -1.0)
    assert np.all(out.angular_velocity_radps == 0.0)


def test_process_summary(run_3axis):
    """The summary counts every sample and states the inclination and G-total statistics."""
    values = summary_values(run_3axis['stdout'])
    assert values['samples_in'] == values['accepted'] == '5400'
    # A level bench cannot see the board's roll: the toolface is the board's (issue 19).
    assert values['toolface_zero'] == 'board'
    assert values['toolface_zero_meaning'].startswith('relative to the sensor board')
    assert all(values[f'dropped_{r}'] == '0'
               for r in ('non_finite', 'saturated', 'zero', 'over_g', 'dynamic',
                         'two_axis_range'))
    survey = bag.concatenate(bag.read(run_3axis['out'], '/survey'))
    low, mean, high = (float(v) for v in values['inclination_deg'].split()[1::2])
    incl_deg = survey.vector[:, 0]
    assert (low, mean, high) == pytest.approx(
        (incl_deg.min(), incl_deg.mean(), incl_deg.max()), abs=1e-6)
    g_mean, g_std = (float(v) for v in values['g_total_mps2'].split()[1::2])
    # |f| of a still sensor: mean g within 6 sigma_n / sqrt(5400); std sigma_n within 10 %.
    assert abs(g_mean - G) <= 6 * NOISE_MPS2 / math.sqrt(5400) + 1e-6
    assert g_std == pytest.approx(NOISE_MPS2, rel=0.1)
    assert '5400/5400' in run_3axis['stderr']  # the tqdm progress bar


def test_process_drops_bad_samples(tmp_path, run_3axis):
    """NaN, Inf, zero and saturated readings are counted per reason and absent from OUT."""
    sim = simulate(Scenario(station_s=0.5))
    raw = sim.raw_mps2.copy()
    bad = {10: [math.nan, 0.0, G], 20: [0.0, math.inf, G], 30: [0.0, 0.0, -math.inf],
           40: [0.0, 0.0, 0.0], 50: [2 * G, 0.0, G], 60: [0.0, -25.0, G]}
    for index, reading in bad.items():
        raw[index] = reading
    in_bag, out_bag = str(tmp_path / 'bad'), str(tmp_path / 'out')
    with bag.BagWriter(in_bag, 'sqlite3') as writer:
        writer.add_topic('/imu/data_raw', bag.IMU)
        writer.write_series({'/imu/data_raw': bag.raw_imu(sim.stamps_ns, 'inclinometer', raw,
                                                          NOISE_MPS2)})
    code, stdout, _ = quiet(['process', in_bag, out_bag,
                             '--calibration', run_3axis['calibration'], '--chunk-size', '25'])
    assert code == 0
    values = summary_values(stdout)
    n = sim.stamps_ns.size
    assert (values['samples_in'], values['accepted']) == (str(n), str(n - 6))
    assert (values['dropped_non_finite'], values['dropped_saturated'], values['dropped_zero'],
            values['dropped_over_g']) == ('3', '2', '1', '0')
    kept = np.delete(sim.stamps_ns, list(bad))
    survey = bag.concatenate(bag.read(out_bag, '/survey'))
    imu = bag.concatenate(bag.read(out_bag, '/imu/data'))
    np.testing.assert_array_equal(survey.stamps_ns, kept)
    np.testing.assert_array_equal(imu.stamps_ns, kept)
    assert np.all(np.isfinite(survey.vector[:, 0]))
    assert np.all(np.isfinite(imu.linear_acceleration_mps2))


def test_two_axis_sensor_end_to_end(tmp_path):
    """A two-axis sensor in an sqlite3 bag: calibrated and processed within its own bound."""
    sim_bag, out_bag, calibration = (str(tmp_path / n) for n in ('sim', 'out', 'cal.json'))
    assert quiet(['simulate', sim_bag, '--axes', '2', '--storage', 'sqlite3'])[0] == 0
    installation = calibrate_from_level(sim_bag, calibration, axes=2)
    assert abs(installation.gamma_deg - 0.8) <= CALIBRATION_DEG
    assert abs(installation.beta_deg - (-1.2)) <= CALIBRATION_DEG
    # The bench goes to 60 deg, the default limit of a two-axis sensor: 65 keeps every sample.
    code, stdout, stderr = quiet(['process', sim_bag, out_bag, '--calibration', calibration,
                                  '--two-axis-max-inclination-deg', '65'])
    assert code == 0, stderr
    truth = bag.concatenate(bag.read(sim_bag, '/truth/survey'))
    survey = bag.concatenate(bag.read(out_bag, '/survey'))
    np.testing.assert_array_equal(survey.stamps_ns, truth.stamps_ns)
    tol_deg = 6 * SIGMA_I_DEG / math.cos(math.radians(60.0)) + CALIBRATION_DEG
    assert np.abs(survey.vector[:, 0] - truth.vector[:, 0]).max() <= tol_deg
    imu = bag.concatenate(bag.read(out_bag, '/imu/data'))
    # The completion z = sqrt(g^2 - x^2 - y^2) carries the noise of x, y (node default 0.01):
    # J = [[1, 0], [0, 1], [-x / z, -y / z]] at the raw reading, then the installation C^-1.
    raw = bag.concatenate(bag.read(sim_bag, '/imu/data_raw')).linear_acceleration_mps2
    x, y = raw[:, 0], raw[:, 1]
    z = np.sqrt(G ** 2 - x ** 2 - y ** 2)
    jacobian = np.zeros((x.size, 3, 2))
    jacobian[:, 0, 0] = jacobian[:, 1, 1] = 1.0
    jacobian[:, 2, 0], jacobian[:, 2, 1] = -x / z, -y / z
    c_inv = installation_matrix(math.radians(installation.gamma_deg),
                                math.radians(installation.beta_deg)).T
    expected = 0.01 ** 2 * c_inv @ jacobian @ jacobian.transpose(0, 2, 1) @ c_inv.T
    np.testing.assert_allclose(imu.linear_acceleration_covariance, expected.reshape(-1, 9),
                               rtol=1e-9, atol=1e-15)


def test_console_script_sqlite3_highside(tmp_path, run_3axis):
    """``inclino`` as a console script: sqlite3 output, ISCWSA toolface = seed000 + 90 deg."""
    out_bag = str(tmp_path / 'out')
    script = installed_script('inclino')
    result = subprocess.run(
        [script, 'process', run_3axis['sim'], out_bag, '--calibration',
         run_3axis['calibration'], '--storage', 'sqlite3', '--noise-mps2', str(NOISE_MPS2),
         '--toolface-convention', 'iscwsa_highside'],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert summary_values(result.stdout)['accepted'] == '5400'
    assert any(name.endswith('.db3') for name in os.listdir(out_bag))
    highside = bag.concatenate(bag.read(out_bag, '/survey'))
    seed000 = bag.concatenate(bag.read(run_3axis['out'], '/survey'))
    np.testing.assert_array_equal(highside.vector[:, 0], seed000.vector[:, 0])
    tilted = ~np.isnan(seed000.vector[:, 1])
    assert tilted.sum() == 4800                  # all but the 600 of the level segment
    np.testing.assert_allclose(
        angle_diff_deg(highside.vector[tilted, 1], seed000.vector[tilted, 1] + 90.0), 0.0,
        atol=1e-9)


@pytest.mark.parametrize('case', ['missing', 'corrupt', 'axes', 'topic', 'exists'])
def test_process_refuses_with_exit_code_2(tmp_path, run_3axis, case):
    """A missing/corrupt calibration, wrong axes, missing topic or existing OUT: exit 2."""
    calibration, out_bag = run_3axis['calibration'], str(tmp_path / 'out')
    extra, expected = [], {
        'missing': 'no calibration file', 'corrupt': 'not valid JSON',
        'axes': 'is for a 3-axis accelerometer', 'topic': 'no topic /imu/other',
        'exists': 'exists already'}[case]
    if case == 'missing':
        calibration = str(tmp_path / 'none.json')
    elif case == 'corrupt':
        calibration = str(tmp_path / 'corrupt.json')
        with open(calibration, 'w') as stream:
            stream.write('{"format": "inclino_ros.calibration", ')
    elif case == 'axes':
        extra = ['--axes', '2']
    elif case == 'topic':
        extra = ['--topic', '/imu/other']
    else:
        os.mkdir(out_bag)
    code, stdout, stderr = quiet(['process', run_3axis['sim'], out_bag,
                                  '--calibration', calibration] + extra)
    assert code == 2
    assert expected in stderr
    assert stdout == ''
    assert os.listdir(out_bag) == [] if case == 'exists' else not os.path.exists(out_bag)


def test_process_without_correction_warns(tmp_path, run_3axis):
    """A calibration file without a correction is processed raw, with a warning on stderr."""
    calibration, out_bag = str(tmp_path / 'empty.json'), str(tmp_path / 'out')
    save_model(calibration, CalibrationModel(accelerometer_axes=3))
    code, _, stderr = quiet(['process', run_3axis['sim'], out_bag, '--calibration', calibration])
    assert code == 0
    assert 'holds no accelerometer correction' in stderr and 'azimuth' not in stderr
    raw = bag.concatenate(bag.read(run_3axis['sim'], '/imu/data_raw'))
    survey = bag.concatenate(bag.read(out_bag, '/survey'))
    np.testing.assert_array_equal(survey.vector[:, 0],
                                  np.degrees(inclination(raw.linear_acceleration_mps2)))


def test_process_averages_every_n_samples(tmp_path, run_3axis):
    """
    ``--average-samples 70``, chunks of 37: 5400 samples make 77 windows and 10 left over.

    A window inside a station is written at the mean stamp of its 70 samples,
    its inclination within 4 standard errors of the truth, the covariance at
    least the per-sample one / 70 (closed form: isotropic noise^2 / 70, the floor
    under the window's own noise, which 70 white samples estimate within 1.5 in
    variance); a window
    over the turn between two stations is not written (counted as moving).
    """
    out_bag = str(tmp_path / 'avg')
    code, stdout, stderr = quiet(['process', run_3axis['sim'], out_bag,
                                  '--calibration', run_3axis['calibration'],
                                  '--noise-mps2', str(NOISE_MPS2), '--chunk-size', '37',
                                  '--average-samples', '70'])
    assert code == 0, stderr
    values = summary_values(stdout)
    written, moving = int(values['windows_written']), int(values['windows_moving'])
    assert written + moving + int(values['windows_dropped']) == 77
    assert values['samples_not_averaged'] == '10'
    survey = bag.concatenate(bag.read(out_bag, '/survey'))
    imu = bag.concatenate(bag.read(out_bag, '/imu/data'))
    assert survey.stamps_ns.size == imu.stamps_ns.size == written
    truth = bag.concatenate(bag.read(run_3axis['sim'], '/truth/survey'))
    window_stamps = truth.stamps_ns[:5390].reshape(77, 70)
    window_truth = truth.vector[:5390, 0].reshape(77, 70)
    means = window_stamps.mean(axis=1)
    index = np.abs(survey.stamps_ns[:, None] - means[None, :]).argmin(axis=1)
    np.testing.assert_allclose(survey.stamps_ns, means[index], atol=1.0)
    still = np.ptp(window_truth[index], axis=1) == 0.0
    assert still.sum() >= 60
    std_deg = math.degrees(NOISE_MPS2 / G / math.sqrt(70))
    error_deg = survey.vector[still, 0] - window_truth[index][still, 0]
    assert np.abs(error_deg).max() < 4 * std_deg + MEAN_TOL_DEG
    variance = imu.linear_acceleration_covariance[:, [0, 4, 8]]
    assert np.all(variance >= NOISE_MPS2 ** 2 / 70 * (1.0 - 1e-12))
    assert np.all(variance[still] <= 1.5 * NOISE_MPS2 ** 2 / 70)


def test_process_bias_instability_adds_its_flicker_to_each_window(tmp_path, run_3axis):
    """
    ``--bias-instability-mps2 B`` (the node's accelerometer_bias_instability_mps2) in process.

    Each averaged window's mean variance grows by the flicker ``(c B)^2``
    (``stillness.floored_count``: 1 / count + (c B / noise)^2, c =
    ``flicker_mean_factor()``), so every /imu/data acceleration variance is the
    one without B plus (c B)^2 (the level calibration's matrix is within 1 % of
    the identity: tolerance 3 %).  Without the option (main: no such option) the
    variances stay those of the white noise.
    """
    from inclino_ros.core.correlated_noise import flicker_mean_factor
    b_mps2 = NOISE_MPS2 / math.sqrt(70.0)
    variances = []
    for extra in ([], ['--bias-instability-mps2', str(b_mps2)]):
        out_bag = str(tmp_path / f'avg{len(extra)}')
        code, _, stderr = quiet(['process', run_3axis['sim'], out_bag,
                                 '--calibration', run_3axis['calibration'],
                                 '--noise-mps2', str(NOISE_MPS2), '--average-samples', '70']
                                + extra)
        assert code == 0, stderr
        imu = bag.concatenate(bag.read(out_bag, '/imu/data'))
        variances.append(imu.linear_acceleration_covariance[:, [0, 4, 8]])
    assert variances[0].shape == variances[1].shape and variances[0].size
    np.testing.assert_allclose(variances[1] - variances[0],
                               (flicker_mean_factor() * b_mps2) ** 2, rtol=0.03)


def test_processed_bag_states_its_toolface_zero(run_3axis):
    """The metadata of OUT holds the toolface zero; compare prints it (issue 19 item 6)."""
    custom = bag.custom_data(run_3axis['out'])
    assert custom['inclino.toolface_zero'] == 'board'
    assert 'inclino.toolface_zero: board' in (Path(run_3axis['out']) / 'metadata.yaml').read_text()
    assert custom['inclino.toolface_zero_meaning'].startswith('relative to the sensor board')
    code, out, err = quiet(['compare', run_3axis['out'], run_3axis['sim']])
    assert code == 0, err
    assert '\ntoolface_zero: board\ntoolface_zero_meaning: relative to the sensor board' in out
    # A bag that states none (the simulated input): compare says it does not know.
    code, out, err = quiet(['compare', run_3axis['sim'], run_3axis['sim'],
                            '--topic', '/truth/survey'])
    assert code == 0, err
    assert 'toolface_zero: unknown' in out
