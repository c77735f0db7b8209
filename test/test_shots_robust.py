"""
Robust reference-free calibration (issue 18): real hand-held shots, pointing wander, outliers.

Real data: six hand-held survey instruments' 24-shot sets (test/data/sap6, SOURCE.md): before
this, one was refused for an 8 sigma outlier shot and one for a roll set wandering 0.715 deg.
Simulated truth from the physical model (``sim.sensor_model.hand_held``, ``iron_near``): a MEMS
instrument whose shots average 100 readings (2 mg, 100 nT each: 0.2 mg, 10 nT a shot, ~0.01 deg
on each vector), as ``test_fit_magnetometer``'s MEMS case, whose targets (1.5 deg azimuth at
random attitudes, 0.5 deg roll-group spread) hold here too: a pointing wander of 0.7 deg RMS
moves each roll group's axis estimate by ~0.7 / sqrt(8) = 0.25 deg, within them.
"""

from dataclasses import replace
import math
import pathlib

from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.magnetometer import calibrate_from_shots
from inclino_ros.calibration.model import CalibrationModel, load_model
from inclino_ros.core import magnetics
from inclino_ros.core.shots import find_roll_groups, fit_shots, ShotFitRefused, ShotLimits
from inclino_ros.io import tables
from inclino_ros.sim import sensor_model
import numpy as np
import pytest
import shots_sim
from shots_sim import angle_error_deg
from test_fit_magnetometer import azimuths, held_shots, write_shots_bag
from test_msa_cli import quiet

SAP6 = pathlib.Path(__file__).parent / 'data' / 'sap6'
REAL = pathlib.Path(__file__).parent / 'data' / 'hand_rotated_accmag'
#: Roll-set azimuth RMS each instrument reaches (all six measured 0.26-0.71 deg); raw 3-67 deg.
SAP6_MAX_ROLL_RMS_DEG = 0.75


def circular_deviation_deg(angles_deg):
    """Return the deviations [deg] of angles from their circular mean."""
    radians = np.radians(angles_deg)
    mean = math.degrees(math.atan2(np.mean(np.sin(radians)), np.mean(np.cos(radians))))
    return angle_error_deg(angles_deg, mean)


@pytest.mark.parametrize('name', ['BB', 'CF', 'FG', 'HC', 'IB', 'JG'])
def test_every_real_instrument_is_calibrated(tmp_path, name):
    """Each of six real instruments calibrates; its roll sets then agree in azimuth."""
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', SAP6 / f'{name}.csv', '--calibration',
                            calibration, '--report-dir', tmp_path])
    assert code == 0, err
    if name == 'BB':   # the 8 sigma shot of the issue, named and left out
        assert 'outlier shot 22 (roll group 2)' in out
    if name == 'FG':   # its wandering roll set is one shot off: named, the set kept
        assert 'outlier shot 14 (roll group 1)' in out
    model = load_model(calibration)
    assert model.tool_axis is not None and model.tool_axis.roll_groups == 2
    used = np.ones(24, dtype=bool)
    used[{'BB': 21, 'FG': 13}.get(name, [])] = False
    assert 3.0 < roll_set_rms_deg(CalibrationModel(3), SAP6 / f'{name}.csv', used) < 90.0
    assert roll_set_rms_deg(model, SAP6 / f'{name}.csv', used) < SAP6_MAX_ROLL_RMS_DEG


def roll_set_rms_deg(model, path, used):
    """
    Return the azimuth RMS [deg] of a 24-shot set's two roll sets about their circular means.

    ``path``: the set's CSV (8 sphere shots, then roll sets of 8); ``used`` (24,) the shots
    counted; the azimuths through ``model``.
    """
    table = np.genfromtxt(path, delimiter=',', names=True, dtype=None, encoding='utf-8')
    accel = np.column_stack([table[c] for c in ('ax', 'ay', 'az')])
    field = np.column_stack([table[c] for c in ('bx', 'by', 'bz')])
    group = np.array([-1] * 8 + [0] * 8 + [1] * 8)
    azimuth = magnetics.survey_of(model.apply(accel), model.apply_magnetic(
        field, before='magnetic'))['azimuth_deg']
    deviation = np.concatenate([circular_deviation_deg(azimuth[(group == k) & used])
                                for k in (0, 1)])
    return float(np.sqrt(np.mean(deviation ** 2)))


