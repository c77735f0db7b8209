"""
Issue 10 through the live node: no request and no reading crashes it, nothing absurd sticks.

Before, a dead magnetometer's stations killed the node at ``~/solve_msa`` (``LinAlgError:
SVD did not converge``, again after every restart), zero readings plus one subnormal one
killed it at ``~/capture_rotation``, a 1e200 T field gave a published azimuth of 310.89 deg,
and bad start-up parameters or a stations path naming a folder ended in tracebacks.
The real node runs (``ros_harness``); a hypothesis fuzz drives every service with hostile
readings and checks the node lives on and a refusal leaves both files byte-identical.
"""

import json
import math
import os
import subprocess
import time

from diagnostic_msgs.msg import DiagnosticStatus
from hypothesis import given, HealthCheck, settings, strategies as st
from inclino_ros.calibration.model import CalibrationModel, load_model, save_model
from inclino_ros.node.capture import Capture, MAX_TIMED_ROWS
import numpy as np
import pytest
from ros_harness import G, NODE_EXECUTABLE
from test_node_magnetic import mag_message, readings, REFERENCE_DIP_DEG, REFERENCE_TOTAL_NT

DEAD = np.zeros(3)


def file_bytes(path):
    """Return the content of ``path``, None if there is none."""
    return path.read_bytes() if path.exists() else None


@pytest.fixture
def magnetic_node(start_node, probe):
    """Start a node with a reference field and short captures; return (node, probe)."""
    def start(**parameters):
        node = start_node(**{'magnetic.reference_total_nT': REFERENCE_TOTAL_NT,
                             'magnetic.reference_dip_deg': REFERENCE_DIP_DEG,
                             'rotation.duration_s': 1.0, 'survey.samples': 10,
                             'survey.timeout_s': 3.0, **parameters})
        probe.wait_for_node()
        return node, probe
    return start


