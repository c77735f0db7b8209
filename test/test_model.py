"""
Calibration model: application, file round trip, atomic write and strict validation.

Round trips compare exactly: JSON writes floats with repr(), which reads back bit for bit.
Applied corrections are compared to the installation module to 1e-12 m/s^2 (round-off of
a 3x3 product on values of order g is ~1e-15).
"""

from datetime import datetime, timedelta, timezone
import json
import math
import os

from inclino_ros.calibration.model import (
    age_seconds, CalibrationFileError, CalibrationModel, FORMAT, Installation, load_model,
    model_from_dict, save_model, SCHEMA_VERSION, utc_now_iso)
from inclino_ros.core.installation import correct_installation, pseudo_inclination
import numpy as np
import pytest

G = 9.80665

INSTALLATION = Installation(gamma_deg=0.0355, beta_deg=-0.2773,
                            captured_at='2026-03-01T10:20:30+00:00', sample_count=100,
                            std_deg=0.0123, g_total_mps2=9.8071)
MODEL = CalibrationModel(accelerometer_axes=2, installation=INSTALLATION)


def valid_doc():
    """Return a fresh, valid calibration document."""
    return MODEL.to_dict()


def write_doc(path, doc):
    """Write ``doc`` as JSON (NaN/Infinity literals allowed) to ``path``."""
    path.write_text(json.dumps(doc))


def test_apply_and_properties():
    """The model applies Eq. 9 with its angles; uncalibrated passes readings through."""
    rng = np.random.default_rng(11)
    f = rng.normal(scale=G, size=(7, 3))
    expected = correct_installation(f, math.radians(0.0355), math.radians(-0.2773))
    np.testing.assert_allclose(MODEL.apply(f), expected, rtol=0, atol=1e-12)
    assert MODEL.calibrated
    assert INSTALLATION.theta_deg == pytest.approx(math.degrees(float(pseudo_inclination(
        math.radians(0.0355), math.radians(-0.2773)))), abs=1e-12)
    assert round(INSTALLATION.theta_deg, 4) == 0.2796      # seed 000, section 4
    bare = CalibrationModel(accelerometer_axes=3)
    assert not bare.calibrated
    np.testing.assert_array_equal(bare.apply(f), f)
    assert bare.to_dict() == {'format': FORMAT, 'schema_version': SCHEMA_VERSION,
                              'accelerometer_axes': 3, 'sensor_id': None}


@pytest.mark.parametrize('model', [MODEL, CalibrationModel(accelerometer_axes=3)])
def test_save_load_round_trip(tmp_path, model):
    """A saved model loads back equal, field for field, bit for bit."""
    path = tmp_path / 'sub' / 'calibration.json'     # folder created on save
    save_model(str(path), model)
    assert load_model(str(path)) == model
    doc = json.loads(path.read_text())
    assert doc['format'] == 'inclino_ros.calibration'
    assert doc['schema_version'] == SCHEMA_VERSION == 11
    assert sorted(os.listdir(path.parent)) == ['calibration.json', 'calibration.json.history']


def test_save_replaces_target_atomically(tmp_path):
    """Saving over a file swaps in a new inode by rename and leaves no temporary file."""
    path = tmp_path / 'calibration.json'
    save_model(str(path), CalibrationModel(accelerometer_axes=3))
    inode_before = os.stat(path).st_ino
    save_model(str(path), MODEL)
    # os.replace of a fresh temporary file: a different inode; an in-place rewrite
    # (open(path, 'w')) would keep the old one and expose a half-written file.
    assert os.stat(path).st_ino != inode_before
    assert load_model(str(path)) == MODEL
    assert sorted(os.listdir(tmp_path)) == ['calibration.json', 'calibration.json.history']


def _previous_file(tmp_path):
    """Save MODEL and return (path, bytes) of that previous good file."""
    path = tmp_path / 'calibration.json'
    save_model(str(path), MODEL)
    return path, path.read_bytes()


@pytest.mark.parametrize('gamma_deg', [{0.1}, math.nan, 50.0])
def test_invalid_model_is_not_written(tmp_path, gamma_deg):
    """A model load_model would refuse is refused at save: old file kept, nothing else."""
    path, before = _previous_file(tmp_path)
    broken = CalibrationModel(accelerometer_axes=3, installation=Installation(
        gamma_deg=gamma_deg, beta_deg=0.0, captured_at='2026-03-01T10:20:30+00:00',
        sample_count=1, std_deg=0.0, g_total_mps2=G))
    with pytest.raises(ValueError, match='gamma_deg'):
        save_model(str(path), broken)
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ['calibration.json', 'calibration.json.history']


