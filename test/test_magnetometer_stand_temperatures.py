"""
The magnetometer on a stand at several temperature plateaus (issue 18): K_m(T), b_m(T).

Truth from the physical simulator alone: ``sim.bench.drifting_magnetometer_tool`` (MEMS triads
on a board that tilts 0.3 deg over 28..60 deg C; the magnetometer's bracket turns a further
0.2 deg about y and 0.1 deg about z over that span and its z bias drifts 400 nT, on top of the
preset's drifts).  Twelve positions with azimuths (``FIELD_STAND_POSITIONS_DEG``) at 28, 44,
60 deg C, 100 samples each: 20 nT per sample averages to 2 nT, leaving each plateau's K_m
elements ~2e-5 (1 sigma, reported), a field direction ~0.002 deg off (measured 0.0034 deg max
at 400 held-out attitudes).  The azimuth of held-out attitudes (inclination 10..170 deg, read
noise-free) divides that by up to sin(10 deg) cos(60 deg) ~ 0.09 (measured 0.008 deg max):
0.1 deg is several sigma.
One K_m over all three plateaus (main) cannot hold the turn: the field residual of its own
positions is 0.35 deg RMS (refused beyond the default 0.1 deg) and, the limit raised, the
held-out azimuths go 0.61 deg RMS, 1.5 deg max off at 28 and 60 deg C.
"""

import csv

from inclino_ros.calibration.model import CalibrationModel, load_model
from inclino_ros.calibration.stand_capture import average_position, solve_positions
from inclino_ros.core.stillness import StillLimits
from inclino_ros.io import bag
from inclino_ros.pipeline import MagneticSettings, run, Settings
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import (
    drifting_magnetometer_tool, field_plateau_stand, FIELD_STAND_POSITIONS_DEG)
import numpy as np
import pytest
from shots_sim import angle_error_deg, random_attitudes
from test_magnetometer_stand import noiseless
from test_msa_cli import quiet

PLATEAUS_C = (28.0, 44.0, 60.0)
REFERENCE = ('--reference-total-nT', '50000', '--reference-dip-deg', '60')
MAX_AZIMUTH_DEG = 0.1
TOOL = drifting_magnetometer_tool()


def write_csv(path, columns):
    """Write ``{name: values}`` as a CSV file with a header row."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(zip(*(np.asarray(v).tolist() for v in columns.values())))


def azimuth_errors_deg(model, temperature_c, count=400, seed=3):
    """Return the azimuth errors [deg] of held-out attitudes read noise-free at a temperature."""
    incl, tf, azim = random_attitudes(np.random.default_rng(seed), count)
    readings = sm.read(noiseless(TOOL), incl, tf, azim, temperature_c=temperature_c)
    survey = run(readings.accel_mps2, model, Settings(), np.full(count, temperature_c),
                 readings.mag_nT, MagneticSettings())
    return angle_error_deg(survey.magnetic.defined_azimuth_deg, azim)


@pytest.fixture(scope='module')
def stand_csv(tmp_path_factory):
    """Return the path of the stand run at 28, 44 and 60 deg C as fit-stand's CSV."""
    path = tmp_path_factory.mktemp('stand') / 'multi.csv'
    write_csv(path, field_plateau_stand(TOOL, PLATEAUS_C))
    return path


def test_the_magnetometer_turns_with_the_temperature():
    """The simulator: the field read at 60 deg C is turned ~0.3 deg from 28 deg C's, noise-free."""
    quiet_tool = noiseless(TOOL)
    at = {t: sm.read(quiet_tool, 45.0, 30.0, 100.0, temperature_c=t) for t in (28.0, 60.0)}
    # Remove the bias drift the simulator adds so that only the turn shows.
    bias = {t: TOOL.magnetometer.bias_at(t)[0] for t in at}
    field = {t: at[t].mag_nT[0] - bias[t] for t in at}
    cosine = field[28.0] @ field[60.0] / np.linalg.norm(field[28.0]) / np.linalg.norm(
        field[60.0])
    turn_deg = np.degrees(np.arccos(min(1.0, cosine)))
    assert 0.1 < turn_deg < 0.6, turn_deg
    assert TOOL.mount.at(60.0).magnetometer_deg[1] - TOOL.mount.at(28.0).magnetometer_deg[1] \
        == pytest.approx(0.2)


def test_fit_stand_writes_k_m_and_b_m_of_t(stand_csv, tmp_path):
    """
    Inclino fit-stand over 28, 44, 60 deg C with bx, by, bz: K_m(T), b_m(T) applied at T.

    Main fitted one K_m to all 36 positions: refused (field residual 0.35 deg RMS beyond the
    limit 0.1) or, with the limit raised, azimuths 1.5 deg off at the ends; here every
    temperature of the range within MAX_AZIMUTH_DEG (measured 0.008 deg max), residual and
    1 sigma reported per plateau.
    """
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-stand', stand_csv, *REFERENCE, '--calibration', calibration])
    assert code == 0, err
    assert out.count('positions at 3 temperature plateaus: K(T) and b(T)') == 2, out
    assert 'plateau  60.00 C: 12 positions, RMS field residual' in out
    model = load_model(calibration)
    magnetometer = model.magnetometer
    assert magnetometer.temperature_dependent and len(magnetometer.scale_coefficients) >= 2
    assert (magnetometer.t_min_c, magnetometer.t_max_c, magnetometer.temperature_c) == (
        28.0, 60.0, 44.0)
    worst = {t: np.abs(azimuth_errors_deg(model, t)).max() for t in (28.0, 36.0, 44.0, 52.0,
                                                                     60.0)}
    assert max(worst.values()) <= MAX_AZIMUTH_DEG, worst
    # Held at the range's end beyond it, and said so by survey.
    np.testing.assert_array_equal(magnetometer.at(70.0)[1], magnetometer.at(60.0)[1])
    incl, tf, azim = random_attitudes(np.random.default_rng(8), 2)
    readings = sm.read(noiseless(TOOL), incl, tf, azim, temperature_c=[44.0, 70.0])
    write_csv(tmp_path / 'shots.csv', {
        'ax': readings.accel_mps2[:, 0], 'ay': readings.accel_mps2[:, 1],
        'az': readings.accel_mps2[:, 2], 'bx': readings.mag_nT[:, 0],
        'by': readings.mag_nT[:, 1], 'bz': readings.mag_nT[:, 2],
        'temperature_c': [44.0, 70.0]})
    code, _, err = quiet(['survey', tmp_path / 'shots.csv', '-o', tmp_path / 'out.csv',
                          '--calibration', calibration, *REFERENCE])
    assert code == 0, err
    assert "1 of 2 temperature readings lie outside the magnetometer stage's fitted range " \
           '28 .. 60 C' in err