def hand_held_set(seed, wander_deg=0.0, outliers=(), iron_nT=0.0):
    """Return (tool, accel, field, group, rng) of a MEMS shot set aimed by hand."""
    rng = np.random.default_rng(seed)
    tool = shots_sim.tool(sensor_model.MEMS)
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    incl, tf, azim = sensor_model.hand_held(incl, tf, azim, wander_deg, rng)
    interference = (np.asarray(shots_sim.INTERFERENCE_NT)
                    + sensor_model.iron_near(len(incl), outliers, iron_nT, rng))
    accel, field = shots_sim.read(tool, incl, tf, azim, rng, 100, interference)
    return tool, accel, field, group, rng


def assert_on_target(tool, model, rng, max_deg=1.5, min_inclination_deg=10.0):
    """Azimuth at 1000 random attitudes within the MEMS target of test_fit_magnetometer."""
    incl, tf, azim = shots_sim.random_attitudes(rng, 1000, min_inclination_deg)
    azimuth, _ = azimuths(model, *shots_sim.read(tool, incl, tf, azim, rng, 100))
    assert np.max(np.abs(angle_error_deg(azimuth, azim))) <= max_deg


@pytest.mark.parametrize('seed', [2, 3, 5])
def test_a_wandering_roll_set_is_weighted_and_reported(seed):
    """
    0.7 deg RMS of pointing wander (a real set's): calibrated, the wander reported.

    These seeds leave a group above 0.5 deg RMS, which the fit refused before.  The wander
    moves the tool axis found by ~0.7 / sqrt(8 shots x 2 groups) = 0.18 deg, an azimuth error
    of 0.35 deg at I = 30 deg: 1.2 deg is 3.5 sigma (measured 0.6-0.9 deg max over 1000).
    """
    tool, accel, field, group, rng = hand_held_set(seed, wander_deg=0.7)
    result = calibrate_from_shots(CalibrationModel(3), accel, field, group)
    fit = result.fit
    assert fit.groups == (0, 1) and fit.freed_groups == ()
    # The wander reported: ~0.7 deg times the sine of the vectors' angle to the axis.
    assert np.all((fit.axial_rms_deg > 0.2) & (fit.axial_rms_deg < 1.4)), fit.axial_rms_deg
    assert fit.axial_rms_deg.max() > 0.5
    assert_on_target(tool, result.model, rng, max_deg=1.2, min_inclination_deg=30.0)


def test_a_roll_set_that_holds_no_direction_is_taken_as_free_shots():
    """Wander of 4 deg: a group beyond 2 deg RMS measures no axis; named, the fit goes on."""
    _, accel, field, group, _ = hand_held_set(4, wander_deg=4.0)
    fit = fit_shots(accel, field, group)
    assert len(fit.groups) < 2 and fit.freed_groups
    assert all('wandered' in why for _, why in fit.freed_groups)


@pytest.mark.parametrize('seed', [1, 2])
def test_an_outlier_shot_is_named_and_left_out(seed):
    """Iron near shot 6 (3000 nT, ~60 sigma): named, left out, the rest calibrates on target."""
    tool, accel, field, group, rng = hand_held_set(seed, outliers=[5], iron_nT=3000.0)
    result = calibrate_from_shots(CalibrationModel(3), accel, field, group)
    assert [shot for shot, _ in result.fit.outliers] == [5]
    assert result.fit.outliers[0][1] > 6.0 and not result.fit.used[5]
    assert result.model.magnetometer.positions == 23
    assert_on_target(tool, result.model, rng)


def test_too_many_outliers_are_refused_naming_every_check():
    """Three outliers where only two can be spared: refused, with every failed check at once."""
    _, accel, field, group, _ = hand_held_set(5, outliers=[1, 4, 6], iron_nT=3000.0)
    limits = ShotLimits(min_shots=22, max_dip_rms_deg=1e-3)
    with pytest.raises(ShotFitRefused) as refused:
        fit_shots(accel, field, group, limits=limits)
    reasons = refused.value.reasons
    assert any('outlier shot(s)' in r for r in reasons), reasons
    assert any('the dip constant' in r for r in reasons), reasons
    assert refused.value.fit is not None and not refused.value.fit.used.all()


def test_a_refused_fit_writes_its_report(tmp_path):
    """The command's refusal names every failed check and leaves fit_magnetometer_refused.txt."""
    _, accel, field, group, _ = hand_held_set(6)
    path = tmp_path / 'shots.csv'
    shots_sim.write_shots(path, accel, field, group)
    code, _, err = quiet(['fit-magnetometer', path, '--calibration', tmp_path / 'cal.json',
                          '--max-dip-rms-deg', '1e-6', '--max-b-rms-fraction', '1e-9',
                          '--max-g-rms-fraction', '1e-9'])
    assert code == 1
    for what in ('|B| constant', 'the dip constant', '|g| constant'):
        assert what in err
    report = (tmp_path / 'fit_magnetometer_refused.txt').read_text()
    assert report.count('REFUSED: ') == 3 and 'dip [deg]' in report
    assert not (tmp_path / 'cal.json').exists()


