"""Magnetic azimuth in the live node: rotation fit, survey stations, MSA (seed 002)."""

import json
import math
import re
import time

from diagnostic_msgs.msg import DiagnosticStatus
from inclino_ros.calibration.model import (
    CalibrationModel, load_model, Magnetometer, save_model, utc_now_iso)
from inclino_ros.core.magnetics import forward, iscwsa_from_tool
import numpy as np
import pytest
from ros_harness import G

REFERENCE_TOTAL_NT, REFERENCE_DIP_DEG, DECLINATION_DEG = 50000.0, 60.0, 5.0
HARD_IRON_NT = np.array([80.0, -80.0])           # tool x, y: turns with the tool
AXIAL_NT = -2000.0                               # drill string along the tool axis (tool z)
NOISE_G, NOISE_NT = 1e-4, 5.0


def readings(inclination_deg, azimuth_deg, toolface_deg, rng=None):
    """
    Return (specific force [m/s^2], field [nT]) the tool reads, z-up tool frame.

    The ISCWSA forward model (formulas.md), turned into the tool frame, plus the
    interference: a hard-iron offset on x, y and an axial offset on z.
    """
    gravity, field = forward(inclination_deg, azimuth_deg, toolface_deg, G,
                             REFERENCE_TOTAL_NT, REFERENCE_DIP_DEG)
    force = -iscwsa_from_tool(gravity)
    field = iscwsa_from_tool(field) + np.array([*HARD_IRON_NT, AXIAL_NT])
    if rng is not None:
        force = force + rng.normal(0.0, NOISE_G * G, 3)
        field = field + rng.normal(0.0, NOISE_NT, 3)
    return force, field


@pytest.fixture
def node_and_probe(start_node, probe):
    """Start a node with a reference field and short captures; wait for the probe."""
    node = start_node(**{
        'magnetic.reference_total_nT': REFERENCE_TOTAL_NT,
        'magnetic.reference_dip_deg': REFERENCE_DIP_DEG,
        'magnetic.declination_deg': DECLINATION_DEG,
        'rotation.duration_s': 3.0, 'survey.samples': 20})
    probe.wait_for_node()
    return node, probe


def azimuth_of(probe, force, field, timeout_s=60.0):
    """
    Publish a magnetometer reading and the raw sample of its stamp until the node pairs them.

    Return (survey azimuth, azimuth topic, the node's magnetics diagnostics statuses
    built from the sample's publication to after its survey came).  Waits for
    conditions, not for fixed times: the sample's survey, its azimuth message, and
    a magnetics status built after the survey whose last sample had a field
    (``b_total_nT`` not NaN).  A reading delivered after its sample leaves that
    sample unpaired (the node corrects a sample as soon as it arrives), and an
    output of an earlier sample may still be on its way: both are sent again.
    """
    end = time.monotonic() + timeout_s
    while True:
        assert time.monotonic() < end, f'no paired sample in {timeout_s} s'
        probe.clear()
        index, sent_ns = probe.sent, time.time_ns()
        probe.mag_publisher.publish(mag_message(index, field))
        probe.publish(force)
        surveys, azimuths = probe.received['survey'], probe.received['azimuth']
        if not spin_until(probe, lambda: any(s.header.stamp.sec == index for s in surveys),
                          end):
            continue
        # The azimuth topic delivers in order: one message per survey (a magnetometer has
        # been heard), unless an earlier sample's came late (one too many: sent again).
        survey_ns = time.time_ns()
        if not spin_until(probe, lambda: len(azimuths) >= len(surveys),
                          min(end, time.monotonic() + 5.0)):
            continue
        statuses = []

        def built_after_survey():
            statuses[:] = [(stamp_ns(array.header.stamp), status)
                           for array in probe.received['/diagnostics']
                           if stamp_ns(array.header.stamp) >= sent_ns
                           for status in array.status if status.name.endswith(': magnetics')]
            return any(stamp > survey_ns for stamp, _ in statuses)

        spin_until(probe, built_after_survey, end)
        last = {kv.key: kv.value for kv in statuses[-1][1].values} if statuses else {}
        if (len(azimuths) == len(surveys) and surveys[-1].header.stamp.sec == index
                and last.get('b_total_nT', 'nan') != 'nan'):
            return surveys[-1].vector.z, azimuths[-1].data, [status for _, status in statuses]


