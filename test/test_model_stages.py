"""The calibration model's stages (seed 001, magnetometer, mount): order, file, validation."""

from dataclasses import replace
import json
import math

from calibration_files import load_refusal
from inclino_ros.calibration.model import (
    CalibrationFileError, CalibrationModel, Installation, load_model, Magnetometer,
    MagnetometerAlignment, save_model, Stand, Temperature, ToolAxis, VERSION_3_FIELDS)
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

G = 9.80665
K = ((1.003, 0.002, -0.004), (-0.001, 0.997, 0.003), (0.005, -0.002, 1.002))
BIAS_MPS2 = (0.02, -0.015, 0.01)
SLOPE = (4e-4, -3e-4, 2e-4)   # K_T = 1 + slope (T - 25)
STAND = Stand(scale_matrix=K, bias_mps2=BIAS_MPS2, method='stand', condition_number=2.1,
              rms_inclination_deg=0.002, positions=9, fitted_at='2026-03-01T10:20:30+00:00')
TEMPERATURE = Temperature(
    coefficients=tuple((1.0 - 25.0 * s, s) for s in SLOPE), t_min_c=20.0, t_max_c=100.0,
    reference_temperature_c=25.0, rms_residual_mps2=(1e-4, 1e-4, 1e-4), samples=90,
    fitted_at='2026-03-01T09:00:00+00:00')
INSTALLATION = Installation(gamma_deg=0.3, beta_deg=-0.2, captured_at='2026-03-02T08:00:00+00:00',
                            sample_count=100, std_deg=0.01, g_total_mps2=G)
MODEL = CalibrationModel(accelerometer_axes=3, installation=INSTALLATION, stand=STAND,
                         temperature=TEMPERATURE)


def forward(f, temperature_c):
    """
    Return what the flawed sensor reads for ideal-frame ``f`` at a temperature.

    The inverse of the model, written out: installation C (seed 000 Eq. 1),
    then K f + b (seed 001 Eq. 10), then the scale K_T(T) per axis (Eq. 6).
    """
    g, b = math.radians(0.3), math.radians(-0.2)
    c = np.array([[math.cos(g), 0, -math.sin(g)],
                  [-math.sin(b) * math.sin(g), math.cos(b), -math.sin(b) * math.cos(g)],
                  [math.cos(b) * math.sin(g), math.sin(b), math.cos(b) * math.cos(g)]])
    sensor = np.asarray(K) @ (c @ f) + np.asarray(BIAS_MPS2)
    return sensor * (1.0 + np.asarray(SLOPE) * (temperature_c - 25.0))


def test_stages_run_in_order_and_invert_the_sensor():
    """Stages temperature -> stand -> installation undo the forward model exactly."""
    rng = np.random.default_rng(5)
    f = rng.normal(size=(20, 3)) * G
    temperatures_c = rng.uniform(20.0, 100.0, 20)
    raw = np.array([forward(v, t) for v, t in zip(f, temperatures_c)])
    np.testing.assert_allclose(MODEL.apply(raw, temperatures_c), f, atol=1e-12)
    # before='installation' stops after the stand stage: the level capture's input.
    no_installation = CalibrationModel(3, stand=STAND, temperature=TEMPERATURE)
    np.testing.assert_allclose(MODEL.apply(raw, temperatures_c, before='installation'),
                               no_installation.apply(raw, temperatures_c), atol=0)


def test_temperature_is_clamped_and_defaults_to_the_reference():
    """Outside the fitted range K_T is that of the nearest end; None means 25 C."""
    f = np.array([[1.0, 2.0, 9.0]])
    np.testing.assert_array_equal(TEMPERATURE.apply(f, 150.0), TEMPERATURE.apply(f, 100.0))
    np.testing.assert_array_equal(TEMPERATURE.apply(f, -5.0), TEMPERATURE.apply(f, 20.0))
    np.testing.assert_allclose(TEMPERATURE.apply(f, None), f, atol=1e-15)


def test_round_trip_with_every_stage(tmp_path):
    """A model with all stages saves and loads back equal; the file is version 8."""
    path = tmp_path / 'calibration.json'
    save_model(path, MODEL)
    assert load_model(path) == MODEL
    assert json.loads(path.read_text())['schema_version'] == 11


def test_version_1_file_still_loads(tmp_path):
    """A version 1 file (installation only, no temperature recorded) is read."""
    doc = CalibrationModel(3, installation=INSTALLATION).to_dict()
    doc['schema_version'] = 1
    del doc['sensor_id'], doc['installation']['temperature_c']
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps(doc))
    assert load_model(path).installation == INSTALLATION


def test_version_2_file_still_loads(tmp_path):
    """A version 2 file (no sensor_id, no stage temperatures, scale-only drift) is read."""
    doc = MODEL.to_dict()
    doc['schema_version'] = 2
    del doc['sensor_id']
    for section, added in VERSION_3_FIELDS.items():
        for field in added:
            doc.get(section, {}).pop(field, None)
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps(doc))
    assert load_model(path) == MODEL


