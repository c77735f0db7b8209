"""
Issue 21, data loss: what a command writes never takes the user's folders or inputs with it.

Before: ``inclino process proj/bench proj --calibration proj/cal.json --force``
deleted ``proj/`` (the input bag, the calibration, the notes); a fit whose report
could not be written exited 2 after the calibration file was already replaced.
"""

import os

from inclino_ros.calibration.model import CalibrationModel, read_model_history, save_model
import pytest
from test_calibration_history import fit_level, level_csv
from test_msa_cli import quiet


@pytest.fixture(scope='module')
def project(tmp_path_factory):
    """Return a project folder: a bench bag, a calibration and the user's notes."""
    proj = tmp_path_factory.mktemp('proj')
    code, _, err = quiet(['simulate', proj / 'bench', '--rate-hz', 200, '--level-s', 1,
                          '--station-s', 0.5])
    assert code == 0, err
    save_model(proj / 'cal.json', CalibrationModel(3))
    (proj / 'notes.txt').write_text('mine')
    return proj


def listing(folder):
    """Return every path under ``folder``, relative, sorted."""
    return sorted(os.path.relpath(os.path.join(root, name), folder)
                  for root, dirs, names in os.walk(folder) for name in dirs + names)


def test_process_force_never_deletes_the_folder_of_its_inputs(project):
    """The output named as the project folder: refused, even with --force; nothing lost."""
    before = listing(project)
    code, _, err = quiet(['process', project / 'bench', project, '--calibration',
                          project / 'cal.json', '--force'])
    assert code == 2 and 'holding the input' in err, err
    assert listing(project) == before


def test_survey_force_never_replaces_a_folder_of_the_user(project, tmp_path):
    """Survey -o DATA --force, where DATA is a folder holding the input: refused."""
    data = tmp_path / 'data'
    data.mkdir()
    (data / 'in.csv').write_text('ax,ay,az,bx,by,bz\n0,0,9.8,20000,0,40000\n')
    code, _, err = quiet(['survey', data / 'in.csv', '-o', data, '--calibration',
                          project / 'cal.json', '--force'])
    assert code == 2 and 'holding the input' in err, err
    assert os.listdir(data) == ['in.csv']


def test_a_fit_whose_report_cannot_be_written_writes_nothing(tmp_path):
    """The report's name is taken by a folder of the user: exit 2, calibration unchanged."""
    calibration = tmp_path / 'cal.json'
    assert fit_level(level_csv(tmp_path / 'a.csv'), calibration)[0] == 0
    before = calibration.read_bytes()
    versions = len(read_model_history(calibration)[0])
    reports = tmp_path / 'reports'
    (reports / 'fit_level.txt').mkdir(parents=True)
    (reports / 'fit_level.txt' / 'mine').write_text('mine')
    code, _, err = fit_level(level_csv(tmp_path / 'b.csv', gamma_deg=0.3), calibration,
                             '--report-dir', reports)
    assert code == 2 and 'not a bag' in err, err
    assert calibration.read_bytes() == before
    assert len(read_model_history(calibration)[0]) == versions
    assert listing(reports) == ['fit_level.txt', 'fit_level.txt/mine']
