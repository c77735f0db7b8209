"""
Benchmark of the magnetometer calibrations (issue 8): accuracy on the physical model, speed.

Accuracy: for QUARTZ_FLUXGATE and MEMS (``sim.sensor_model``, every error source, mount
gamma 0.8 / beta -1.2 / roll 30 deg, magnetometer turned a further (0.5, -0.3, 1.0) deg,
drill-string field (80, 80, -2000) nT), 10 seeds each:

- stand: 12 positions with known azimuth, 100 readings each, K and K_m (seed 001 Eqs. 10-12);
- reference-free: 24 shots (8 spread + two roll groups of 8), one reading a shot for quartz,
  100 for MEMS; ``calibrate_from_shots`` (what ``inclino fit-magnetometer`` runs);

then azimuth and inclination errors at 1000 random attitudes (inclination 10-170 deg), read
noise-free (the calibration's error alone) and with the preset's noise (one reading), and
the azimuth spread of each roll group's own shots.

Speed: ``inclino fit-magnetometer`` on 100 shots (36 spread + four roll groups of 16), the
whole process (interpreter start, imports, fit, report, atomic write), median of 11 runs.

Run: ``.venv/bin/python bench/bench_fit_magnetometer.py``.
"""

import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

from inclino_ros.calibration.magnetometer import calibrate_from_shots
from inclino_ros.calibration.model import CalibrationModel
from inclino_ros.calibration.stand_capture import average_position, solve_positions
from inclino_ros.core.stillness import StillLimits
from inclino_ros.pipeline import MagneticSettings, run, Settings
from inclino_ros.sim import sensor_model
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / 'test'))
import shots_sim  # noqa: E402  (the tests' physical-model scenarios)
from test_magnetometer_stand import noiseless, POSITIONS_DEG  # noqa: E402

SEEDS = range(10)


def errors(tool, model, rng, noisy):
    """Return (azimuth, inclination) errors [deg] at 1000 random attitudes."""
    incl, tf, azim = shots_sim.random_attitudes(rng, 1000)
    accel, field = shots_sim.read(tool if noisy else noiseless(tool), incl, tf, azim, rng)
    survey = run(accel, model, Settings(), None, field, MagneticSettings())
    return (shots_sim.angle_error_deg(survey.magnetic.defined_azimuth_deg, azim),
            survey.inclination_deg - incl)


def stand_model(tool, rng):
    """Return the model of a 12-position stand calibration of both triads (500 samples each)."""
    positions = []
    for incl, tf, azim in POSITIONS_DEG:
        accel, field = shots_sim.read(tool, np.full(500, incl), np.full(500, tf),
                                      np.full(500, azim), rng)
        positions.append(average_position(accel, incl, tf, StillLimits(), fields_nT=field,
                                          azimuth_deg=azim))
    stand, field, _, _ = solve_positions(positions, 9.80665, 1.0, (50000.0, 60.0), 1.0)
    return CalibrationModel(3, stand=stand, magnetometer=field.magnetometer,
                            magnetometer_alignment=field.alignment), None


def shots_model(tool, rng, samples):
    """Return (model, group spreads) of a 24-shot reference-free calibration."""
    incl, tf, azim, group = shots_sim.shot_attitudes(rng)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng, samples)
    model = calibrate_from_shots(CalibrationModel(3), accel, field, group).model
    spreads = []
    for k in (0, 1):
        survey = run(accel[group == k], model, Settings(), None, field[group == k],
                     MagneticSettings())
        azimuth = survey.magnetic.defined_azimuth_deg
        spreads.append(float(np.sqrt(np.mean(
            shots_sim.angle_error_deg(azimuth, np.mean(azimuth)) ** 2))))
    return model, spreads


def accuracy_rows():
    """Return the markdown rows of the accuracy table."""
    rows = []
    for preset, samples in (('QUARTZ_FLUXGATE', 1), ('MEMS', 100)):
        tool = shots_sim.tool(getattr(sensor_model, preset))
        for method in ('stand', 'shots'):
            worst = {'az': 0.0, 'inc': 0.0, 'az_noisy': 0.0, 'spread': 0.0}
            rms = []
            for seed in SEEDS:
                rng = np.random.default_rng(seed)
                model, spreads = (stand_model(tool, rng) if method == 'stand'
                                  else shots_model(tool, rng, samples))
                azimuth, inclination = errors(tool, model, rng, noisy=False)
                noisy, _ = errors(tool, model, rng, noisy=True)
                worst['az'] = max(worst['az'], float(np.max(np.abs(azimuth))))
                worst['inc'] = max(worst['inc'], float(np.max(np.abs(inclination))))
                worst['az_noisy'] = max(worst['az_noisy'], float(np.max(np.abs(noisy))))
                rms.append(float(np.sqrt(np.mean(azimuth ** 2))))
                if spreads:
                    worst['spread'] = max(worst['spread'], max(spreads))
            rows.append(f'| {preset} | {method} | {worst["az"]:.4f} | {max(rms):.4f} | '
                        f'{worst["inc"]:.4f} | {worst["az_noisy"]:.4f} | '
                        + (f'{worst["spread"]:.4f} |' if method == 'shots' else '- |'))
    return rows


def timing(runs=11):
    """Return the median and spread [s] of ``inclino fit-magnetometer`` on 100 shots."""
    rng = np.random.default_rng(1)
    tool = shots_sim.tool(sensor_model.QUARTZ_FLUXGATE)
    axes = ((60.0, 30.0), (35.0, 200.0), (80.0, 110.0), (20.0, 300.0))
    incl, tf, azim, group = shots_sim.shot_attitudes(rng, free=36, per_group=16, axes_deg=axes)
    accel, field = shots_sim.read(tool, incl, tf, azim, rng)
    inclino = os.path.join(os.path.dirname(sys.executable), 'inclino')
    with tempfile.TemporaryDirectory() as folder:
        shots_sim.write_shots(f'{folder}/shots.csv', accel, field, group)
        seconds = []
        for _ in range(runs + 1):
            start = time.perf_counter()
            subprocess.run([inclino, 'fit-magnetometer', f'{folder}/shots.csv', '--calibration',
                            f'{folder}/cal.json'], check=True, capture_output=True)
            seconds.append(time.perf_counter() - start)
    seconds = seconds[1:]   # the first run warms the file cache
    return statistics.median(seconds), min(seconds), max(seconds)


def main():
    """Print the accuracy table and the timing."""
    print('| sensor | calibration | azimuth max, noise-free [deg] | azimuth RMS, worst seed '
          '[deg] | inclination max, noise-free [deg] | azimuth max, one noisy reading [deg] | '
          'roll-group azimuth spread RMS, worst [deg] |')
    print('|---|---|---|---|---|---|---|')
    print('\n'.join(accuracy_rows()))
    median, fastest, slowest = timing()
    print(f'\ninclino fit-magnetometer, 100 shots: median {median:.3f} s '
          f'(min {fastest:.3f}, max {slowest:.3f}) over 11 runs')


if __name__ == '__main__':
    main()