def edited(section, **changes):
    """Return MODEL's document with fields of one section changed."""
    doc = MODEL.to_dict()
    doc[section] = dict(doc[section], **changes)
    return doc


BAD = {
    'stand NaN': (edited('stand', bias_mps2=[0.0, math.nan, 0.0]), 'bias_mps2'),
    'stand shape': (edited('stand', scale_matrix=[[1, 0], [0, 1]]), 'scale_matrix'),
    'stand singular': (edited('stand', scale_matrix=[[1, 0, 0], [0, 1, 0], [0, 0, 0]]),
                       'is not a sensor'),
    'stand method': (edited('stand', method='guess'), 'not stand or sphere'),
    'stand field': (edited('stand', extra=1), 'needs exactly the fields'),
    'temperature range': (edited('temperature', t_min_c=30.0), 'does not contain'),
    'temperature not 1': (edited('temperature', coefficients=[[1.1, 0.0]] * 3),
                          'not 1 at the reference'),
    'temperature wild': (edited('temperature', coefficients=[[0.0, 0.04]] * 3),
                         'outside 0.8 .. 1.2'),
    'temperature rows': (edited('temperature', coefficients=[[1.0, 0.0]] * 2), '3 rows'),
    'two axes': (dict(MODEL.to_dict(), accelerometer_axes=2), 'three-axis'),
}


@pytest.mark.parametrize('name', sorted(BAD))
def test_invalid_stage_is_a_loud_error(tmp_path, name):
    """A defective stand or temperature section is refused, naming the file."""
    doc, reason = BAD[name]
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps(doc))
    with pytest.raises(CalibrationFileError) as caught:
        load_model(path)
    assert str(path) in str(caught.value) and reason in caught.value.reason


MAGNETOMETER = Magnetometer(
    scale_matrix=((1.01, 0.002, 0.0), (0.002, 0.99, 0.001), (0.0, 0.001, 1.0)),
    bias_nT=(120.0, -80.0, 300.0), method='ellipsoid', condition_number=3.0,
    rms_residual_nT=4.0, field_nT=50000.0, positions=24, fitted_at='2026-03-03T08:00:00+00:00')
ALIGNMENT = MagnetometerAlignment(
    rotation=tuple(map(tuple, np.round(Rotation.from_rotvec([0.01, -0.02, 0.005]).as_matrix(),
                                       15).tolist())),
    method='dip', dip_deg=60.0, dip_rms_deg=0.01, shots=24,
    fitted_at='2026-03-03T08:00:00+00:00')
TOOL_AXIS = ToolAxis(gamma_deg=0.8, beta_deg=-1.2, roll_groups=2, shots=16, axial_rms_deg=0.005,
                     fitted_at='2026-03-03T08:00:00+00:00')
FULL = replace(MODEL, magnetometer=MAGNETOMETER, magnetometer_alignment=ALIGNMENT,
               tool_axis=TOOL_AXIS)


def test_magnetometer_stages_round_trip_and_order(tmp_path):
    """Version 3 stages save and load back equal; the chain is own stages, mount, seed 002."""
    path = tmp_path / 'calibration.json'
    save_model(path, FULL)
    assert load_model(path) == FULL
    assert FULL.magnetometer_stages == ('magnetometer', 'magnetometer_alignment', 'installation',
                                        'tool_axis')
    b = np.array([[20000.0, -5000.0, 43000.0]])
    expected = MAGNETOMETER.apply(b) @ (STAND.rotation @ ALIGNMENT.matrix).T
    expected = TOOL_AXIS.apply(INSTALLATION.apply(expected))
    np.testing.assert_allclose(FULL.apply_magnetic(b), expected, rtol=1e-12)
    # The accelerometer's specific force goes through the same mount.
    f = np.array([[1.0, 2.0, 9.0]])
    np.testing.assert_allclose(
        FULL.apply(f), TOOL_AXIS.apply(MODEL.apply(f)), rtol=1e-12)


BAD_MAGNETOMETER = {
    'not a rotation': ('magnetometer_alignment', {'rotation': [[1, 0, 0], [0, 1, 0], [0, 0, 2]]},
                       'is not a rotation'),
    'mirror': ('magnetometer_alignment', {'rotation': [[1, 0, 0], [0, 1, 0], [0, 0, -1]]},
               'is not a rotation'),
    'method': ('magnetometer', {'method': 'guess'}, 'not stand or ellipsoid'),
    'microtesla K': ('magnetometer', {'scale_matrix': [[1e-3, 0, 0], [0, 1e-3, 0],
                                                       [0, 0, 1e-3]]}, 'not in nT'),
    'tool axis angle': ('tool_axis', {'gamma_deg': 50.0}, 'not an installation error'),
}


