"""
The calibration model, one import for all of it.

What is applied to every sample, and its file, live in modules by concern:

- ``stages``: the stage dataclasses and their math;
- ``corrections``: ``CalibrationModel``, the stages in the order they are
  applied (see its docstring for the chain of each triad);
- ``schema``: the JSON document and its one validated reader;
- ``migrations``: the file's versions and how an older one is read;
- ``store``: load, atomic save (the one door of every write, its history
  kept: ``history``), the sensor check (``CalibrationFileError``);
- ``provenance``: stage ages and staleness, the temperatures stages stand for.

Every public name of those modules can be imported from here.
"""

from inclino_ros.calibration.corrections import (
    CalibrationModel, MAGNETOMETER_STAGES, MOUNT_STAGES, STAGES, STANDARD_GRAVITY_MPS2)
from inclino_ros.calibration.migrations import (
    READABLE_VERSIONS, SCHEMA_VERSION, SECTIONS, upgraded, VERSION_3_FIELDS)
from inclino_ros.calibration.provenance import (
    age_seconds, common_stage_temperature, missing_temperature, MissingTemperature,
    readings_temperature_c, stage_ages_s, stage_temperatures, STAGE_TIMES, stale_stages,
    temperature_conflict, TEMPERATURE_FIELDS, TEMPERATURE_STAGES, utc_now_iso)
from inclino_ros.calibration.schema import (
    AXES_MAP_SENSORS, FORMAT, is_int, model_from_dict, model_to_dict, STAGE_FIELDS,
    stage_from_dict)
from inclino_ros.calibration.stages import (
    Installation, Magnetic, Magnetometer, MagnetometerAlignment, MagnetometerTemperature,
    NO_MAGNETIC_CORRECTION, Stand, Temperature, ToolAxis, ToolfaceMark)
from inclino_ros.calibration.store import (
    CalibrationChanged, CalibrationFileError, check_axes_maps, check_sensor, load_model,
    model_text, PYTHON_WRITER, read_model_history, save_model, UNCHECKED)

__all__ = [
    'age_seconds', 'AXES_MAP_SENSORS', 'CalibrationChanged', 'CalibrationFileError',
    'CalibrationModel', 'check_axes_maps', 'check_sensor', 'common_stage_temperature', 'FORMAT',
    'Installation', 'is_int', 'load_model', 'Magnetic', 'Magnetometer', 'MAGNETOMETER_STAGES',
    'MagnetometerAlignment', 'MagnetometerTemperature', 'missing_temperature',
    'MissingTemperature', 'model_from_dict', 'model_text', 'model_to_dict', 'MOUNT_STAGES',
    'NO_MAGNETIC_CORRECTION', 'PYTHON_WRITER', 'READABLE_VERSIONS', 'read_model_history',
    'readings_temperature_c', 'save_model', 'SCHEMA_VERSION', 'SECTIONS', 'stage_ages_s',
    'STAGE_FIELDS', 'stage_from_dict', 'stage_temperatures', 'STAGE_TIMES', 'STAGES',
    'stale_stages', 'Stand', 'STANDARD_GRAVITY_MPS2', 'Temperature', 'temperature_conflict',
    'TEMPERATURE_FIELDS', 'TEMPERATURE_STAGES', 'ToolAxis', 'ToolfaceMark', 'UNCHECKED',
    'upgraded', 'utc_now_iso', 'VERSION_3_FIELDS',
]
