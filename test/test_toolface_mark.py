"""
The high-side mark (issue 19 item 6): the toolface's zero tied without a stand.

Truth from the physical simulator (``sim.sensor_model``): a board rolled 20 deg about
the tool axis on a misaligned mount.  A level bench cannot see the roll: every toolface
is 20 deg off under a 1 sigma of hundredths.  A still capture with the tool's high-side
mark up on a 30 deg bench (``inclino fit-toolface-mark``) ties it: the toolface then
reads the tool's within its 1 sigma (which now holds the mark's own), the azimuth and
the inclination are unchanged (a turn of G and B together about the tool axis).
"""

import csv
from dataclasses import replace
import json
import math

from inclino_ros.calibration.model import CalibrationModel, load_model, model_from_dict
from inclino_ros.calibration.stations import raw_survey_inputs
from inclino_ros.core.magnetics import azimuth_deg, iscwsa_from_tool
from inclino_ros.pipeline import MagneticSettings, run, Settings
from inclino_ros.sim import sensor_model
import numpy as np
import pytest
from shots_sim import angle_error_deg
from test_msa_cli import quiet
from test_plausibility import ALL_STAGES

NOISE_MPS2 = 0.01
ROLL_DEG = 20.0
CAPTURE = 600
STATION_SAMPLES = 400
TOOL = replace(sensor_model.IDEAL,
               accelerometer=replace(sensor_model.IDEAL.accelerometer, noise_std=NOISE_MPS2),
               mount=sensor_model.Mount(gamma_deg=0.8, beta_deg=-1.2, roll_deg=ROLL_DEG))


def write_rows(path, header, rows):
    """Write a CSV file."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(header)
        writer.writerows(rows)


def capture_csv(path, inclination_deg, toolface_deg, rng):
    """Write a still capture of the tool (CAPTURE samples, 100 Hz) as fit-level's CSV."""
    accel = sensor_model.read(TOOL, np.full(CAPTURE, inclination_deg),
                              np.full(CAPTURE, toolface_deg), rng=rng).accel_mps2
    write_rows(path, ['time_s', 'ax', 'ay', 'az'],
               [[k * 0.01, *a] for k, a in enumerate(accel)])


def survey(tmp_path, name, stations):
    """Return the rows of ``inclino survey`` of the station means with the calibration."""
    code, out, err = quiet(['survey', stations, '-o', tmp_path / f'{name}.csv',
                            '--calibration', tmp_path / 'cal.json',
                            '--noise-mps2', NOISE_MPS2, '--mag-noise-nT', 1.0])
    assert code == 0, err
    with open(tmp_path / f'{name}.csv', newline='') as stream:
        return list(csv.DictReader(stream)), out


def test_the_mark_ties_the_toolface_the_level_bench_leaves_off(tmp_path):
    """Board only: off by the roll, zero 'board'; with the mark: within 4 sigma, zero 'mark'."""
    rng = np.random.default_rng(6)
    capture_csv(tmp_path / 'level.csv', 0.0, 0.0, rng)
    code, out, err = quiet(['fit-level', tmp_path / 'level.csv', '--calibration',
                            tmp_path / 'cal.json'])
    assert code == 0, err
    assert 'toolface_zero: board' in out
    incl, tf = rng.uniform(10.0, 170.0, 40), rng.uniform(0.0, 360.0, 40)
    azim = rng.uniform(0.0, 360.0, 40)
    readings = sensor_model.read(TOOL, np.repeat(incl, STATION_SAMPLES),
                                 np.repeat(tf, STATION_SAMPLES), np.repeat(azim, STATION_SAMPLES),
                                 rng=rng)
    means = [r.reshape(40, STATION_SAMPLES, 3).mean(axis=1)
             for r in (readings.accel_mps2, readings.mag_nT)]
    write_rows(tmp_path / 'stations.csv', ['ax', 'ay', 'az', 'bx', 'by', 'bz', 'samples'],
               [[*a, *b, STATION_SAMPLES] for a, b in zip(*means)])
    board, _ = survey(tmp_path, 'board', tmp_path / 'stations.csv')
    error = angle_error_deg(np.array([float(r['toolface_deg']) for r in board]), tf)
    sigma = np.array([float(r['toolface_std_deg']) for r in board])
    # The board-only 1 sigma (noise, level bench; up to ~0.07 deg at I = 10 deg) is hundreds of
    # times smaller than the 20 deg it leaves out.
    assert np.all(np.abs(error + ROLL_DEG) < 4.0 * sigma) and sigma.max() < 0.1
    assert {r['toolface_zero'] for r in board} == {'board'}

    capture_csv(tmp_path / 'mark.csv', 30.0, 0.0, rng)   # high-side mark up: toolface 0
    code, out, err = quiet(['fit-toolface-mark', tmp_path / 'mark.csv', '--calibration',
                            tmp_path / 'cal.json'])
    assert code == 0, err
    assert 'toolface_zero: mark\ntoolface_zero_meaning: calibrated' in out
    model = load_model(tmp_path / 'cal.json')
    mark = model.toolface_mark
    assert model.installation is not None and model.toolface_zero == 'mark'
    # Its 1 sigma: the capture's tilt standard error over sin I (white noise, closed form).
    expected_std_deg = math.degrees(NOISE_MPS2 / 9.80665 / math.sqrt(CAPTURE)) / 0.5
    assert abs(mark.std_deg / expected_std_deg - 1.0) < 0.15
    assert abs(mark.offset_deg + ROLL_DEG) < 4.0 * mark.std_deg
    marked, _ = survey(tmp_path, 'marked', tmp_path / 'stations.csv')
    error = angle_error_deg(np.array([float(r['toolface_deg']) for r in marked]), tf)
    marked_sigma = np.array([float(r['toolface_std_deg']) for r in marked])
    assert np.all(np.abs(error) < 4.0 * marked_sigma)
    assert {r['toolface_zero'] for r in marked} == {'mark'}
    # The mark's own sigma enters every toolface's (independent, in quadrature).
    np.testing.assert_allclose(marked_sigma ** 2, sigma ** 2 + mark.std_deg ** 2, rtol=1e-3)
    for name in ('inclination_deg', 'azimuth_deg', 'inclination_std_deg'):
        np.testing.assert_allclose([float(r[name]) for r in marked],
                                   [float(r[name]) for r in board], rtol=0, atol=1e-9)