@pytest.mark.parametrize('target', ['replace', 'fsync'])
def test_failing_rename_or_fsync_keeps_previous_file(tmp_path, monkeypatch, target):
    """An OSError at fsync or rename leaves the old file whole and no temporary file."""
    path, before = _previous_file(tmp_path)

    def fail(*args):
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(os, target, fail)
    with pytest.raises(OSError):
        save_model(str(path), CalibrationModel(accelerometer_axes=3))
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert os.listdir(tmp_path / 'calibration.json.history') == ['v000001.json']  # none added
    assert sorted(os.listdir(tmp_path)) == ['calibration.json', 'calibration.json.history']


def test_unwritable_folder_keeps_previous_file(tmp_path, monkeypatch):
    """No temporary file can be made (read-only folder): PermissionError, old file intact."""
    path, before = _previous_file(tmp_path)

    def refuse(*args, **kwargs):
        raise PermissionError(13, 'Permission denied')

    # Simulated so that the test also bites when run as root, who ignores chmod.
    monkeypatch.setattr('inclino_ros.io.files.open', refuse, raising=False)
    with pytest.raises(PermissionError):
        save_model(str(path), CalibrationModel(accelerometer_axes=3))
    monkeypatch.undo()
    assert path.read_bytes() == before


@pytest.mark.skipif(os.geteuid() == 0, reason='root writes into read-only folders')
def test_read_only_folder_keeps_previous_file(tmp_path):
    """A real read-only folder: the save fails and the old file is unchanged."""
    path, before = _previous_file(tmp_path)
    os.chmod(tmp_path, 0o555)
    try:
        with pytest.raises(PermissionError):
            save_model(str(path), CalibrationModel(accelerometer_axes=3))
    finally:
        os.chmod(tmp_path, 0o755)
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ['calibration.json', 'calibration.json.history']


def test_missing_file_is_file_not_found(tmp_path):
    """No file is FileNotFoundError (start uncalibrated), not a corrupt-file error."""
    with pytest.raises(FileNotFoundError):
        load_model(str(tmp_path / 'absent.json'))
    assert not issubclass(FileNotFoundError, CalibrationFileError)


def _edit(**changes):
    """Return a valid document with top-level changes (None deletes the key)."""
    doc = valid_doc()
    for key, value in changes.items():
        if value is None:
            del doc[key]
        else:
            doc[key] = value
    return doc


def _edit_installation(**changes):
    """Return a valid document with installation changes (None deletes the field)."""
    doc = valid_doc()
    for key, value in changes.items():
        if value is None:
            del doc['installation'][key]
        else:
            doc['installation'][key] = value
    return doc


BAD_DOCUMENTS = {
    'wrong format': (_edit(format='other.calibration'), 'not an inclino_ros.calibration'),
    'no format': (_edit(format=None), 'not an inclino_ros.calibration'),
    'not an object': ([valid_doc()], 'not an inclino_ros.calibration'),
    'schema 12': (_edit(schema_version=12),
                  'schema_version 12 is not one of (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11)'),
    'schema string': (_edit(schema_version='1'), "schema_version '1' is not one of"),
    'no schema': (_edit(schema_version=None), 'schema_version None is not one of'),
    'schema bool': (_edit(schema_version=True), 'schema_version True is not one of'),
    'stand in version 1': (_edit(schema_version=1, stand={}, sensor_id=None),
                           "unknown sections ['stand']"),
    'sensor_id in version 2': (_edit(schema_version=2), "unknown sections ['sensor_id']"),
    'sensor_id number': (_edit(sensor_id=7), 'sensor_id 7 is not a string'),
    'axes float': (_edit(accelerometer_axes=3.0), 'accelerometer_axes 3.0 is not 2 or 3'),
    'axes 4': (_edit(accelerometer_axes=4), 'accelerometer_axes 4 is not 2 or 3'),
    'no axes': (_edit(accelerometer_axes=None), 'accelerometer_axes'),
    'unknown section': (_edit(scale_matrix={'k': 1.0}), "unknown sections ['scale_matrix']"),
    'extra field': (_edit_installation(alpha_deg=1.0), 'needs exactly the fields'),
    'NaN gamma': (_edit_installation(gamma_deg=math.nan), 'gamma_deg = nan'),
    'Infinity beta': (_edit_installation(beta_deg=math.inf), 'beta_deg = inf'),
    '-Infinity std': (_edit_installation(std_deg=-math.inf), 'std_deg = -inf'),
    'string gamma': (_edit_installation(gamma_deg='0.0355'), "gamma_deg = '0.0355'"),
    'bool beta': (_edit_installation(beta_deg=True), 'beta_deg = True'),
    'null g_total': (_edit_installation(g_total_mps2=None), 'g_total_mps2 = None'),
    'huge integer': (_edit_installation(gamma_deg=10 ** 400), 'too large'),
    'gamma 45': (_edit_installation(gamma_deg=45.0), 'gamma_deg = 45.0'),
    'gamma -45': (_edit_installation(gamma_deg=-45.0), '|angle| must be < 45 deg'),
    'beta 90': (_edit_installation(beta_deg=90), 'beta_deg = 90'),
    'count 0': (_edit_installation(sample_count=0), 'sample_count = 0'),
    'count 1.5': (_edit_installation(sample_count=1.5), 'sample_count = 1.5'),
    'count string': (_edit_installation(sample_count='100'), "sample_count = '100'"),
    'negative std': (_edit_installation(std_deg=-0.1), 'std_deg = -0.1 deg is outside'),
    'zero g': (_edit_installation(g_total_mps2=0.0), 'g_total_mps2 = 0 m/s^2 is outside'),
    'naive time': (_edit_installation(captured_at='2026-03-01T10:20:30'), 'no time zone'),
    'bad time': (_edit_installation(captured_at='yesterday'), 'yesterday'),
    'number time': (_edit_installation(captured_at=1700000000), 'not an ISO 8601 time'),
    'installation 5': (_edit(installation=5), 'needs exactly the fields'),
    'installation list': (_edit(installation=[]), 'needs exactly the fields'),
}
# _edit_installation deletes a field given None; this one must stay, as a JSON null.
BAD_DOCUMENTS['null g_total'][0]['installation']['g_total_mps2'] = None


