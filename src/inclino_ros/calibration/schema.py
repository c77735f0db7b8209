"""
The calibration document: the model as JSON and the one validated way back.

``model_to_dict`` writes the current version (``migrations.SCHEMA_VERSION``);
``model_from_dict`` reads every readable version (older sections upgraded by
``migrations``), checking each section's structure here and what each stage
can physically be in ``plausibility``; a defect raises ValueError (or
KeyError, TypeError) with the reason, never a silent zero correction.
"""

from dataclasses import asdict, fields
from datetime import datetime
from functools import partial
import math

from inclino_ros.calibration import plausibility
from inclino_ros.calibration.corrections import CalibrationModel
from inclino_ros.calibration.migrations import (
    READABLE_VERSIONS, SCHEMA_VERSION, SECTIONS, upgraded)
from inclino_ros.calibration.stages import (
    covariance_sizes, COVARIANCE_STAGE_SIZES, Installation, Magnetic, Magnetometer,
    MagnetometerAlignment, MagnetometerNonlinear, MagnetometerTemperature, Stand, Temperature,
    ToolAxis, ToolfaceMark)
from inclino_ros.core.attitude import TOOLFACE_CONVENTIONS
from inclino_ros.core.mounting import axes_map_matrix
import numpy as np

FORMAT = 'inclino_ros.calibration'
#: The sensors of the ``axes_maps`` record, in the order of CalibrationModel.axes_maps.
AXES_MAP_SENSORS = ('accelerometer', 'magnetometer')


def model_to_dict(model):
    """Return the JSON-ready document of ``model``."""
    doc = {'format': FORMAT, 'schema_version': SCHEMA_VERSION,
           'accelerometer_axes': model.accelerometer_axes, 'sensor_id': model.sensor_id}
    if model.axes_maps is not None:
        doc['axes_maps'] = dict(zip(AXES_MAP_SENSORS, model.axes_maps))
    for name in SECTIONS[SCHEMA_VERSION]:
        stage = getattr(model, name)
        if stage is not None:
            doc[name] = asdict(stage)
    return doc


def is_int(value):
    """Return whether ``value`` is a JSON integer (not a bool, not a float)."""
    return isinstance(value, int) and not isinstance(value, bool)


def model_from_dict(doc):
    """Return the model of a parsed document; ValueError/KeyError if invalid."""
    if not isinstance(doc, dict) or doc.get('format') != FORMAT:
        raise ValueError(f'not an {FORMAT} document')
    version = doc.get('schema_version')
    if not is_int(version) or version not in READABLE_VERSIONS:
        raise ValueError(f'schema_version {version!r} is not one of {READABLE_VERSIONS}')
    axes = doc['accelerometer_axes']
    if not is_int(axes) or axes not in (2, 3):
        raise ValueError(f'accelerometer_axes {axes!r} is not 2 or 3')
    stages = SECTIONS[version]
    top = {'format', 'schema_version', 'accelerometer_axes'} | (
        {'sensor_id', 'axes_maps'} if version >= 3 else set())
    unknown = set(doc) - top - set(stages)
    if unknown:
        raise ValueError(f'unknown sections {sorted(unknown)} in a version {version} file')
    sensor_id = doc.get('sensor_id') if version >= 3 else None
    if sensor_id is not None and not isinstance(sensor_id, str):
        raise ValueError(f'sensor_id {sensor_id!r} is not a string')
    sections = {name: upgraded(doc[name], name, version)
                for name in stages if doc.get(name) is not None}
    stage_values = {name: stage_from_dict(name, section) for name, section in sections.items()}
    model = CalibrationModel(accelerometer_axes=axes, sensor_id=sensor_id,
                             axes_maps=_axes_maps(doc.get('axes_maps')), **stage_values)
    if axes == 2 and (model.stand or model.temperature):
        raise ValueError('stand and temperature stages need a three-axis accelerometer')
    return model