@pytest.mark.parametrize('name', sorted(BAD_MAGNETOMETER))
def test_invalid_magnetometer_stage_is_a_loud_error(tmp_path, name):
    """A defective magnetometer, alignment or tool-axis section is refused, naming the file."""
    section, changes, reason = BAD_MAGNETOMETER[name]
    doc = FULL.to_dict()
    doc[section] = dict(doc[section], **changes)
    assert reason in load_refusal(tmp_path, doc)


def test_version_2_file_has_no_magnetometer_stage(tmp_path):
    """A version 2 file loads as before; a magnetometer section in it is unknown."""
    doc = MODEL.to_dict()
    doc['schema_version'] = 2
    del doc['sensor_id']            # a version 3 field
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps(doc))
    assert load_model(path) == MODEL
    doc['magnetometer'] = FULL.to_dict()['magnetometer']
    path.write_text(json.dumps(doc))
    with pytest.raises(CalibrationFileError, match='unknown sections'):
        load_model(path)


#: K_m(T) = K_m + (T - 40) dK, b_m(T) = b_m + (T - 40) db over 20..60 C (issue 18).
D_SCALE = ((2e-4, 1e-5, 0.0), (0.0, -1e-4, 2e-5), (3e-5, 0.0, 1e-4))
D_BIAS_NT = (2.0, -1.5, 12.5)
MAGNETOMETER_OF_T = replace(
    MAGNETOMETER, method='stand', temperature_c=40.0,
    scale_coefficients=(MAGNETOMETER.scale_matrix, D_SCALE),
    bias_coefficients_nT=(MAGNETOMETER.bias_nT, D_BIAS_NT), t_min_c=20.0, t_max_c=60.0)


def test_magnetometer_of_temperature_round_trips_and_inverts_the_sensor(tmp_path):
    """
    K_m(T), b_m(T) (schema 6) save and load back equal and undo ``m = K_m(T) B + b_m(T)``.

    The forward model written out here at each reading's temperature; beyond the range
    K_m and b_m of the nearer end.  Main had no such fields (the file was refused).
    """
    model = replace(FULL, magnetometer=MAGNETOMETER_OF_T)
    path = tmp_path / 'calibration.json'
    save_model(path, model)
    assert load_model(path) == model
    rng = np.random.default_rng(2)
    truth = rng.normal(size=(12, 3)) * 30000.0
    temperatures_c = np.concatenate([rng.uniform(20.0, 60.0, 10), [10.0, 75.0]])
    held = np.clip(temperatures_c, 20.0, 60.0) - 40.0
    raw = np.array([(np.array(MAGNETOMETER.scale_matrix) + dt * np.array(D_SCALE)) @ b
                    + np.array(MAGNETOMETER.bias_nT) + dt * np.array(D_BIAS_NT)
                    for b, dt in zip(truth, held)])
    np.testing.assert_allclose(MAGNETOMETER_OF_T.apply(raw, temperatures_c), truth, atol=1e-8)
    assert MAGNETOMETER_OF_T.outside_range(temperatures_c).tolist() == [False] * 10 + [True] * 2
    assert [name for name, _ in model.polynomial_stages] == ['magnetometer']
    # Without a temperature: K_m, b_m at the stage's own temperature.
    np.testing.assert_allclose(MAGNETOMETER_OF_T.apply(raw[:1]), MAGNETOMETER.apply(raw[:1]))


BAD_MAGNETOMETER_OF_T = {
    'range only': ({'scale_coefficients': None}, 'are all given or none'),
    'first term': ({'bias_coefficients_nT': [[0.0, 0.0, 0.0], list(D_BIAS_NT)]},
                   "bias_nT must be the polynomials' first terms"),
    'range': ({'t_max_c': 30.0}, 'does not contain its temperature 40.0 C'),
    'shape': ({'bias_coefficients_nT': [list(D_BIAS_NT)]}, 'finite numbers of shape (2, 3)'),
}


@pytest.mark.parametrize('name', sorted(BAD_MAGNETOMETER_OF_T))
def test_invalid_magnetometer_polynomial_is_a_loud_error(tmp_path, name):
    """A K_m(T), b_m(T) that is half given, off its first terms or its range: refused."""
    changes, reason = BAD_MAGNETOMETER_OF_T[name]
    doc = replace(FULL, magnetometer=MAGNETOMETER_OF_T).to_dict()
    doc['magnetometer'] = dict(doc['magnetometer'], **changes)
    assert reason in load_refusal(tmp_path, doc)


def test_version_5_magnetometer_loads_constant(tmp_path):
    """A version 5 file's magnetometer (no polynomial fields) loads with constant K_m, b_m."""
    doc = FULL.to_dict()
    doc['schema_version'] = 5
    for key in ('scale_coefficients', 'bias_coefficients_nT', 't_min_c', 't_max_c'):
        del doc['magnetometer'][key]
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps(doc))
    assert load_model(path) == FULL and not load_model(path).magnetometer.temperature_dependent