def spin_until(probe, done, end):
    """Spin ``probe`` until ``done()`` (True) or time.monotonic() reaches ``end`` (False)."""
    while not done():
        if time.monotonic() >= end:
            return False
        probe.executor.spin_once(timeout_sec=0.01)
    return True


def stamp_ns(stamp):
    """Return a builtin_interfaces/Time as ns."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def mag_message(index, field_nT):
    """Return a MagneticField stamped like the index-th raw sample."""
    from sensor_msgs.msg import MagneticField
    msg = MagneticField()
    msg.header.stamp.sec = index
    msg.magnetic_field.x, msg.magnetic_field.y, msg.magnetic_field.z = (
        float(v) * 1e-9 for v in field_nT)
    return msg


def error_deg(a, b):
    """Return a - b wrapped to [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


def test_rotation_stations_and_msa_give_the_true_azimuth(node_and_probe, tmp_path):
    """Rotation fit, 20 stations, MSA: then the azimuth is within 0.1 deg (east-west well)."""
    node, probe = node_and_probe
    rng = np.random.default_rng(11)
    # 1. The tool turns at one attitude: the rotation fit finds the hard iron.
    answer = probe.calibrate(
        lambda i: probe.mag_publisher.publish(mag_message(probe.sent, readings(
            60.0, 100.0, (i * 3.0) % 360.0, rng)[1])) or readings(60.0, 100.0, i * 3.0, rng)[0],
        service='capture_rotation')
    assert answer.success, answer.message
    magnetic = load_model(tmp_path / 'calibration.json').magnetic
    # 5 nT noise over ~500 samples on a 25000 nT circle: offsets to about 1 nT.
    np.testing.assert_allclose(magnetic.hard_iron_nT, HARD_IRON_NT, atol=3.0)

    # 2. Stations with spread toolfaces along an east-west well, inclination 30-90.
    stations = [(30.0 + 3.0 * k, 88.0 + 0.2 * k, (k * 137.0) % 360.0) for k in range(20)]
    for incl_deg, az_deg, tf_deg in stations:
        probe.spin_for(0.2)
        answer = probe.calibrate(
            lambda i: probe.mag_publisher.publish(mag_message(probe.sent, readings(
                incl_deg, az_deg, tf_deg, rng)[1])) or readings(incl_deg, az_deg, tf_deg,
                                                                rng)[0],
            service='take_survey')
        assert answer.success, answer.message
    doc = json.loads((tmp_path / 'stations.json').read_text())
    assert len(doc['stations']) == 20

    # Before MSA the 2000 nT axial error puts B-total ~600 nT off the reference:
    # QC fails and the azimuth is withheld (NaN), not published wrong.
    before, _, _ = azimuth_of(probe, *readings(70.0, 90.0, 40.0))
    assert math.isnan(before)

    answer = probe.call('solve_msa')
    assert answer.success, answer.message
    interference = load_model(tmp_path / 'calibration.json').magnetic.interference_nT
    assert interference[2] == pytest.approx(AXIAL_NT, abs=20.0)

    # Station-averaged noise (20 samples) sets a floor of a few hundredths of a degree.
    for incl_deg, az_deg, tf_deg in ((45.0, 90.0, 10.0), (85.0, 270.0, 200.0),
                                     (60.0, 30.0, 300.0)):
        survey_z, true_az, _ = azimuth_of(probe, *readings(incl_deg, az_deg, tf_deg))
        assert abs(error_deg(survey_z, az_deg)) < 0.1
        assert true_az == pytest.approx((survey_z + DECLINATION_DEG) % 360.0, abs=1e-9)

    cleared = probe.call('clear_surveys')
    assert cleared.success and 'cleared 20 stations' in cleared.message
    assert json.loads((tmp_path / 'stations.json').read_text())['stations'] == []
    assert node.stop() == 0


def test_unpaired_and_dead_field_give_no_azimuth(node_and_probe):
    """A sample without a near magnetometer reading, or a zero field, has NaN azimuth."""
    _, probe = node_and_probe
    force, field = readings(50.0, 120.0, 0.0)
    # With its 2000 nT interference the field fails B-total QC: not trusted.
    assert math.isnan(azimuth_of(probe, force, field)[0])
    clean = field - np.array([*HARD_IRON_NT, AXIAL_NT])
    survey_z, _, _ = azimuth_of(probe, force, clean)
    assert survey_z == pytest.approx(120.0, abs=1e-6)  # paired and passing QC
    probe.clear()
    index = probe.publish(force)            # its stamp is 1 s after the last imu/mag
    probe.spin_until(lambda: any(s.header.stamp.sec == index for s in probe.received['survey']))
    survey = next(s for s in probe.received['survey'] if s.header.stamp.sec == index)
    assert math.isnan(survey.vector.z)
    assert survey.vector.x == pytest.approx(50.0, abs=1e-9)
    # A dead (zero) field, paired: NaN, and the status of its period says so (failing QC:
    # neither unpaired, as the sample before, nor imprecise).
    survey_z, _, statuses = azimuth_of(probe, force, np.zeros(3))
    assert math.isnan(survey_z)
    assert any(s.level == DiagnosticStatus.WARN and 'azimuth is NaN' in s.message
               and int({kv.key: kv.value for kv in s.values}['untrusted']) >= 1
               for s in statuses)


def test_a_corrupt_stations_file_stops_the_node(start_node, tmp_path):
    """A stations file that cannot be trusted is a loud error and a non-zero exit."""
    path = tmp_path / 'stations.json'
    path.write_text(json.dumps({'format': 'inclino_ros.calibration.stations', 'schema_version': 1,
                                'stations': [{'specific_force_mps2': [0.0, 0.0, 'x'],
                                              'field_nT': [1.0, 2.0, 3.0], 'samples': 5,
                                              'captured_at': '2026-01-01T00:00:00+00:00'}]}))
    node = start_node()
    assert node.process.wait(timeout=30) != 0
    assert str(path) in node.log() and 'refusing to start' in node.log()


def test_an_unknown_msa_method_is_refused_at_set_time(node_and_probe):
    """msa.method takes only the solvers there are; a bad value changes nothing."""
    from rclpy.parameter import Parameter
    _, probe = node_and_probe
    future = probe.parameters.set_parameters([Parameter('msa.method', value='guess')])
    probe.executor.spin_until_future_complete(future, timeout_sec=10.0)
    (result,) = future.result().results
    assert not result.successful
    assert "msa.method must be one of improved, classic, axial, not 'guess'" in result.reason
    probe.set_parameters(msa__method='classic')  # a known one is taken


#: A robot IMU with its y along the tool axis, and an AK8963-style magnetometer beside it.
ACCELEROMETER_MAP = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])   # '+X-Z+Y'
MAGNETOMETER_MAP = np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1]])    # '+Y+X-Z'


