"""
False refusals of the still test (``core.stillness``) on still white-noise captures.

Each draw is a still capture: N samples of two tilt components (one for a rotation's axis)
of white Gaussian noise sigma, at 100 Hz, the mean direction fixed.  For each capture size
it prints, over ``--draws`` captures:

- each gate's tail probability against its law: the fraction of still captures whose
  ``drift_p`` / ``scatter_p`` is below 1e-2 and 1e-3 (an exact F law gives 1e-2 and 1e-3,
  binomial spread);
- the refusals at FALSE_MOTION_P, each gate alone (significance only) and the still test
  as the captures run it (``judge`` with the default ``StillLimits``, significance and the
  size of the motion).

Usage: .venv/bin/python bench/bench_stillness.py [--draws 20000] [--seed 1]
"""

import argparse
import math

from inclino_ros.core.stillness import assess, FALSE_MOTION_P, judge, StillLimits
import numpy as np

RATE_HZ = 100.0
#: (samples, components, per-sample noise [deg]): the survey station of test_node_quality
#: (16 samples, 4e-4 g), a short capture, the rotation's axis (k = 1), the default capture
#: of a MEMS (500 samples, 0.02 m/s^2).
CASES = ((6, 2, 0.02), (16, 2, 0.023), (50, 2, 0.08), (100, 1, 0.03), (500, 2, 0.117))


def draw_rates(samples, components, noise_deg, draws, rng):
    """Return the refusal counts of ``draws`` still captures (a dict of counts)."""
    counts = dict.fromkeys(('drift<1e-2', 'drift<1e-3', 'steady<1e-2', 'steady<1e-3',
                            'drift', 'steady', 'judge'), 0)
    times_s = np.arange(samples) / RATE_HZ
    limits = StillLimits()
    sigma = math.radians(noise_deg)
    for _ in range(draws):
        result = assess(rng.normal(0.0, sigma, (samples, components)), times_s)
        counts['drift<1e-2'] += result.drift_p < 1e-2
        counts['drift<1e-3'] += result.drift_p < 1e-3
        counts['steady<1e-2'] += result.scatter_p < 1e-2
        counts['steady<1e-3'] += result.scatter_p < 1e-3
        counts['drift'] += result.drift_p < FALSE_MOTION_P
        counts['steady'] += result.scatter_p < FALSE_MOTION_P
        counts['judge'] += (judge(result, limits) or '').startswith('tool is moving')
    return counts


def main():
    """Print the table (markdown)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--draws', type=int, default=20000)
    parser.add_argument('--seed', type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f'{args.draws} still captures per row, seed {args.seed}; FALSE_MOTION_P '
          f'{FALSE_MOTION_P:g}; binomial 1 sigma of a 1e-2 rate: '
          f'{math.sqrt(1e-2 * (1 - 1e-2) / args.draws):.1e}\n')
    print('| samples | k | noise deg | drift p<1e-2 | drift p<1e-3 | steady p<1e-2 | '
          'steady p<1e-3 | refused: drift | refused: steady | refused: judge |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for samples, components, noise_deg in CASES:
        c = draw_rates(samples, components, noise_deg, args.draws, rng)
        rate = {key: value / args.draws for key, value in c.items()}
        print(f"| {samples} | {components} | {noise_deg} | {rate['drift<1e-2']:.2e} | "
              f"{rate['drift<1e-3']:.1e} | {rate['steady<1e-2']:.2e} | "
              f"{rate['steady<1e-3']:.1e} | {c['drift']} | {c['steady']} | {c['judge']} |")


if __name__ == '__main__':
    main()
