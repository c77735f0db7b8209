"""
The difference of two calibrations (``inclino calibration diff``): stages and angles.

Which stages were removed, added or changed (field by field), and how the
corrected inclination and toolface of one raw reading move between them
(``pipeline.run``) at a few attitudes.
"""

from dataclasses import asdict, fields
import math

from inclino_ros.calibration.model import MAGNETOMETER_STAGES, STAGES
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.pipeline import run, Settings
import numpy as np

#: Attitudes (inclination, seed 000 toolface) [deg] at which ``diff`` compares the angles.
ATTITUDES_DEG = ((1.0, 0.0), (5.0, 90.0), (30.0, 45.0), (60.0, 200.0), (90.0, 300.0))
#: The stages of both triads, each once, in the order they are applied.
ALL_STAGES = STAGES + tuple(name for name in MAGNETOMETER_STAGES if name not in STAGES)


def _field_changes(a, b):
    """Return 'name: old -> new' of the fields two stages differ in."""
    old, new = asdict(a), asdict(b)
    return [f'{f.name}: {_show(old[f.name])} -> {_show(new[f.name])}'
            for f in fields(a) if old[f.name] != new[f.name]]


def _show(value):
    """Return a stage field's value as the diff prints it."""
    if isinstance(value, float):
        return f'{value:.6g}'
    if isinstance(value, (list, tuple)):
        return '(' + ', '.join(_show(v) for v in value) + ')'
    return repr(value)


def stage_changes(model_a, model_b):
    """Return the lines of the stages removed, added and changed from A to B."""
    lines = []
    for name in ALL_STAGES:
        a, b = getattr(model_a, name), getattr(model_b, name)
        if a is None and b is None:
            continue
        if b is None:
            lines.append(f'{name}: removed')
        elif a is None:
            lines.append(f'{name}: added')
        else:
            changes = _field_changes(a, b)
            lines.append(f'{name}: ' + ('unchanged' if not changes else 'changed'))
            lines += [f'  {change}' for change in changes]
    if model_a.sensor_id != model_b.sensor_id:
        lines.append(f'sensor_id: {model_a.sensor_id!r} -> {model_b.sensor_id!r}')
    return lines


def corrected_angles(model, raw):
    """Return (inclination, toolface) [deg] of raw readings ``model`` corrects (NaN: dropped)."""
    settings = Settings(accelerometer_axes=model.accelerometer_axes, noise_std_mps2=1e-6,
                        toolface_max_std_deg=180.0, two_axis_max_inclination_deg=89.0)
    survey = run(raw, model, settings)
    inclination, toolface = np.full(len(raw), np.nan), np.full(len(raw), np.nan)
    inclination[survey.accepted] = survey.inclination_deg
    toolface[survey.accepted] = survey.toolface_deg
    return inclination, toolface


def angle_changes(model_a, model_b, gravity_mps2=STANDARD_GRAVITY_MPS2):
    """
    Return lines: how the corrected angles move from ``model_a`` to ``model_b`` at ATTITUDES_DEG.

    The raw reading at each attitude is the true specific force of a still
    tool (seed 000 Eq. 1 without installation error); each model corrects it
    through ``pipeline.run``, at its stages' reference temperature.
    """
    i, t = np.radians(np.array(ATTITUDES_DEG)).T
    raw = gravity_mps2 * np.column_stack([np.sin(i) * np.cos(t), np.sin(i) * np.sin(t),
                                          np.cos(i)])
    (inc_a, tf_a), (inc_b, tf_b) = corrected_angles(model_a, raw), corrected_angles(model_b, raw)
    lines = ['corrected angles of the same raw reading (B minus A):']
    for (inclination, toolface), d_inc, d_tf in zip(
            ATTITUDES_DEG, inc_b - inc_a, (tf_b - tf_a + 180.0) % 360.0 - 180.0):
        lines.append(f'  at inclination {inclination:g} deg, toolface {toolface:g} deg: '
                     f'inclination {_delta(d_inc)}, toolface {_delta(d_tf)}')
    return lines


def _delta(value_deg):
    """Return an angle change as the diff prints it."""
    return 'n/a (not corrected by both)' if not math.isfinite(value_deg) else \
        f'{value_deg:+.4f} deg'
