"""
Fuzzing (hypothesis): hostile input gets a clean refusal or a correct result.

Every reader and every fit; never another exception, a hang or a changed file.
Values are drawn from every float there is (NaN, infinities, subnormals, 1e308, 0) as well
as from plausible ones.  The corrupted-bag fuzz is in ``test_reliability_cli.py``, the node's
services in ``test_reliability_node.py``.
"""

from dataclasses import replace
import json
import math

from hypothesis import assume, given, HealthCheck, settings, strategies as st
from hypothesis.extra.numpy import arrays
from inclino_ros import pipeline
from inclino_ros.calibration import plausibility
from inclino_ros.calibration.level_capture import (
    CaptureRefused, LevelLimits, solve_level_capture)
from inclino_ros.calibration.model import (
    CalibrationFileError, CalibrationModel, Installation, load_model, Magnetic, save_model)
from inclino_ros.calibration.stations import load_stations, StationsFileError
from inclino_ros.core.cross_axial import fit_cross_axial, RotationFitRefused
from inclino_ros.core.msa import (
    MsaRefused, short_collar, solve_msa_axial, solve_msa_classic, solve_msa_improved)
from inclino_ros.core.stand import fit_sphere, fit_stand, StandFitRefused
from inclino_ros.core.temperature import fit_temperature, TemperatureFitRefused
from inclino_ros.io.tables import read_csv, read_rows, TableError
import numpy as np
import pytest
from test_model_stages import MODEL

#: Overflow and invalid-value warnings of numpy are what the hostile values are for.
pytestmark = pytest.mark.filterwarnings('ignore::RuntimeWarning')
G = 9.80665
FUZZ = settings(max_examples=150, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
#: Any float64 at all, and plausible magnitudes (so that the fits also get past their checks).
ANY = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True, width=64)
SCALES = st.sampled_from([0.0, 5e-324, 1e-300, 1e-9, 1.0, G, 5e4, 1e155, 1e300])


def vectors(rows=st.integers(0, 40), columns=3, elements=None):
    """Return a strategy of (N, columns) float arrays: wild, or plausible times a scale."""
    wild = rows.flatmap(lambda n: arrays(np.float64, (n, columns), elements=elements or ANY))
    tame = st.tuples(rows, SCALES, st.integers(0, 2 ** 32 - 1)).map(
        lambda t: np.random.default_rng(t[2]).normal(size=(t[0], columns)) * t[1])
    return st.one_of(wild, tame)


# --- readers ----------------------------------------------------------------------------

@FUZZ
@given(content=st.one_of(st.binary(max_size=400), st.text(max_size=400),
                         st.lists(st.lists(st.one_of(ANY.map(repr), st.text(max_size=5)),
                                           max_size=5), max_size=8).map(
                             lambda rows: 'ax,ay,az\n' + '\n'.join(map(','.join, rows)))))
def test_csv_reader(tmp_path, content):
    """Any file: the columns as floats, or a TableError."""
    path = tmp_path / 'in.csv'
    path.write_bytes(content if isinstance(content, bytes) else content.encode('utf-8', 'replace'))
    try:
        table = read_csv(path, ('ax', 'ay'), optional=('az',))
    except TableError:
        return
    assert set(table) >= {'ax', 'ay'} and table['ax'].dtype == float
    assert table['ax'].shape == table['ay'].shape and table['ax'].size > 0


VALID = CalibrationModel(3, installation=MODEL.installation, stand=MODEL.stand,
                         temperature=MODEL.temperature).to_dict()
JSON_VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10 ** 30, 10 ** 30), ANY,
              st.text(max_size=8)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=6), inner, max_size=4)),
    max_leaves=10)


def mutated(doc, path, value):
    """Return a deep copy of ``doc`` with the value at key path ``path`` replaced."""
    doc = json.loads(json.dumps(doc))
    target = doc
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return doc


def key_paths(doc, prefix=()):
    """Return every key path of a nested dict/list document."""
    paths = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) \
        if isinstance(doc, list) else ()
    for key, value in items:
        paths.append(prefix + (key,))
        paths += key_paths(value, prefix + (key,))
    return paths