def test_axes_maps_turn_both_sensors_before_every_capture(start_node, probe, tmp_path):
    """Sensor-axis readings of a mounted board: level, rotation and survey work in tool axes."""
    from ros_harness import tilted_reading
    start_node(accelerometer_axes_map='+X-Z+Y', magnetometer_axes_map='+Y+X-Z',
               **{'rotation.duration_s': 3.0, 'survey.samples': 20})
    probe.wait_for_node()
    rng = np.random.default_rng(5)
    # The accelerometer is misaligned by gamma 0.8, beta -1.2 deg: C f in its nominal axes.
    c = np.column_stack([tilted_reading(incl, tf, 0.8, -1.2)
                         for incl, tf in ((90.0, 0.0), (90.0, 90.0), (0.0, 0.0))]) / G
    answer = probe.calibrate(
        lambda i: ACCELEROMETER_MAP.T @ (c @ [0.0, 0.0, G] + rng.normal(0.0, 0.002, 3)))
    assert answer.success, answer.message
    installation = load_model(tmp_path / 'calibration.json').installation
    assert (installation.gamma_deg, installation.beta_deg) == (
        pytest.approx(0.8, abs=0.005), pytest.approx(-1.2, abs=0.005))

    def sample(incl_deg, az_deg, tf_deg):
        # Both triads sit on the one misaligned board (the shared mount): C turns the
        # tool-frame field, drill-string interference included, as it turns the force.
        force, field = readings(incl_deg, az_deg, tf_deg, rng)
        probe.mag_publisher.publish(mag_message(probe.sent, MAGNETOMETER_MAP.T @ c @ field))
        return ACCELEROMETER_MAP.T @ c @ force

    answer = probe.calibrate(lambda i: sample(60.0, 100.0, (i * 3.0) % 360.0),
                             service='capture_rotation')
    assert answer.success, answer.message
    np.testing.assert_allclose(load_model(tmp_path / 'calibration.json').magnetic.hard_iron_nT,
                               HARD_IRON_NT, atol=3.0)
    answer = probe.calibrate(lambda i: sample(40.0, 200.0, 70.0), service='take_survey')
    assert answer.success, answer.message
    # Level-corrected (uncorrected: 1.4 deg off).  The station's 1 sigma: its 20 samples'
    # noise (1e-4 g per axis: 0.0013 deg) and the 500-sample level capture's (0.0005 deg);
    # 0.01 deg is 7 of them.  (Not '=40.0' in the text: 39.999 is as right as 40.001.)
    incl_deg = float(re.search(r'inclination_deg=([-0-9.]+)', answer.message).group(1))
    assert incl_deg == pytest.approx(40.0, abs=0.01), answer.message
    stored = json.loads((tmp_path / 'stations.json').read_text())['stations'][0]
    # A station keeps the field as read (axes map applied): MSA applies the magnetometer's
    # stages, the shared mount among them, itself (calibration.stations).
    np.testing.assert_allclose(stored['field_nT'], c @ readings(40.0, 200.0, 70.0)[1], atol=5.0)


