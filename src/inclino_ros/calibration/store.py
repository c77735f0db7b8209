"""
The calibration file: read and validated, written atomically, matched to its sensor.

The file is JSON (``schema``), written atomically (temporary file, fsync,
rename, ``io.files``) and validated on load and before every write; any
defect raises ``CalibrationFileError`` naming the file.
"""

import os

from inclino_ros.calibration.schema import model_from_dict
from inclino_ros.io.files import read_json, write_json


class CalibrationFileError(Exception):
    """A calibration file that exists but cannot be trusted."""

    def __init__(self, path, reason):
        super().__init__(f'calibration file {path}: {reason}')
        self.path = path
        self.reason = reason


def save_model(path, model):
    """Write ``model`` to ``path`` atomically: a reader sees old or new, whole."""
    model_from_dict(model.to_dict())  # never write what load_model would refuse
    write_json(os.path.expanduser(path), model.to_dict())


def load_model(path):
    """
    Read and validate a calibration file.

    Raises FileNotFoundError when there is no file, CalibrationFileError when
    there is one that cannot be trusted.
    """
    path = os.path.expanduser(path)
    try:
        doc = read_json(path)
    except ValueError as err:
        raise CalibrationFileError(path, str(err)) from None
    try:
        return model_from_dict(doc)
    except (KeyError, TypeError, ValueError, OverflowError) as err:
        raise CalibrationFileError(path, str(err)) from None


def check_sensor(model, sensor_id, path):
    """
    Raise CalibrationFileError when ``model`` belongs to another sensor than ``sensor_id``.

    A file that names no sensor (older files) matches any; a node or command
    that names none matches only such a file.
    """
    if model.sensor_id is not None and model.sensor_id != (sensor_id or None):
        wanted = repr(sensor_id) if sensor_id else 'an unnamed one (no sensor_id given)'
        raise CalibrationFileError(
            path, f'belongs to sensor {model.sensor_id!r}, not to {wanted}: the calibration '
            'of another tool (set sensor_id / --sensor-id, or use the file of this tool)')