@FUZZ
@given(data=st.data())
def test_calibration_loader(tmp_path, data):
    """A valid file with one value replaced by anything (or garbage): a model, or a refusal."""
    kind = data.draw(st.sampled_from(['mutate', 'bytes']))
    if kind == 'bytes':
        raw = data.draw(st.binary(max_size=300))
    else:
        path = data.draw(st.sampled_from(key_paths(VALID)))
        raw = json.dumps(mutated(VALID, path, data.draw(JSON_VALUES)),
                         allow_nan=True).encode()
    file = tmp_path / 'calibration.json'
    file.write_bytes(raw)
    try:
        model = load_model(file)
    except CalibrationFileError:
        return
    for name in model.stages:  # what loads is plausible, and applies without error
        getattr(plausibility, f'check_{name}')(getattr(model, name))
    assert np.all(np.isfinite(model.apply(np.array([[0.0, 0.0, G]]))))


@FUZZ
@given(raw=st.one_of(st.binary(max_size=300), JSON_VALUES.map(
    lambda v: json.dumps({'format': 'inclino_ros.calibration.stations', 'schema_version': 1,
                          'stations': v}).encode())))
def test_stations_loader(tmp_path, raw):
    """Any stations file: a list of stations, or a StationsFileError."""
    file = tmp_path / 'stations.json'
    file.write_bytes(raw)
    try:
        stations = load_stations(file)
    except StationsFileError:
        return
    assert isinstance(stations, list)


# --- fits -------------------------------------------------------------------------------

def assert_finite_or_refused(fit, *args):
    """Assert that the stand or sphere ``fit(*args)`` gives a finite K and b, or refuses."""
    try:
        result = fit(*args)
    except StandFitRefused:
        return
    assert np.all(np.isfinite(result.scale_matrix)) and np.all(np.isfinite(result.bias_mps2))


@FUZZ
@given(readings=vectors(), truth_scale=SCALES, seed=st.integers(0, 2 ** 32 - 1))
def test_fit_stand(readings, truth_scale, seed):
    """Stand positions: a finite K and b, or StandFitRefused."""
    rng = np.random.default_rng(seed)
    truth = rng.normal(size=readings.shape)
    truth = truth / np.maximum(np.linalg.norm(truth, axis=1)[:, None], 1e-300) * truth_scale
    assert_finite_or_refused(fit_stand, readings, truth)


@FUZZ
@given(readings=vectors(rows=st.integers(0, 60)), g=st.sampled_from([G, 1.0, 1e-300, 1e300]))
def test_fit_sphere(readings, g):
    """Readings of a still sensor: a finite K and b, or StandFitRefused (1e155: no hang)."""
    assert_finite_or_refused(fit_sphere, readings, g)


@FUZZ
@given(readings=vectors(rows=st.integers(0, 30)), temperatures=st.lists(
    st.one_of(ANY, st.floats(-60.0, 260.0)), min_size=30, max_size=30),
    order=st.integers(1, 4))
def test_fit_temperature(readings, temperatures, order):
    """Readings against temperature: K_T polynomials, or TemperatureFitRefused."""
    temperature_c = np.array(temperatures[:readings.shape[0]])
    reference = np.array([5.6, 5.6, 5.6])
    try:
        fit = fit_temperature(temperature_c, readings, reference, order)
    except TemperatureFitRefused:
        return
    assert np.all(np.isfinite(fit.coefficients))


@FUZZ
@given(samples=vectors(rows=st.integers(0, 80), columns=2), noise=SCALES,
       seed=st.integers(0, 2 ** 32 - 1))
def test_fit_cross_axial(samples, noise, seed):
    """A rotation, or anything: a finite ellipse correction, or RotationFitRefused."""
    rng = np.random.default_rng(seed)
    angle = np.linspace(0.0, 2.0 * math.pi, samples.shape[0], endpoint=False)
    circle = np.column_stack([np.cos(angle), np.sin(angle)]) * 20000.0
    for points in (samples, circle + samples * 1e-3, circle + rng.normal(size=circle.shape)
                   * min(noise, 1e300)):
        try:
            fit = fit_cross_axial(points)
        except RotationFitRefused:
            continue
        assert np.all(np.isfinite(fit.offset_nT)) and np.all(np.isfinite(fit.correction))


def test_zero_readings_and_a_subnormal_one_are_a_refusal():
    """Zeros and one (1, 1e-310) nT reading: a LinAlgError out of fit_ellipse before."""
    points = np.zeros((20, 3))
    points[3] = (1.0, 1e-310, 0.0)
    try:
        fit_cross_axial(points)
    except RotationFitRefused as refusal:
        assert 'degenerate fit' in str(refusal)
    else:
        raise AssertionError('a fit of zeros was accepted')


