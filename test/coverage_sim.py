"""
Calibrate on the physical simulator, then survey: the coverage of the azimuth, inclination sigma.

Issue 19 item 2: a calibration's own error belongs in every sigma computed from
it.  Each draw calibrates a fresh tool of ``sim.sensor_model`` one way
(``CALIBRATIONS``), then reads one station (the mean of STATION_SAMPLES samples)
at a random attitude (inclination 10-80 deg, azimuth N, E or W, toolface
uniform) through ``pipeline.run``: its error is the calibration's and the
station's noise.  Shared by ``test_calibration_coverage`` and
``bench/bench_coverage.py``.

Calibrations:

- ``fit-magnetometer``: 24 shots (8 spread, two roll groups of 8) of the tool of
  ``shots_sim`` (mount 0.8 / -1.2 / 30 deg, the magnetometer turned a further
  (0.5, -0.3, 1.0) deg, each triad's matrix and bias, hard and soft iron, a
  drill-string field), ``calibrate_from_shots`` on an empty model (what
  ``inclino fit-magnetometer`` runs): sphere fit, K_m, b_m, the triads' rotation,
  the tool axis;
- ``stand``: both triads on a 12-position stand with known azimuth, 500
  readings a position (``solve_positions``: seed 001 Eqs. 10-12);
- ``fit-stand``: the accelerometer alone on the 12-position stand, STAND_SAMPLES
  readings a position (``solve_stand``: what ``inclino fit-stand`` runs), no
  magnetometer stage (inclination and toolface only), then a station of
  FIT_STAND_STATION_SAMPLES (the stand's own error then weighs as much as the
  station's noise, and the former rule, its residual RMS as a tilt variance,
  over-states it);
- ``plateau-stand``: both triads of ``sim.bench.drifting_magnetometer_tool`` (its board
  tilts 0.3 deg over 28..60 deg C, the magnetometer's bracket turns a further 0.2 / 0.1
  deg, z biases drift; the preset's noise) on the 12 positions with azimuths at each of
  PLATEAUS_C, STAND_SAMPLES readings a position (``solve_stand``, ``fit_field_stand``:
  K(T), b(T), K_m(T), b_m(T), issue 18), then the station at a temperature uniform over
  the plateaus' range, fed to ``pipeline.run`` (no drill-string field);
- ``sphere + level``: the accelerometer's reference-free sphere fit (``fit-stand
  --method sphere``: SPHERE_POSES still means of SPHERE_SAMPLES readings at attitudes
  uniform over the sphere), then a level bench (seed 000 Eqs. 11-14: LEVEL_SAMPLES
  readings of the vertical tool through the sphere's correction, ``solve_level_capture``),
  then a station of FIT_STAND_STATION_SAMPLES, of ``shots_sim``'s tool; inclination
  only (neither the sphere nor the bench sees the board's roll about the tool axis);
- ``rotation``: 36 single readings of one rotation about the tool axis
  (inclination 30 deg, azimuth 45 deg) of a tool whose only magnetometer error is
  cross-axial hard and soft iron (det 1: the rotation fit's circle keeps the
  field), ``solve_rotation`` on an empty model (seed 002 §2.1).

``without_covariance`` drops the fits' parameter covariance (what files before
schema 7 held, schema 9 for the accelerometer stand, every multi-temperature stand
before this covariance): the former sigma.
"""

from dataclasses import replace
import math

from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.magnetometer import calibrate_from_shots, fit_field_stand
from inclino_ros.calibration.model import CalibrationModel
from inclino_ros.calibration.rotation import solve_rotation
from inclino_ros.calibration.stand_capture import solve_positions
from inclino_ros.calibration.stand_fit import solve_sphere, solve_stand
from inclino_ros.pipeline import MagneticSettings, run, Settings
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import drifting_magnetometer_tool, FIELD_STAND_POSITIONS_DEG
import numpy as np
import shots_sim
from test_magnetometer_stand import POSITIONS_DEG, REFERENCE, stand_positions

STATION_SAMPLES = 100
#: The range of the stations' inclinations [deg].
STATION_INCLINATION_DEG = (10.0, 80.0)
CALIBRATIONS = ('fit-magnetometer', 'stand', 'fit-stand', 'plateau-stand', 'rotation',
                'sphere + level')
#: The calibrations that read no field (inclination and toolface only).
ACCELEROMETER_ONLY = ('fit-stand', 'sphere + level')
#: Readings a stand position of ``fit-stand`` averages, and its station.
STAND_SAMPLES = 50
FIT_STAND_STATION_SAMPLES = 500
#: (name, preset, readings a shot of fit-magnetometer).
TOOLS = (('quartz', sm.QUARTZ_FLUXGATE, 1), ('MEMS', sm.MEMS, 1))
ROTATION_SAMPLES = 36
#: ``sphere + level``: poses of the sphere fit, readings a pose, readings of the level bench.
SPHERE_POSES, SPHERE_SAMPLES, LEVEL_SAMPLES = 40, 50, 500
LEVEL_LIMITS = LevelLimits(max_tilt_deg=5.0, gravity_mps2=sm.STANDARD_GRAVITY_MPS2,
                           g_total_tolerance_mps2=0.3)
