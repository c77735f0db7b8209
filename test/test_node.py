"""The inclinometer node through real rclpy: the node runs as a subprocess."""

import json
import math
import re

from diagnostic_msgs.msg import DiagnosticStatus
from inclino_ros.calibration.corrections import TOOLFACE_ZEROS
from inclino_ros.calibration.model import load_model
import numpy as np
import pytest
from ros_harness import G, Probe, tilted_reading
from std_srvs.srv import Trigger
import transforms3d

GAMMA_DEG, BETA_DEG = 0.8, -1.2
NOISE_MPS2 = 0.002
CAPTURE_SAMPLES = 100
# The level capture averages CAPTURE_SAMPLES readings of noise NOISE_MPS2: the
# installation angles are then off by about NOISE/g/sqrt(N) rad = 0.0012 deg (1 sigma).
# 4 sigma bounds the angles; a corrected inclination inherits at most the tilt error.
ANGLE_TOL_DEG = 4 * math.degrees(NOISE_MPS2 / G / math.sqrt(CAPTURE_SAMPLES))
STATIONS = ((2.0, 30.0), (0.5, 200.0), (5.0, 300.0), (30.0, 120.0))
#: The node as these tests use it: level captures of CAPTURE_SAMPLES, its noise NOISE_MPS2.
NODE = {'level_capture.samples': CAPTURE_SAMPLES, 'accelerometer_noise_std_mps2': NOISE_MPS2}


def level_samples(seed=1, scale=1.0):
    """Return a sample function: the misaligned tool on a level bench, with noise."""
    rng = np.random.default_rng(seed)
    level = tilted_reading(0.0, 0.0, GAMMA_DEG, BETA_DEG) * scale
    return lambda i: level + rng.normal(0.0, NOISE_MPS2, 3)


def survey_of(probe, inclination_deg, toolface_deg):
    """Publish one station of the misaligned tool; return its survey vector."""
    reading = tilted_reading(inclination_deg, toolface_deg, GAMMA_DEG, BETA_DEG)
    return probe.survey_for(lambda: probe.publish(reading)).vector


