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

Slow turns and steps (issue 19 item 5, ``--turn-draws``): captures of two tilt components at
100 Hz, MEMS (0.117 deg per sample: 0.02 m/s^2) and quartz (0.0057 deg: 1e-4 g) noise, 3 / 5 /
10 s long: still ones with white and AR(1) noise (rho 0.5, 0.9: false refusals), and ones that
turn at 0.005-0.05 deg/s or step by 0.1 deg at mid-capture (white noise): the fraction
accepted by ``judge`` (default ``StillLimits``), and of the accepted, the fraction whose mean
lies within 1 and 2 ``stated_sem_deg`` of the attitude at both ends of the capture (for a
still capture: of the attitude), and the median stated sigma.

Usage: .venv/bin/python bench/bench_stillness.py [--draws 20000] [--turn-draws 1000] [--seed 1]
"""

import argparse
import math

from inclino_ros.core.stillness import assess, FALSE_MOTION_P, judge, StillLimits
import numpy as np
from scipy.signal import lfilter

RATE_HZ = 100.0
#: Per-sample tilt noise [deg] of the slow-turn rows: MEMS 0.02 m/s^2, quartz 1e-4 g.
SENSORS = (('MEMS', 0.117), ('quartz', 0.0057))
#: Capture lengths [s] and motions of the slow-turn rows: (name, rate deg/s, step deg, rho).
DURATIONS_S = (3.0, 5.0, 10.0)
MOTIONS = (('still white', 0.0, 0.0, 0.0), ('still AR(1) 0.5', 0.0, 0.0, 0.5),
           ('still AR(1) 0.9', 0.0, 0.0, 0.9), ('turn 0.005 deg/s', 0.005, 0.0, 0.0),
           ('turn 0.015 deg/s', 0.015, 0.0, 0.0), ('turn 0.05 deg/s', 0.05, 0.0, 0.0),
           ('step 0.1 deg', 0.0, 0.1, 0.0))
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


def motion_rates(noise_deg, duration_s, motion, draws, rng):
    """
    Return (accepted, moving, covered 1 sigma, covered 2 sigma, median stated sigma) of ``draws``.

    ``motion`` (name, rate deg/s, step deg, rho): the first tilt component turns at the rate or
    steps at mid-capture; the noise is AR(1) of stationary 1 sigma ``noise_deg``.
    """
    _, rate, step, rho = motion
    samples = int(round(duration_s * RATE_HZ))
    times_s = np.arange(samples) / RATE_HZ
    truth = rate * times_s + step * (times_s >= times_s[samples // 2])
    limits = StillLimits()
    accepted, moving, one, two, stated = 0, 0, 0, 0, []
    for _ in range(draws):
        white = rng.normal(0.0, 1.0, (samples, 2))
        # Stationary AR(1): w_0 = e_0, w_i = rho w_(i-1) + sqrt(1 - rho^2) e_i.
        white[0] /= math.sqrt(1.0 - rho ** 2)
        noise = lfilter([math.sqrt(1.0 - rho ** 2)], [1.0, -rho], white, axis=0)
        angles_deg = noise * noise_deg
        angles_deg[:, 0] += truth
        result = assess(np.radians(angles_deg), times_s)
        reason = judge(result, limits)
        if reason is not None:
            moving += reason.startswith('tool is moving')
            continue
        accepted += 1
        mean_deg = angles_deg[:, 0].mean()
        error = max(abs(mean_deg - truth[0]), abs(mean_deg - truth[-1]))
        one += error <= result.stated_sem_deg
        two += error <= 2.0 * result.stated_sem_deg
        stated.append(result.stated_sem_deg)
    return accepted, moving, one, two, float(np.median(stated)) if stated else math.nan


def slow_turns(draws, rng):
    """Print the slow-turn table (markdown)."""
    print(f'\n{draws} captures per row; accepted: by judge (default StillLimits: max_sem_deg '
          f'{StillLimits.max_sem_deg}, max_motion_deg {StillLimits.max_motion_deg}, '
          f'max_drift_deg_per_s {StillLimits.max_drift_deg_per_s}); covered: of the accepted, '
          'mean within 1 / 2 stated sigma of the attitude at both ends\n')
    print('| sensor | capture s | motion | accepted | refused moving | covered 1 sigma | '
          'covered 2 sigma | median stated sigma deg | sem deg |')
    print('|---|---|---|---|---|---|---|---|---|')
    for sensor, noise_deg in SENSORS:
        for duration_s in DURATIONS_S:
            sem_deg = noise_deg / math.sqrt(duration_s * RATE_HZ)
            for motion in MOTIONS:
                accepted, moving, one, two, stated = motion_rates(
                    noise_deg, duration_s, motion, draws, rng)
                share = (f'{one / accepted:.2f} | {two / accepted:.2f}' if accepted else '- | -')
                print(f'| {sensor} | {duration_s:g} | {motion[0]} | {accepted / draws:.3f} | '
                      f'{moving / draws:.3f} | {share} | {stated:.4f} | {sem_deg:.4f} |')


def main():
    """Print the table (markdown)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--draws', type=int, default=20000)
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--turn-draws', type=int, default=1000)
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
    slow_turns(args.turn_draws, rng)


if __name__ == '__main__':
    main()