#: The temperature plateaus of ``plateau-stand`` [deg C].
PLATEAUS_C = (28.0, 44.0, 60.0)


def rotation_tool(preset):
    """Return error-free triads with ``preset``'s noise and cross-axial hard and soft iron."""
    return sm.Tool(
        accelerometer=sm.Triad(noise_std=preset.accelerometer.noise_std),
        magnetometer=sm.Triad(noise_std=preset.magnetometer.noise_std),
        hard_iron_nT=(300.0, -150.0, 0.0),
        soft_iron=((1.02, 0.01, 0.0), (0.01, (1.0 + 1e-4) / 1.02, 0.0), (0.0, 0.0, 1.0)))


def plateau_tool(preset):
    """Return ``sim.bench.drifting_magnetometer_tool`` with ``preset``'s noise."""
    return drifting_magnetometer_tool(preset.accelerometer.noise_std,
                                      preset.magnetometer.noise_std)


def plateau_stand_model(tool, rng, samples=STAND_SAMPLES):
    """
    Return (model, FieldStandFit) of both triads' stand at PLATEAUS_C (``plateau-stand``).

    The twelve positions with azimuths (``FIELD_STAND_POSITIONS_DEG``), ``samples``
    readings a position at each plateau, fitted as ``inclino fit-stand`` fits them.
    """
    positions = np.array(FIELD_STAND_POSITIONS_DEG, dtype=float)
    accel, field = zip(*(shots_sim.read(tool, *positions.T, rng, samples, (0.0, 0.0, 0.0),
                                        temperature) for temperature in PLATEAUS_C))
    attitudes = np.tile(positions, (len(PLATEAUS_C), 1))
    temperatures = np.repeat(PLATEAUS_C, len(positions))
    stand = solve_stand(np.vstack(accel), attitudes, sm.STANDARD_GRAVITY_MPS2, 1.0,
                        temperatures).stage
    fit = fit_field_stand(np.vstack(field), attitudes, shots_sim.FIELD.total_nT,
                          shots_sim.FIELD.dip_deg, stand, 1.0, temperatures)
    return CalibrationModel(3, stand=stand, magnetometer=fit.magnetometer,
                            magnetometer_alignment=fit.alignment), fit


def calibrate(kind, preset, shot_samples, rng):
    """Return (tool, model) of one calibration ``kind`` of a fresh ``preset`` tool."""
    if kind == 'fit-magnetometer':
        tool = shots_sim.tool(preset)
        incl, tf, azim, group = shots_sim.shot_attitudes(rng)
        accel, field = shots_sim.read(tool, incl, tf, azim, rng, shot_samples)
        return tool, calibrate_from_shots(CalibrationModel(3), accel, field, group).model
    if kind == 'stand':
        tool = shots_sim.tool(preset)
        stand, field, _, _ = solve_positions(stand_positions(tool, rng, POSITIONS_DEG, 500),
                                             sm.STANDARD_GRAVITY_MPS2, 1.0, REFERENCE, 1.0)
        return tool, CalibrationModel(3, stand=stand, magnetometer=field.magnetometer,
                                      magnetometer_alignment=field.alignment)
    if kind == 'fit-stand':
        tool = shots_sim.tool(preset)
        means = [shots_sim.read(tool, [incl], [tf], [azim], rng, STAND_SAMPLES)[0][0]
                 for incl, tf, azim in POSITIONS_DEG]
        solution = solve_stand(means, POSITIONS_DEG, sm.STANDARD_GRAVITY_MPS2, 1.0)
        return tool, CalibrationModel(3, stand=solution.stage)
    if kind == 'plateau-stand':
        tool = plateau_tool(preset)
        return tool, plateau_stand_model(tool, rng)[0]
    if kind == 'sphere + level':
        return sphere_level(shots_sim.tool(preset), rng)
    tool = rotation_tool(preset)
    toolface = np.arange(ROTATION_SAMPLES) * 360.0 / ROTATION_SAMPLES + rng.uniform(0.0, 10.0)
    readings = sm.read(tool, np.full(ROTATION_SAMPLES, 30.0), toolface,
                       np.full(ROTATION_SAMPLES, 45.0), field=shots_sim.FIELD, rng=rng)
    return tool, solve_rotation(CalibrationModel(3), readings.mag_nT).model


def sphere_level(tool, rng, level_samples=LEVEL_SAMPLES):
    """Return (tool, model) of a sphere fit of ``tool`` then a level bench (module docstring)."""
    attitudes = shots_sim.random_attitudes(rng, SPHERE_POSES, min_inclination_deg=0.0)
    means = shots_sim.read(tool, *attitudes, rng, SPHERE_SAMPLES)[0]
    model = CalibrationModel(3, stand=solve_sphere(means, sm.STANDARD_GRAVITY_MPS2, 1.0).stage)
    level = sm.read(tool, np.zeros(level_samples), np.full(level_samples, rng.uniform(0.0, 360.0)),
                    np.zeros(level_samples), field=shots_sim.FIELD, rng=rng).accel_mps2
    installation = solve_level_capture(model.apply(level, before='installation'), 3,
                                       LEVEL_LIMITS)
    return tool, replace(model, installation=installation)


