"""
Accelerometer-only tools (issue 18): survey without a magnetometer, raw angles, text labels.

The readings come from the physical simulator (``sim.sensor_model``: the MEMS tool on its
mount, 2e-4 g of noise per sample, 25 deg C).  Tolerances: one reading's inclination has
2e-4 rad = 0.0115 deg of noise per component; after the stand fit (100 samples a position,
K to ~1e-5) the error of a single shot stays below 0.06 deg (5 sigma).  The raw angles are
compared with their closed form, atan2(hypot(ax, ay), az) and atan2(ay, ax), to round-off.
"""

import csv
import math

from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import (
    make_tool, simulate_heating, simulate_stand, StandRun, TURNED_OVER_HEATING_ATTITUDES_DEG)
import numpy as np
import pytest
from test_msa_cli import quiet

G = 9.80665
NOISE_MPS2 = 2e-4 * G
TOOL = make_tool('mems', 0.8, -1.2, noise_mps2=NOISE_MPS2)


def write_csv(path, columns):
    """Write ``{name: values}`` as a CSV file with a header row."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(zip(*(list(v) for v in columns.values())))


def read_columns(path):
    """Return (header, {name: list of strings}) of a CSV file."""
    with open(path, newline='') as stream:
        rows = list(csv.DictReader(stream))
    return list(rows[0]), {name: [row[name] for row in rows] for name in rows[0]}


def shots(count, seed):
    """Return (inclination_deg, toolface_deg, readings (N, 3), temperatures) of random shots."""
    rng = np.random.default_rng(seed)
    incl = np.degrees(np.arccos(rng.uniform(-0.95, 0.99, count)))
    tf = rng.uniform(-180.0, 180.0, count)
    return incl, tf, sm.read(TOOL, incl, tf, rng=rng).accel_mps2, np.full(count, 25.0)


@pytest.fixture(scope='module')
def calibration(tmp_path_factory):
    """Return a calibration file with the stand stage of the simulated tool."""
    work = tmp_path_factory.mktemp('accel_only')
    run = simulate_stand(StandRun(TOOL))
    write_csv(work / 'stand.csv', {'inclination_deg': run.inclination_deg,
                                   'toolface_deg': run.toolface_deg, 'ax': run.raw_mps2[:, 0],
                                   'ay': run.raw_mps2[:, 1], 'az': run.raw_mps2[:, 2]})
    code, _, err = quiet(['fit-stand', work / 'stand.csv', '--calibration', work / 'cal.json'])
    assert code == 0, err
    return work / 'cal.json'


def test_survey_of_an_accelerometer_only_csv(calibration, tmp_path):
    """Ax, ay, az (and temperature_c) give inclination and toolface; no azimuth, said once."""
    incl, tf, readings, temperature = shots(100, 1)
    write_csv(tmp_path / 'in.csv', {'ax': readings[:, 0], 'ay': readings[:, 1],
                                    'az': readings[:, 2], 'temperature_c': temperature})
    code, out, err = quiet(['survey', tmp_path / 'in.csv', '-o', tmp_path / 'out.csv',
                            '--calibration', calibration])
    assert code == 0, err
    assert err.count('no bx, by, bz') == 1 and 'no azimuth' in err
    assert 'wrote' in out and 'azimuth' not in out
    header, columns = read_columns(tmp_path / 'out.csv')
    assert 'azimuth_deg' not in header and 'inclination_deg' in header
    got_incl = np.array(columns['inclination_deg'], dtype=float)
    got_tf = np.array(columns['toolface_deg'], dtype=float)
    assert np.abs(got_incl - incl).max() < 0.06
    assert np.abs((got_tf - tf + 180.0) % 360.0 - 180.0)[incl > 5.0].max() < 0.06 / math.sin(
        math.radians(5.0))
    raw_incl = np.degrees(np.arctan2(np.hypot(readings[:, 0], readings[:, 1]), readings[:, 2]))
    assert np.abs(raw_incl - incl).max() > 0.3    # the calibration did something


def test_survey_without_calibration_gives_the_raw_angles(tmp_path):
    """No --calibration: the angles of the raw readings, said on stderr."""
    _, _, readings, _ = shots(50, 2)
    write_csv(tmp_path / 'in.csv', {'ax': readings[:, 0], 'ay': readings[:, 1],
                                    'az': readings[:, 2]})
    code, _, err = quiet(['survey', tmp_path / 'in.csv', '-o', tmp_path / 'out.csv'])
    assert code == 0, err
    assert 'raw angles' in err
    _, columns = read_columns(tmp_path / 'out.csv')
    np.testing.assert_allclose(
        np.array(columns['inclination_deg'], dtype=float),
        np.degrees(np.arctan2(np.hypot(readings[:, 0], readings[:, 1]), readings[:, 2])),
        rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.array(columns['toolface_deg'], dtype=float),
                               np.degrees(np.arctan2(readings[:, 1], readings[:, 0])) % 360.0,
                               rtol=0, atol=1e-9)


def test_fit_temperature_takes_text_labels(tmp_path):
    """The attitude column 'up' / 'turned over' fits exactly as the numbers 0 / 1."""
    run = simulate_heating(StandRun(TOOL, seed=1), TURNED_OVER_HEATING_ATTITUDES_DEG,
                           samples=401)
    base = {'temperature_c': run.temperature_c, 'ax': run.raw_mps2[:, 0],
            'ay': run.raw_mps2[:, 1], 'az': run.raw_mps2[:, 2]}
    labels = {'text': np.where(run.segment == 1, 'up', 'turned over'),
              'number': run.segment - 1}
    stages = {}
    for name, label in labels.items():
        write_csv(tmp_path / f'{name}.csv', dict(base, attitude=label))
        code, out, err = quiet(['fit-temperature', tmp_path / f'{name}.csv', '--calibration',
                                tmp_path / f'{name}.json'])
        assert code == 0, err
        assert '2 attitudes heated' in out
        stages[name] = (tmp_path / f'{name}.json').read_text().split('"fitted_at"')[0]
    assert stages['text'] == stages['number']