def test_near_vertical_is_refused_and_keeps_the_file(tmp_path):
    """A capture 2 deg off vertical has no high side: refused with the reason, file unchanged."""
    rng = np.random.default_rng(7)
    capture_csv(tmp_path / 'mark.csv', 2.0, 0.0, rng)
    (tmp_path / 'cal.json').write_text(json.dumps(CalibrationModel(3).to_dict()))
    before = (tmp_path / 'cal.json').read_text()
    code, _, err = quiet(['fit-toolface-mark', tmp_path / 'mark.csv', '--calibration',
                          tmp_path / 'cal.json'])
    assert code == 1
    assert 'deg from vertical: near vertical the toolface is undefined' in err
    assert (tmp_path / 'cal.json').read_text() == before


def test_the_mark_turns_both_triads_about_the_tool_axis():
    """The stage: toolface moved by -offset, inclination and azimuth kept; file round trip."""
    rng = np.random.default_rng(8)
    incl, tf, azim = rng.uniform(5, 175, 50), rng.uniform(0, 360, 50), rng.uniform(0, 360, 50)
    ideal = replace(sensor_model.IDEAL, mount=sensor_model.Mount())
    readings = sensor_model.read(ideal, incl, tf, azim, rng=rng)
    doc = {'format': 'inclino_ros.calibration', 'schema_version': 11, 'accelerometer_axes': 3,
           'toolface_mark': {'offset_deg': 12.5, 'std_deg': 0.01, 'inclination_deg': 30.0,
                             'toolface_convention': 'seed000', 'sample_count': 600,
                             'captured_at': '2026-11-26T00:00:00+00:00',
                             'temperature_c': None}}
    marked = model_from_dict(doc)
    assert model_from_dict(json.loads(json.dumps(marked.to_dict()))) == marked
    settings, field = Settings(), MagneticSettings(50000.0, 60.0)
    plain = run(readings.accel_mps2, CalibrationModel(3), settings, None, readings.mag_nT, field)
    turned = run(readings.accel_mps2, marked, settings, None, readings.mag_nT, field)
    np.testing.assert_allclose(angle_error_deg(turned.toolface_deg, plain.toolface_deg), -12.5,
                               atol=1e-9)
    np.testing.assert_allclose(turned.inclination_deg, plain.inclination_deg, atol=1e-9)
    np.testing.assert_allclose(angle_error_deg(turned.magnetic.azimuth_deg,
                                               plain.magnetic.azimuth_deg), 0.0, atol=1e-9)
    np.testing.assert_allclose(turned.magnetic.azimuth_std_deg, plain.magnetic.azimuth_std_deg,
                               rtol=1e-6)
    doc['toolface_mark']['inclination_deg'] = 1.0
    with pytest.raises(ValueError, match='toolface_mark.inclination_deg'):
        model_from_dict(doc)


def test_msa_stations_keep_g_and_b_in_one_frame():
    """The MSA's G of raw survey readings skips the mark as B does: its azimuth is the same."""
    rng = np.random.default_rng(9)
    incl, tf, azim = rng.uniform(10, 80, 20), rng.uniform(0, 360, 20), rng.uniform(0, 360, 20)
    readings = sensor_model.read(replace(sensor_model.IDEAL, mount=sensor_model.Mount()),
                                 incl, tf, azim, rng=rng)
    gravity = -iscwsa_from_tool(readings.accel_mps2) / 9.80665
    field = iscwsa_from_tool(readings.mag_nT)
    plain = CalibrationModel(3, installation=ALL_STAGES.installation)
    marked = replace(plain, toolface_mark=ALL_STAGES.toolface_mark)
    azimuths = [azimuth_deg(*raw_survey_inputs(model, gravity, field, 9.80665))
                for model in (plain, marked)]
    np.testing.assert_allclose(angle_error_deg(azimuths[1], azimuths[0]), 0.0, atol=1e-9)
    np.testing.assert_allclose(marked.before_mark(marked.apply(readings.accel_mps2)),
                               plain.apply(readings.accel_mps2), atol=1e-12)