def test_one_constant_k_m_cannot_hold_the_turn(stand_csv, tmp_path):
    """The same stand with one plateau's positions only: constant K_m, azimuth off at 60 C."""
    table = np.genfromtxt(stand_csv, delimiter=',', names=True)
    first = table['temperature_c'] == 28.0
    write_csv(tmp_path / 'one.csv', {name: table[name][first] for name in table.dtype.names})
    code, _, err = quiet(['fit-stand', tmp_path / 'one.csv', *REFERENCE, '--calibration',
                          tmp_path / 'one.json'])
    assert code == 0, err
    model = load_model(tmp_path / 'one.json')
    assert not model.magnetometer.temperature_dependent
    assert np.abs(azimuth_errors_deg(model, 28.0)).max() <= MAX_AZIMUTH_DEG
    assert np.abs(azimuth_errors_deg(model, 60.0)).max() > 3 * MAX_AZIMUTH_DEG


def test_the_node_rule_fits_k_m_of_t_from_captured_positions():
    """
    ``stand_capture.solve_positions`` (the node's ``~/solve_stand_calibration``): the same.

    Positions as the node averages them, each recording the temperature its field stood for.
    """
    columns = field_plateau_stand(TOOL, PLATEAUS_C)
    segment = np.repeat(np.arange(len(PLATEAUS_C) * len(FIELD_STAND_POSITIONS_DEG)), 100)
    positions = []
    for number in np.unique(segment):
        mine = segment == number
        accel = np.column_stack([columns[name][mine] for name in ('ax', 'ay', 'az')])
        field = np.column_stack([columns[name][mine] for name in ('bx', 'by', 'bz')])
        temperature = float(columns['temperature_c'][mine][0])
        positions.append(average_position(
            accel, columns['inclination_deg'][mine][0], columns['toolface_deg'][mine][0],
            StillLimits(max_sem_deg=1.0), temperature_c=temperature, fields_nT=field,
            azimuth_deg=columns['azimuth_deg'][mine][0], field_temperature_c=temperature))
    stand, field, note, _ = solve_positions(positions, sm.STANDARD_GRAVITY_MPS2, 0.05,
                                            (50000.0, 60.0), 0.05)
    assert note is None and stand.temperature_dependent
    assert field.magnetometer.temperature_dependent and field.plateaus.order >= 1
    assert field.plateau_rms_deg.shape == (3,) and field.plateau_rms_deg.max() < 0.01
    model = CalibrationModel(3, stand=stand, magnetometer=field.magnetometer,
                             magnetometer_alignment=field.alignment)
    for temperature in (28.0, 52.0, 60.0):
        assert np.abs(azimuth_errors_deg(model, temperature)).max() <= MAX_AZIMUTH_DEG


def test_fit_stand_from_a_bag_with_the_temperature_topic(tmp_path):
    """The same stand as a bag (/imu/data_raw, /imu/mag, /stand/attitude, /imu/temperature)."""
    columns = field_plateau_stand(TOOL, PLATEAUS_C)
    count = columns['ax'].size
    stamps = np.arange(count, dtype=np.int64) * 5_000_000 + 10 ** 18
    frames = np.full(count, 'tool')
    path = str(tmp_path / 'stand_bag')
    with bag.BagWriter(path, 'mcap') as out:
        for topic, kind in (('/imu/data_raw', bag.IMU), ('/imu/mag', bag.MAGNETIC_FIELD),
                            ('/stand/attitude', bag.VECTOR3_STAMPED),
                            ('/imu/temperature', bag.TEMPERATURE)):
            out.add_topic(topic, kind)
        out.write_series({
            '/imu/data_raw': bag.raw_imu(stamps, 'tool', np.column_stack(
                [columns[name] for name in ('ax', 'ay', 'az')]), 2e-3),
            '/imu/mag': bag.magnetometer(stamps, 'tool', np.column_stack(
                [columns[name] for name in ('bx', 'by', 'bz')]), 20.0),
            '/stand/attitude': bag.Vector3Series(stamps, frames, np.column_stack(
                [columns[name] for name in ('inclination_deg', 'toolface_deg',
                                            'azimuth_deg')])),
            '/imu/temperature': bag.TemperatureSeries(stamps, frames, columns['temperature_c'],
                                                      np.zeros(count))})
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-stand', path, *REFERENCE, '--calibration', calibration])
    assert code == 0, err
    model = load_model(calibration)
    assert model.magnetometer.temperature_dependent and model.stand.temperature_dependent
    for temperature in (28.0, 44.0, 60.0):
        assert np.abs(azimuth_errors_deg(model, temperature)).max() <= MAX_AZIMUTH_DEG
