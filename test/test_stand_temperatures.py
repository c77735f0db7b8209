"""
A stand at several temperature plateaus (issue 18): K(T), b(T) where per-axis drift cannot hold.

The physical simulator grows a mount that turns with the temperature (``sim.sensor_model.Mount``
``drift_deg_per_c``): the MEMS tool (2e-4 g per sample, 100 samples a position) whose board
tilts by 0.3 deg between 28 and 60 deg C (gamma, 0.3/32 deg/C) and whose z bias drifts by 14 mg
over the same span (with the preset's own drifts).  Compared, on 400 held-out attitudes read
noise-free (only the calibration's error shows), as the angle between the corrected and the
true gravity direction:

- today's recipe: ``fit-stand`` at 28 deg C, then ``fit-temperature`` (heated 20 -> 64 deg C at
  two attitudes, turned over: a bias and a scale drift per axis, order 2).  A turn of the mount
  is no per-axis drift: measured 0.30 deg RMS, 0.59 deg max at 60 deg C;
- ``core.stand.fit_stand_plateaus``: nine positions at each of 28, 44 and 60 deg C, K and b per
  plateau, every element a polynomial of T (order chosen by chi-square: 2 here, the preset's
  drifts being quadratic).  Each plateau's K and b carry ~1e-5 of noise (test_stand.py): the
  held-out error is ~0.002 deg at and between the plateaus; the issue's bound 0.04 deg is >10x.
"""

import csv
from dataclasses import replace
import math

from inclino_ros.calibration.model import load_model
from inclino_ros.core.stand import (
    fit_stand_plateaus, plateau_numbers, stand_specific_force, StandFitRefused)
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import (
    drifting_mount_tool, held_out_errors_deg, make_tool, plateau_stand, simulate_heating,
    simulate_stand, STAND_POSITIONS_DEG, StandRun, TURNED_OVER_HEATING_ATTITUDES_DEG)
import numpy as np
import pytest
from test_msa_cli import quiet

G = 9.80665
PLATEAUS_C = (28.0, 44.0, 60.0)


TOOL = drifting_mount_tool()
NOISE_FREE = replace(TOOL, accelerometer=replace(TOOL.accelerometer, noise_std=0.0))


def held_out_error_deg(correct, temperature_c):
    """Return the held-out errors [deg] of a calibration (``sim.bench.held_out_errors_deg``)."""
    return held_out_errors_deg(TOOL, correct, temperature_c)


def plateau_positions(temperatures_c=PLATEAUS_C):
    """Return (mean readings, truth, temperatures) of the nine positions at each plateau."""
    means, attitudes, temps = plateau_stand(TOOL, temperatures_c)
    return means, stand_specific_force(attitudes[:, 0], attitudes[:, 1], G), temps