@FUZZ
@given(gravity=vectors(rows=st.integers(0, 12)), field=vectors(rows=st.integers(0, 12)),
       reference=st.tuples(st.sampled_from([50000.0, 0.0, -1.0, math.nan, 1e300]),
                           st.sampled_from([60.0, 90.0, -95.0, math.nan])),
       method=st.sampled_from(['classic', 'axial', 'improved', 'short-collar']),
       exclude=st.booleans())
def test_msa(gravity, field, reference, method, exclude):
    """Stations (dead magnetometer, 1e300, NaN): an MsaResult with finite eps, or MsaRefused."""
    n = min(gravity.shape[0], field.shape[0])
    gravity, field = gravity[:n], field[:n]
    try:
        if method == 'short-collar':
            short_collar(gravity, field, *reference)
            return
        solver = {'classic': solve_msa_classic, 'axial': solve_msa_axial,
                  'improved': solve_msa_improved}[method]
        result = solver(gravity, field, *reference, exclude_failing_qc=exclude)
    except MsaRefused:
        return
    assert np.all(np.isfinite(result.eps_nT))


@FUZZ
@given(samples=vectors(rows=st.integers(0, 30)), axes=st.sampled_from([2, 3]))
def test_level_capture(samples, axes):
    """Level samples: an Installation, or CaptureRefused."""
    try:
        installation = solve_level_capture(samples, axes, LevelLimits(5.0, G, 0.3))
    except CaptureRefused:
        return
    plausibility.check_installation(installation)


# --- the chain the node and inclino process share ---------------------------------------

@FUZZ
@given(raw=vectors(rows=st.integers(0, 20)), field=vectors(rows=st.integers(20, 20)),
       temperature=st.one_of(st.none(), ANY), axes=st.sampled_from([2, 3]),
       reference=st.sampled_from([0.0, 50000.0]))
def test_pipeline(raw, field, temperature, axes, reference):
    """Any batch: never an exception; an accepted sample has finite angles, NaN or not."""
    model = CalibrationModel(axes, installation=Installation(
        0.3, -0.2, '2026-01-01T00:00:00+00:00', 100, 0.01, G),
        **({'stand': MODEL.stand, 'temperature': MODEL.temperature} if axes == 3 else {}),
        magnetic=Magnetic((80.0, -80.0), ((1.0, 0.0), (0.0, 1.0)), (0.0, 0.0, -2000.0), None,
                          None, 0, 0.0, 0.0, None))
    settings_ = pipeline.Settings(accelerometer_axes=axes)
    keep = plausibility.field_reading_ok(field[:raw.shape[0]])
    field = np.where(keep[:, None], field[:raw.shape[0]], np.nan)  # as the node pairs them
    survey = pipeline.run(raw, model, settings_, temperature, field,
                          pipeline.MagneticSettings(reference_total_nT=reference,
                                                    reference_dip_deg=60.0))
    assert np.all(np.isfinite(survey.inclination_deg))
    assert np.all(np.isfinite(survey.corrected_mps2))
    trusted = survey.magnetic.trusted
    assert np.all(np.isfinite(survey.magnetic.azimuth_deg[trusted]))
    assume(survey.inclination_deg.size)


def test_save_model_refuses_and_keeps_the_file(tmp_path):
    """A fit's implausible result: ValueError from save_model, the old file byte-identical."""
    path = tmp_path / 'calibration.json'
    save_model(path, MODEL)
    before = path.read_bytes()
    bad = CalibrationModel(3, stand=replace(MODEL.stand, bias_mps2=(1e300, 0.0, 0.0)))
    try:
        save_model(path, bad)
    except ValueError as err:
        assert 'bias' in str(err)
    else:
        raise AssertionError('an absurd bias was written')
    assert path.read_bytes() == before


# --- tables, stamps, options (issue 21) -------------------------------------------------

CELL = st.one_of(ANY.map(repr), st.text(alphabet='0123456789.-e ', max_size=6))


@FUZZ
@given(rows=st.lists(st.lists(CELL, min_size=0, max_size=5), min_size=1, max_size=8),
       blank=st.booleans())
