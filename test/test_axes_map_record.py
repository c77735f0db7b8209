"""
A calibration records the axes maps it was fitted in; used in others it is refused (issue 21).

A stand or level fitted on readings turned by one map corrects readings
turned by another by degrees (2.9 deg, or 90 deg, of inclination), silently:
the file names its maps, and every command and the node compare.
"""

import json

from inclino_ros.calibration.model import (
    CalibrationFileError, CalibrationModel, check_axes_maps, load_model, save_model)
import numpy as np
import pytest
from test_msa_cli import quiet
from test_survey_cli import write_rows

G = 9.80665


def level_csv(path, reading):
    """Write fit-level's CSV: 200 readings of a still tool around ``reading`` [m/s^2]."""
    rng = np.random.default_rng(7)
    write_rows(path, ['ax', 'ay', 'az'], np.asarray(reading) + rng.normal(0.0, 0.01, (200, 3)))
    return path


def test_the_maps_are_written_and_read_back(tmp_path):
    """axes_maps round-trips; a map that is none, or one sensor only, is refused on load."""
    model = CalibrationModel(accelerometer_axes=3, axes_maps=('-Y+X+Z', 'rpy:0,0,90'))
    save_model(tmp_path / 'cal.json', model)
    assert load_model(tmp_path / 'cal.json').axes_maps == ('-Y+X+Z', 'rpy:0,0,90')
    doc = json.loads((tmp_path / 'cal.json').read_text())
    for maps in ({'accelerometer': '+X+Q+Z', 'magnetometer': '+X+Y+Z'},
                 {'accelerometer': '+X+Y+Z'}):
        (tmp_path / 'bad.json').write_text(json.dumps({**doc, 'axes_maps': maps}))
        with pytest.raises(CalibrationFileError, match='axes'):
            load_model(tmp_path / 'bad.json')


def test_same_turns_match_and_others_are_refused(tmp_path):
    """The same turn written two ways matches; another, or none, is refused naming both."""
    model = CalibrationModel(accelerometer_axes=3, axes_maps=('+Y-X+Z', '+X+Y+Z'))
    check_axes_maps(model, ('rpy:0,0,-90', '+x+y+z'), 'cal.json')
    with pytest.raises(CalibrationFileError, match=r"axes map '\+Y-X\+Z'.*'\+X\+Y\+Z'"):
        check_axes_maps(model, ('+X+Y+Z', '+X+Y+Z'), 'cal.json')
    check_axes_maps(CalibrationModel(accelerometer_axes=3), ('-Y+X+Z', '+X+Y+Z'), 'old.json')


def test_fit_in_one_map_then_another_is_refused(tmp_path):
    """fit-level records its maps; a later fit in other maps is refused, the file unchanged."""
    calibration = tmp_path / 'cal.json'
    csv = level_csv(tmp_path / 'level.csv', [0.0, 0.05, G])
    code, _, err = quiet(['fit-level', csv, '--calibration', calibration,
                          '--accelerometer-axes-map=-Y+X+Z'])
    assert code == 0, err
    assert load_model(calibration).axes_maps == ('-Y+X+Z', '+X+Y+Z')
    before = calibration.read_bytes()
    code, _, err = quiet(['fit-level', csv, '--calibration', calibration])
    assert code == 2 and "fitted with the accelerometer axes map '-Y+X+Z'" in err
    assert calibration.read_bytes() == before
    code, _, err = quiet(['fit-level', csv, '--calibration', calibration,
                          '--accelerometer-axes-map=rpy:0,0,90'])
    assert code == 0, err
