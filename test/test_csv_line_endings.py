"""Every CSV the package writes ends its lines with LF alone, not the csv module's CRLF."""

import pathlib

from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2 as G
from inclino_ros.io.tables import write_csv
from test_msa_cli import quiet, read_table


def assert_lf(path):
    """Assert the file's lines end in LF and hold no carriage return (CR)."""
    data = pathlib.Path(path).read_bytes()
    assert b'\r' not in data and data.endswith(b'\n') and data.count(b'\n') >= 2


def test_every_csv_writer_ends_lines_with_lf(tmp_path):
    """simulate-well, survey and msa (every command writing a CSV goes through write_csv)."""
    stations = tmp_path / 'stations.csv'
    code, _, err = quiet(['simulate-well', stations, '--stations', '6'])
    assert code == 0, err
    assert_lf(stations)
    table = read_table(stations)
    write_csv(tmp_path / 'shots.csv', {name: table[column] * scale for name, column, scale in (
        ('ax', 'gx', G), ('ay', 'gy', G), ('az', 'gz', G), ('bx', 'bx', 1), ('by', 'by', 1),
        ('bz', 'bz', 1))})
    assert_lf(tmp_path / 'shots.csv')
    code, _, err = quiet(['survey', tmp_path / 'shots.csv', '-o', tmp_path / 'survey.csv'])
    assert code == 0, err
    assert_lf(tmp_path / 'survey.csv')
    code, _, err = quiet(['msa', stations, '-o', tmp_path / 'msa.csv', '--reference-total-nT',
                          '50000', '--reference-dip-deg', '60'])
    assert code == 0, err
    assert_lf(tmp_path / 'msa.csv')
    write_csv(tmp_path / 'table.csv', {'name': ['a', 'b,c'], 'value': [1.5, float('nan')]})
    assert (tmp_path / 'table.csv').read_bytes() == b'name,value\na,1.5\n"b,c",nan\n'
