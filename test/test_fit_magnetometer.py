"""
Reference-free calibration of both triads from shots (issue 8 item 3): accuracy, cross-check, CLI.

Truth from the physical model only (``shots_sim``: every error source of the foundation
issue).  A shot is one reading; quartz/fluxgate noise 1e-4 g and 5 nT per shot is 1e-4 rad
on each vector, so one shot's azimuth scatters ~1e-4 rad / (sin I cos D) ~ 0.07 deg at
I = 10 deg, D = 60 deg (3.5 sigma over 1000 attitudes: ~0.25 deg): the 0.3 deg target
holds the evaluation shot's own noise too; the calibration itself leaves ~0.02 deg RMS.
Roll-group spread: 8 shots at I = 35 and 60 deg scatter ~0.01-0.02 deg RMS from noise:
0.1 deg is 5 sigma.  MEMS figures (2 mg, 100 nT per reading; shots of 100 readings as a
hand-held instrument averages them) are asserted at 5x the quartz limits.
"""

import csv
import math

from inclino_ros.calibration.magnetometer import calibrate_from_shots
from inclino_ros.calibration.model import CalibrationModel, load_model, save_model
from inclino_ros.core.shots import fit_shots
from inclino_ros.io import bag
from inclino_ros.pipeline import MagneticSettings, run, Settings
from inclino_ros.sim import sensor_model
import numpy as np
import pytest
import shots_sim
from shots_sim import angle_error_deg
from test_msa_cli import quiet

TARGETS = {'QUARTZ_FLUXGATE': (1, 0.3, 0.1), 'MEMS': (100, 1.5, 0.5)}


def calibrated(preset, seed, samples=1):
    """Return (tool, model after fit-magnetometer's calibration, rng) of one shot set."""
    rng = np.random.default_rng(seed)
    tool = shots_sim.tool(getattr(sensor_model, preset))
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng, samples)
    result = calibrate_from_shots(CalibrationModel(3), accel, field, group)
    return tool, result.model, rng, (accel, field, group)


def azimuths(model, accel, field):
    """Return (azimuth, inclination) [deg] of readings through the pipeline (no QC)."""
    survey = run(accel, model, Settings(), None, field, MagneticSettings())
    return survey.magnetic.defined_azimuth_deg, survey.inclination_deg


@pytest.mark.parametrize('preset', sorted(TARGETS))
@pytest.mark.parametrize('seed', [1, 2, 3])
def test_reference_free_azimuth_at_random_attitudes(preset, seed):
    """24 shots, two roll groups of 8: azimuth at 1000 attitudes and group spread on target."""
    samples, max_azimuth_deg, max_spread_deg = TARGETS[preset]
    tool, model, rng, (accel, field, group) = calibrated(preset, seed, samples)
    model = save_and_load(model)
    incl, tf, azim = shots_sim.random_attitudes(rng, 1000)
    azimuth, inclination = azimuths(model, *shots_sim.read(tool, incl, tf, azim, rng, samples))
    error = angle_error_deg(azimuth, azim)
    assert np.max(np.abs(error)) <= max_azimuth_deg, np.max(np.abs(error))
    for k in (0, 1):
        shot_azimuth, _ = azimuths(model, accel[group == k], field[group == k])
        spread = angle_error_deg(shot_azimuth, np.mean(shot_azimuth))
        assert np.sqrt(np.mean(spread ** 2)) <= max_spread_deg
    # Uncorrected the same tool is degrees off: the test would see a missing stage.
    raw_azimuth, _ = azimuths(CalibrationModel(3), *shots_sim.read(tool, incl, tf, azim, rng))
    assert np.max(np.abs(angle_error_deg(raw_azimuth, azim))) > 3.0


def save_and_load(model, tmp=None):
    """Return ``model`` after a round trip through its file (what the commands apply)."""
    import tempfile
    with tempfile.TemporaryDirectory() as folder:
        save_model(f'{folder}/cal.json', model)
        return load_model(f'{folder}/cal.json')


def test_mount_found_without_a_level_bench():
    """The roll groups put the tool axis where the mount put it: inclination to 0.03 deg."""
    tool, model, rng, _ = calibrated('QUARTZ_FLUXGATE', 4)
    incl, tf, azim = shots_sim.random_attitudes(rng, 300, min_inclination_deg=0.0)
    _, inclination = azimuths(model, *shots_sim.read(tool, incl, tf, azim, rng))
    assert np.max(np.abs(inclination - incl)) < 0.03
    no_axis = CalibrationModel(3, stand=model.stand, magnetometer=model.magnetometer,
                               magnetometer_alignment=model.magnetometer_alignment)
    _, tilted = azimuths(no_axis, *shots_sim.read(tool, incl, tf, azim, rng))
    assert np.max(np.abs(tilted - incl)) > 1.0   # the 0.8 / -1.2 deg mount


