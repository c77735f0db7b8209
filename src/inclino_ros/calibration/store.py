"""
The calibration file: read and validated, written atomically, matched to its sensor.

The file is JSON (``schema``), written atomically (temporary file, fsync,
rename, ``io.files``) and validated on load and before every write; any
defect raises ``CalibrationFileError`` naming the file (a FIFO or a device
too, never waited on).  ``save_model`` is the one door of every write (node
services, ``inclino fit-*``, ``msa``, ``calibration restore``): it keeps
every version in the file's history (``calibration.history``) and refuses to
write over a file that changed since the writer read it
(``CalibrationChanged``).
"""

from dataclasses import replace
import json
import os

from inclino_ros.calibration import history
from inclino_ros.calibration.corrections import CalibrationModel
from inclino_ros.calibration.provenance import utc_now_iso
from inclino_ros.calibration.schema import AXES_MAP_SENSORS, model_from_dict
from inclino_ros.core.mounting import axes_map_matrix
from inclino_ros.io.files import loads_strict, Outputs, read_json, write_text
import numpy as np

#: ``save_model``'s ``based_on`` when the file on disk is not compared.
UNCHECKED = object()
#: Writer recorded for a version written from Python (scripts, tests) rather than a command.
PYTHON_WRITER = 'python (inclino_ros.calibration.model.save_model)'


class CalibrationFileError(Exception):
    """A calibration file that exists but cannot be trusted."""

    def __init__(self, path, reason):
        super().__init__(f'calibration file {path}: {reason}')
        self.path = path
        self.reason = reason


class CalibrationChanged(Exception):
    """The file changed on disk since its writer read it: nothing written, the file kept."""

    def __init__(self, path):
        """Name the file that changed."""
        super().__init__(
            f'{path} changed on disk since it was read (another writer, e.g. an inclino fit-* '
            'command, replaced it): not written over, so the stages it holds are kept; read it '
            'again (restart the node) and redo this calibration on top of it')


def model_text(model):
    """Return the text of the calibration file of ``model``."""
    return json.dumps(model.to_dict(), indent=2) + '\n'


def save_model(path, model, writer=PYTHON_WRITER, outputs=None, based_on=UNCHECKED,
               history_keep=history.DEFAULT_KEEP, report=None):
    """
    Write ``model`` to ``path`` atomically, its new version kept in the history; return its digest.

    The one door of every calibration write: a reader sees old or new,
    whole; the file's history (``calibration.history``) receives the new
    version, and the one on disk first if it lacks it, in the same commit,
    as written by ``writer`` (e.g. ``'node /inclinometer/calibrate_level'``).
    With ``outputs`` (an open ``io.files.Outputs``) the file is one output of
    that command, renamed into place with its others.  ``based_on``: the
    digest of the file the writer read (``history.file_digest``; None: there
    was none); when the file on disk is another one at the commit,
    CalibrationChanged and nothing is written.  ValueError for a model
    load_model would refuse.  Once it has landed, the history is pruned to its
    newest ``history_keep`` versions (``history.prune``); ``report(line)``
    is told which were removed (or why none could be).
    """
    path = os.path.abspath(os.path.expanduser(path))
    model_from_dict(model.to_dict())  # never write what load_model would refuse
    if outputs is None:
        with Outputs(force=True) as own:
            return save_model(path, model, writer, own, based_on, history_keep, report)
    text = model_text(model)

    def unchanged():
        if based_on is not UNCHECKED and history.file_digest(path) != based_on:
            raise CalibrationChanged(path)

    unchanged()
    outputs.require(unchanged)

    def prune():
        try:
            pruned = history.prune(path, history_keep, in_use={history.digest(text)})
        except OSError as err:
            pruned, line = [], f'{path}: its history was not pruned ({err})'
        else:
            line = history.pruned_message(path, pruned, history_keep) if pruned else None
        if line is not None and report is not None:
            report(line)

    outputs.after(prune)
    history.record(path, text, writer, model.sensor_id, utc_now_iso(), outputs)
    write_text(path, text, outputs=outputs, update=True)
    return history.digest(text)


def load_model(path, with_digest=False):
    """
    Read and validate a calibration file.

    Raises FileNotFoundError when there is no file, CalibrationFileError when
    there is one that cannot be trusted (a FIFO or a device too, never
    waited on).  ``with_digest``: return (model, the digest of the bytes it
    was read from), the ``based_on`` of a later ``save_model``.
    """
    path = os.path.expanduser(path)
    try:
        doc, sha256 = read_json(path, with_digest=True)
    except ValueError as err:
        raise CalibrationFileError(path, str(err)) from None
    try:
        model = model_from_dict(doc)
    except (KeyError, TypeError, ValueError, OverflowError) as err:
        raise CalibrationFileError(path, str(err)) from None
    return (model, sha256) if with_digest else model


def _check_text(text):
    """Raise ValueError unless ``text`` is a valid calibration file's text."""
    try:
        model_from_dict(loads_strict(text))
    except (KeyError, TypeError, ValueError, OverflowError, RecursionError) as err:
        raise ValueError(f'not a valid calibration ({err})') from None


def read_model_history(path):
    """Return (versions, problems) of the history of ``path``, each version validated."""
    return history.read_history(path, _check_text)


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


def check_axes_maps(model, maps, path):
    """
    Raise CalibrationFileError when ``model`` was fitted in other axes maps than ``maps``.

    ``maps``: (accelerometer, magnetometer) axes maps the readings are turned
    by now.  A calibration fitted on readings turned one way corrects
    readings turned another way wrongly (degrees, silently), so the maps must
    be the same turns; a file that records none (older files) matches any.
    """
    if model.axes_maps is None:
        return
    for name, fitted, used in zip(AXES_MAP_SENSORS, model.axes_maps, maps):
        if not np.allclose(axes_map_matrix(fitted, allow_left_handed=True),
                           axes_map_matrix(used, allow_left_handed=True), atol=1e-9):
            raise CalibrationFileError(
                path, f'was fitted with the {name} axes map {fitted!r}, but the readings are '
                f'turned by {used!r}: use the map it was fitted in, or fit again')


def axes_refusal(model, axes, path):
    """Return why ``model`` cannot correct an ``axes``-axis accelerometer, or None."""
    if axes is None or model.accelerometer_axes == axes:
        return None
    return f'{path} is for a {model.accelerometer_axes}-axis accelerometer, not {axes} axes'


def model_to_update(model, path, sensor_id=None, axes=3, maps=None):
    """
    Return the model a fit updates: ``model`` (the file's, None: none) or a new one.

    A new model has ``axes`` accelerometer axes (3 when None), names
    ``sensor_id`` and records ``maps`` (the (accelerometer, magnetometer)
    axes maps the readings are turned by; None: readings in tool axes
    already).  A file fitted in other maps is a CalibrationFileError
    (``check_axes_maps``); one for another number of accelerometer axes
    than ``axes`` (None: any) a ValueError (``axes_refusal``: a stand and a
    temperature stage need three).  The model returned names ``sensor_id``
    (if given) and records ``maps``.
    """
    if model is None:
        return CalibrationModel(accelerometer_axes=axes or 3, sensor_id=sensor_id or None,
                                axes_maps=maps)
    if maps is not None:
        check_axes_maps(model, maps, path)
    model = replace(model, sensor_id=sensor_id or model.sensor_id,
                    axes_maps=maps or model.axes_maps)
    reason = axes_refusal(model, axes, path)
    if reason is not None:
        raise ValueError(reason + ('; stand and temperature stages need three'
                                   if axes == 3 else ''))
    return model