def test_a_calibration_fitted_in_other_axes_maps_stops_the_node(start_node, probe, tmp_path):
    """A file fitted in '+X-Z+Y' read through the identity: refused, both maps named."""
    save_model(tmp_path / 'calibration.json',
               CalibrationModel(accelerometer_axes=3, axes_maps=('+X-Z+Y', '+Y+X-Z')))
    node = start_node()
    assert node.process.wait(timeout=30) != 0
    assert "fitted with the accelerometer axes map '+X-Z+Y'" in node.log()
    start_node(accelerometer_axes_map='+X-Z+Y', magnetometer_axes_map='+Y+X-Z')
    probe.wait_for_node()


def test_a_left_handed_axes_map_stops_the_node(start_node):
    """A map of determinant -1 is a wiring error: the node says so and exits non-zero."""
    node = start_node(magnetometer_axes_map='+X+Y-Z')
    assert node.process.wait(timeout=30) != 0
    assert 'magnetometer_axes_map' in node.log() and 'left-handed' in node.log()


def test_rotation_gives_one_calibration_through_the_service_and_the_command(
        start_node, probe, tmp_path):
    """
    One rotation, two doors: ~/capture_rotation and inclino fit-rotation write the same stage.

    Both start from one file holding an MSA interference: both reset it (it was
    solved on the old cross-axial correction) and record the temperature the
    readings stood for.  The field is noise-free, so that any window of the
    turn the node happens to capture gives the same ellipse (to rounding).
    """
    import shutil

    from inclino_ros.calibration.model import (
        CalibrationModel, NO_MAGNETIC_CORRECTION, save_model)
    from test_msa_cli import quiet

    start = CalibrationModel(3, magnetic=NO_MAGNETIC_CORRECTION.__class__(**{
        **NO_MAGNETIC_CORRECTION.__dict__, 'interference_nT': (10.0, -5.0, -2000.0),
        'interference_std_nT': (1.0, 1.0, 5.0), 'msa_method': 'classic', 'msa_stations': 20,
        'msa_reference_total_nT': REFERENCE_TOTAL_NT,
        'msa_reference_dip_deg': REFERENCE_DIP_DEG,
        'msa_fitted_at': '2026-01-01T00:00:00+00:00'}))
    save_model(tmp_path / 'node.json', start)
    shutil.copy(tmp_path / 'node.json', tmp_path / 'command.json')
    start_node(calibration_file=str(tmp_path / 'node.json'), **{'rotation.duration_s': 3.0})
    probe.wait_for_node()
    rng = np.random.default_rng(5)
    temperature_c, fields = 31.5, []

    def turn(i):
        field = readings(60.0, 100.0, (i * 3.0) % 360.0)[1]
        fields.append(field)
        probe.publish_temperature(temperature_c)
        probe.mag_publisher.publish(mag_message(probe.sent, field))
        return readings(60.0, 100.0, (i * 3.0) % 360.0, rng)[0]

    probe.set_temperature(temperature_c)
    answer = probe.calibrate(turn, service='capture_rotation')
    assert answer.success, answer.message
    rows = np.column_stack([np.array(fields), np.full(len(fields), temperature_c)])
    np.savetxt(tmp_path / 'rotation.csv', rows, delimiter=',', header='bx,by,bz,temperature_c',
               comments='')
    code, _, err = quiet(['fit-rotation', tmp_path / 'rotation.csv', '--calibration',
                          tmp_path / 'command.json', '--report-dir', tmp_path / 'report'])
    assert code == 0, err

    node_doc = json.loads((tmp_path / 'node.json').read_text())
    command_doc = json.loads((tmp_path / 'command.json').read_text())
    node_magnetic, command_magnetic = node_doc.pop('magnetic'), command_doc.pop('magnetic')
    assert node_doc == command_doc
    for name in ('hard_iron_nT', 'soft_iron'):   # noise-free: rounding only
        np.testing.assert_allclose(node_magnetic.pop(name), command_magnetic.pop(name),
                                   rtol=0, atol=1e-6)
    # The fit's covariance of noise-free readings: rounding only (below 1e-20 nT^2).
    np.testing.assert_allclose(node_magnetic.pop('rotation_covariance'),
                               command_magnetic.pop('rotation_covariance'), rtol=0, atol=1e-20)
    assert node_magnetic.pop('rotation_fitted_at') is not None
    assert command_magnetic.pop('rotation_fitted_at') is not None
    assert node_magnetic == command_magnetic
    assert command_magnetic['interference_nT'] == [0.0, 0.0, 0.0]
    assert command_magnetic['msa_method'] is None
    assert command_magnetic['rotation_temperature_c'] == pytest.approx(temperature_c)