def _axes_maps(section):
    """Return the (accelerometer, magnetometer) maps of an ``axes_maps`` section (None: none)."""
    if section is None:
        return None
    if not isinstance(section, dict) or set(section) != set(AXES_MAP_SENSORS):
        raise ValueError(f'axes_maps {section!r} must name the {" and ".join(AXES_MAP_SENSORS)} '
                         'maps')
    for name in AXES_MAP_SENSORS:
        if not isinstance(section[name], str):
            raise ValueError(f'axes_maps.{name} {section[name]!r} is not an axes map')
        axes_map_matrix(section[name], allow_left_handed=True)   # ValueError if it is none
    return tuple(section[name] for name in AXES_MAP_SENSORS)


def stage_from_dict(name, section):
    """
    Return the validated stage ``name`` from its file section; ValueError (the reason) if not.

    ``STAGE_FIELDS`` drives it: the section must hold exactly its dataclass's
    fields, each field is read by its reader, then the checks across fields
    and the stage's ``plausibility`` check run.
    """
    kind, readers, checks, plausible = STAGE_FIELDS[name]
    expected = {f.name for f in fields(kind)}
    if not isinstance(section, dict) or set(section) != expected:
        got = sorted(section) if isinstance(section, dict) else section
        raise ValueError(f'{name} needs exactly the fields {sorted(expected)}, got {got}')
    values = {key: read(section, name, key) for key, read in readers.items()}
    for check in checks:
        check(values, name)
    stage = kind(**values)
    plausible(stage)
    return stage


def _finite(section, name, key, shape=()):
    """Return ``section[key]`` as a finite float array of ``shape``; ValueError if not."""
    value = section[key]
    array = np.asarray(value, dtype=object)
    if array.shape != shape or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
            for v in array.flat):
        what = 'a finite number' if shape == () else f'finite numbers of shape {shape}'
        raise ValueError(f'{name}.{key} = {value!r} is not {what}')
    return np.asarray(value, dtype=float)


def _number(section, name, key):
    """Read a finite number, as written."""
    _finite(section, name, key)
    return section[key]


def _array(*shape):
    """Return the reader of finite numbers of ``shape``, as nested tuples of floats."""
    def read(section, name, key):
        value = _finite(section, name, key, shape)
        return tuple(map(tuple, value.tolist())) if len(shape) == 2 else tuple(value.tolist())
    return read


def _optional(read):
    """Return ``read`` letting None through."""
    def read_optional(section, name, key):
        return None if section[key] is None else read(section, name, key)
    return read_optional


def _count(section, name, key):
    """Read a positive integer."""
    if not is_int(section[key]) or section[key] < 1:
        raise ValueError(f'{name}.{key} = {section[key]!r} is not a positive integer')
    return section[key]


def _time(section, name, key):
    """Read an ISO 8601 time with a zone."""
    try:
        moment = datetime.fromisoformat(section[key])
    except (TypeError, ValueError):
        raise ValueError(f'{name}.{key} = {section[key]!r} is not an ISO 8601 time') from None
    if moment.tzinfo is None:
        raise ValueError(f'{name}.{key} has no time zone')
    plausibility.check_time(moment, f'{name}.{key}')
    return section[key]


def _choice(*options):
    """Return the reader of one of ``options``."""
    def read(section, name, key):
        if section[key] not in options:
            raise ValueError(f'{name}.{key} = {section[key]!r} is not '
                             + ', '.join(options[:-1]) + f' or {options[-1]}')
        return section[key]
    return read


def _temperature(section, name, key):
    """Read the temperature [deg C] a stage's readings stood for: None or a sensor's."""
    if section[key] is not None:
        plausibility.check_temperatures([float(_finite(section, name, key))], f'{name}.{key}')
    return section[key]


def _kept(section, name, key):
    """Read a field the checks across fields look at (or none does), as written."""
    return section[key]


def _rows(section, name, key):
    """Read 3 rows of polynomial coefficients a0..an, shaped as ``coefficients``."""
    coefficients = np.asarray(section['coefficients'], dtype=object)
    if coefficients.ndim != 2 or coefficients.shape[0] != 3 or coefficients.shape[1] < 1:
        raise ValueError(f'{name}.coefficients must be 3 rows of a0..an')
    return _array(*coefficients.shape)(section, name, key)


