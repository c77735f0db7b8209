"""Calibration files written by hand for the tests of what load_model refuses."""

import json

from inclino_ros.calibration.model import CalibrationFileError, load_model
import pytest


def load_refusal(tmp_path, doc):
    """Write ``doc`` as a calibration file; return the reason load_model refuses it with."""
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps(doc))
    with pytest.raises(CalibrationFileError) as caught:
        load_model(path)
    return caught.value.reason
