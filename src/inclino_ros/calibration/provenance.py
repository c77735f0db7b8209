"""
Provenance of a calibration's stages: when they were fitted, and at what temperature.

Ages against the limits (the drill string's interference has its own,
shorter one), and the temperatures the stages' readings stood for, so that
stages captured at different temperatures are not combined unnoticed.
"""

from datetime import datetime, timezone

import numpy as np


def utc_now_iso():
    """Return the current UTC time as an ISO 8601 string."""
    return datetime.now(timezone.utc).isoformat(timespec='seconds')


def age_seconds(iso_time, now=None):
    """Return the seconds elapsed since ``iso_time`` (an ISO 8601 string)."""
    now = now or datetime.now(timezone.utc)
    return (now - datetime.fromisoformat(iso_time)).total_seconds()


#: Stages with a time, the field holding it, and which age limit applies: the drill
#: string's interference (MSA) has its own, shorter one.
STAGE_TIMES = (('temperature', 'fitted_at', 'calibration'),
               ('stand', 'fitted_at', 'calibration'),
               ('installation', 'captured_at', 'calibration'),
               ('tool_axis', 'fitted_at', 'calibration'),
               ('toolface_mark', 'captured_at', 'calibration'),
               ('magnetometer_temperature', 'fitted_at', 'calibration'),
               ('magnetometer', 'fitted_at', 'calibration'),
               ('magnetometer_alignment', 'fitted_at', 'calibration'),
               ('magnetometer_nonlinear', 'fitted_at', 'calibration'),
               ('magnetic', 'rotation_fitted_at', 'calibration'),
               ('magnetic', 'msa_fitted_at', 'interference'))


def stage_ages_s(model, now=None):
    """Return ``[(stage name, age [s], limit kind)]`` of every dated stage of ``model``."""
    ages = []
    for name, field, kind in STAGE_TIMES:
        stage = getattr(model, name)
        when = None if stage is None else getattr(stage, field)
        if when is not None:
            label = 'msa' if field == 'msa_fitted_at' else (
                'rotation' if field == 'rotation_fitted_at' else name)
            ages.append((label, age_seconds(when, now), kind))
    return ages


def stale_stages(model, max_age_s, interference_max_age_s, now=None):
    """Return ``[(stage, age [s], limit [s])]`` of the stages older than their limit."""
    limits = {'calibration': max_age_s, 'interference': interference_max_age_s}
    return [(name, age, limits[kind]) for name, age, kind in stage_ages_s(model, now)
            if age > limits[kind]]


def readings_temperature_c(temperature_stage, measured_c):
    """
    Return the temperature [deg C] corrected readings stand for.

    Through a temperature stage: its reference; without: the temperature they
    were measured at (``measured_c``, None when unknown).
    """
    return measured_c if temperature_stage is None else temperature_stage.reference_temperature_c


#: The field of a stage that records the temperature its readings stood for.
TEMPERATURE_FIELDS = {'magnetic': 'rotation_temperature_c'}


def stage_temperatures(model, names=('stand', 'installation')):
    """Return ``{name: temperature_c}`` of the stages ``names`` present that record one."""
    found = {name: getattr(getattr(model, name), TEMPERATURE_FIELDS.get(name, 'temperature_c'),
                           None) for name in names if getattr(model, name) is not None}
    return {name: value for name, value in found.items() if value is not None}


def temperature_conflict(model, temperature_c, tolerance_c, names=('stand', 'installation')):
    """
    Return why a new stage standing for ``temperature_c`` disagrees with ``names``, or None.

    Stages whose readings stood for temperatures more than ``tolerance_c``
    apart do not fit together without a temperature stage to bring their
    readings to one temperature (``temperature_c`` None: nothing to compare).
    """
    if temperature_c is None:
        return None
    for name, other_c in stage_temperatures(model, names).items():
        if abs(other_c - temperature_c) > tolerance_c:
            return (f'this capture stands for {temperature_c:.1f} C but the {name} stage for '
                    f'{other_c:.1f} C (more than {tolerance_c:g} C apart): without a temperature '
                    'stage the drift between them is not corrected; fit the temperature stage '
                    f'(inclino fit-temperature) or capture at {other_c:.1f} C')
    return None


def common_stage_temperature(model, tolerance_c, names=('stand', 'installation')):
    """
    Return the one temperature the stages ``names`` stand for (their mean), None if none is known.

    A new temperature stage must compensate to it.  ValueError (the reason)
    when they lie more than ``tolerance_c`` apart: no one compensation suits
    them all.
    """
    known = stage_temperatures(model, names)
    if not known:
        return None
    values = np.array(list(known.values()))
    if np.ptp(values) > tolerance_c:
        raise ValueError(
            'the stages were captured at different temperatures ('
            + ', '.join(f'{name} {value:.1f} C' for name, value in known.items())
            + f', more than {tolerance_c:g} C apart): no one temperature compensation suits '
            'them; capture them again after the temperature fit')
    return float(values.mean())


#: The stages that compensate a temperature, each needing the temperature of every reading.
TEMPERATURE_STAGES = ('temperature', 'magnetometer_temperature')


class MissingTemperature(ValueError):
    """A calibration compensates temperature and the input gives none (refused)."""


def missing_temperature(model, calibration, missing, at_reference=False,
                        option='--at-reference-temperature'):
    """
    Apply the one rule for readings without a temperature (``inclino process`` and ``survey``).

    A calibration with a temperature stage corrects each reading at its
    temperature; without one it would compensate at the reference
    temperature, a silent error of up to the stage's whole drift (5° of
    inclination over 60 K).  So it is refused (MissingTemperature, naming the
    stages, what is ``missing`` and the way out) unless ``at_reference``:
    then the readings are compensated at the reference temperature with
    every 1 sigma widened by the stage's drift over its fitted range
    (``_TemperatureStage.compensation_covariance``), and the text of a loud
    warning naming the reference temperature(s) is returned.  None: the
    calibration compensates no temperature.  ``option``: the way out as the
    caller spells it.  The one rule of ``inclino
    process``, ``inclino survey`` (``--at-reference-temperature``) and the
    node (parameter ``temperature.at_reference``).
    """
    stages = [name for name in TEMPERATURE_STAGES if getattr(model, name) is not None]
    if not stages:
        return None
    if not at_reference:
        raise MissingTemperature(
            f'{missing} but {calibration} compensates temperature ({", ".join(stages)}): give '
            f'the temperature of every reading, or {option} to compensate at the reference '
            'temperature (1 sigma widened by the drift over the fitted range)')
    references = ', '.join(f'{name} {getattr(model, name).reference_temperature_c:g} deg C'
                           for name in stages)
    return (f'warning: {missing}: {option}: {calibration} compensates at its reference '
            f'temperature ({references}), not at that of the readings: every 1 sigma is '
            'widened by the drift over the fitted range')