def _parameter_covariance(section, name, key):
    """Read 3 symmetric positive semi-definite covariances of the drift coefficients, or None."""
    if section[key] is None:
        return None
    order = np.asarray(section['coefficients'], dtype=object).shape[-1] - 1
    size = order * (1 if section[f'bias_coefficients_{_unit_of(name)}'] is None else 2)
    value = _finite(section, name, key, (3, size, size))
    if not (np.allclose(value, value.transpose(0, 2, 1), rtol=1e-9,
                        atol=1e-12 * np.abs(value).max(initial=0.0))
            and np.all(np.linalg.eigvalsh(0.5 * (value + value.transpose(0, 2, 1)))
                       >= -1e-9 * np.abs(value).max(initial=0.0))):
        raise ValueError(f'{name}.{key} is not 3 symmetric positive semi-definite matrices')
    return tuple(tuple(map(tuple, axis)) for axis in value.tolist())


def _covariance(section, name, key, size):
    """Return ``section[key]`` as a symmetric positive semi-definite size x size matrix."""
    value = _finite(section, name, key, (size, size))
    scale = np.abs(value).max(initial=0.0)
    if not (np.allclose(value, value.T, rtol=1e-9, atol=1e-12 * scale)
            and np.linalg.eigvalsh(0.5 * (value + value.T)).min() >= -1e-9 * scale):
        raise ValueError(f'{name}.{key} is not a symmetric positive semi-definite matrix')
    return tuple(map(tuple, value.tolist()))


def _magnetometer_covariance(values, name):
    """
    Raise ValueError unless the covariance and the stages it covers are both given or none.

    The stages: 'magnetometer' with 'stand' before and 'tool_axis' after it, each
    once, in that order; the covariance square over their sizes (COVARIANCE_STAGE_SIZES).
    """
    stages, covariance = values['covariance_stages'], values['parameter_covariance']
    if stages is None and covariance is None:
        return
    if (stages is None or covariance is None or not isinstance(stages, list | tuple)
            or not all(isinstance(stage, str) for stage in stages)
            or 'magnetometer' not in stages
            or tuple(stages) != tuple(n for n in COVARIANCE_STAGE_SIZES if n in stages)):
        raise ValueError(f'{name}: covariance_stages {stages!r} must name magnetometer (after '
                         'stand, before tool_axis, each once) with parameter_covariance, or '
                         'both be null')
    values['covariance_stages'] = tuple(stages)
    sizes = covariance_sizes(_coefficient_count(values))
    size = sum(sizes[stage] for stage in stages)
    values['parameter_covariance'] = _covariance(values, name, 'parameter_covariance', size)


def _stand_covariance(values, name):
    """
    Read the stand's covariance: 12 square, 12 (order + 1) with K(T), b(T) (``Stand``).

    After ``_stand_polynomial`` (the coefficients checked); None stays None.
    """
    if values['parameter_covariance'] is not None:
        values['parameter_covariance'] = _covariance(values, name, 'parameter_covariance',
                                                     _coefficient_count(values))


def _coefficient_count(values):
    """Return the parameters of a checked K, b: 12, times the terms of K(T), b(T)."""
    return 12 * (1 if values['scale_coefficients'] is None
                 else len(values['scale_coefficients']))


def _square_covariance(size):
    """Return the reader of a size x size covariance (``_covariance``)."""
    def read_covariance(section, name, key):
        return _covariance(section, name, key, size)
    return read_covariance


def _unit_of(name):
    """Return the unit suffix of the temperature stage ``name``'s fields."""
    return 'nT' if name == 'magnetometer_temperature' else 'mps2'


def _temperature_range(values, name):
    """Raise ValueError unless the fitted range is not empty and holds the reference."""
    t_min, t_max, t_ref = (values[key] for key in ('t_min_c', 't_max_c',
                                                   'reference_temperature_c'))
    if not t_min <= t_ref <= t_max or t_min == t_max:
        raise ValueError(f'{name} range [{float(t_min)}, {float(t_max)}] C is empty or does '
                         f'not contain the reference {float(t_ref)} C')