def test_ellipsoid_agrees_with_an_independent_fit():
    """
    The magnetometer ellipsoid equals ctef's (Cayley-transform geometric fit) on the same data.

    ctef fits ``|A R (m - c)| = 1`` by trust-region least squares from its own start; we
    compare the centre c with our hard iron and the quadric ``(A R)^T A R`` with ours
    ``K_m^-T K_m^-1``, both normalised to determinant 1.
    Noise-free: centre and normalised shape to 1e-6; with quartz noise to a few nT and 5e-4
    (the two fits weigh the noise differently, and ours uses the dip and the roll groups too).
    """
    ctef = pytest.importorskip('ctef.ctef')
    for noise, centre_nT, shape in ((0.0, 1e-6, 1e-9), (None, 10.0, 5e-4)):
        preset = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
        if noise is not None:
            from dataclasses import replace
            preset = replace(preset, accelerometer=replace(preset.accelerometer, noise_std=0.0),
                             magnetometer=replace(preset.magnetometer, noise_std=0.0))
        rng = np.random.default_rng(11)
        incl, tf, azim, group = shots_sim.shot_attitudes(rng)
        accel, field = shots_sim.read(preset, incl, tf, azim, rng)
        ours = fit_shots(accel, field, group)
        # ctef's trust region sometimes stops in a local minimum: its best of three widths.
        theirs = min((ctef.ctef(field, w=w) for w in (0.5, 1.0, 2.0)),
                     key=lambda fit: fit['result'].cost)
        np.testing.assert_allclose(ours.mag_bias_nT, theirs['center'], atol=centre_nT)
        t = np.linalg.inv(ours.mag_matrix)
        quadrics = [t.T @ t, theirs['Lambda_inv'].T @ theirs['Lambda_inv']]
        quadrics = [q / np.cbrt(np.linalg.det(q)) for q in quadrics]
        np.testing.assert_allclose(quadrics[0], quadrics[1], atol=shape)


def shots_csv(tmp_path, seed=7, count_free=8, per_group=8, scale_field=1.0, edit=None):
    """Write a quartz shots CSV; return its path."""
    rng = np.random.default_rng(seed)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    incl, tf, azim, group = shots_sim.shot_attitudes(rng, count_free, per_group)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng)
    if edit:
        accel, field, group = edit(accel, field, group)
    path = tmp_path / 'shots.csv'
    shots_sim.write_shots(path, accel, field, group, scale_field)
    return path


def test_command_writes_the_stages_and_survey_reads_true(tmp_path):
    """The contract: fit-magnetometer then survey; other stages kept; the report written."""
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', shots_csv(tmp_path), '--calibration',
                            calibration, '--report-dir', tmp_path / 'report'])
    assert code == 0, err
    model = load_model(calibration)
    assert model.magnetometer_stages == ('magnetometer', 'magnetometer_alignment', 'tool_axis')
    assert model.magnetometer.method == 'ellipsoid' and model.stand.method == 'sphere'
    report = (tmp_path / 'report' / 'fit_magnetometer.txt').read_text()
    for text in ('|B| before', 'dip before', 'roll group 1: azimuth spread',
                 'roll group 2: azimuth spread'):
        assert text in report
    assert report == out  # the text report is what was printed


def test_existing_stages_are_kept(tmp_path):
    """A file's stand (K kept, not refitted), temperature and seed 002 stages stay."""
    rng = np.random.default_rng(3)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng)
    first = calibrate_from_shots(CalibrationModel(3), accel, field, group).model
    second = calibrate_from_shots(first, accel, field, group)
    assert second.model.stand == first.stand
    assert any('stand stage of the file kept' in note for note in second.notes)


def unit_microtesla(accel, field, group):
    return accel, field / 1000.0, group


def no_rotation(accel, field, group):
    return np.repeat(accel[:1], len(accel), 0), np.repeat(field[:1], len(field), 0), group


def one_plane(accel, field, group):
    keep = group == 0
    return accel[keep], field[keep], group[keep]


def nan_rows(accel, field, group):
    accel = accel.copy()
    accel[[3, 9], 1] = np.nan
    return accel, field, group


def outlier(accel, field, group):
    field = field.copy()
    field[5] += (0.0, 3000.0, 0.0)   # iron near shot 6
    return accel, field, group


BAD = {
    'NaN rows': ({'edit': nan_rows}, 'row(s) [4, 10]'),
    'no rotation': ({'edit': no_rotation}, 'never change'),
    'one plane': ({'count_free': 0, 'per_group': 16, 'edit': one_plane}, 'one plane'),
    'microtesla': ({'scale_field': 1e-3}, 'uT'),
    'too few rows': ({'count_free': 3, 'per_group': 4}, 'only 11 shot(s)'),
}