def test_a_magnetometer_k_of_t_is_applied_at_the_temperature(start_node, probe, tmp_path):
    """
    K_m(T), b_m(T) of a multi-temperature stand (issue 18) in the live node, from imu/temperature.

    K_m(T) = I + (T - 40) dK, b_m(T) = (T - 40) db over 20..60 C: a field read through them at T
    gives the true azimuth (rounding only); beyond the range K_m and b_m of the nearer end,
    and the temperature diagnostics say so.  At 55 C the readings are ~2.5 % and 4700 nT off:
    read with K_m(40 C) the azimuth would be degrees off (main had no K_m(T)).
    """
    d_scale = np.diag([2e-3, -1.5e-3, 1e-3])
    d_bias_nT = np.array([300.0, -200.0, 150.0])
    eye = tuple(map(tuple, np.eye(3).tolist()))
    save_model(tmp_path / 'calibration.json', CalibrationModel(3, magnetometer=Magnetometer(
        scale_matrix=eye, bias_nT=(0.0, 0.0, 0.0), method='stand', condition_number=1.0,
        rms_residual_nT=1.0, field_nT=REFERENCE_TOTAL_NT, positions=36,
        fitted_at=utc_now_iso(), temperature_c=40.0,
        scale_coefficients=(eye, tuple(map(tuple, d_scale.tolist()))),
        bias_coefficients_nT=((0.0, 0.0, 0.0), tuple(d_bias_nT.tolist())), t_min_c=20.0,
        t_max_c=60.0)))
    start_node(**{'magnetic.reference_total_nT': REFERENCE_TOTAL_NT,
                  'magnetic.reference_dip_deg': REFERENCE_DIP_DEG})
    probe.wait_for_node()
    for temperature_c, held_c, (incl_deg, az_deg, tf_deg) in (
            (20.0, 20.0, (45.0, 100.0, 10.0)), (55.0, 55.0, (70.0, 250.0, 200.0)),
            (75.0, 60.0, (30.0, 20.0, 120.0))):
        probe.set_temperature(temperature_c)
        gravity, field = forward(incl_deg, az_deg, tf_deg, G, REFERENCE_TOTAL_NT,
                                 REFERENCE_DIP_DEG)
        dt = held_c - 40.0
        raw = (np.eye(3) + dt * d_scale) @ iscwsa_from_tool(field) + dt * d_bias_nT
        survey_z, _, _ = azimuth_of(probe, -iscwsa_from_tool(gravity), raw)
        assert abs(error_deg(survey_z, az_deg)) < 1e-6, (temperature_c, survey_z, az_deg)
    status = probe.wait_status(': temperature')[0]
    assert status.level == DiagnosticStatus.WARN and 'outside the fitted range' in status.message