def _stand_polynomial(values, name):
    """
    Raise ValueError unless K(T), b(T) are all given or none, shaped and finite, T in range.

    Coefficients (order + 1) x 3 x 3 and (order + 1) x 3 of ``T - temperature_c``,
    ``t_min_c < t_max_c`` holding ``temperature_c``; all four None: constant K, b.  The
    stand's (bias in m/s^2) and the magnetometer's (nT) alike.
    """
    unit = 'nT' if name == 'magnetometer' else 'mps2'
    bias_terms, bias_key = f'bias_coefficients_{unit}', f'bias_{unit}'
    keys = ('scale_coefficients', bias_terms, 't_min_c', 't_max_c')
    given = [values[key] is not None for key in keys]
    if not any(given):
        return
    if not all(given) or values['temperature_c'] is None:
        raise ValueError(f'{name}: {", ".join(keys)} and temperature_c are all given or none')
    scale = np.asarray(values['scale_coefficients'], dtype=object)
    if scale.ndim != 3 or scale.shape[1:] != (3, 3) or not 1 <= scale.shape[0] <= 8:
        raise ValueError(f'{name}.scale_coefficients must be 1..8 terms of 3 x 3')
    order = scale.shape[0]
    values['scale_coefficients'] = tuple(tuple(map(tuple, term)) for term in _finite(
        values, name, 'scale_coefficients', (order, 3, 3)).tolist())
    values[bias_terms] = tuple(map(tuple, _finite(values, name, bias_terms,
                                                  (order, 3)).tolist()))
    tolerance = 1e-9 * max(1.0, float(np.max(np.abs(values[bias_key]))))
    if not np.allclose(values['scale_coefficients'][0], values['scale_matrix'], rtol=0,
                       atol=1e-9) or not np.allclose(values[bias_terms][0], values[bias_key],
                                                     rtol=0, atol=tolerance):
        raise ValueError(f"{name}: scale_matrix and {bias_key} must be the polynomials' first "
                         'terms (their values at temperature_c)')
    if not values['t_min_c'] <= values['temperature_c'] <= values['t_max_c'] \
            or values['t_min_c'] == values['t_max_c']:
        raise ValueError(f'{name} range [{values["t_min_c"]}, {values["t_max_c"]}] C is empty '
                         f'or does not contain its temperature {values["temperature_c"]} C')


def _nonlinear_weights(section, name, key):
    """Read 2 rows (x, y) of 1..12 RBF weights, as nested tuples."""
    weights = np.asarray(section[key], dtype=object)
    if weights.ndim != 2 or weights.shape[0] != 2 or not 1 <= weights.shape[1] <= 12:
        raise ValueError(f'{name}.{key} must be 2 rows of 1..12 weights')
    return _array(*weights.shape)(section, name, key)


def _nonlinear_covariance(section, name, key):
    """Read the weights' covariance (2 centres square) or None."""
    if section[key] is None:
        return None
    size = 2 * np.asarray(section['weights'], dtype=object).shape[-1]
    return _covariance(section, name, key, size)


def _msa(values, name):
    """Raise ValueError unless a solved interference names its method, stations and field."""
    if values['msa_method'] is not None:
        _count(values, name, 'msa_stations')
        for key in ('msa_reference_total_nT', 'msa_reference_dip_deg'):
            _finite(values, name, key)


def _temperature_fields(unit):
    """Return the field readers of a temperature stage whose unit-named fields end in ``unit``."""
    return {'coefficients': _rows, f'bias_coefficients_{unit}': _optional(_rows),
            't_min_c': _number, 't_max_c': _number, 'reference_temperature_c': _number,
            f'rms_residual_{unit}': _array(3), 'samples': _count, 'attitudes': _count,
            'fitted_at': _time, 'parameter_covariance': _parameter_covariance,
            'axes_map': _optional(_axes_map)}


def _axes_map(section, name, key):
    """Read an axes map (``core.mounting``), as written; ValueError if it is none."""
    value = section[key]
    if not isinstance(value, str):
        raise ValueError(f'{name}.{key} {value!r} is not an axes map')
    axes_map_matrix(value, allow_left_handed=True)
    return value