@pytest.mark.parametrize('name', sorted(BAD_DOCUMENTS))
def test_load_refuses_bad_document(tmp_path, name):
    """Each defective document raises CalibrationFileError naming the file and the defect."""
    doc, reason = BAD_DOCUMENTS[name]
    path = tmp_path / 'calibration.json'
    write_doc(path, doc)
    with pytest.raises(CalibrationFileError) as caught:
        load_model(str(path))
    assert caught.value.path == str(path)
    assert str(caught.value).startswith(f'calibration file {path}: ')
    assert reason in caught.value.reason


@pytest.mark.parametrize('field', sorted(Installation.__dataclass_fields__))
def test_load_refuses_missing_field(tmp_path, field):
    """Any one installation field missing is refused, with the field list in the reason."""
    path = tmp_path / 'calibration.json'
    write_doc(path, _edit_installation(**{field: None}))
    with pytest.raises(CalibrationFileError) as caught:
        load_model(str(path))
    assert caught.value.path == str(path)
    assert 'needs exactly the fields' in caught.value.reason
    assert field in caught.value.reason


@pytest.mark.parametrize('content', [
    b'', b'   ', b'{', b'{"format": "inclino_ros.calibration", "schema_', b'\x80\x81\x82{}',
    b'[' * 100000, b'nul'])
def test_load_refuses_unparsable_file(tmp_path, content):
    """Empty, truncated, undecodable or absurdly nested files are CalibrationFileError."""
    path = tmp_path / 'calibration.json'
    path.write_bytes(content)
    with pytest.raises(CalibrationFileError) as caught:
        load_model(str(path))
    assert caught.value.path == str(path)
    assert caught.value.reason.startswith('not valid JSON')


def test_load_refuses_truncated_save(tmp_path):
    """A real saved file cut short at any point does not load."""
    path = tmp_path / 'calibration.json'
    save_model(str(path), MODEL)
    text = path.read_bytes().rstrip()
    for cut in range(0, len(text), 7):
        path.write_bytes(text[:cut])
        with pytest.raises(CalibrationFileError):
            load_model(str(path))


def test_load_accepts_boundaries():
    """Values just inside each limit load (the refusals above are not over-broad)."""
    doc = _edit_installation(gamma_deg=44.999, beta_deg=-44.999, sample_count=1, std_deg=0,
                             captured_at='2026-03-01T10:20:30.5-05:00')
    model = model_from_dict(doc)
    assert model.installation.gamma_deg == 44.999
    assert model.installation.std_deg == 0
    assert model_from_dict(_edit(installation=None)) == CalibrationModel(accelerometer_axes=2)


def test_times():
    """utc_now_iso is zone-aware UTC; age_seconds counts exactly against a given now."""
    stamp = utc_now_iso()
    parsed = datetime.fromisoformat(stamp)
    assert parsed.utcoffset() == timedelta(0)
    assert 0.0 <= age_seconds(stamp) < 60.0
    now = datetime(2026, 3, 1, 11, 20, 30, tzinfo=timezone.utc)
    assert age_seconds('2026-03-01T10:20:30+00:00', now) == 3600.0
    assert age_seconds('2026-03-01T12:20:30+02:00', now) == 3600.0


def test_an_unreadable_path_is_a_calibration_file_error(tmp_path):
    """A path that exists but cannot be read as a file is a loud error, not 'missing'."""
    with pytest.raises(CalibrationFileError, match='cannot be read'):
        load_model(str(tmp_path))