def test_the_hand_rotated_log_is_refused_with_every_reason(tmp_path):
    """
    The real hand-rotated log (every 10th sample): refused on |B|, the dip and |g| at once.

    What prevents it (measured on the whole log, README): the board never stops (no 10-sample
    window within 1 deg), its accelerometer reads the hand's motion, 4.1 % of g RMS left in |g|
    (2.3 % of g sample to sample, lag-1 correlation 0.4-0.55: motion, not noise), which makes
    the dip vary 2.6 deg; and the magnetometer leaves its own best ellipsoid by 1.2 % RMS where
    its noise is 0.37 %.  With limits widened to what the log holds the fit is accepted.
    """
    table = np.genfromtxt(REAL / 'acc_mag_log_every10.csv', delimiter=',', names=True)
    accel = np.column_stack([table[c] for c in ('ax', 'ay', 'az')]) * 9.80665
    field = np.column_stack([table[c] for c in ('mx', 'my', 'mz')]) * 1e5
    path = tmp_path / 'log.csv'
    shots_sim.write_shots(path, accel, field)
    calibration = tmp_path / 'cal.json'
    code, _, err = quiet(['fit-magnetometer', path, '--calibration', calibration])
    assert code == 1 and not calibration.exists()
    figures = {what: float(err.split(f'make {what} constant: RMS ')[1].split()[0])
               for what in ('|B|', 'the dip', '|g|')}
    assert 0.01 < figures['|B|'] < 0.015 and 2.0 < figures['the dip'] < 3.0
    assert 0.03 < figures['|g|'] < 0.05
    report = (tmp_path / 'fit_magnetometer_refused.txt').read_text()
    assert report.count('REFUSED: ') == 3 and 'outlier shot' in report
    code, out, err = quiet(['fit-magnetometer', path, '--calibration', calibration,
                            '--max-b-rms-fraction', '0.015', '--max-dip-rms-deg', '3',
                            '--max-g-rms-fraction', '0.05'])
    assert code == 0, err
    before, after = (float(v.rstrip(',')) for v in
                     out.split('spread (std) of |B| [nT] over the shots used: before ')[1]
                     .split('\n')[0].split(', after '))
    assert after < before / 20.0


def test_without_roll_groups_the_level_bench_stage_is_kept(tmp_path):
    """
    Shots without roll groups (a bag's) keep the level-bench installation, in the new frame.

    Quartz tool on the issue's mount (0.8 / -1.2 deg): the level bench measured it from 500
    raw readings of the vertical tool (1e-4 g each: 5e-6 rad of tilt).  Kept, the inclination
    at 300 attitudes stays within 0.05 deg (the sphere fit's own frame error, ~0.01 deg, with
    the shots' noise); dropped, as before, the 1.44 deg of mount tilt comes back (> 1 deg).
    Nothing measuring the mount is said on stderr.
    """
    rng = np.random.default_rng(12)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    level = sensor_model.read(tool, np.zeros(500), np.zeros(500), rng=rng).accel_mps2
    installation = solve_level_capture(level, 3, LevelLimits(
        max_tilt_deg=5.0, gravity_mps2=tool.gravity_mps2, g_total_tolerance_mps2=0.05))
    existing = CalibrationModel(3, installation=installation)
    incl, tf, azim, _ = shots_sim.shot_attitudes(rng, free=24, per_group=0, axes_deg=())
    accel, field = shots_sim.read(tool, incl, tf, azim, rng)
    result = calibrate_from_shots(existing, accel, field)
    assert result.model.installation is not None and result.model.tool_axis is None
    incl, tf, azim = shots_sim.random_attitudes(rng, 300, min_inclination_deg=0.0)
    _, inclination = azimuths(result.model, *shots_sim.read(tool, incl, tf, azim, rng))
    assert np.max(np.abs(inclination - incl)) < 0.05
    path = tmp_path / 'shots.csv'
    shots_sim.write_shots(path, accel, field)
    code, out, err = quiet(['fit-magnetometer', path, '--calibration', tmp_path / 'cal.json'])
    assert code == 0 and 'WARNING: the mount is NOT calibrated' in err