#: Each stage's section: its dataclass, a reader per field (which validates and
#: converts), the checks across fields, in the order they run, and what the stage can
#: physically be (``plausibility``).
STAGE_FIELDS = {
    'installation': (Installation, {
        'gamma_deg': _number, 'beta_deg': _number, 'std_deg': _number, 'g_total_mps2': _number,
        'sample_count': _count, 'captured_at': _time, 'temperature_c': _temperature}, (),
        plausibility.check_installation),
    'toolface_mark': (ToolfaceMark, {
        'offset_deg': _number, 'std_deg': _number, 'inclination_deg': _number,
        'toolface_convention': _choice(*TOOLFACE_CONVENTIONS), 'sample_count': _count,
        'captured_at': _time, 'temperature_c': _temperature}, (),
        plausibility.check_toolface_mark),
    'tool_axis': (ToolAxis, {
        'gamma_deg': _number, 'beta_deg': _number, 'axial_rms_deg': _number,
        'roll_groups': _count, 'shots': _count, 'fitted_at': _time,
        'temperature_c': _temperature}, (),
        plausibility.check_tool_axis),
    'stand': (Stand, {
        'scale_matrix': _array(3, 3), 'bias_mps2': _array(3), 'condition_number': _number,
        'method': _choice('stand', 'sphere'), 'rms_inclination_deg': _optional(_number),
        'positions': _count, 'fitted_at': _time, 'temperature_c': _temperature,
        'scale_coefficients': _kept, 'bias_coefficients_mps2': _kept,
        't_min_c': _optional(_number), 't_max_c': _optional(_number),
        'parameter_covariance': _kept}, (_stand_polynomial, _stand_covariance),
        plausibility.check_stand),
    'magnetometer': (Magnetometer, {
        'scale_matrix': _array(3, 3), 'bias_nT': _array(3), 'condition_number': _number,
        'rms_residual_nT': _number, 'field_nT': _number,
        'method': _choice('stand', 'ellipsoid'), 'positions': _count, 'fitted_at': _time,
        'temperature_c': _temperature, 'scale_coefficients': _kept,
        'bias_coefficients_nT': _kept, 't_min_c': _optional(_number),
        't_max_c': _optional(_number), 'parameter_covariance': _kept,
        'covariance_stages': _kept}, (_stand_polynomial, _magnetometer_covariance),
        plausibility.check_magnetometer),
    'magnetometer_alignment': (MagnetometerAlignment, {
        'rotation': _array(3, 3), 'method': _choice('dip', 'stand', 'given'),
        'dip_deg': _optional(_number), 'dip_rms_deg': _optional(_number), 'shots': _count,
        'fitted_at': _time, 'temperature_c': _temperature}, (),
        plausibility.check_magnetometer_alignment),
    'magnetometer_nonlinear': (MagnetometerNonlinear, {
        'weights': _nonlinear_weights, 'scale_nT': _number, 'rms_residual_nT': _number,
        'roll_sets': _count, 'shots': _count, 'held_out_before_deg': _optional(_number),
        'held_out_after_deg': _optional(_number), 'held_out_noise_deg': _optional(_number),
        'fitted_at': _time,
        'parameter_covariance': _nonlinear_covariance, 'temperature_c': _temperature}, (),
        plausibility.check_magnetometer_nonlinear),
    'temperature': (Temperature, _temperature_fields('mps2'), (_temperature_range,),
                    partial(plausibility.check_temperature, name='temperature')),
    'magnetometer_temperature': (
        MagnetometerTemperature, _temperature_fields('nT'), (_temperature_range,),
        partial(plausibility.check_temperature, name='magnetometer_temperature')),
    'magnetic': (Magnetic, {
        'soft_iron': _array(2, 2), 'hard_iron_nT': _array(2), 'interference_nT': _array(3),
        'rotation_fitted_at': _optional(_time), 'msa_fitted_at': _optional(_time),
        'msa_method': _optional(_choice('improved', 'classic', 'axial')),
        'msa_stations': _kept, 'msa_reference_total_nT': _kept, 'msa_reference_dip_deg': _kept,
        'interference_std_nT': _optional(_array(3)), 'rotation_temperature_c': _temperature,
        'rotation_covariance': _optional(_square_covariance(6))},
        (_msa,), plausibility.check_magnetic),
}
