"""
``inclino simulate-well`` and ``inclino msa``: the CLI contract, end to end.

The default simulated well (30 stations, inclination 30 -> 90 deg, azimuth 85 -> 95 deg: east,
the hard case; 2000 nT axial, (80, -80) nT cross-axial; 1e-4 g and 5 nT of noise; ideal triads
mounted true in the physical model) is corrected within 0.1 deg (test_msa.py gives the
reasoning); uncorrected it is ~4.6 deg off.
"""

import contextlib
import csv
import io
import json

from inclino_ros.cli.main import main as inclino
from inclino_ros.core.msa import azimuth_difference_deg
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import make_tool
from inclino_ros.sim.well import simulate_well, WellScenario, write_stations_csv
import numpy as np
import pytest

REFERENCE_ARGS = ('--reference-total-nT', '50000', '--reference-dip-deg', '60')


def quiet(argv):
    """Run ``inclino argv`` in-process; return (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = inclino([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def read_table(path):
    """Return ``{column: float array}`` of a CSV file with a header row."""
    with open(path, newline='') as stream:
        rows = list(csv.DictReader(stream))
    return {name: np.array([float(row[name]) for row in rows]) for name in rows[0]}


@pytest.fixture(scope='module')
def stations(tmp_path_factory):
    """Return the path of the default simulated well's station CSV."""
    path = tmp_path_factory.mktemp('well') / 'stations.csv'
    code, out, _ = quiet(['simulate-well', path])
    assert code == 0 and 'inclino msa' in out
    return path


def test_simulate_well_truth_and_options(stations, tmp_path):
    """OUT.csv.truth.json holds every error source; --sensor and the mount reach the model."""
    truth = json.loads((stations.parent / 'stations.csv.truth.json').read_text())
    assert truth['sensor'] == 'ideal' and truth['tool']['mount']['gamma_deg'] == 0.0
    assert truth['interference_iscwsa_nT'] == [80.0, -80.0, 2000.0]
    assert truth['interference_tool_nT'] == [80.0, 80.0, -2000.0]
    assert truth['tool']['accelerometer']['noise_std'] == pytest.approx(1e-4 * 9.80665)
    path = tmp_path / 'quartz.csv'
    code, out, err = quiet(['simulate-well', path, '--sensor', 'quartz', '--gamma-deg', '0.8',
                            '--beta-deg', '-1.2', '--roll-deg', '3', '--samples-per-station',
                            '4', '--interference-nT', '0', '0', '500', '--stations', '6'])
    assert code == 0, err
    truth = json.loads((tmp_path / 'quartz.csv.truth.json').read_text())
    tool = make_tool('quartz', 0.8, -1.2, 3.0)
    assert truth['tool'] == json.loads(json.dumps(sm.truth_dict(tool)))
    assert (truth['samples_per_station'], truth['interference_tool_nT']) == \
        (4, [0.0, 0.0, -500.0])
    well = simulate_well(WellScenario(stations=6, tool=tool, samples_per_station=4,
                                      interference_tool_nT=(0.0, 0.0, -500.0)))
    table = read_table(path)
    np.testing.assert_array_equal(np.column_stack([table[c] for c in ('bx', 'by', 'bz')]),
                                  well.field_nT)
    assert quiet(['simulate-well', path, '--stations', '0'])[0] == 2
    assert quiet(['simulate-well', path, '--field-noise-nT', '-1'])[0] == 2


def test_default_improved_corrects_within_target(stations, tmp_path):
    """Default method: exit 0, the CSV columns, the JSON and the report; error <= 0.1 deg."""
    out_csv, report = tmp_path / 'out.csv', tmp_path / 'report.png'
    code, out, err = quiet(['msa', stations, '-o', out_csv, *REFERENCE_ARGS,
                            '--declination-deg', '-3.5', '--report', report])
    assert code == 0, err
    assert 'eps x, y, z' in out and 'search bracket' in out and 'from the classic solve' in out
    table = read_table(out_csv)
    for column in ('md', 'inclination_deg', 'toolface_deg', 'azimuth_raw_deg', 'azimuth_deg',
                   'azimuth_true_north_deg', 'b_total_ok', 'dip_ok', 'g_total_ok', 'used',
                   'true_azimuth_deg', 'azimuth_error_deg'):
        assert column in table, column
    assert np.max(np.abs(table['azimuth_error_deg'])) <= 0.1
    raw_error = azimuth_difference_deg(table['azimuth_raw_deg'], table['true_azimuth_deg'])
    assert np.max(np.abs(raw_error)) > 4.0
    np.testing.assert_allclose(table['azimuth_true_north_deg'], table['azimuth_deg'] - 3.5)
    assert table['b_total_ok'].all() and table['dip_ok'].all() and table['used'].all()
    record = json.loads((tmp_path / 'out.csv.msa.json').read_text())
    assert record['method'] == 'improved'
    assert record['eps_nT'][2] == pytest.approx(2000.0, abs=15.0)
    assert record['search_bracket_nT'][0] < 2000.0 < record['search_bracket_nT'][1]
    assert record['v_after_nT2'] < record['v_before_nT2']
    assert report.stat().st_size > 0
    # No calibration: the toolface of G as given is the board's, and says so (issue 19 item 6).
    assert record['toolface_zero'] == 'board'
    assert 'toolface_zero: board\ntoolface_zero_meaning: relative to the sensor board' in out


