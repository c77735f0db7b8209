"""
A stand at several temperature plateaus against seed 001's per-axis drift, on a turning mount.

The physical simulator's ``sim.bench.drifting_mount_tool`` (MEMS triads, 2e-4 g per sample; the
mount tilts 0.3 deg between 28 and 60 deg C, the z bias drifts 14 mg): (a) today's recipe,
``inclino fit-stand`` at 28 deg C then ``inclino fit-temperature`` on a two-attitude heating run
20 -> 64 deg C; (b) ``core.stand.fit_stand_plateaus`` on nine positions at 28, 44 and 60 deg C
(also (c): plateaus 28 and 60 only).  Each calibration corrects 400 held-out attitudes read
noise-free at 28..60 deg C; the table gives the angle between corrected and true gravity (RMS /
max).  The magnetometer, the same way on ``sim.bench.drifting_magnetometer_tool`` (its bracket
turning a further 0.2 deg about y and 0.1 deg about z over 28..60 deg C, its z bias drifting
400 nT; 20 nT a sample): (a) ``fit-stand`` of twelve positions with azimuths at 28 deg C then
``fit-temperature --triad magnetometer`` on the same heating run (per-axis bias and scale drift
of the field); (b), (c) ``fit-stand`` over the plateaus: K_m(T), b_m(T); the angle between the
corrected and the true field of 400 held-out attitudes and azimuths read noise-free.  Writes
``bench/results/stand_temperatures.md``.  Run:
``.venv/bin/python bench/bench_stand_temperatures.py`` (~20 s).
"""

import csv
import os
import subprocess
import sys
import tempfile

from _results import results_path, write_results
from inclino_ros.calibration.model import load_model
from inclino_ros.core.stand import fit_stand_plateaus, stand_specific_force
from inclino_ros.sim.bench import (
    drifting_magnetometer_tool, drifting_mount_tool, field_plateau_stand,
    held_out_errors_deg, held_out_field_errors_deg, plateau_stand, simulate_heating,
    simulate_stand, StandRun, TURNED_OVER_HEATING_ATTITUDES_DEG)
import numpy as np

G = 9.80665
TOOL = drifting_mount_tool()
MAG_TOOL = drifting_magnetometer_tool()
TEMPERATURES_C = (28.0, 36.0, 44.0, 52.0, 60.0)
REFERENCE = ['--reference-total-nT', '50000', '--reference-dip-deg', '60']


def write_csv(path, columns):
    """Write ``{name: values}`` as a CSV file with a header row."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(zip(*(np.asarray(v).tolist() for v in columns.values())))


def errors_deg(correct, temperature_c):
    """Return the held-out errors [deg] of a calibration (``sim.bench.held_out_errors_deg``)."""
    return held_out_errors_deg(TOOL, correct, temperature_c)


def per_axis_drift_model(work):
    """Return the calibration of stand@28 C + fit-temperature (two attitudes, 20 -> 64 C)."""
    inclino = os.path.join(os.path.dirname(sys.executable), 'inclino')
    stand = simulate_stand(StandRun(TOOL), temperature_c=28.0)
    write_csv(os.path.join(work, 'stand.csv'), {
        'inclination_deg': stand.inclination_deg, 'toolface_deg': stand.toolface_deg,
        'temperature_c': stand.temperature_c, 'ax': stand.raw_mps2[:, 0],
        'ay': stand.raw_mps2[:, 1], 'az': stand.raw_mps2[:, 2]})
    heating = simulate_heating(StandRun(TOOL, seed=1), TURNED_OVER_HEATING_ATTITUDES_DEG,
                               t_start_c=20.0, t_end_c=64.0)
    write_csv(os.path.join(work, 'heating.csv'), {
        'temperature_c': heating.temperature_c, 'attitude': heating.segment,
        'ax': heating.raw_mps2[:, 0], 'ay': heating.raw_mps2[:, 1],
        'az': heating.raw_mps2[:, 2]})
    calibration = os.path.join(work, 'cal.json')
    for command, path in (('fit-stand', 'stand.csv'), ('fit-temperature', 'heating.csv')):
        subprocess.run([inclino, command, os.path.join(work, path), '--calibration',
                        calibration], check=True, capture_output=True)
    return load_model(calibration)


def inclino(*argv):
    """Run the ``inclino`` command of this interpreter's environment; raise on failure."""
    command = os.path.join(os.path.dirname(sys.executable), 'inclino')
    subprocess.run([command, *map(str, argv)], check=True, capture_output=True)


