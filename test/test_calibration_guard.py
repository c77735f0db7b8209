"""
Who may change the calibration, through the real node (issues 23 and 21).

- Field mode (``field_mode:=true``, read-only): every service and parameter
  that would change the calibration is refused, nothing is written, the
  correction goes on unchanged (before: any node on the domain could rewrite it).
- A write never erases what another writer put in the file meanwhile: the node
  refuses when the file changed under it (before: it wrote back the model it
  loaded at start, dropping the stages an ``inclino fit-*`` had just written).
- Every node write is a version in the file's history.
"""

import os
import subprocess

from diagnostic_msgs.msg import DiagnosticStatus
from inclino_ros.calibration.model import (
    CalibrationModel, Installation, load_model, read_model_history, save_model, utc_now_iso)
import pytest
from rclpy.parameter import Parameter
from ros_harness import installed_script
from test_calibration_history import level_csv
from test_node import (
    ANGLE_TOL_DEG, BETA_DEG, GAMMA_DEG, latest_status, level_samples, NODE, survey_of)

CHANGING = ('calibrate_level', 'solve_stand_calibration', 'capture_rotation', 'solve_msa')
LOCKED = 'refused: the calibration is locked (field mode)'


def refused_parameters(probe, **values):
    """Try to set parameters; return the reasons of those refused."""
    future = probe.parameters.set_parameters(
        [Parameter(name, value=value) for name, value in values.items()])
    probe.executor.spin_until_future_complete(future, timeout_sec=10.0)
    return [r.reason for r in future.result().results if not r.successful]


def test_field_mode_refuses_every_change_and_keeps_correcting(start_node, probe, tmp_path):
    """Four services, a live parameter, field_mode itself: refused; file and outputs unchanged."""
    path = tmp_path / 'calibration.json'
    save_model(path, CalibrationModel(3, installation=Installation(
        gamma_deg=GAMMA_DEG, beta_deg=BETA_DEG, captured_at=utc_now_iso(),
        sample_count=100, std_deg=0.01, g_total_mps2=9.80665)))
    before = path.read_bytes()
    node = start_node(**NODE, field_mode='true', **{'magnetic.reference_total_nT': 50000.0,
                                                    'magnetic.reference_dip_deg': 60.0})
    probe.wait_for_node()
    survey = survey_of(probe, 2.0, 30.0)
    assert survey.x == pytest.approx(2.0, abs=ANGLE_TOL_DEG)
    for service in CHANGING:
        response = probe.call(service)
        assert not response.success and response.message.startswith(LOCKED), response.message
    reasons = refused_parameters(probe, **{'level_capture.samples': 10})
    assert reasons == [LOCKED]
    assert refused_parameters(probe, field_mode=False)  # read-only: never switched off remotely
    assert path.read_bytes() == before
    assert len(read_model_history(path)[0]) == 1
    again = survey_of(probe, 2.0, 30.0)
    assert (again.x, again.y) == (survey.x, survey.y)
    status, values = latest_status(probe, ': calibration')
    assert values['calibration_mode'].startswith('field (locked')
    assert status.level == DiagnosticStatus.OK
    assert 'calibration mode: field' in node.log()
    response = probe.call('clear_positions')  # a request that changes no calibration
    assert response.success


def test_the_node_never_writes_over_an_offline_fit(start_node, probe, tmp_path):
    """calibrate_level, then an inclino fit-level on the file: the node's next write is refused."""
    path = tmp_path / 'calibration.json'
    node = start_node(**NODE)
    probe.wait_for_node()
    assert 'calibration mode: bench' in node.log()
    assert probe.calibrate(level_samples()).success
    offline = subprocess.run(
        [installed_script('inclino'), 'fit-level', level_csv(tmp_path / 'a.csv', gamma_deg=0.3),
         '--calibration', str(path), '--report-dir', str(tmp_path / 'reports')],
        capture_output=True, text=True, timeout=120)
    assert offline.returncode == 0, offline.stderr
    written = path.read_bytes()
    response = probe.calibrate(level_samples(seed=2))
    assert not response.success and 'changed on disk since it was read' in response.message
    assert path.read_bytes() == written
    assert load_model(path).installation.gamma_deg == pytest.approx(0.3, abs=0.01)
    versions, problems = read_model_history(path)
    assert problems == []
    assert [v.writer for v in versions] == ['node /inclinometer/calibrate_level',
                                            'inclino fit-level']


@pytest.mark.parametrize('which', ['calibration_file', 'stations_file'])
def test_a_fifo_as_the_nodes_file_stops_it_with_the_reason(start_node, tmp_path, which):
    """Before, the node waited for ever on the FIFO's writer; now it exits 1 naming it."""
    fifo = tmp_path / 'fifo.json'
    os.mkfifo(fifo)
    node = start_node(**{which: str(fifo)})
    assert node.process.wait(timeout=60) == 1
    assert 'FIFO' in node.log()


def test_a_damaged_history_never_stops_the_node(start_node, probe, tmp_path):
    """A version edited by hand: the node loads the file, corrects, and reports the damage."""
    path = tmp_path / 'calibration.json'
    save_model(path, CalibrationModel(3, installation=Installation(
        gamma_deg=GAMMA_DEG, beta_deg=BETA_DEG, captured_at=utc_now_iso(),
        sample_count=100, std_deg=0.01, g_total_mps2=9.80665)))
    entry = tmp_path / 'calibration.json.history' / 'v000001.json'
    entry.write_text(entry.read_text().replace('gamma_deg', 'gamma_deX'))
    node = start_node(**NODE)
    probe.wait_for_node()
    assert survey_of(probe, 2.0, 30.0).x == pytest.approx(2.0, abs=ANGLE_TOL_DEG)
    _, values = latest_status(probe, ': calibration')
    assert values['history_problems'].startswith('version 1 (')
    assert 'does not match its sha256' in node.log()
