"""
Which kept stages a new fit leaves wrong (``calibration.invalidation``): measured on the simulator.

Truth from the physical model (``sim.sensor_model``): the issue's mount (gamma 0.8, beta -1.2,
roll 30 deg).  A high-side mark is captured through the stand and the mount: a fit replacing
either moves the toolface by far more than the mark's own 1 sigma, so the fit drops it and says
so.  The magnetometer's non-linear stage (a cubic magnetometer, ``Triad.cubic``) is fitted
through the roll sets' tool axis; ``fit-level`` measures the same mount again and keeps it:
the azimuth with the kept stage is that of the fit it came from.
"""

from dataclasses import replace

from inclino_ros.calibration.invalidation import replace_stages
from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.magnetometer import calibrate_from_shots
from inclino_ros.calibration.model import CalibrationModel, load_model
from inclino_ros.calibration.rotation import solve_rotation
from inclino_ros.calibration.toolface_mark import MarkLimits, solve_toolface_mark
from inclino_ros.core.attitude import toolface_seed000
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2 as G
from inclino_ros.sim import sensor_model
import numpy as np
import shots_sim
from shots_sim import angle_error_deg
from test_fit_magnetometer import azimuths
from test_msa_cli import quiet
from test_toolface_mark import write_rows

LEVEL = LevelLimits(max_tilt_deg=10.0, gravity_mps2=G, g_total_tolerance_mps2=0.5)
MARK = MarkLimits(gravity_mps2=G, g_total_tolerance_mps2=0.5)
QUARTZ = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)


def capture(tool, inclination_deg, rng, count=2000):
    """Return a still capture's raw specific force at toolface 0 (the high-side mark up)."""
    return sensor_model.read(tool, np.full(count, inclination_deg), np.zeros(count),
                             rng=rng).accel_mps2


def mark_of(model, tool, rng):
    """Return the ToolfaceMark of a capture on a 30 deg bench through ``model``."""
    return solve_toolface_mark(model.apply(capture(tool, 30.0, rng), before='toolface_mark'),
                               MARK, 'seed000')


def toolface_bias_deg(model, tool, rng):
    """Return the mean toolface error [deg] of ``model`` over 300 random attitudes."""
    incl, tf, azim = shots_sim.random_attitudes(rng, 300)
    accel, _ = shots_sim.read(tool, incl, tf, azim, rng, 100)
    return float(np.mean(angle_error_deg(np.degrees(toolface_seed000(model.apply(accel))), tf)))


def file_with_mark(tmp_path, rng):
    """Return a calibration file holding only a mark captured on a 30 deg bench (the command)."""
    write_rows(tmp_path / 'mark.csv', ['time_s', 'ax', 'ay', 'az'],
               [[k * 0.01, *a] for k, a in enumerate(capture(QUARTZ, 30.0, rng, 600))])
    calibration = tmp_path / 'cal.json'
    code, _, err = quiet(['fit-toolface-mark', tmp_path / 'mark.csv', '--calibration',
                          calibration])
    assert code == 0, err
    return calibration


def test_fit_level_drops_a_mark_captured_without_the_mount(tmp_path):
    """
    Kept, a mark captured before the level bench leaves every toolface 1.3 deg off (main did).

    Its 1 sigma is 0.0003 deg; captured again through the new mount the bias is 0.02 deg (the
    quartz sensor's own errors, no stand).  ``inclino fit-level`` drops it and says so.
    """
    rng = np.random.default_rng(1)
    calibration = file_with_mark(tmp_path, rng)
    write_rows(tmp_path / 'level.csv', ['time_s', 'ax', 'ay', 'az'],
               [[k * 0.01, *a] for k, a in enumerate(capture(QUARTZ, 0.0, rng, 600))])
    mark = load_model(calibration).toolface_mark
    code, out, err = quiet(['fit-level', tmp_path / 'level.csv', '--calibration', calibration])
    assert code == 0, err
    model = load_model(calibration)
    assert model.toolface_mark is None and 'toolface_zero: board' in out
    assert ('toolface_mark stage dropped: it was measured through the installation stage '
            'this fit replaced; capture the high-side mark again') in out
    kept = toolface_bias_deg(replace(model, toolface_mark=mark), QUARTZ, rng)
    again = toolface_bias_deg(replace(model, toolface_mark=mark_of(model, QUARTZ, rng)),
                              QUARTZ, rng)
    assert abs(kept) > 0.5 and abs(kept) > 1000 * mark.std_deg
    assert abs(again) < 0.1


