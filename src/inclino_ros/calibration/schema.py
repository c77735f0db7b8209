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
import math

from inclino_ros.calibration import plausibility
from inclino_ros.calibration.corrections import CalibrationModel
from inclino_ros.calibration.migrations import (
    READABLE_VERSIONS, SCHEMA_VERSION, SECTIONS, upgraded)
from inclino_ros.calibration.stages import (
    Installation, Magnetic, Magnetometer, MagnetometerAlignment, MagnetometerTemperature, Stand,
    Temperature, ToolAxis)
import numpy as np

FORMAT = 'inclino_ros.calibration'


def model_to_dict(model):
    """Return the JSON-ready document of ``model``."""
    doc = {'format': FORMAT, 'schema_version': SCHEMA_VERSION,
           'accelerometer_axes': model.accelerometer_axes, 'sensor_id': model.sensor_id}
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
        {'sensor_id'} if version >= 3 else set())
    unknown = set(doc) - top - set(stages)
    if unknown:
        raise ValueError(f'unknown sections {sorted(unknown)} in a version {version} file')
    sensor_id = doc.get('sensor_id') if version >= 3 else None
    if sensor_id is not None and not isinstance(sensor_id, str):
        raise ValueError(f'sensor_id {sensor_id!r} is not a string')
    readers = {'installation': installation_from_dict, 'stand': stand_from_dict,
               'temperature': temperature_from_dict, 'magnetic': magnetic_from_dict,
               'tool_axis': tool_axis_from_dict, 'magnetometer': magnetometer_from_dict,
               'magnetometer_alignment': alignment_from_dict,
               'magnetometer_temperature': magnetometer_temperature_from_dict}
    sections = {name: upgraded(doc[name], name, version)
                for name in stages if doc.get(name) is not None}
    model = CalibrationModel(accelerometer_axes=axes, sensor_id=sensor_id, **{
        name: readers[name](section) for name, section in sections.items()})
    if axes == 2 and (model.stand or model.temperature):
        raise ValueError('stand and temperature stages need a three-axis accelerometer')
    return model


def _optional_temperature(section, name):
    """Raise ValueError unless ``section['temperature_c']`` is None or a sensor's deg C."""
    value = section['temperature_c']
    if value is not None:
        (value,) = _finite(section, name, 'temperature_c')
        plausibility.check_temperatures([value], f'{name}.temperature_c')


def _check_fields(section, kind, name):
    """Raise ValueError unless ``section`` has exactly the fields of dataclass ``kind``."""
    expected = {f.name for f in fields(kind)}
    if not isinstance(section, dict) or set(section) != expected:
        got = sorted(section) if isinstance(section, dict) else section
        raise ValueError(f'{name} needs exactly the fields {sorted(expected)}, got {got}')


def _finite(section, name, *keys, shape=()):
    """Return ``section[key]`` as finite float arrays of ``shape``; ValueError if not."""
    values = []
    for key in keys:
        value = section[key]
        array = np.asarray(value, dtype=object)
        if array.shape != shape or any(
                isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                for v in array.flat):
            what = 'a finite number' if shape == () else f'finite numbers of shape {shape}'
            raise ValueError(f'{name}.{key} = {value!r} is not {what}')
        values.append(np.asarray(value, dtype=float))
    return values


def _count(section, name, key):
    """Raise ValueError unless ``section[key]`` is a positive integer."""
    if not is_int(section[key]) or section[key] < 1:
        raise ValueError(f'{name}.{key} = {section[key]!r} is not a positive integer')


def _time(section, name, key):
    """Raise ValueError unless ``section[key]`` is an ISO 8601 time with a zone."""
    try:
        moment = datetime.fromisoformat(section[key])
    except (TypeError, ValueError):
        raise ValueError(f'{name}.{key} = {section[key]!r} is not an ISO 8601 time') from None
    if moment.tzinfo is None:
        raise ValueError(f'{name}.{key} has no time zone')


def installation_from_dict(section):
    """Return a validated Installation from its file section."""
    _check_fields(section, Installation, 'installation')
    _finite(section, 'installation', 'gamma_deg', 'beta_deg', 'std_deg', 'g_total_mps2')
    _count(section, 'installation', 'sample_count')
    _time(section, 'installation', 'captured_at')
    _optional_temperature(section, 'installation')
    stage = Installation(**section)
    plausibility.check_installation(stage)
    return stage


def tool_axis_from_dict(section):
    """Return a validated ToolAxis from its file section."""
    _check_fields(section, ToolAxis, 'tool_axis')
    _finite(section, 'tool_axis', 'gamma_deg', 'beta_deg', 'axial_rms_deg')
    _count(section, 'tool_axis', 'roll_groups')
    _count(section, 'tool_axis', 'shots')
    _time(section, 'tool_axis', 'fitted_at')
    stage = ToolAxis(**section)
    plausibility.check_tool_axis(stage)
    return stage


def magnetometer_from_dict(section):
    """Return a validated Magnetometer from its file section."""
    _check_fields(section, Magnetometer, 'magnetometer')
    (k,) = _finite(section, 'magnetometer', 'scale_matrix', shape=(3, 3))
    _finite(section, 'magnetometer', 'bias_nT', shape=(3,))
    _finite(section, 'magnetometer', 'condition_number', 'rms_residual_nT', 'field_nT')
    if section['method'] not in ('stand', 'ellipsoid'):
        raise ValueError(f'magnetometer.method = {section["method"]!r} is not stand or ellipsoid')
    _count(section, 'magnetometer', 'positions')
    _time(section, 'magnetometer', 'fitted_at')
    stage = Magnetometer(**dict(section, scale_matrix=tuple(map(tuple, k.tolist())),
                                bias_nT=tuple(section['bias_nT'])))
    plausibility.check_magnetometer(stage)
    return stage