def write_csv(path, columns):
    """Write ``{name: values}`` as a CSV file with a header row."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(zip(*(np.asarray(v).tolist() for v in columns.values())))


def test_the_mount_turns_with_the_temperature():
    """Mount.at: gamma + 0.3 deg at 60 vs 28 deg C; the reading turns by that much."""
    mount = TOOL.mount
    assert mount.at(60.0).gamma_deg - mount.at(28.0).gamma_deg == pytest.approx(0.3)
    f = sm.read(NOISE_FREE, 0.0, 0.0, temperature_c=[28.0, 60.0]).accel_mps2
    no_drift = replace(NOISE_FREE, mount=replace(TOOL.mount, drift_deg_per_c=(0, 0, 0)))
    g = sm.read(no_drift, 0.0, 0.0, temperature_c=[28.0, 60.0]).accel_mps2
    turn_deg = math.degrees(math.atan2(np.linalg.norm(np.cross(f[1], g[1])), f[1] @ g[1])
                            - math.atan2(np.linalg.norm(np.cross(f[0], g[0])), f[0] @ g[0]))
    assert abs(turn_deg) == pytest.approx(0.3, abs=0.01)


def test_plateaus_and_order():
    """Three plateaus found; the order chosen and reported; one plateau refused."""
    assert plateau_numbers([60.1, 28.0, 44.2, 27.9, 59.8]).tolist() == [2, 0, 1, 0, 2]
    means, truth, temps = plateau_positions()
    fit = fit_stand_plateaus(means, truth, temps)
    np.testing.assert_allclose(fit.plateaus_c, PLATEAUS_C)
    assert fit.range_c == (28.0, 60.0)
    assert fit.order == 2 and [order for order, _, _ in fit.chi_square] == [0, 1, 2]
    with pytest.raises(StandFitRefused, match='one temperature plateau'):
        fit_stand_plateaus(means[:9], truth[:9], temps[:9])


def order_chosen(tool, plateaus_c, draws, seed):
    """Return how often each order was chosen over ``draws`` stands of ``tool`` (50 samples)."""
    rng = np.random.default_rng(seed)
    positions = np.array(STAND_POSITIONS_DEG)
    truth = np.tile(stand_specific_force(positions[:, 0], positions[:, 1], G),
                    (len(plateaus_c), 1))
    temperatures = np.repeat(plateaus_c, len(positions))
    counts = np.zeros(len(plateaus_c), dtype=int)
    for _ in range(draws):
        samples = sm.read(tool, np.tile(np.repeat(positions[:, 0], 50), len(plateaus_c)),
                          np.tile(np.repeat(positions[:, 1], 50), len(plateaus_c)),
                          temperature_c=np.repeat(plateaus_c, 50 * len(positions)), rng=rng)
        means = samples.accel_mps2.reshape(-1, 50, 3).mean(axis=1)
        counts[fit_stand_plateaus(means, truth, temperatures).order] += 1
    return counts


def test_order_of_a_temperature_independent_sensor():
    """
    A sensor whose K and b do not change with T: order 0 at five plateaus, but for 5 % of stands.

    The order test's significance is 0.05, so of 100 stands order 0 is expected in 95 +- 2.2
    (binomial): the test asks 88 (3 binomial sigma).  Before (a per-element chi-square with
    each plateau's own noise estimate, 5 degrees of freedom an axis, significance 1e-3), the
    orders 0-4 were chosen about equally: 13 of 100 order 0 at this seed (failed first).
    """
    tool = make_tool('ideal', 0.8, -1.2, noise_mps2=2e-4 * G)
    counts = order_chosen(tool, (20.0, 35.0, 50.0, 65.0, 80.0), 100, seed=3)
    assert counts[0] >= 88, counts


def test_multi_temperature_stand_against_per_axis_drift(tmp_path):
    """Stand@28 + fit-temperature: ~0.3 deg at 60 deg C; the plateau stand: <= 0.04 deg."""
    stand = simulate_stand(StandRun(TOOL), temperature_c=28.0)
    write_csv(tmp_path / 'stand28.csv', {
        'inclination_deg': stand.inclination_deg, 'toolface_deg': stand.toolface_deg,
        'temperature_c': stand.temperature_c, 'ax': stand.raw_mps2[:, 0],
        'ay': stand.raw_mps2[:, 1], 'az': stand.raw_mps2[:, 2]})
    heating = simulate_heating(StandRun(TOOL, seed=1), TURNED_OVER_HEATING_ATTITUDES_DEG,
                               t_start_c=20.0, t_end_c=64.0)
    write_csv(tmp_path / 'heating.csv', {
        'temperature_c': heating.temperature_c, 'attitude': heating.segment,
        'ax': heating.raw_mps2[:, 0], 'ay': heating.raw_mps2[:, 1],
        'az': heating.raw_mps2[:, 2]})
    for argv in (['fit-stand', tmp_path / 'stand28.csv'],
                 ['fit-temperature', tmp_path / 'heating.csv']):
        code, _, err = quiet(argv + ['--calibration', tmp_path / 'cal.json'])
        assert code == 0, err
    model = load_model(tmp_path / 'cal.json')
    per_axis = held_out_error_deg(model.apply, 60.0)
    fit = fit_stand_plateaus(*plateau_positions())
    plateau = {t: held_out_error_deg(fit.apply, t) for t in (28.0, 36.0, 44.0, 52.0, 60.0)}
    print(f'60 C: per-axis drift {np.sqrt(np.mean(per_axis ** 2)):.4f} RMS / '
          f'{per_axis.max():.4f} max deg; plateau stand '
          + ', '.join(f'{t:g} C {e.max():.4f}' for t, e in plateau.items()))
    assert np.sqrt(np.mean(per_axis ** 2)) > 0.2 and per_axis.max() > 0.3
    assert max(e.max() for e in plateau.values()) <= 0.04


def test_fit_stand_command_writes_k_and_b_of_t(tmp_path):
    """
    Inclino fit-stand on positions at 28, 44, 60 deg C: K(T), b(T) in the file, applied at T.

    Main refused the CSV (its temperatures span 32 C without a temperature stage).  The
    file's stand carries the polynomials and their range; the model read back corrects the
    held-out attitudes within 0.04 deg at and between the plateaus (measured ~0.003 deg),
    holds K, b at the range's ends beyond it, and one plateau gives constant K, b as before.
    """
    rows = []
    for seed, temperature in enumerate(PLATEAUS_C):
        run = simulate_stand(StandRun(TOOL, seed=seed), temperature_c=temperature)
        rows.append({'inclination_deg': run.inclination_deg, 'toolface_deg': run.toolface_deg,
                     'temperature_c': run.temperature_c, 'ax': run.raw_mps2[:, 0],
                     'ay': run.raw_mps2[:, 1], 'az': run.raw_mps2[:, 2]})
    write_csv(tmp_path / 'multi.csv', {name: np.concatenate([r[name] for r in rows])
                                       for name in rows[0]})
    code, out, err = quiet(['fit-stand', tmp_path / 'multi.csv', '--calibration',
                            tmp_path / 'cal.json'])
    assert code == 0, err
    assert 'positions at 3 temperature plateaus: K(T) and b(T)' in out
    assert 'of order 2' in out and 'plateau  60.00 C: 9 positions' in out
    stand = load_model(tmp_path / 'cal.json').stand
    assert (stand.t_min_c, stand.t_max_c, stand.temperature_c) == (28.0, 60.0, 44.0)
    assert len(stand.scale_coefficients) == 3
    model = load_model(tmp_path / 'cal.json')
    for temperature in (28.0, 36.0, 44.0, 52.0, 60.0):
        assert held_out_error_deg(model.apply, temperature).max() <= 0.04
    assert stand.outside_range([27.0, 44.0, 61.0]).tolist() == [True, False, True]
    np.testing.assert_array_equal(stand.at(70.0)[0], stand.at(60.0)[0])
    write_csv(tmp_path / 'one.csv', rows[0])
    assert quiet(['fit-stand', tmp_path / 'one.csv', '--calibration',
                  tmp_path / 'one.json'])[0] == 0
    assert load_model(tmp_path / 'one.json').stand.scale_coefficients is None


def test_survey_flags_a_temperature_outside_the_stand_range(tmp_path):
    """Survey at 70 deg C with a 28..60 C stand: said on stderr (K, b held at 60 C)."""
    means, truth, temps = plateau_positions((28.0, 60.0))
    attitudes = np.degrees(np.column_stack([
        np.arctan2(np.hypot(truth[:, 0], truth[:, 1]), truth[:, 2]),
        np.arctan2(truth[:, 1], truth[:, 0])]))
    write_csv(tmp_path / 'stand.csv', {
        'inclination_deg': attitudes[:, 0], 'toolface_deg': attitudes[:, 1],
        'temperature_c': temps, 'ax': means[:, 0], 'ay': means[:, 1], 'az': means[:, 2]})
    assert quiet(['fit-stand', tmp_path / 'stand.csv', '--calibration',
                  tmp_path / 'cal.json'])[0] == 0
    write_csv(tmp_path / 'shots.csv', {'ax': [0.0, 0.0], 'ay': [0.0, 0.0], 'az': [G, G],
                                       'temperature_c': [44.0, 70.0]})
    code, _, err = quiet(['survey', tmp_path / 'shots.csv', '-o', tmp_path / 'out.csv',
                          '--calibration', tmp_path / 'cal.json'])
    assert code == 0, err
    assert '1 of 2 temperature readings lie outside the stand stage' in err