def test_a_new_sphere_stand_drops_the_mark():
    """
    fit-magnetometer on a file without a stand: its sphere frame turns the kept mark 0.02 deg.

    That is 70 of the mark's sigmas (0.00025 deg); captured again, 0.0004 deg.  Dropped, noted.
    """
    rng = np.random.default_rng(1)
    model = CalibrationModel(3)
    model = replace(model, installation=solve_level_capture(
        model.apply(capture(QUARTZ, 0.0, rng), before='installation'), 3, LEVEL))
    mark = mark_of(model, QUARTZ, rng)
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    accel, field = shots_sim.read(QUARTZ, incl, tf, azim, rng, 100)
    result = calibrate_from_shots(replace(model, toolface_mark=mark), accel, field, group)
    assert result.model.toolface_mark is None and result.model.stand.method == 'sphere'
    assert any(note.startswith('toolface_mark stage dropped: it was measured through the '
                               'stand and installation and tool_axis stages')
               for note in result.notes)
    kept = toolface_bias_deg(replace(result.model, toolface_mark=mark), QUARTZ, rng)
    again = toolface_bias_deg(replace(result.model, toolface_mark=mark_of(result.model, QUARTZ,
                                                                          rng)), QUARTZ, rng)
    assert abs(kept) > 0.01 and abs(kept) > 20 * mark.std_deg
    assert abs(again) < 0.005


def test_fit_level_and_rotation_keep_the_nonlinear_stage_harmlessly():
    """
    A level bench after roll sets measures the same mount: the kept non-linear stage still fits.

    MEMS with a cubic magnetometer (-6e-12 / nT^2).  The stage's input moves by the two mount
    estimates' difference (measured 3-13 nT), its output by under 0.1 nT; at 500 random
    attitudes the azimuth RMS error with it kept is the fit's (0.19 deg, 0.27 without the
    stage).  A rotation (seed 002) comes after it: its fit sees the stage's output.
    """
    rng = np.random.default_rng(1)
    tool = shots_sim.tool(sensor_model.MEMS)
    tool = replace(tool, magnetometer=replace(tool.magnetometer, cubic=(-6e-12,) * 3))
    incl, tf, azim, group = shots_sim.shot_attitudes(
        rng, axes_deg=((60.0, 30.0), (35.0, 200.0), (80.0, 120.0)))
    accel, field = shots_sim.read(tool, incl, tf, azim, rng, 100, interference_nT=(0, 0, 0))
    fitted = calibrate_from_shots(CalibrationModel(3), accel, field, group).model
    stage = fitted.magnetometer_nonlinear
    assert stage is not None and fitted.tool_axis is not None
    level = solve_level_capture(fitted.apply(capture(tool, 0.0, rng), before='installation'),
                                3, LEVEL)
    model, notes = replace_stages(fitted, installation=level, tool_axis=None)
    assert model.magnetometer_nonlinear is stage and notes == ()
    incl, tf, azim = shots_sim.random_attitudes(rng, 500)
    readings = shots_sim.read(tool, incl, tf, azim, rng, 100, interference_nT=(0, 0, 0))
    before, after = (m.apply_magnetic(readings[1], before='magnetometer_nonlinear')
                     for m in (fitted, model))
    assert np.max(np.abs(stage.apply(after) - after - (stage.apply(before) - before))) < 0.5
    error = [float(np.sqrt(np.mean(angle_error_deg(azimuths(m, *readings)[0], azim) ** 2)))
             for m in (fitted, model, replace(model, magnetometer_nonlinear=None))]
    assert abs(error[1] - error[0]) < 0.01 and error[1] < error[2] - 0.04
    turn = np.arange(0.0, 360.0, 10.0)
    _, ring = shots_sim.read(tool, np.full(turn.size, 60.0), turn, np.full(turn.size, 30.0),
                             rng, 20, interference_nT=(0, 0, 0))
    solution = solve_rotation(model, ring)
    assert solution.model.magnetometer_nonlinear is stage
    np.testing.assert_allclose(solution.readings_nT, model.apply_magnetic(ring, before='magnetic'))


def test_fit_stand_says_the_mark_it_drops(tmp_path):
    """
    ``inclino fit-stand`` drops a high-side mark like every fit (``with_stand``) and says so.

    main dropped it silently: the report named only the installation stage.
    """
    rng = np.random.default_rng(2)
    calibration = file_with_mark(tmp_path, rng)
    assert load_model(calibration).toolface_mark is not None
    incl, tf, _ = shots_sim.random_attitudes(rng, 60)
    readings = sensor_model.read(QUARTZ, incl, tf, rng=rng).accel_mps2
    write_rows(tmp_path / 'sphere.csv', ['ax', 'ay', 'az'], readings.tolist())
    code, out, err = quiet(['fit-stand', tmp_path / 'sphere.csv', '--method', 'sphere',
                            '--calibration', calibration])
    assert code == 0, err
    assert load_model(calibration).toolface_mark is None
    assert ('toolface_mark stage dropped: it was measured through the stand stage this fit '
            'replaced; capture the high-side mark again') in out