def angle_diff_deg(a, b):
    """Return the signed difference of two angles in degrees, in [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


def parse_angles(message):
    """Return gamma_deg, beta_deg and theta_deg from a service message."""
    return {key: float(value) for key, value in
            re.findall(r'(gamma_deg|beta_deg|theta_deg)=(-?[0-9.]+)', message)}


def latest_status(probe, suffix):
    """Return a diagnostics status whose name ends with ``suffix``, built after the call."""
    return probe.wait_status(suffix)


@pytest.mark.parametrize('axes', [3, 2])
def test_calibration_round_trip_corrects_the_stations(start_node, probe, tmp_path, axes):
    """Calibrate through the service, then every station reads its true attitude."""
    node = start_node(**NODE, accelerometer_axes=axes)
    probe.wait_for_node()
    raw = survey_of(probe, 2.0, 30.0)
    # Uncalibrated: the misaligned reading's own inclination, 0.39 deg off the truth.
    reading = tilted_reading(2.0, 30.0, GAMMA_DEG, BETA_DEG)
    if axes == 2:
        reading[2] = math.sqrt(G ** 2 - reading[0] ** 2 - reading[1] ** 2)
    assert raw.x == pytest.approx(
        math.degrees(math.acos(reading[2] / np.linalg.norm(reading))), abs=1e-6)
    assert abs(raw.x - 2.0) > 0.3
    calibration = probe.listen_latched('/inclinometer/calibration')
    probe.spin_until(lambda: calibration)
    assert calibration[-1]['toolface_zero'] == 'board'

    response = probe.calibrate(level_samples())
    assert response.success, response.message
    # Every output carrying a toolface states its zero (issue 19 item 6): the answer, the
    # latched ~/calibration, the diagnostics; a level bench leaves it the board's.
    assert 'toolface_zero: board' in response.message
    assert 'toolface_zero_meaning: relative to the sensor board' in response.message
    probe.spin_until(lambda: 'installation' in calibration[-1]['stages'])
    assert calibration[-1]['toolface_zero'] == 'board'
    assert calibration[-1]['toolface_zero_meaning'] == TOOLFACE_ZEROS['board']
    angles = parse_angles(response.message)
    assert angles['gamma_deg'] == pytest.approx(GAMMA_DEG, abs=ANGLE_TOL_DEG)
    assert angles['beta_deg'] == pytest.approx(BETA_DEG, abs=ANGLE_TOL_DEG)
    assert angles['theta_deg'] == pytest.approx(
        math.degrees(math.acos(math.cos(math.radians(GAMMA_DEG))
                               * math.cos(math.radians(BETA_DEG)))), abs=2 * ANGLE_TOL_DEG)
    assert f'from {CAPTURE_SAMPLES} samples' in response.message
    saved = load_model(tmp_path / 'calibration.json').installation
    assert saved.gamma_deg == pytest.approx(angles['gamma_deg'], abs=1e-4)
    assert saved.sample_count == CAPTURE_SAMPLES

    for inclination_deg, toolface_deg in STATIONS:
        survey = survey_of(probe, inclination_deg, toolface_deg)
        assert survey.x == pytest.approx(inclination_deg, abs=2 * ANGLE_TOL_DEG)
        # Toolface error ~ tilt error / sin(I): loose at 0.5 deg inclination.
        tolerance_deg = math.degrees(2 * math.radians(ANGLE_TOL_DEG)
                                     / math.sin(math.radians(inclination_deg)))
        assert abs(angle_diff_deg(survey.y, toolface_deg)) < tolerance_deg
        assert math.isnan(survey.z)
        incl = probe.wait_outputs('inclination', 1)[0].data
        assert incl == survey.x
        assert probe.wait_outputs('toolface', 1)[0].data == survey.y
        imu = probe.wait_outputs('imu/data', 1)[0]
        acc = imu.linear_acceleration
        assert math.hypot(acc.x, acc.y, acc.z) == pytest.approx(G, abs=1e-9)
        q = imu.orientation
        up = transforms3d.quaternions.quat2mat([q.w, q.x, q.y, q.z])[2]
        assert math.degrees(math.acos(up[2])) == pytest.approx(survey.x, abs=1e-9)
        assert imu.orientation_covariance[8] == pytest.approx(math.pi ** 2 / 3)
        assert imu.angular_velocity_covariance[0] == -1.0
        assert imu.header.frame_id == 'inclinometer'
    status, values = latest_status(probe, ': calibration')
    assert status.level == DiagnosticStatus.OK
    assert float(values['gamma_deg']) == pytest.approx(angles['gamma_deg'], abs=1e-4)
    # A level bench cannot see the board's roll: the toolface is the board's (issue 19).
    assert values['toolface_zero'] == 'board'
    assert values['toolface_zero_meaning'] == TOOLFACE_ZEROS['board']
    assert status.message.endswith('toolface zero: board')

    # ~/capture_high_side_mark: near vertical refused; on a 30 deg bench, mark up (toolface 0)
    # the zero is the mark's (this board has no roll: an offset within its 1 sigma).
    rng = np.random.default_rng(3)
    refused = probe.calibrate(lambda i: tilted_reading(1.0, 0.0, GAMMA_DEG, BETA_DEG)
                              + rng.normal(0.0, NOISE_MPS2, 3), service='capture_high_side_mark')
    assert not refused.success
    if axes == 2:
        assert 'needs a three-axis accelerometer' in refused.message
        assert node.stop() == 0
        return
    assert 'near vertical the toolface is undefined' in refused.message
    answer = probe.calibrate(lambda i: tilted_reading(30.0, 0.0, GAMMA_DEG, BETA_DEG)
                             + rng.normal(0.0, NOISE_MPS2, 3), service='capture_high_side_mark')
    assert answer.success, answer.message
    mark = load_model(tmp_path / 'calibration.json').toolface_mark
    assert abs(mark.offset_deg) < 4.0 * mark.std_deg and 'toolface_zero: mark' in answer.message
    probe.spin_until(lambda: calibration[-1]['toolface_zero'] == 'mark')
    assert latest_status(probe, ': calibration')[1]['toolface_zero'] == 'mark'
    assert node.stop() == 0


def test_refused_captures_keep_the_previous_calibration(start_node, probe, tmp_path):
    """Each refusal names its reason and leaves file and correction untouched."""
    start_node(**NODE, **{'level_capture.timeout_s': 5.0})
    probe.wait_for_node()
    assert probe.calibrate(level_samples()).success
    path = tmp_path / 'calibration.json'
    before = path.read_text()
    rng = np.random.default_rng(7)
    refusals = {
        # stamps 1 s apart: 0.05 deg a sample is 0.05 deg/s, beyond 0.02 deg/s.
        'tool is moving (drift 0.0500 deg/s': lambda i: tilted_reading(
            0.05 * i, 90.0, GAMMA_DEG, BETA_DEG),
        # a stable mean, but 0.3 deg of noise per sample: 0.03 deg from 100 samples.
        'too noisy for the target': lambda i: tilted_reading(
            rng.uniform(0.0, 1.0), 90.0, GAMMA_DEG, BETA_DEG),
        'bench is not level': lambda i: tilted_reading(8.0, 45.0, GAMMA_DEG, BETA_DEG),
        'implausible G-total': level_samples(scale=1.1),
    }
    for reason, samples in refusals.items():
        response = probe.calibrate(samples)
        assert not response.success
        assert reason in response.message and 'previous calibration kept' in response.message
        assert path.read_text() == before
        assert survey_of(probe, 3.0, 100.0).x == pytest.approx(3.0, abs=2 * ANGLE_TOL_DEG)

    # Two calls, no samples: one is refused at once, the other times out.
    first = probe.client.call_async(Trigger.Request())
    second = probe.client.call_async(Trigger.Request())
    probe.spin_for(8.0)
    answers = sorted([first.result().message, second.result().message])
    assert any('already running' in a for a in answers)
    assert any('no data: 0 of 100 samples' in a for a in answers)
    assert path.read_text() == before


def test_calibration_persists_across_a_restart(start_node, probe, tmp_path):
    """A restarted node loads the file and corrects without a new capture."""
    node = start_node(**NODE)
    probe.wait_for_node()
    assert probe.calibrate(level_samples()).success
    assert node.stop() == 0
    restarted = start_node(**NODE)
    probe.wait_for_node()
    assert survey_of(probe, 4.0, 250.0).x == pytest.approx(4.0, abs=2 * ANGLE_TOL_DEG)
    assert f'loaded {tmp_path / "calibration.json"}' in restarted.log()


@pytest.mark.parametrize('content, reason', [
    ('{"format": "inclino_ros.calibration", "schema_vers', 'not valid JSON'),
    (json.dumps({'format': 'inclino_ros.calibration', 'schema_version': 2,
                'accelerometer_axes': 3, 'installation': {
                    'gamma_deg': float('nan'), 'beta_deg': 0.1, 'sample_count': 100,
                    'std_deg': 0.01, 'g_total_mps2': 9.8,
                    'captured_at': '2026-01-01T00:00:00+00:00'}}),
     'installation.gamma_deg = nan is not a finite number'),
])
def test_a_corrupt_calibration_file_stops_the_node(start_node, tmp_path, content, reason):
    """A file that cannot be trusted is a loud error and a non-zero exit."""
    path = tmp_path / 'calibration.json'
    path.write_text(content)
    node = start_node()
    code = node.process.wait(timeout=30)
    assert code != 0
    assert str(path) in node.log() and 'refusing to start' in node.log()
    assert reason in node.log()


def test_bad_samples_are_dropped_counted_and_good_ones_answered(start_node, ros):
    """NaN, Inf, zero and saturated samples give no angle; diagnostics count them."""
    start_node()
    probe = Probe(best_effort=True)  # a best-effort publisher is accepted too
    try:
        probe.wait_for_node()
        # A best-effort sample sent before the node's reader has discovered the probe is
        # lost: a first good sample answered says it has (and the counts are taken from it).
        probe.survey_for(lambda: probe.publish(tilted_reading(10.0, 0.0)))
        _, before = latest_status(probe, ': input')
        probe.clear()
        bad = [(math.nan, 0.0, G), (0.0, math.inf, G), (0.0, 0.0, 0.0), (0.0, 0.0, 25.0),
               (0.0, -math.inf, G)]
        first = probe.sent
        for reading in bad:
            probe.publish(reading)
        good = probe.publish(tilted_reading(10.0, 0.0))
        probe.spin_until(lambda: any(s.header.stamp.sec == good
                                     for s in probe.received['survey']))
        # In order on the one writer: the bad ones were taken before the good one.
        surveys = [s for s in probe.received['survey'] if s.header.stamp.sec >= first]
        assert [s.header.stamp.sec for s in surveys] == [good]
        assert surveys[0].vector.x == pytest.approx(10.0, abs=1e-9)
        status, values = latest_status(probe, ': input')
        counts = {key: int(values[key]) - int(before[key]) for key in (
            'dropped_non_finite', 'dropped_zero', 'dropped_saturated', 'accepted_total')}
        assert counts == {'dropped_non_finite': 3, 'dropped_zero': 1, 'dropped_saturated': 1,
                          'accepted_total': 1}
        calibration, _ = latest_status(probe, ': calibration')
        assert calibration.level == DiagnosticStatus.WARN
        assert 'uncalibrated' in calibration.message
    finally:
        probe.destroy()


def test_an_unwritable_calibration_file_refuses_and_keeps_the_correction(start_node, probe):
    """When the file cannot be written the capture is refused and nothing is applied."""
    # /proc takes no new folders, even from root: the file is missing and cannot be made.
    path = '/proc/inclino-ros-test/calibration.json'
    start_node(**NODE, calibration_file=path)
    probe.wait_for_node()
    response = probe.calibrate(level_samples())
    assert not response.success
    assert f'cannot write {path}' in response.message
    # Still uncalibrated: the misaligned reading's own inclination comes out.
    reading = tilted_reading(2.0, 30.0, GAMMA_DEG, BETA_DEG)
    assert survey_of(probe, 2.0, 30.0).x == pytest.approx(
        math.degrees(math.acos(reading[2] / np.linalg.norm(reading))), abs=1e-6)


def test_capture_progress_and_calibration_are_latched_topics(start_node, probe, tmp_path):
    """A late subscriber sees the calibration; a capture reports its progress, then its answer."""
    start_node(**{'level_capture.samples': 200, 'level_capture.timeout_s': 10.0})
    probe.wait_for_node()
    calibration = probe.listen_latched('/inclinometer/calibration')
    progress = probe.listen_latched('/inclinometer/capture_progress')
    probe.spin_for(1.0)
    assert calibration[-1]['stages'] == [] and calibration[-1]['model']['accelerometer_axes'] == 3
    assert calibration[-1]['calibration_file'] == str(tmp_path / 'calibration.json')

    response = probe.calibrate(level_samples(), rate_hz=200.0)
    assert response.success, response.message
    probe.spin_for(0.5)
    collecting = [p for p in progress if p['state'] == 'collecting']
    assert len(collecting) >= 3          # 200 samples at 200 Hz, a report every 0.2 s
    assert all(p['service'] == 'calibrate_level' and p['needed'] == 200 for p in collecting)
    counts = [p['samples'] for p in collecting]
    assert counts == sorted(counts) and counts[0] < 200
    assert all(0.0 < p['time_left_s'] <= 10.0 for p in collecting)   # of level_capture.timeout_s
    assert all(p['elapsed_s'] + p['time_left_s'] == pytest.approx(10.0, abs=2e-3)
               for p in collecting)
    # The spread of still noisy samples: 0.002 m/s^2 per axis is ~0.016 deg about the mean.
    assert 0.005 < collecting[-1]['spread_deg'] < 0.05
    assert progress[-1] == {'service': 'calibrate_level', 'state': 'succeeded',
                            'message': response.message}
    assert calibration[-1]['stages'] == ['installation']
    assert calibration[-1]['model'] == json.loads((tmp_path / 'calibration.json').read_text())

    refused = probe.call('solve_stand_calibration')
    probe.spin_for(0.3)
    assert progress[-1]['state'] == 'refused' and progress[-1]['message'] == refused.message


def test_samples_queued_before_a_capture_are_not_captured(start_node, probe, tmp_path):
    """
    50 samples of a tool tilted 3 deg wait in the node's queue when ~/calibrate_level comes.

    With a 0.1 s input_batch_period_s they are still queued when the call is
    taken; they are corrected and published first, and the capture holds only
    the level samples streamed after the call: gamma and beta are the level
    bench's (a capture that took the tilted ones would be refused as moving,
    or off by degrees).
    """
    start_node(**NODE, input_batch_period_s=0.1)
    probe.wait_for_node()
    tilted = tilted_reading(3.0, 45.0, GAMMA_DEG, BETA_DEG)
    for _ in range(50):
        probe.publish(tilted)
    response = probe.calibrate(level_samples())
    assert response.success, response.message
    angles = parse_angles(response.message)
    assert angles['gamma_deg'] == pytest.approx(GAMMA_DEG, abs=ANGLE_TOL_DEG)
    assert angles['beta_deg'] == pytest.approx(BETA_DEG, abs=ANGLE_TOL_DEG)
    assert load_model(tmp_path / 'calibration.json').installation.sample_count == \
        CAPTURE_SAMPLES


def test_a_slow_level_turn_is_refused_or_in_the_stated_sigma(start_node, probe, tmp_path):
    """
    Level captures turning too slowly to be significant state a 1 sigma that holds the turn.

    Issue 19 item 5, through ~/calibrate_level: 100 samples stamped 1 s apart
    turning 1.5e-4 deg/s put a capture's ends h = 0.0074 deg from its mean,
    3.6 times the fitted drift's standard error at the ends (sqrt(3) times the
    mean's, 0.0020 deg): rarely significant at 1e-6.  Accepted, the saved
    1 sigma of the tilt (``Installation``: std_deg / sqrt(N)) should put both
    ends within 2 sigma; else the capture is refused as moving.  Whether one
    capture's does depends on its noise (core.stillness, "Slow turns": a turn
    near the noise is partly covered) and on which samples it takes (when the
    call is taken), so the test counts over 16 captures.  Of 3000 captures of
    this stream (solve_level_capture with the node's limits) 4 % were refused
    and 13 % accepted uncovered: more than 9 of 16 uncovered has a probability
    below 1e-5.  Before the rule every accepted capture kept the noise's
    1 sigma, 0.0012 deg, and none held the turn (failed first).
    """
    captures, max_uncovered = 16, 9
    start_node(**NODE)
    probe.wait_for_node()
    rng = np.random.default_rng(3)
    rate_deg = 1.5e-4
    half_turn_deg = rate_deg * (CAPTURE_SAMPLES - 1) / 2
    uncovered = []
    for _ in range(captures):
        response = probe.calibrate(
            lambda i: tilted_reading(rate_deg * i, 90.0, GAMMA_DEG, BETA_DEG)
            + rng.normal(0.0, NOISE_MPS2, 3), rate_hz=500.0)
        if not response.success:
            assert 'tool is moving' in response.message, response.message
            continue
        saved = load_model(tmp_path / 'calibration.json').installation
        sigma_deg = math.degrees(saved.tilt_std_rad)
        if 2.0 * sigma_deg < half_turn_deg:
            uncovered.append(sigma_deg)
    assert len(uncovered) <= max_uncovered, (uncovered, half_turn_deg)
