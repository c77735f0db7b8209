"""
Time and accuracy of the improved (seed 002) and classic (Brooks) MSA on 30-station wells.

Wells from ``sim.well`` (the physical sensor model's ideal triads mounted true, so the
interference and the noise are the only errors; inclination 30 -> 90 deg, azimuth +-5 deg about
0, 45, ..., 315 deg, toolfaces spread; 2000 nT axial, (80, -80) nT cross-axial in ISCWSA axes;
1e-4 g, 5 nT noise per station), several seeds each.  The improved method is given the true
cross-axial (the circle fit of the rotation captures is another module), the classic solves all
three components.  Prints per method the
median and worst wall time per 30-station solve and their ratio to the 0.3 s target, and the
worst max error and the worst RMS excess over the floor (the error of the noisy readings with
no interference: ``SimulatedWell.floor_azimuth_deg``).

Usage: .venv/bin/python bench/bench_msa.py [--seeds 5] [--repeats 5]
"""

import argparse
from dataclasses import replace
import time

from inclino_ros.core.msa import azimuth_difference_deg, solve_msa_classic, solve_msa_improved
from inclino_ros.sim.well import simulate_well, WellScenario
import numpy as np

TARGET_S = 0.3
HEADINGS_DEG = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)
SOLVERS = {
    'improved': lambda well: solve_msa_improved(
        well.gravity, well.field_nT, 50000.0, 60.0,
        cross_axial_nT=well.interference_iscwsa_nT[:2]),
    'classic': lambda well: solve_msa_classic(well.gravity, well.field_nT, 50000.0, 60.0),
}


def rms(values):
    """Return the root mean square of ``values``."""
    return float(np.sqrt(np.mean(np.square(values))))


def main():
    """Run every solver on every well and print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, default=5)
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args()
    wells = [simulate_well(replace(WellScenario(), azimuth_deg=(h - 5.0, h + 5.0), seed=seed))
             for h in HEADINGS_DEG for seed in range(args.seeds)]
    print(f'{len(wells)} wells of 30 stations, best of {args.repeats} runs each\n')
    print('| method | median s | worst s | worst / 0.3 s | max error deg | '
          'worst rms - floor rms deg | floor max deg |')
    print('|---|---|---|---|---|---|---|')
    for name, solver in SOLVERS.items():
        seconds, max_error, excess, floor_max = [], 0.0, -np.inf, 0.0
        for well in wells:
            runs = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                result = solver(well)
                runs.append(time.perf_counter() - start)
            seconds.append(min(runs))
            error = azimuth_difference_deg(result.azimuth_deg, well.azimuth_deg)
            floor = azimuth_difference_deg(well.floor_azimuth_deg, well.azimuth_deg)
            max_error = max(max_error, float(np.max(np.abs(error))))
            excess = max(excess, rms(error) - rms(floor))
            floor_max = max(floor_max, float(np.max(np.abs(floor))))
        print(f'| {name} | {np.median(seconds):.4f} | {max(seconds):.4f} | '
              f'{max(seconds) / TARGET_S:.3f} | {max_error:.4f} | {excess:+.4f} | '
              f'{floor_max:.4f} |')


if __name__ == '__main__':
    main()