@pytest.mark.parametrize('method', ('classic', 'axial', 'short-collar'))
def test_other_methods_run(stations, tmp_path, method):
    """Every method writes its outputs; short-collar flags the east-bound stations."""
    out_csv = tmp_path / 'out.csv'
    code, out, err = quiet(['msa', stations, '-o', out_csv, *REFERENCE_ARGS, '--method', method,
                            '--report', tmp_path / 'r.png'])
    assert code == 0, err
    table = read_table(out_csv)
    if method == 'short-collar':
        assert table['east_west'].all() and np.isnan(table['azimuth_deg']).all()
    elif method == 'classic':
        assert np.max(np.abs(table['azimuth_error_deg'])) <= 0.1


def test_unspread_toolfaces(tmp_path):
    """One toolface: classic and improved (nothing gives the cross-axial) exit 1 with reasons."""
    path = tmp_path / 'stations.csv'
    write_stations_csv(path, simulate_well(WellScenario(
        toolface_step_deg=0.0, interference_tool_nT=(0.0, 0.0, -2000.0))))
    code, _, err = quiet(['msa', path, '-o', tmp_path / 'c.csv', *REFERENCE_ARGS,
                          '--method', 'classic'])
    assert code == 1 and 'toolfaces not spread' in err
    assert not (tmp_path / 'c.csv').exists()
    code, out, err = quiet(['msa', path, '-o', tmp_path / 'i.csv', *REFERENCE_ARGS])
    assert code == 1 and 'improved needs the cross-axial interference' in err
    assert not (tmp_path / 'i.csv').exists()
    code, out, err = quiet(['msa', path, '-o', tmp_path / 'a.csv', *REFERENCE_ARGS,
                            '--method', 'axial'])
    assert code == 0, err
    assert np.max(np.abs(read_table(tmp_path / 'a.csv')['azimuth_error_deg'])) <= 0.1
    code, out, err = quiet(['msa', path, '-o', tmp_path / 'g.csv', *REFERENCE_ARGS,
                            '--cross-axial-nT', '0', '0'])
    assert code == 0 and 'given' in out


def test_refused_too_few_stations(tmp_path):
    """Four stations: exit 1, nothing written."""
    path = tmp_path / 'stations.csv'
    write_stations_csv(path, simulate_well(WellScenario(stations=4)))
    code, _, err = quiet(['msa', path, '-o', tmp_path / 'o.csv', *REFERENCE_ARGS,
                          '--method', 'axial'])
    assert code == 1 and 'refused' in err
    assert not (tmp_path / 'o.csv').exists()


def test_unusable_input(stations, tmp_path):
    """A missing column, a missing file or an impossible reference: exit 2."""
    bad = tmp_path / 'bad.csv'
    bad.write_text('gx,gy,gz,bx,by\n0,0,1,1,2\n')
    code, _, err = quiet(['msa', bad, '-o', tmp_path / 'o.csv', *REFERENCE_ARGS])
    assert code == 2 and 'bz' in err
    code, _, _ = quiet(['msa', tmp_path / 'none.csv', '-o', tmp_path / 'o.csv',
                        *REFERENCE_ARGS])
    assert code == 2
    code, _, err = quiet(['msa', stations, '-o', tmp_path / 'o.csv',
                          '--reference-total-nT', '-5', '--reference-dip-deg', '60'])
    assert code == 2 and '-5 is not between 20000 and 70000 nT' in err
