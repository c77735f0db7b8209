"""
The reference-free shot fit is as efficient as maximum likelihood (issue 19 item 10).

One-reading MEMS shots (2 mg, 100 nT per reading) of the tool of ``shots_sim``
(every sensor and mount error of the physical simulator): 24 shots, 8 spread and two
roll groups of 8.  Each draw fits them with ``core.shots.fit_shots`` and with the
maximum-likelihood reference ``ml_shots`` (errors in variables, written apart:
every shot's attitude a parameter, the readings' own residuals over their known
noise), then reads both calibrations' azimuth and inclination errors at noise-free
random attitudes.  Efficiency: the ratio of the mean squared errors over the draws.

Measured, 40 draws (seed 11): before (independent residual families |g|, |B|, dip,
axial, each with its own weight) azimuth 1.35, inclination 1.29 times the ML
variance, worst draw RMS 0.74 deg vs 0.56 deg, worst error 3.16 deg vs 2.22 deg;
after (each shot's residuals whitened by their covariance from the readings' noise):
1.075 and 1.03, worst draw 0.54 vs 0.56 deg, worst error 2.40 vs 2.22 deg.  Over the
DRAWS = 24 here (seed 7) the ratio's own spread is ~0.1 (finite draws): the new fit
gives 1.04 / 0.91, the old one 1.16 / 0.97 and failed the limit 1.1 on the azimuth.
"""

from dataclasses import replace

from inclino_ros.core.shots import fit_shots
from inclino_ros.sim import sensor_model as sm
import ml_shots
import numpy as np
import shots_sim

DRAWS = 24
EVALUATIONS = 300
LIMIT = 1.1


def test_shot_fit_is_as_efficient_as_maximum_likelihood():
    rng = np.random.default_rng(7)
    tool = shots_sim.tool(sm.MEMS)
    clean = replace(tool, accelerometer=replace(tool.accelerometer, noise_std=0.0),
                    magnetometer=replace(tool.magnetometer, noise_std=0.0))
    ours, ml = [], []
    for _ in range(DRAWS):
        incl, toolface, azim, group = shots_sim.shot_attitudes(rng)
        accel, field = shots_sim.read(tool, incl, toolface, azim, rng)
        fitted = ml_shots.Calibration.of_shot_fit(
            fit_shots(accel, field, group, reference_total_nT=shots_sim.FIELD.total_nT))
        reference = ml_shots.fit(accel, field, group, fitted, sm.STANDARD_GRAVITY_MPS2,
                                 shots_sim.FIELD.total_nT, sm.MEMS.accelerometer.noise_std,
                                 sm.MEMS.magnetometer.noise_std)
        attitudes = shots_sim.random_attitudes(rng, EVALUATIONS)
        readings = shots_sim.read(clean, *attitudes, rng)
        ours.append(ml_shots.angle_errors(fitted, *readings, attitudes[0], attitudes[2]))
        ml.append(ml_shots.angle_errors(reference, *readings, attitudes[0], attitudes[2]))
    ours, ml = np.square(ours), np.square(ml)   # (draws, angle, attitude)
    ratio = ours.mean(axis=(0, 2)) / ml.mean(axis=(0, 2))
    assert np.all(ratio <= LIMIT), ratio