def turned(force, angle_deg):
    """Return ``force`` turned about the tool axis (another toolface, the same |G|)."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    return (c * force[0] - s * force[1], s * force[0] + c * force[1], force[2])


def paired(probe, force, field_nT):
    """Return a sample function publishing ``field_nT`` paired with ``force``."""
    return lambda i: probe.mag_publisher.publish(mag_message(probe.sent, field_nT)) or force


@pytest.mark.parametrize('method', ['classic', 'axial'])
def test_a_dead_magnetometer_does_not_kill_the_node(magnetic_node, tmp_path, method):
    """Stations of a 0 T magnetometer are refused; stored ones make solve_msa refuse, not die."""
    node, probe = magnetic_node(**{'msa.method': method})
    for k in range(7):
        answer = probe.calibrate(paired(probe, readings(30 + 5 * k, 90.0, 50.0 * k)[0], DEAD),
                                 service='take_survey')
        assert not answer.success and 'dead magnetometer' in answer.message
    assert not (tmp_path / 'stations.json').exists()
    answer = probe.call('solve_msa')
    assert not answer.success and node.process.poll() is None
    node.stop()

    # The stations of an older version, dead field and all: loaded, and refused at the solve.
    station = {'field_nT': [0.0, 0.0, 0.0], 'samples': 10,
               'captured_at': '2026-01-01T00:00:00+00:00'}
    (tmp_path / 'stations.json').write_text(json.dumps({
        'format': 'inclino_ros.calibration.stations', 'schema_version': 1,
        'stations': [dict(station, specific_force_mps2=list(readings(30 + 5 * k, 90.0,
                                                                     50.0 * k)[0]))
                     for k in range(7)]}))
    node, probe = magnetic_node(**{'msa.method': method})
    for _ in range(2):
        answer = probe.call('solve_msa')
        assert not answer.success and '|B|' in answer.message, answer.message
        assert node.process.poll() is None
    assert not (tmp_path / 'calibration.json').exists()
    assert node.stop() == 0


def test_zero_readings_and_a_subnormal_one_are_refused(magnetic_node, tmp_path):
    """A rotation of zero readings and one subnormal killed the node (fit_ellipse)."""
    node, probe = magnetic_node()
    force = readings(60.0, 90.0, 0.0)[0]
    answer = probe.calibrate(
        lambda i: paired(probe, force, [1.0, 1e-310, 0.0] if i == 3 else DEAD)(i),
        service='capture_rotation')
    assert not answer.success and 'dead magnetometer' in answer.message
    assert node.process.poll() is None and not (tmp_path / 'calibration.json').exists()
    assert node.stop() == 0


def test_a_field_of_1e200_tesla_gives_no_azimuth(start_node, probe):
    """Without a reference, 1e200 T gave azimuth 310.89 deg; the reading is dropped, counted."""
    start_node()
    probe.wait_for_node()
    force = readings(60.0, 100.0, 30.0)[0]
    probe.mag_publisher.publish(mag_message(probe.sent, [1e200 * 1e9] * 3))
    probe.spin_for(0.1)
    probe.clear()
    probe.publish(force)
    (survey,) = probe.wait_outputs('survey', 1)
    assert math.isnan(survey.vector.z)
    _, values = probe.wait_status(': magnetics')
    assert values['rejected_implausible'] == '1'


@pytest.mark.parametrize('arguments,reason', [
    (['-p', 'gravity_mps2:=abc'], "expecting type 'DOUBLE'"),
    (['-p', 'gravity_mps2:=20.0'], 'out of range'),
    (['-p', 'accelerometer_axes:=7'], 'out of range'),
    (['-p', 'magnetic.reference_total_nT:=5.0'], 'an Earth field'),
    (['-p', 'calibration_file:=" "'], 'must name a file'),
    (['-p', 'output.rate_hz:=1e-12'], 'at least 0.01 Hz'),
    (['-p', 'output.rate_hz:=1e-300'], 'at least 0.01 Hz'),
    (['-p', 'gravity_mps2'], "Couldn't parse parameter override rule"),
    (['--params-file', '/nonexistent.yaml'], "Couldn't parse params file"),
])
def test_bad_start_up_parameters_are_one_line(tmp_path, arguments, reason):
    """Each was a traceback; now one line and exit code 1."""
    result = subprocess.run(
        [NODE_EXECUTABLE, '--ros-args', '-p', f'calibration_file:={tmp_path / "c.json"}',
         '-p', f'stations_file:={tmp_path / "s.json"}', *arguments],
        capture_output=True, text=True, timeout=60)
    log = result.stdout + result.stderr
    assert result.returncode == 1, log
    assert reason in log and 'Traceback' not in log and 'refusing to start' in log, log


def test_a_calibration_for_another_number_of_axes_is_one_line(tmp_path):
    """The node refuses a 3-axis file for a 2-axis sensor by the rule ``process`` uses."""
    path = tmp_path / 'c.json'
    save_model(str(path), CalibrationModel(accelerometer_axes=3))
    result = subprocess.run(
        [NODE_EXECUTABLE, '--ros-args', '-p', f'calibration_file:={path}',
         '-p', f'stations_file:={tmp_path / "s.json"}', '-p', 'accelerometer_axes:=2'],
        capture_output=True, text=True, timeout=60)
    log = result.stdout + result.stderr
    assert result.returncode == 1, log
    assert f'{path} is for a 3-axis accelerometer, not 2 axes' in log, log
    assert 'Traceback' not in log, log


def test_a_stations_file_that_is_a_folder(start_node, tmp_path):
    """A stations path naming a folder: one line naming it, exit 1 (IsADirectoryError before)."""
    node = start_node(stations_file=str(tmp_path))
    assert node.process.wait(timeout=30) == 1
    assert 'cannot be read' in node.log() and 'Traceback' not in node.log()


def test_a_timed_capture_holds_a_bounded_spread_of_samples():
    """capture_rotation grew ~115 bytes a sample for 600 s; now at most MAX_TIMED_ROWS rows."""
    capture = Capture(None)
    for i in range(5 * MAX_TIMED_ROWS + 123):
        capture.add((float(i), 0.0, G), None, (0.0, 0.0, 0.0), 0.01 * i)
    capture.expire()
    rows = capture.future.result()
    assert MAX_TIMED_ROWS // 2 <= rows.shape[0] <= MAX_TIMED_ROWS
    first = rows[:, 0]
    assert first[0] == 0.0 and first[-1] > 4.5 * MAX_TIMED_ROWS  # spread over the capture
    assert np.all(np.diff(first) == np.diff(first)[0])  # evenly
    np.testing.assert_allclose(rows[:, -1], 0.01 * first)  # each row keeps its stamp
    counted = Capture(7)
    for i in range(20):
        counted.add((float(i), 0.0, G), 25.0, (1.0, 2.0, 3.0), 0.01 * i)
    np.testing.assert_array_equal(counted.future.result()[:, 0], np.arange(7.0))


# --- fuzz -------------------------------------------------------------------------------

HOSTILE_FORCE = st.sampled_from([
    (0.0, 0.0, G), (math.nan, 0.0, G), (math.inf, 0.0, 0.0), (0.0, 0.0, 0.0),
    (5e-324, 0.0, 0.0), (1e300, 1e300, 1e300), (0.0, 0.0, 1.0), (3.0, -4.0, 8.5),
    (5.0, 0.0, 8.44), (0.0, 6.0, 7.75)])
HOSTILE_FIELD = st.sampled_from([
    (0.0, 0.0, 0.0), (5e-315, 0.0, 0.0), (1e209,) * 3, (math.nan, 0.0, 0.0),
    (20000.0, -10000.0, 40000.0), (2e6, 0.0, 0.0), (2e-5, 1e-5, 4e-5)])
SERVICES = ['calibrate_level', 'capture_position', 'solve_stand_calibration',
            'clear_positions', 'capture_rotation', 'take_survey', 'solve_msa', 'clear_surveys']


@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(force=HOSTILE_FORCE, field=HOSTILE_FIELD, stations=st.integers(0, 8),
       method=st.sampled_from(['improved', 'classic', 'axial']),
       others=st.lists(st.tuples(st.sampled_from(SERVICES), HOSTILE_FORCE, HOSTILE_FIELD),
                       max_size=3))
def test_every_service_under_hostile_readings(fuzz_node, force, field, stations, method,
                                              others):
    """
    Any service, any reading: an answer, a live node, and on refusal both files unchanged.

    Each example takes ``stations`` surveys of one hostile reading (turned about the tool
    axis by 137 deg each time), solves the MSA with ``method``, then calls ``others``.
    """
    node, probe, folder = fuzz_node
    probe.set_parameters(msa__method=method)
    probe.call('clear_surveys')
    steps = [('take_survey', turned(force, 137.0 * k), field)
             for k in range(stations)] + [('solve_msa', force, field)] + others
    for service, reading, reading_field in steps:
        before = file_bytes(folder / 'calibration.json'), file_bytes(folder / 'stations.json')
        if service in ('clear_positions', 'solve_stand_calibration', 'solve_msa',
                       'clear_surveys'):
            answer = probe.call(service)
        else:
            answer = probe.calibrate(paired(probe, reading, reading_field), service=service,
                                     timeout_s=15.0)
        assert answer is not None and isinstance(answer.message, str)
        assert node.process.poll() is None, node.log()[-2000:]
        after = file_bytes(folder / 'calibration.json'), file_bytes(folder / 'stations.json')
        if not answer.success:
            assert after == before, answer.message
        elif after[0] is not None:
            load_model(folder / 'calibration.json')  # what was written loads


@pytest.fixture
def fuzz_node(start_node, probe, tmp_path):
    """One node for every example of the fuzz: (node, probe, folder of its files)."""
    node = start_node(**{'magnetic.reference_total_nT': REFERENCE_TOTAL_NT,
                         'magnetic.reference_dip_deg': REFERENCE_DIP_DEG,
                         'rotation.duration_s': 1.0, 'survey.samples': 6,
                         'survey.timeout_s': 0.5, 'level_capture.samples': 6,
                         'level_capture.timeout_s': 0.5, 'stand.samples': 6,
                         'stand.timeout_s': 0.5})
    probe.wait_for_node()
    yield node, probe, tmp_path
    assert node.process.poll() is None
    assert os.path.exists(node.log_path)


def test_a_capture_under_sim_time_without_clock_ends(start_node, probe):
    """
    use_sim_time and no /clock: the capture's progress froze for ever; refused, named.

    /diagnostics came never (a timer on ROS time): it comes on wall time, and the input
    status says ROS time stood still, asking for /clock.
    """
    start_node(use_sim_time=True)
    probe.wait_for_node()
    status, _ = probe.wait_status(': input')
    assert status.level == DiagnosticStatus.WARN
    assert status.message.startswith('ROS time stood still since the last status: use_sim_time '
                                     'is set: does anything publish /clock?'), status.message
    started = time.monotonic()
    answer = probe.call('calibrate_level', timeout_s=60.0)
    assert answer is not None, 'no answer within 60 s'
    assert not answer.success and 'ROS time stood still' in answer.message, answer.message
    assert time.monotonic() - started >= 4.0   # not before the clock had a chance to tick