def test_csv_cell_counts_and_blank_lines(tmp_path, rows, blank):
    """Rows of 0-5 cells under a 3-column header: read only when every row has 3, else named."""
    lines = ['ax,ay,az'] + [','.join(row) for row in rows] + ([''] if blank else [])
    if blank:
        lines.insert(2, '')
    path = tmp_path / 'in.csv'
    path.write_text('\n'.join(lines) + '\n')
    whole = all(len(row) == 3 for row in rows) and not blank
    try:   # survey's reader: the rows as text (columns carried through)
        header, read = read_rows(path)
    except TableError as err:
        assert not whole and 'line' in str(err), err
    else:
        assert whole, rows   # a shifted or blank row is never read
        assert header == ['ax', 'ay', 'az'] and read == rows
    try:
        table = read_csv(path, ('ax', 'ay', 'az'))
    except TableError as err:
        assert 'line' in str(err), err   # the line is named, whatever was wrong with it
        return
    assert whole, rows
    assert table['ax'].size == len(rows)


@FUZZ
@given(scale=st.sampled_from([1.0 / G, 1000.0 / G, 1.0, 10.0, 1e-3, 1e3]),
       seed=st.integers(0, 2 ** 32 - 1))
def test_acceleration_units(scale, seed):
    """Readings of a still tool in any unit: m/s^2 passes, anything else is Implausible."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(30, 3))
    readings = G * directions / np.linalg.norm(directions, axis=1)[:, None] * scale
    try:
        plausibility.check_acceleration_unit(readings, G)
    except plausibility.Implausible as err:
        assert scale != 1.0, err
        if scale in (1.0 / G, 1000.0 / G):
            assert 'is it in' in err.reason
        return
    assert scale == 1.0


@FUZZ
@given(stamps=st.lists(st.integers(-2 ** 62, 2 ** 62), min_size=1, max_size=60),
       rate_hz=st.sampled_from([0.01, 1.0, 30.0, 1000.0, 10000.0]),
       sizes=st.lists(st.integers(1, 20), min_size=1, max_size=4))
def test_averaging_any_stamps(stamps, rate_hz, sizes):
    """Any stamps (back, forth, huge): every sample lands in one closed window or the open one."""
    from inclino_ros.core.averaging import Averager
    averager = Averager(rate_hz=rate_hz)
    stamps = np.array(stamps, dtype=np.int64)
    closed, start, k = 0, 0, 0
    while start < stamps.size:
        stop = min(start + sizes[k % len(sizes)], stamps.size)
        n = stop - start
        windows = averager.push(stamps[start:stop], ['f'] * n, np.ones((n, 3)),
                                np.full(n, np.nan), np.full((n, 3), np.nan))
        if windows is not None:
            closed += int(windows.samples.sum())
            assert np.all(windows.samples >= 1)
        start, k = stop, k + 1
    assert closed + averager.pending == stamps.size


@FUZZ
@given(argv=st.sampled_from([
    ['play', 'bag', '--rate'], ['monitor', '--period-s'], ['call', 'calibrate_level', '--wait-s'],
    ['process', 'in', 'out', '--calibration', 'c.json', '--output-rate-hz'],
    ['compare', 'r', 't', '--max-error-deg'], ['compare', 'r', 't', '--min-inclination-deg']]),
    value=st.one_of(ANY, st.integers(-10 ** 30, 10 ** 30)).map(repr))
def test_option_extremes(tmp_path, monkeypatch, argv, value):
    """Any number for a rate, period, wait or tolerance: a usage error or a sane value."""
    from inclino_ros.cli.main import build_parser
    monkeypatch.chdir(tmp_path)
    try:
        args = build_parser().parse_args(argv + [f'{value}'] if not value.startswith('-')
                                         else argv[:-1] + [f'{argv[-1]}={value}'])
    except SystemExit as done:
        assert done.code == 2
        return
    chosen = [v for v in vars(args).values() if isinstance(v, float)]
    assert all(math.isfinite(v) for v in chosen)
    for name, low, high in (('rate', 1e-3, 1e6), ('period_s', 0.01, 3600.0),
                            ('wait_s', 0.0, 86400.0), ('max_error_deg', 0.0, 180.0),
                            ('min_inclination_deg', 0.0, 180.0)):
        if getattr(args, name, None) is not None:
            assert low <= getattr(args, name) <= high
    if getattr(args, 'output_rate_hz', 0.0):
        assert args.output_rate_hz >= 0.01