def test_roll_sets_are_found_in_a_bag(tmp_path):
    """
    A bag of 8 shots over the sphere and two roll sets of 8: the sets found, the mount measured.

    Quartz tool on the issue's mount (1.44 deg of tilt): with the tool axis from the found
    roll sets the inclination at 300 attitudes is within 0.05 deg (the CSV with its roll_group
    column reaches 0.03, ``test_mount_found_without_a_level_bench``); without, 1.44 deg.
    """
    rng = np.random.default_rng(21)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    path = write_shots_bag(str(tmp_path / 'shots_bag'), tool, incl, tf, azim, rng)
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', path, '--calibration', calibration])
    assert code == 0, err
    assert '2 roll group(s) found in the order of the shots' in out
    assert 'shots 9-16, shots 17-24' in out and 'WARNING' not in err
    model = load_model(calibration)
    assert model.tool_axis is not None and model.tool_axis.roll_groups == 2
    incl, tf, azim = shots_sim.random_attitudes(rng, 300, min_inclination_deg=0.0)
    _, inclination = azimuths(model, *shots_sim.read(tool, incl, tf, azim, rng))
    assert np.max(np.abs(inclination - incl)) < 0.05


def test_a_bag_with_a_temperature_topic_records_what_its_shots_stood_for(tmp_path):
    """
    ``--temperature-topic`` of a bag is read: the stages record the shots' mean temperature.

    The tool warms 30 -> 40 C over the run (linear in time): the segments' mean
    temperature is 35 C within the still parts' asymmetry (< 0.5 C).  Main read no
    temperature from a bag (the stages stood for an unknown one; failed first).
    """
    rng = np.random.default_rng(21)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    incl, tf, azim, _ = shots_sim.shot_attitudes(rng)
    path = write_shots_bag(str(tmp_path / 'shots_bag'), tool, incl, tf, azim, rng,
                           lambda stamps: 30.0 + 10.0 * stamps / stamps[-1])
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', path, '--calibration', calibration])
    assert code == 0, err
    model = load_model(calibration)
    assert model.magnetometer.temperature_c == pytest.approx(35.0, abs=0.5)
    assert model.stand.temperature_c == pytest.approx(model.magnetometer.temperature_c)


def test_a_continuous_log_gives_its_still_segments_as_shots(tmp_path):
    """
    A CSV log (``time_s``, ax..bz) of the bag's run: its still segments are the shots, as a bag's.

    The same 24 holds as ``test_roll_sets_are_found_in_a_bag``, 7200 rows at 100 Hz: main
    took every row as a shot (the turning ones named outliers at hundreds of sigma).
    """
    rng = np.random.default_rng(21)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    incl, tf, azim, _ = shots_sim.shot_attitudes(rng)
    stamps, readings = held_shots(tool, incl, tf, azim, rng)
    path = tmp_path / 'log.csv'
    np.savetxt(path, np.column_stack([stamps * 1e-9, readings.accel_mps2, readings.mag_nT]),
               delimiter=',', header='time_s,ax,ay,az,bx,by,bz', comments='')
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', path, '--calibration', calibration])
    assert code == 0, err
    assert f'24 still segment(s) found in the log {path}' in out
    assert '2 roll group(s) found in the order of the shots' in out
    assert 'shots 9-16, shots 17-24' in out and 'outlier' not in out and 'WARNING' not in err
    model = load_model(calibration)
    assert model.tool_axis is not None and model.tool_axis.roll_groups == 2
    incl, tf, azim = shots_sim.random_attitudes(rng, 300, min_inclination_deg=0.0)
    _, inclination = azimuths(model, *shots_sim.read(tool, incl, tf, azim, rng))
    assert np.max(np.abs(inclination - incl)) < 0.05


@pytest.mark.parametrize('name', ['BB', 'CF', 'FG', 'HC', 'IB', 'JG'])
def test_real_roll_sets_are_found_without_their_column(tmp_path, name):
    """The six real sets without ``roll_group``: each finds its two roll sets, shots 9-24."""
    rows = (SAP6 / f'{name}.csv').read_text().splitlines()
    path = tmp_path / 'shots.csv'
    path.write_text('\n'.join([rows[0]] + [row.rsplit(',', 1)[0] + ',' for row in rows[1:]]))
    code, out, err = quiet(['fit-magnetometer', path, '--calibration', tmp_path / 'cal.json'])
    assert code == 0, err
    assert '2 roll group(s) found in the order of the shots' in out
    assert 'shots 9-16, shots 17-24' in out


CAL_DATA = pathlib.Path(__file__).parent / 'data' / 'mag_cal_cal_data'
#: Roll-set azimuth RMS [deg] each of these instruments reaches (measured 0.24-0.54); raw 37-62.
CAL_DATA_MAX_ROLL_RMS_DEG = 0.65