def without_covariance(model):
    """Return ``model`` without the fits' parameter covariance (a schema-6 file)."""
    if model.magnetometer is not None:
        model = replace(model, magnetometer=replace(
            model.magnetometer, parameter_covariance=None, covariance_stages=None))
    if model.magnetic is not None:
        model = replace(model, magnetic=replace(model.magnetic, rotation_covariance=None))
    if model.stand is not None:
        model = replace(model, stand=replace(model.stand, parameter_covariance=None))
    return model


def ratios(kind, preset, shot_samples, draws, rng, inclination_deg=STATION_INCLINATION_DEG):
    """
    Return |error| / sigma (draws, 3, 2): [azimuth, inclination, toolface] x [with, without].

    With and without the fits' covariance (``without_covariance``); each station's
    inclination uniform in ``inclination_deg`` (the module's 10-80 deg).  A NaN
    azimuth (beyond its sigma limit: none at these inclinations; every azimuth
    of ``ACCELEROMETER_ONLY``, which read no field) gives NaN; so does the toolface of a
    model whose zero is the board's (``toolface_zero``, issue 19 item 6: no stand)
    on a tool whose board is turned about the tool axis (``Mount.roll_deg``): its
    offset is the board's roll, which no 1 sigma claims to cover.
    """
    settings = Settings(noise_std_mps2=preset.accelerometer.noise_std)
    magnetic = MagneticSettings(noise_std_nT=preset.magnetometer.noise_std,
                                azimuth_max_std_deg=5.0)
    out = np.full((draws, 3, 2), np.nan)
    for k in range(draws):
        tool, model = calibrate(kind, preset, shot_samples, rng)
        incl, azim = rng.uniform(*inclination_deg), rng.choice([0.0, 90.0, 270.0])
        toolface = rng.uniform(0.0, 360.0)
        samples = FIT_STAND_STATION_SAMPLES if kind in ACCELEROMETER_ONLY else STATION_SAMPLES
        temperature = (rng.uniform(min(PLATEAUS_C), max(PLATEAUS_C))
                       if kind == 'plateau-stand' else None)
        accel, field = shots_sim.read(
            tool, [incl], [toolface], [azim], rng, samples,
            interference_nT=((0.0, 0.0, 0.0) if kind in ('rotation', 'plateau-stand')
                             else shots_sim.INTERFERENCE_NT),
            temperature_c=25.0 if temperature is None else temperature)
        for column, used in enumerate((model, without_covariance(model))):
            survey = run(accel, used, settings, temperature,
                         None if kind in ACCELEROMETER_ONLY else field, magnetic,
                         averaged=samples)
            if survey.magnetic is not None:
                out[k, 0, column] = abs(shots_sim.angle_error_deg(
                    survey.magnetic.defined_azimuth_deg[0], azim)
                ) / survey.magnetic.azimuth_std_deg[0]
            out[k, 1, column] = (abs(survey.inclination_deg[0] - incl)
                                 / survey.inclination_std_deg[0])
            if used.toolface_zero == 'stand' or not tool.mount.roll_deg:
                out[k, 2, column] = abs(shots_sim.angle_error_deg(
                    survey.toolface_deg[0], toolface)) / survey.toolface_std_deg[0]
    return out


def coverage(values):
    """Return (fraction within 1 sigma, within 2 sigma) of |error| / sigma values (no NaN)."""
    values = np.asarray(values)
    values = values[~np.isnan(values)]
    if values.size == 0:
        return math.nan, math.nan
    return float(np.mean(values <= 1.0)), float(np.mean(values <= 2.0))


#: MEMS accelerometer noise per sample [m/s^2] of ``correlated_captures`` (2 mg).
MEMS_NOISE_MPS2 = 2e-3 * sm.STANDARD_GRAVITY_MPS2


def correlated_captures(rho, inclination_deg, draws, samples, seed):
    """
    Return (accel (draws, samples, 3), toolface_deg (draws,), times_s (samples,)) of captures.

    Still captures at 100 Hz of a MEMS accelerometer (MEMS_NOISE_MPS2) with AR(1)
    noise of ``rho``, toolface uniform, each capture its own record of the physical
    simulator (independent draws).
    """
    tool = sm.Tool(accelerometer=sm.Triad(noise_std=MEMS_NOISE_MPS2, noise_rho=rho),
                   magnetometer=sm.Triad(noise_std=100.0))
    rng = np.random.default_rng(seed)
    toolface_deg = rng.uniform(0.0, 360.0, draws)
    readings = sm.read(tool, inclination_deg, np.repeat(toolface_deg, samples), rng=rng,
                       records=draws)
    return (readings.accel_mps2.reshape(draws, samples, 3), toolface_deg,
            np.arange(samples) / 100.0)
