"""
A stand that visits its attitudes again (issue 18): repeats weighed and reported, not refused.

The physical simulator's factory sequence (``sim.bench.simulate_stand`` with ``visits``):
the nine positions visited three times, each visit set within 0.01 deg (1 sigma per angle,
what the encoders read: e.g. position 1 and 10 are 0.012 deg apart), the stand turned 180
deg in azimuth at every visit, and the tool seated anew each time, its gravity tilted by
SEATING_DEG per component (1 sigma) that no encoder sees.  The MEMS tool with 2e-4 g of noise
per sample; 100 samples a position.

Tolerances: a visit's error is the seating tilt plus the noise of its mean (2e-5 rad =
0.00115 deg per component): the repeatability (sample standard deviation of the visits'
error vectors, both components) is expected at sqrt(2 (SEATING^2 + 0.00115^2)) = 0.0142 deg;
pooled over 9 attitudes x 2 degrees of freedom x 2 components (36) its relative standard
error is 1/sqrt(72) = 12 %, so +-40 % is > 3 sigma.  K and b: the seating tilts act as noise
of 1.7e-4 rad on each visit mean; 27 visits give a K element to ~6e-5 at 1 sigma, so the limit
3e-4 is 5 sigma.
"""

import contextlib
import csv
import io
import math

from inclino_ros.cli.main import main as inclino
from inclino_ros.core.stand import fit_stand, stand_specific_force
from inclino_ros.sim.bench import make_tool, simulate_stand, StandRun, tool_stand_truth
import numpy as np
import pytest

G = 9.80665
NOISE_MPS2 = 2e-4 * G
SAMPLES = 100
SEATING_DEG = 0.01
TOOL = make_tool('mems', 0.8, -1.2, noise_mps2=NOISE_MPS2)
TOOL_K, TOOL_BIAS_MPS2 = tool_stand_truth(TOOL)
MEAN_NOISE_DEG = math.degrees(NOISE_MPS2 / G / math.sqrt(SAMPLES))
EXPECTED_REPEATABILITY_DEG = math.sqrt(2.0 * (SEATING_DEG ** 2 + MEAN_NOISE_DEG ** 2))


def factory_run(seed=0):
    """Return the simulated three-visit factory sequence (module docstring)."""
    return simulate_stand(StandRun(TOOL, seed=seed), samples=SAMPLES, visits=3,
                          azimuth_step_deg=180.0, setting_error_deg=0.01,
                          seating_error_deg=SEATING_DEG)


def visit_means(run):
    """Return (read attitudes (P, 2), mean readings (P, 3)) of each visit."""
    first = np.flatnonzero(np.diff(run.segment, prepend=-1))
    means = np.array([run.raw_mps2[run.segment == s].mean(axis=0)
                      for s in run.segment[first]])
    return np.column_stack([run.inclination_deg[first], run.toolface_deg[first]]), means


def test_the_simulator_repeats_its_attitudes():
    """27 positions; visits of one attitude read 0.0x deg apart, at azimuth 0, 180, 0."""
    run = factory_run()
    attitudes, _ = visit_means(run)
    assert attitudes.shape == (27, 2)
    visits = attitudes.reshape(3, 9, 2)
    apart = np.abs(visits[1:] - visits[0])
    assert 0.0 < apart.max() < 0.06
    repeats = run.truth['repeats']
    assert [r['visit'] for r in repeats[::9]] == [0, 1, 2]
    assert repeats[9]['nominal_deg'] == repeats[0]['nominal_deg']
    assert {s['azimuth_deg'] for s in run.truth['segments'][9:18]} == {180.0}


@pytest.mark.parametrize('seed', range(3))
def test_repeats_are_fitted_and_their_repeatability_reported(seed):
    """fit_stand takes the 27 visits of 9 attitudes (old code refused: 'one attitude')."""
    attitudes, means = visit_means(factory_run(seed))
    truth = stand_specific_force(attitudes[:, 0], attitudes[:, 1], G)
    fit = fit_stand(means, truth)
    assert fit.attitudes == 9
    assert fit.attitude.tolist() == list(range(9)) * 3
    assert np.all(np.isfinite(fit.repeatability_deg))
    print(f'seed {seed}: repeatability {fit.rms_repeatability_deg:.4f} deg (expected '
          f'{EXPECTED_REPEATABILITY_DEG:.4f}), per attitude '
          f'{np.round(fit.repeatability_deg, 4).tolist()}')
    assert fit.rms_repeatability_deg == pytest.approx(EXPECTED_REPEATABILITY_DEG, rel=0.4)
    assert np.abs(fit.scale_matrix - TOOL_K).max() < 3e-4
    assert np.abs(fit.bias_mps2 - TOOL_BIAS_MPS2).max() < 3e-4 * G


def test_repeatability_closed_form():
    """Two visits with errors +-d about the truth: repeatability sqrt(2) d; one visit: NaN."""
    truth = stand_specific_force(np.array([10.0, 10.0, 50.0]), np.zeros(3), 1.0)
    d = math.radians(0.01)
    tilted = truth + np.array([[0.0, d, 0.0], [0.0, -d, 0.0], [0.0, 0.0, 0.0]])
    from inclino_ros.core.stand import repeatability
    per, overall = repeatability(tilted, truth, np.array([0, 0, 1]))
    assert per[0] == pytest.approx(math.sqrt(2.0) * 0.01, rel=1e-6)
    assert math.isnan(per[1]) and overall == pytest.approx(per[0], rel=1e-12)
    assert math.isnan(repeatability(truth, truth, np.arange(3))[1])


def test_fit_stand_command_takes_a_factory_sequence(tmp_path):
    """The command fit-stand on every sample of the sequence: accepted, repeatability said."""
    run = factory_run()
    path = tmp_path / 'stand.csv'
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(['time_s', 'inclination_deg', 'toolface_deg', 'azimuth_deg',
                         'ax', 'ay', 'az'])
        writer.writerows(zip(((run.stamps_ns - run.stamps_ns[0]) * 1e-9).tolist(),
                             run.inclination_deg.tolist(), run.toolface_deg.tolist(),
                             run.azimuth_deg.tolist(), *run.raw_mps2.T.tolist()))
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        code = inclino(['fit-stand', str(path), '--calibration', str(tmp_path / 'cal.json')])
    text = out.getvalue()
    assert code == 0, text
    assert '9 distinct attitudes, 9 repeated: repeatability' in text
    reported = float(text.split('repeatability ')[1].split(' deg')[0])
    assert reported == pytest.approx(EXPECTED_REPEATABILITY_DEG, rel=0.4)
    report = (tmp_path / 'fit_stand.txt').read_text()
    assert ' 10   1 ' in report  # position 10 is attitude 1 again
