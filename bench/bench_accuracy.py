"""
Accuracy of the level-bench calibration: Monte Carlo over simulated tools.

Every reading comes from the physical sensor model (``inclino_ros.sim.sensor_model``).
For each case, many tools with random installation angles (gamma, beta
uniform in +-3 deg, the board carrying the triads) are captured on a level
bench (``--samples`` noisy readings, the node's default 100), solved with the
core (``level_capture.solve_level_capture``), and then read at random
attitudes (inclination 0-90 deg, noise-free, so that only the calibration's
error is measured).

Table 1: ideal triads, noise 1e-4, 2e-4, 1e-3 g per sample: the errors of
gamma/beta and of the corrected inclination beside the closed-form
expectation sigma / (g sqrt(N)) rad for the angles.
Table 2: the presets (``ideal`` without noise, ``quartz``, ``mems``) with
their own noise: what the level calibration alone leaves when the triads
have their own K and bias (seed 001's stand calibration is for those).

Usage: .venv/bin/python bench/bench_accuracy.py [--trials 500] [--samples 100]
"""

import argparse
from dataclasses import replace
import math

from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.model import CalibrationModel
from inclino_ros.core.stillness import StillLimits
from inclino_ros.pipeline import run, Settings
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import make_tool
import numpy as np

G = sm.STANDARD_GRAVITY_MPS2
NOISE_G = (1e-4, 2e-4, 1e-3)  # per-sample noise, 1 sigma, in g
PRESETS = ('ideal', 'quartz', 'mems')


def rms(errors):
    """Return the root mean square of ``errors``."""
    return math.sqrt(np.mean(np.square(errors)))


def trial(rng, sensor, noise_mps2, samples, stations):
    """Return (gamma, beta errors [deg], corrected and raw inclination errors [deg])."""
    gamma_deg, beta_deg = rng.uniform(-3.0, 3.0, 2)
    tool = make_tool(sensor, gamma_deg, beta_deg, noise_mps2=noise_mps2)
    level = sm.read(tool, np.zeros(samples), 0.0, rng=rng).accel_mps2
    limits = LevelLimits(max_tilt_deg=10.0, gravity_mps2=G, g_total_tolerance_mps2=1.0,
                         still=StillLimits(max_sem_deg=10.0))
    installation = solve_level_capture(level, 3, limits)
    inclination_deg = rng.uniform(0.0, 90.0, stations)
    toolface_deg = rng.uniform(0.0, 360.0, stations)
    noise_free = replace(tool, accelerometer=replace(tool.accelerometer, noise_std=0.0))
    raw = sm.read(noise_free, inclination_deg, toolface_deg).accel_mps2
    settings = Settings()
    corrected = run(raw, CalibrationModel(3, installation), settings).inclination_deg
    uncorrected = run(raw, CalibrationModel(3), settings).inclination_deg
    return (installation.gamma_deg - gamma_deg, installation.beta_deg - beta_deg,
            corrected - inclination_deg, uncorrected - inclination_deg)


def monte_carlo(rng, args, sensor, noise_mps2):
    """Return the four error arrays of ``args.trials`` tools (see ``trial``)."""
    results = [trial(rng, sensor, noise_mps2, args.samples, args.stations)
               for _ in range(args.trials)]
    return [np.concatenate([np.atleast_1d(r[k]) for r in results]) for k in range(4)]


def main():
    """Run the Monte Carlo and print two Markdown tables."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--trials', type=int, default=500)
    parser.add_argument('--samples', type=int, default=100)
    parser.add_argument('--stations', type=int, default=20)
    parser.add_argument('--seed', type=int, default=2026)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f'{args.trials} tools, gamma/beta uniform in +-3 deg, {args.samples}-sample level '
          f'capture, {args.stations} random attitudes (0-90 deg) each\n')
    print('| noise per sample | expected 1 sigma of gamma, beta | gamma error rms | '
          'beta error rms | corrected inclination error rms / max | raw error rms / max |')
    print('|---|---|---|---|---|---|')
    for noise_g in NOISE_G:
        d_gamma, d_beta, d_incl, d_raw = monte_carlo(rng, args, 'ideal', noise_g * G)
        expected = math.degrees(noise_g / math.sqrt(args.samples))
        print(f'| {noise_g:g} g | {expected:.4f} deg | {rms(d_gamma):.4f} deg | '
              f'{rms(d_beta):.4f} deg | {rms(d_incl):.4f} / {np.max(np.abs(d_incl)):.4f} deg | '
              f'{rms(d_raw):.3f} / {np.max(np.abs(d_raw)):.3f} deg |')
    print('\n| sensor (own noise) | corrected inclination error rms / max | '
          'raw error rms / max |')
    print('|---|---|---|')
    for sensor in PRESETS:
        _, _, d_incl, d_raw = monte_carlo(rng, args, sensor, None)
        noise = np.max(make_tool(sensor).accelerometer.noise_std) / G
        print(f'| {sensor} ({noise:g} g) | {rms(d_incl):.4f} / {np.max(np.abs(d_incl)):.4f} deg '
              f'| {rms(d_raw):.3f} / {np.max(np.abs(d_raw)):.3f} deg |')


if __name__ == '__main__':
    main()