def magnetometer_models(work):
    """Return {name: calibration} of the magnetometer: per-axis drift and plateau stands."""
    heating = simulate_heating(StandRun(MAG_TOOL, seed=1), TURNED_OVER_HEATING_ATTITUDES_DEG,
                               t_start_c=20.0, t_end_c=64.0)
    write_csv(os.path.join(work, 'mag_heating.csv'), {
        'temperature_c': heating.temperature_c, 'attitude': heating.segment,
        'bx': heating.mag_nT[:, 0], 'by': heating.mag_nT[:, 1], 'bz': heating.mag_nT[:, 2]})
    models = {}
    for name, plateaus_c in (('drift', (28.0,)), ('three', (28.0, 44.0, 60.0)),
                             ('two', (28.0, 60.0))):
        stand, calibration = (os.path.join(work, f'mag_{name}.{ext}') for ext in ('csv', 'json'))
        write_csv(stand, field_plateau_stand(MAG_TOOL, plateaus_c))
        inclino('fit-stand', stand, *REFERENCE, '--calibration', calibration)
        if name == 'drift':
            inclino('fit-temperature', os.path.join(work, 'mag_heating.csv'), '--triad',
                    'magnetometer', '--calibration', calibration)
        models[name] = load_model(calibration)
    return models


def plateau_fit(plateaus_c):
    """Return the fit_stand_plateaus of nine positions at each plateau."""
    means, attitudes, temperatures = plateau_stand(TOOL, plateaus_c)
    truth = stand_specific_force(attitudes[:, 0], attitudes[:, 1], G)
    return fit_stand_plateaus(means, truth, temperatures)


def main():
    """Run the three calibrations and write the table."""
    with tempfile.TemporaryDirectory() as work:
        model = per_axis_drift_model(work)
        magnetometer = magnetometer_models(work)
    three, two = plateau_fit((28.0, 44.0, 60.0)), plateau_fit((28.0, 60.0))
    methods = [('stand at 28 C + fit-temperature (per-axis bias and scale drift, order 2)',
                model.apply),
               (f'stand at 28, 44, 60 C (K(T), b(T), order {three.order} chosen)', three.apply),
               (f'stand at 28, 60 C (order {two.order})', two.apply)]
    rows = []
    for name, correct in methods:
        cells = []
        for temperature in TEMPERATURES_C:
            error = errors_deg(correct, temperature)
            cells.append(f'{np.sqrt(np.mean(error ** 2)):.4f} / {error.max():.4f}')
        rows.append(f'| {name} | ' + ' | '.join(cells) + ' |')
    mag_rows = []
    three, two = magnetometer['three'].magnetometer, magnetometer['two'].magnetometer
    for name, key in (('stand at 28 C + fit-temperature --triad magnetometer (per-axis bias and '
                       'scale drift)', 'drift'),
                      (f'stand at 28, 44, 60 C (K_m(T), b_m(T), order '
                       f'{len(three.scale_coefficients) - 1} chosen)', 'three'),
                      (f'stand at 28, 60 C (order {len(two.scale_coefficients) - 1})', 'two')):
        model = magnetometer[key]
        cells = []
        for temperature in TEMPERATURES_C:
            error = held_out_field_errors_deg(
                MAG_TOOL, lambda b, t, model=model: model.apply_magnetic(
                    b, t, before='installation'), temperature)
            cells.append(f'{np.sqrt(np.mean(error ** 2)):.4f} / {error.max():.4f}')
        mag_rows.append(f'| {name} | ' + ' | '.join(cells) + ' |')
    text = '\n'.join([
        '# Multi-temperature stand against per-axis drift (a mount that turns with T)',
        '',
        'bench/bench_stand_temperatures.py: sim.bench.drifting_mount_tool (MEMS, 2e-4 g a sample,',
        'mount tilting 0.3 deg over 28-60 C, z bias 14 mg over it), 100 samples a position, 400',
        'held-out attitudes read noise-free; angle between corrected and true gravity, RMS / max',
        '[deg].',
        '',
        '| calibration | ' + ' | '.join(f'{t:g} C' for t in TEMPERATURES_C) + ' |',
        '|---|' + '---|' * len(TEMPERATURES_C), *rows, '',
        '## The magnetometer (K_m(T), b_m(T))',
        '',
        'sim.bench.drifting_magnetometer_tool (the board as above; the magnetometer bracket',
        'turning a further 0.2 deg about y and 0.1 deg about z over 28-60 C, z bias 400 nT over',
        'it; 20 nT a sample), twelve positions with azimuths, 100 samples each; 400 held-out',
        'attitudes and azimuths read noise-free; angle between corrected and true field, RMS /',
        'max [deg].',
        '',
        '| calibration | ' + ' | '.join(f'{t:g} C' for t in TEMPERATURES_C) + ' |',
        '|---|' + '---|' * len(TEMPERATURES_C), *mag_rows, ''])
    write_results(results_path('stand_temperatures.md'), text)


if __name__ == '__main__':
    main()
