"""
A toolface near vertical is defined for every capture or none, not for its lucky ones (issue 19).

MEMS noise (2 mg per sample) at inclination 0.1 deg, 1000-sample captures of AR(1) noise:
the toolface's 1 sigma of a capture's mean is ~5 deg at rho 0.73 and ~9 deg at rho 0.9,
about the 5 deg limit.  Its 1 sigma is the capture's own noise estimated from a short
correlated window (a relative 1 sigma of ~0.1-0.3): deciding the NaN from that estimate
published only the captures whose noise it under-estimated (main: 30 % of them at rho
0.73 covering 0.65 / 0.90, 1 in 1000 at rho 0.9).  ``pipeline.toolface_defined`` decides
from the 1 sigma at the configured noise, independent of that estimate's error.  Truth:
the physical simulator (``sim.sensor_model``, each capture its own record).
"""

import coverage_sim
from inclino_ros.calibration.model import CalibrationModel
from inclino_ros.pipeline import capture_mean, Settings
import numpy as np
import pytest


@pytest.mark.parametrize('rho', [0.73, 0.9])
def test_near_vertical_toolface_published_for_every_capture_covers(rho):
    """
    1000 captures through ``capture_mean``: every toolface defined, coverage 0.60-0.76 / 0.93-0.98.

    Binomial 1 sigma of a coverage over 1000 draws: 0.015 at 1 sigma, 0.0066 at 2 sigma:
    the band's edges are 5.5 / 3.6 of them from 0.683 / 0.954.  Main failed both: only
    some defined (the bench: ~300 of 1000 at rho 0.73 covering 0.65 / 0.90, 0-1 at 0.9).
    """
    draws, samples, inclination_deg = 1000, 1000, 0.1
    accel, toolface_deg, times_s = coverage_sim.correlated_captures(
        rho, inclination_deg, draws, samples, 31)
    settings = Settings(noise_std_mps2=coverage_sim.MEMS_NOISE_MPS2)
    model = CalibrationModel(3)
    surveys = [capture_mean(accel[k], times_s, model, settings) for k in range(draws)]
    value = np.array([s.toolface_deg[0] for s in surveys])
    sigma = np.array([s.toolface_std_deg[0] for s in surveys])
    defined = np.isfinite(value)
    assert defined.all(), f'{np.count_nonzero(defined)} of {draws} defined'
    error = (value - toolface_deg + 180.0) % 360.0 - 180.0
    ratio = np.abs(error) / sigma
    one, two = np.mean(ratio <= 1.0), np.mean(ratio <= 2.0)
    assert 0.60 <= one <= 0.76 and 0.93 <= two <= 0.98, (one, two)
    assert np.median(sigma) > 0.9 * settings.toolface_max_std_deg   # the case: about the limit