def test_an_outlier_is_named_and_the_fit_goes_on(tmp_path):
    """Iron near shot 6: named and left out; the other 23 shots calibrate (issue 18)."""
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', shots_csv(tmp_path, edit=outlier),
                            '--calibration', calibration])
    assert code == 0, err
    assert 'outlier shot 6:' in out and 'left out of the fit' in out
    assert load_model(calibration).magnetometer.positions == 23


@pytest.mark.parametrize('name', sorted(BAD) + ['missing column'])
def test_bad_input_is_refused_and_the_file_is_untouched(tmp_path, name):
    """Exit 1, the reason on stderr, the calibration file byte-identical."""
    calibration = tmp_path / 'cal.json'
    save_model(calibration, CalibrationModel(3, installation=None))
    before = calibration.read_bytes()
    if name == 'missing column':
        path = shots_csv(tmp_path)
        rows = list(csv.reader(path.open()))
        with path.open('w', newline='') as stream:
            csv.writer(stream).writerows([row[:5] + row[6:] for row in rows])
        reason = 'lacks the column(s) bz'
    else:
        kwargs, reason = BAD[name]
        path = shots_csv(tmp_path, **kwargs)
    code, _, err = quiet(['fit-magnetometer', path, '--calibration', calibration])
    assert code == 1 and reason in err and 'left unchanged' in err, err
    assert calibration.read_bytes() == before


def held_shots(tool, incl, tf, azim, rng):
    """
    Return (stamps_ns, readings) of the tool held 2.5 s at each attitude, 0.5 s turning on.

    100 Hz; the one still rule (``stillness.find_still_segments``) leaves out the first and
    last 0.5 s window of a still run (the tool settling, the hand taking it): 1.5 s remain.
    """
    rate_hz, still, moving = 100, 250, 50
    parts = []
    for k in range(len(incl)):   # held 2.5 s, then 0.5 s turning to the next attitude
        nxt = (k + 1) % len(incl)
        frac = np.concatenate([np.zeros(still), np.linspace(0.0, 1.0, moving)])
        parts.append([incl[k] + frac * (incl[nxt] - incl[k]), tf[k] + frac * (tf[nxt] - tf[k]),
                      azim[k] + frac * (azim[nxt] - azim[k])])
    attitude = np.concatenate(parts, axis=1)
    readings = sensor_model.read(tool, *attitude, field=shots_sim.FIELD,
                                 interference_nT=shots_sim.INTERFERENCE_NT, rng=rng)
    return np.arange(attitude.shape[1], dtype=np.int64) * (10 ** 9 // rate_hz), readings


def write_shots_bag(path, tool, incl, tf, azim, rng, temperature_c=None):
    """
    Write a bag of the tool held at each attitude in turn (``held_shots``).

    ``temperature_c``: a function of the stamps [ns] giving /imu/temperature, or None.
    """
    stamps, readings = held_shots(tool, incl, tf, azim, rng)
    series = {'/imu/data_raw': bag.raw_imu(stamps, 'tool', readings.accel_mps2, 1e-3),
              '/imu/mag': bag.magnetometer(stamps, 'tool', readings.mag_nT, 5.0)}
    if temperature_c is not None:
        series['/imu/temperature'] = bag.TemperatureSeries(
            stamps, np.full(stamps.size, 'tool'), temperature_c(stamps), np.zeros(stamps.size))
    with bag.BagWriter(path, 'mcap') as out:
        out.add_topic('/imu/data_raw', bag.IMU)
        out.add_topic('/imu/mag', bag.MAGNETIC_FIELD)
        if temperature_c is not None:
            out.add_topic('/imu/temperature', bag.TEMPERATURE)
        out.write_series(series)
    return path


def test_shots_from_a_bag(tmp_path):
    """Still segments of /imu/data_raw + /imu/mag become shots; a fit comes out of them."""
    rng = np.random.default_rng(9)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    incl, tf, azim, _ = shots_sim.shot_attitudes(rng, free=16, per_group=0, axes_deg=())
    path = write_shots_bag(str(tmp_path / 'shots_bag'), tool, incl, tf, azim, rng)
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', path, '--calibration', calibration])
    assert code == 0, err
    assert '16 still segment(s)' in out
    model = load_model(calibration)
    incl, tf, azim = shots_sim.random_attitudes(rng, 200, min_inclination_deg=30.0)
    azimuth, _ = azimuths(model, *shots_sim.read(tool, incl, tf, azim, rng))
    # No roll groups: the tool axis is the accelerometer's z sensing axis, ~1.4 deg off.
    assert np.max(np.abs(angle_error_deg(azimuth, azim))) < 5.0
    assert math.isclose(model.magnetometer.field_nT, 50000.0, rel_tol=0.01)
