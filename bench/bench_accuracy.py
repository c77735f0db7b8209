"""
Accuracy of the level-bench calibration: Monte Carlo over simulated tools.

For each noise level, many tools with random installation angles (gamma,
beta uniform in +-3 deg) are captured on a level bench (``--samples`` noisy
readings, the node's default 100), solved with the core
(``level_capture.solve_level_capture``), and then read at random attitudes
(inclination 0-90 deg, noise-free, so that only the calibration's error is
measured).  Prints the errors of gamma/beta and of the corrected inclination
beside the closed-form expectation sigma / (g sqrt(N)) rad for the angles.

Usage: .venv/bin/python bench/bench_accuracy.py [--trials 500] [--samples 100]
"""

import argparse
import math

from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.model import CalibrationModel
from inclino_ros.core.stillness import StillLimits
from inclino_ros.pipeline import run, Settings
from inclino_ros.sim.bench import sensor_matrix, specific_force
import numpy as np

G = 9.80665
NOISE_G = (1e-4, 2e-4, 1e-3)  # per-sample noise, 1 sigma, in g


def rms(errors):
    """Return the root mean square of ``errors``."""
    return math.sqrt(np.mean(np.square(errors)))


def trial(rng, noise_mps2, samples, stations):
    """Return (gamma, beta errors [deg], corrected and raw inclination errors [deg])."""
    gamma_deg, beta_deg = rng.uniform(-3.0, 3.0, 2)
    c = sensor_matrix(math.radians(gamma_deg), math.radians(beta_deg))
    level = c @ np.array([0.0, 0.0, G]) + rng.normal(0.0, noise_mps2, (samples, 3))
    limits = LevelLimits(max_tilt_deg=10.0, gravity_mps2=G, g_total_tolerance_mps2=1.0,
                         still=StillLimits(max_sem_deg=10.0))
    installation = solve_level_capture(level, 3, limits)
    inclination_deg = rng.uniform(0.0, 90.0, stations)
    toolface_deg = rng.uniform(0.0, 360.0, stations)
    raw = specific_force(np.radians(inclination_deg), np.radians(toolface_deg), G) @ c.T
    settings = Settings()
    corrected = run(raw, CalibrationModel(3, installation), settings).inclination_deg
    uncorrected = run(raw, CalibrationModel(3), settings).inclination_deg
    return (installation.gamma_deg - gamma_deg, installation.beta_deg - beta_deg,
            corrected - inclination_deg, uncorrected - inclination_deg)


def main():
    """Run the Monte Carlo and print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--trials', type=int, default=500)
    parser.add_argument('--samples', type=int, default=100)
    parser.add_argument('--stations', type=int, default=20)
    parser.add_argument('--seed', type=int, default=2026)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f'{args.trials} tools, gamma/beta uniform in +-3 deg, {args.samples}-sample level '
          f'capture, {args.stations} random attitudes (0-90 deg) each')
    print('| noise per sample | expected 1 sigma of gamma, beta | gamma error rms | '
          'beta error rms | corrected inclination error rms / max | raw error rms / max |')
    print('|---|---|---|---|---|---|')
    for noise_g in NOISE_G:
        results = [trial(rng, noise_g * G, args.samples, args.stations)
                   for _ in range(args.trials)]
        d_gamma, d_beta, d_incl, d_raw = (np.concatenate([np.atleast_1d(r[k]) for r in results])
                                          for k in range(4))
        expected = math.degrees(noise_g / math.sqrt(args.samples))
        print(f'| {noise_g:g} g | {expected:.4f} deg | {rms(d_gamma):.4f} deg | '
              f'{rms(d_beta):.4f} deg | {rms(d_incl):.4f} / {np.max(np.abs(d_incl)):.4f} deg | '
              f'{rms(d_raw):.3f} / {np.max(np.abs(d_raw)):.3f} deg |')


if __name__ == '__main__':
    main()