def alignment_from_dict(section):
    """Return a validated MagnetometerAlignment from its file section."""
    _check_fields(section, MagnetometerAlignment, 'magnetometer_alignment')
    (r,) = _finite(section, 'magnetometer_alignment', 'rotation', shape=(3, 3))
    if section['method'] not in ('dip', 'stand', 'given'):
        raise ValueError(f'magnetometer_alignment.method = {section["method"]!r} is not dip, '
                         'stand or given')
    for key in ('dip_deg', 'dip_rms_deg'):
        if section[key] is not None:
            _finite(section, 'magnetometer_alignment', key)
    _count(section, 'magnetometer_alignment', 'shots')
    _time(section, 'magnetometer_alignment', 'fitted_at')
    stage = MagnetometerAlignment(**dict(section, rotation=tuple(map(tuple, r.tolist()))))
    plausibility.check_magnetometer_alignment(stage)
    return stage


def stand_from_dict(section):
    """Return a validated Stand from its file section."""
    _check_fields(section, Stand, 'stand')
    (k,) = _finite(section, 'stand', 'scale_matrix', shape=(3, 3))
    _finite(section, 'stand', 'bias_mps2', shape=(3,))
    _finite(section, 'stand', 'condition_number')
    if section['method'] not in ('stand', 'sphere'):
        raise ValueError(f'stand.method = {section["method"]!r} is not stand or sphere')
    if section['rms_inclination_deg'] is not None:
        _finite(section, 'stand', 'rms_inclination_deg')
    _count(section, 'stand', 'positions')
    _time(section, 'stand', 'fitted_at')
    _optional_temperature(section, 'stand')
    stage = Stand(**dict(section, scale_matrix=tuple(map(tuple, k.tolist())),
                         bias_mps2=tuple(section['bias_mps2'])))
    plausibility.check_stand(stage)
    return stage


def temperature_from_dict(section):
    """Return a validated (accelerometer) Temperature from its file section."""
    return _temperature_stage(section, Temperature, 'temperature', 'mps2')


def magnetometer_temperature_from_dict(section):
    """Return a validated MagnetometerTemperature from its file section."""
    return _temperature_stage(section, MagnetometerTemperature, 'magnetometer_temperature', 'nT')


def _temperature_stage(section, kind, name, unit):
    """Return a validated temperature stage ``kind``; its unit-named fields end in ``unit``."""
    _check_fields(section, kind, name)
    coefficients = np.asarray(section['coefficients'], dtype=object)
    if coefficients.ndim != 2 or coefficients.shape[0] != 3 or coefficients.shape[1] < 1:
        raise ValueError(f'{name}.coefficients must be 3 rows of a0..an')
    _finite(section, name, 'coefficients', shape=coefficients.shape)
    bias_key, rms_key = f'bias_coefficients_{unit}', f'rms_residual_{unit}'
    if section[bias_key] is not None:
        _finite(section, name, bias_key, shape=coefficients.shape)
    t_min, t_max, t_ref = _finite(section, name, 't_min_c', 't_max_c',
                                  'reference_temperature_c')
    _finite(section, name, rms_key, shape=(3,))
    if not t_min <= t_ref <= t_max or t_min == t_max:
        raise ValueError(f'{name} range [{t_min}, {t_max}] C is empty or does not '
                         f'contain the reference {t_ref} C')
    _count(section, name, 'samples')
    _count(section, name, 'attitudes')
    _time(section, name, 'fitted_at')
    bias = section[bias_key]
    stage = kind(**dict(section, coefficients=tuple(map(tuple, section['coefficients'])),
                        **{rms_key: tuple(section[rms_key]),
                           bias_key: None if bias is None else tuple(map(tuple, bias))}))
    plausibility.check_temperature(stage, name)
    return stage


def magnetic_from_dict(section):
    """Return a validated Magnetic from its file section."""
    _check_fields(section, Magnetic, 'magnetic')
    _finite(section, 'magnetic', 'soft_iron', shape=(2, 2))
    _finite(section, 'magnetic', 'hard_iron_nT', shape=(2,))
    _finite(section, 'magnetic', 'interference_nT', shape=(3,))
    for key in ('rotation_fitted_at', 'msa_fitted_at'):
        if section[key] is not None:
            _time(section, 'magnetic', key)
    if section['msa_method'] is not None:
        if section['msa_method'] not in ('improved', 'classic', 'axial'):
            raise ValueError(f'magnetic.msa_method = {section["msa_method"]!r} is unknown')
        _count(section, 'magnetic', 'msa_stations')
        _finite(section, 'magnetic', 'msa_reference_total_nT', 'msa_reference_dip_deg')
    std = section['interference_std_nT']
    if std is not None:
        (std,) = _finite(section, 'magnetic', 'interference_std_nT', shape=(3,))
        std = tuple(std.tolist())
    _optional_temperature({'temperature_c': section['rotation_temperature_c']},
                          'magnetic.rotation')
    stage = Magnetic(**dict(section, hard_iron_nT=tuple(section['hard_iron_nT']),
                            soft_iron=tuple(map(tuple, section['soft_iron'])),
                            interference_nT=tuple(section['interference_nT']),
                            interference_std_nT=std))
    plausibility.check_magnetic(stage)
    return stage