@pytest.mark.parametrize('name', ['ab', 'ai', 'bh', 'bi', 'ee', 'fb', 'hj', 'hj2', 'jd'])
def test_nine_more_real_instruments_are_calibrated(tmp_path, name):
    """
    Nine more real instruments (mag_cal_cal_data, SOURCE.md): each calibrates, its roll sets agree.

    Main refused eight: ``ab``'s raw field (113000 nT median: 80 uT of hard iron) beyond the
    plausible 100000 nT, seven for an ill-conditioned ellipsoid design (condition 114-747 of
    readings centred far from zero).  Measured here 0.24-0.54 deg RMS over both roll sets.
    """
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', CAL_DATA / f'{name}.csv', '--calibration',
                            calibration, '--report-dir', tmp_path])
    assert code == 0, err
    model = load_model(calibration)
    assert model.tool_axis is not None and model.tool_axis.roll_groups == 2
    every = np.ones(24, dtype=bool)
    assert 20.0 < roll_set_rms_deg(CalibrationModel(3), CAL_DATA / f'{name}.csv', every) < 90.0
    assert roll_set_rms_deg(model, CAL_DATA / f'{name}.csv', every) < CAL_DATA_MAX_ROLL_RMS_DEG


@pytest.mark.parametrize('roll_sets', [(0, 1), (0,), (1,)], ids=['both', 'first', 'second'])
@pytest.mark.parametrize('path', sorted(SAP6.glob('*.csv')) + sorted(CAL_DATA.glob('*.csv')),
                         ids=lambda path: path.stem)
def test_real_roll_sets_are_found_on_a_tilted_mount(path, roll_sets):
    """
    The 15 real instruments without roll_group: the finder's sets are the file's, the fit too.

    The 8 sphere shots with both roll sets, or one (the held-out protocol of
    bench/bench_sap6_peer.py).  Their mounts tilt 1.2-3.6 deg, so before the tool axis is known
    a set's z axes lie on a cone 2.4-7.2 deg across: main's one pass (5 deg about the running
    mean) split or missed the sets of ab (3.55 deg: 8 sphere shots + its first set found none,
    no tool axis, held-out azimuth 1.632 deg RMS vs 0.506 with the labels), fb, hj2, IB, JG
    (failed first on 8 of these 45 cases).
    """
    accel, field, labels, _ = tables.read_shots(path)
    shots = np.r_[0:8, np.concatenate([np.flatnonzero(labels == k) for k in roll_sets])]
    accel, field, labels = accel[shots], field[shots], np.r_[[-1] * 8, np.repeat(
        np.arange(len(roll_sets)), 8)]
    found = calibrate_from_shots(CalibrationModel(3), accel, field, nonlinear='off')
    given = calibrate_from_shots(CalibrationModel(3), accel, field, labels, nonlinear='off')
    assert np.array_equal(found.roll_group, labels)
    for angle in ('gamma_deg', 'beta_deg'):
        assert getattr(found.model.tool_axis, angle) == pytest.approx(
            getattr(given.model.tool_axis, angle), abs=1e-9)


@pytest.mark.parametrize('seed', range(4))
def test_roll_sets_are_found_on_a_mount_tilted_4_5_deg(seed):
    """
    Simulated MEMS sets hand-held (0.7 deg wander) on a mount tilted 4.5 deg: the sets found.

    The sensors' z axes trace a 9 deg cone in each set; main found the true sets in 0 of 100
    draws at 4 deg (none at all in 51 of 100 at 5 deg), 99 of 100 now at 1.4-5 deg (the
    miss: a sphere shot 3 deg from a set's direction, joined to it, as main did).  24 shots
    over the sphere give no set (both: 0 of 100).
    """
    rng = np.random.default_rng(seed)
    mount = replace(shots_sim.MOUNT, gamma_deg=4.5, beta_deg=0.0)
    tool = replace(sensor_model.MEMS, mount=mount)
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    incl, tf, azim = sensor_model.hand_held(incl, tf, azim, 0.7, rng)
    fit = fit_shots(*shots_sim.read(tool, incl, tf, azim, rng, 100))
    assert np.array_equal(find_roll_groups(fit.accel_corrected_mps2, fit.field_corrected_nT),
                          group)
    sphere = shots_sim.shot_attitudes(rng, free=24, axes_deg=())[:3]
    fit = fit_shots(*shots_sim.read(tool, *sphere, rng, 100))
    assert find_roll_groups(fit.accel_corrected_mps2, fit.field_corrected_nT).max() == -1
