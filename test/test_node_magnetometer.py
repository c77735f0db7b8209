"""
The magnetometer's stages live in the node (issue 8 items 2 and 6), over real rclpy.

Truth from the physical model (``shots_sim``, quartz/fluxgate, every error source).  Stand
positions of 20 paired readings (noise 1e-4 g and 5 nT per reading); the azimuths published
afterwards are compared with the truth within 0.1 deg (the stand target; noise of one
reading ~0.01 deg).
"""

import time

from diagnostic_msgs.msg import DiagnosticStatus
from inclino_ros.calibration.magnetometer import calibrate_from_shots
from inclino_ros.calibration.model import CalibrationModel, load_model, save_model
from inclino_ros.sim import sensor_model
import numpy as np
import pytest
import shots_sim
from shots_sim import angle_error_deg
from std_srvs.srv import Trigger
from test_magnetometer_stand import POSITIONS_DEG

SAMPLES = 20


def capture(probe, accel, field, timeout_s=20.0):
    """Call ~/capture_position while publishing paired readings; return the response."""
    future = probe.services['capture_position'].call_async(Trigger.Request())
    end, i = time.monotonic() + timeout_s, 0
    while not future.done() and time.monotonic() < end:
        probe.publish_pair(accel[i % len(accel)], field[i % len(field)])
        i += 1
        probe.executor.spin_once(timeout_sec=0.005)
    return future.result()


def azimuths_of(probe, accel, field):
    """Publish paired readings one by one; return the node's survey.z for each (``survey_for``)."""
    return np.array([probe.survey_for(lambda: probe.publish_pair(a, b), paired=True).vector.z
                     for a, b in zip(accel, field)])


def magnetics_status(probe):
    """Return a 'magnetics' diagnostics status built after the call, as (status, values)."""
    return probe.wait_status(': magnetics')


@pytest.fixture
def reference():
    """Return the node parameters of the reference field (50000 nT, dip 60 deg)."""
    return {'magnetic.reference_total_nT': 50000.0, 'magnetic.reference_dip_deg': 60.0}


def test_stand_calibrates_the_magnetometer_live(start_node, probe, tmp_path, reference):
    """
    Twelve positions with azimuths: K and K_m solved, applied, listed with their age.

    Captured at 33.5 C (no temperature stage): every stage made records it (issue 19 item 8;
    main's node left the magnetometer's stages without one).
    """
    node = start_node(**{'stand.samples': SAMPLES, **reference})
    probe.wait_for_node()
    probe.set_temperature(33.5)
    rng = np.random.default_rng(8)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    for number, (incl, tf, azim) in enumerate(POSITIONS_DEG, start=1):
        probe.set_parameters(stand__inclination_deg=float(incl), stand__toolface_deg=float(tf),
                             stand__azimuth_deg=float(azim))
        probe.spin_for(0.2)
        accel, field = shots_sim.read(tool, np.full(SAMPLES, incl), np.full(SAMPLES, tf),
                                      np.full(SAMPLES, azim), rng)
        answer = capture(probe, accel, field)
        assert answer.success, answer.message
        assert f'position {number} captured' in answer.message and 'field (' in answer.message
    solved = probe.call('solve_stand_calibration')
    assert solved.success and 'magnetometer K_m, b_m fitted' in solved.message, solved.message
    model = load_model(tmp_path / 'calibration.json')
    assert model.magnetometer.method == 'stand' and model.magnetometer_alignment.method == 'stand'
    assert (model.stand.temperature_c, model.magnetometer.temperature_c,
            model.magnetometer_alignment.temperature_c) == (33.5, 33.5, 33.5)

    incl, tf, azim = shots_sim.random_attitudes(rng, 8, min_inclination_deg=15.0)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng)
    assert np.max(np.abs(angle_error_deg(azimuths_of(probe, accel, field), azim))) < 0.1

    status, values = magnetics_status(probe)
    assert values['magnetometer_stages'] == 'magnetometer, magnetometer_alignment'
    assert float(values['magnetometer_age_s']) < 60.0
    assert values['magnetometer_method'] == 'stand'
    assert node.stop() == 0


def test_reference_free_file_is_applied_live(start_node, probe, tmp_path, reference):
    """A fit-magnetometer file (ellipsoid, alignment, tool axis) corrects the live azimuth."""
    rng = np.random.default_rng(9)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng)
    model = calibrate_from_shots(CalibrationModel(3), accel, field, group,
                                 reference_total_nT=50000.0).model
    save_model(tmp_path / 'calibration.json', model)
    start_node(**reference)
    probe.wait_for_node()
    incl, tf, azim = shots_sim.random_attitudes(rng, 8, min_inclination_deg=15.0)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng)
    assert np.max(np.abs(angle_error_deg(azimuths_of(probe, accel, field), azim))) < 0.3
    status, values = magnetics_status(probe)
    assert values['magnetometer_stages'] == ('magnetometer, magnetometer_alignment, '
                                             'tool_axis (shared)')
    assert status.level == DiagnosticStatus.OK and 'tool_axis_age_s' in values
