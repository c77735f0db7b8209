"""
An MSA that refuses what it cannot solve and says how well it solved the rest (issue 9, bullet 5).

Stations come from the physical sensor model (``sim.sensor_model``): a tool with station-
averaged noise 1e-4 g and 5 nT per axis in the reference field F = 50000 nT, dip 60 deg, with
the drill string's interference (80, -80, 2000) nT (ISCWSA axes) fixed to the tool.

Closed forms behind the tolerances:
- a 1 sigma reference error (WMM 2025: 138 nT, 0.20 deg) moves eps_z by
  ``(J^T J)^-1 J^T dR/dref`` (core.msa docstring); its Monte Carlo scatter over 300 wells
  estimates the predicted 1 sigma to 1 / sqrt(2 * 300) = 4 % (1 sigma): within 20 %;
- the per-station azimuth 1 sigma is the same propagation through seed 001 Eq. 4 plus the
  station's noise: the errors of 300 wells divided by it have an RMS of at most 1 (it is
  conservative: the noise term counts what the fit's residual already holds), and at least
  0.5.
"""

import csv

from inclino_ros.core import magnetics
from inclino_ros.core.msa import (
    azimuth_difference_deg, improved_cross_axial, MsaLimits, MsaRefused, solve_msa_axial,
    solve_msa_classic, solve_msa_improved, WMM_REFERENCE_STD)
from inclino_ros.sim import sensor_model
import numpy as np
import pytest
from test_msa_cli import quiet, read_table

REFERENCE = (50000.0, 60.0)
EPS_ISCWSA_NT = np.array([80.0, -80.0, 2000.0])
STATIONS = 30
TOOL = sensor_model.Tool(accelerometer=sensor_model.Triad(noise_std=1e-4 * 9.80665),
                         magnetometer=sensor_model.Triad(noise_std=5.0))
GOLDEN_DEG = 137.5


def stations(inclination_deg, azimuth_deg, toolface_deg, seed=2):
    """Return (G, B) in ISCWSA axes and the true azimuth of station readings."""
    readings = sensor_model.read(TOOL, inclination_deg, toolface_deg, azimuth_deg,
                                 field=sensor_model.Field(*REFERENCE),
                                 interference_nT=magnetics.iscwsa_from_tool(EPS_ISCWSA_NT),
                                 rng=seed)
    return (magnetics.gravity_from_specific_force(readings.accel_mps2),
            magnetics.iscwsa_from_tool(readings.mag_nT), readings.azimuth_deg)


def east_west_well(seed=2, toolface_step_deg=GOLDEN_DEG):
    """Return a 30-station well from 30 to 90 deg inclination, azimuth 85 -> 95 deg."""
    return stations(np.linspace(30.0, 90.0, STATIONS), np.linspace(85.0, 95.0, STATIONS),
                    (np.arange(STATIONS) * toolface_step_deg) % 360.0, seed)


def test_geometry_is_judged_at_the_solution():
    """
    Thirty horizontal east-west stations: eps_z is not observable at the solution.

    At eps = 0 the 2000 nT in the readings make the geometry look posed; at the solution
    eps_z moves the stations by 0.02 nT per nT, below 0.05: refused (formerly accepted
    with an eps_z ~20 nT off and no word).
    """
    G, B, _ = stations(np.full(STATIONS, 90.0), np.linspace(88.0, 92.0, STATIONS),
                       (np.arange(STATIONS) * GOLDEN_DEG) % 360.0)
    with pytest.raises(MsaRefused, match='singular geometry at the solution'):
        solve_msa_classic(G, B, *REFERENCE)


def test_the_reference_field_uncertainty_is_reported():
    """
    The reference off by its 1 sigma (138 nT, 0.2 deg): up to 0.8 deg of azimuth, all QC passing.

    Nothing told before; now each station's 1 sigma (WMM included) covers its error.
    """
    G, B, truth = east_west_well()
    wrong = solve_msa_classic(G, B, REFERENCE[0] + 138.0, REFERENCE[1] + 0.2)
    error = np.abs(azimuth_difference_deg(wrong.azimuth_deg, truth))
    assert wrong.qc.ok.all() and error.max() > 0.5
    assert np.all(error <= 3.0 * wrong.azimuth_std_deg)
    exact = solve_msa_classic(G, B, *REFERENCE, reference_std=(0.0, 0.0))
    assert exact.azimuth_std_deg.max() < 0.1 < wrong.azimuth_std_deg.min()
    assert wrong.reference_std == WMM_REFERENCE_STD


def test_eps_sigma_matches_the_scatter_over_wells():
    """300 wells, reference errors drawn from the WMM 1 sigma: the predicted sigma holds."""
    rng = np.random.default_rng(5)
    limits = MsaLimits(qc=magnetics.QcLimits(1000.0, 1.0, 0.019))  # the reference is off
    eps_z, predicted, z_scores = [], [], []
    for k in range(300):
        G, B, truth = east_west_well(seed=100 + k)
        reference = (REFERENCE[0] + rng.normal(0.0, 138.0), REFERENCE[1] + rng.normal(0.0, 0.2))
        result = solve_msa_axial(G, B - (*EPS_ISCWSA_NT[:2], 0.0), *reference, limits=limits)
        eps_z.append(result.eps_nT[2])
        predicted.append(result.eps_std_nT[2])
        z_scores.append(azimuth_difference_deg(result.azimuth_deg, truth)
                        / result.azimuth_std_deg)
    assert np.std(eps_z) == pytest.approx(np.mean(predicted), rel=0.2)
    rms = np.sqrt(np.mean(np.square(z_scores), axis=0))
    assert np.all(rms <= 1.0) and np.all(rms >= 0.5)


def test_improved_without_a_cross_axial_source_refuses():
    """
    Improved needs eps_x, eps_y: from a rotation fit, the classic solve, or it refuses.

    One toolface and no rotation: refused (formerly taken as zero, 0.23 deg on this well).
    Toolfaces spread: from the classic solve, said so, and the azimuth right.
    """
    G, B, truth = east_west_well(toolface_step_deg=0.0)
    with pytest.raises(MsaRefused, match='improved needs the cross-axial interference'):
        improved_cross_axial(G, B, *REFERENCE)
    zero = solve_msa_improved(G, B, *REFERENCE)
    assert np.abs(azimuth_difference_deg(zero.azimuth_deg, truth)).max() > 0.15
    assert improved_cross_axial(G, B, *REFERENCE, rotation_fitted_at='t')[0] == (0.0, 0.0)
    G, B, truth = east_west_well()
    cross_axial, source, covariance = improved_cross_axial(G, B, *REFERENCE)
    assert source.startswith('from the classic solve')
    np.testing.assert_allclose(cross_axial, EPS_ISCWSA_NT[:2], atol=10.0)
    result = solve_msa_improved(G, B, *REFERENCE, cross_axial_nT=cross_axial,
                                cross_axial_covariance_nT2=covariance)
    assert np.abs(azimuth_difference_deg(result.azimuth_deg, truth)).max() < 0.1
    # The classic solve's uncertainty of eps_x, eps_y is carried along.
    np.testing.assert_allclose(result.eps_covariance_nT2[:2, :2], covariance)


def test_a_minimum_on_the_search_bracket_edge_is_refused():
    """
    The bracket is a search range (+-11 nT here around a 1 sigma of 237 nT), not a confidence.

    Narrowed to +-0.001 nT about eps_z0 (the mean station's closed form, a few tenths of a
    nT off the least squares of noisy stations): the minimum falls on its edge, refused.
    """
    G, B, _ = east_west_well()
    B = B - (*EPS_ISCWSA_NT[:2], 0.0)
    result = solve_msa_improved(G, B, *REFERENCE)
    low, high = result.search_bracket_nT
    assert high - low < 0.2 * result.eps_std_nT[2]
    narrow = MsaLimits(interval_margin=1e-6, min_interval_nT=1e-3)
    with pytest.raises(MsaRefused, match='on the edge of the search bracket'):
        solve_msa_improved(G, B, *REFERENCE, limits=narrow)


def test_msa_command_reports_sigma_and_a_vertical_station_has_no_angles(tmp_path):
    """The msa command: 1 sigma of eps and each azimuth; a vertical station: NaN, not 0, 180."""
    inclination_deg = np.r_[0.0, np.linspace(30.0, 90.0, STATIONS - 1)]
    G, B, truth = stations(inclination_deg, np.linspace(85.0, 95.0, STATIONS),
                           (np.arange(STATIONS) * GOLDEN_DEG) % 360.0)
    G[0] = (0.0, 0.0, 9.80665)                          # exactly vertical
    path = tmp_path / 'stations.csv'
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(['gx', 'gy', 'gz', 'bx', 'by', 'bz', 'true_azimuth_deg'])
        writer.writerows(np.column_stack([G, B, truth]).tolist())
    code, out, err = quiet(['msa', path, '-o', tmp_path / 'out.csv', '--reference-total-nT',
                            '50000', '--reference-dip-deg', '60', '--method', 'classic'])
    assert code == 0, err
    assert '+-' in out and 'the fit and the reference field, 138 nT and 0.2 deg' in out
    table = read_table(tmp_path / 'out.csv')
    assert np.isnan(table['azimuth_deg'][0]) and np.isnan(table['toolface_deg'][0])
    assert np.isnan(table['azimuth_std_deg'][0])
    assert np.isfinite(table['azimuth_deg'][1:]).all()
    assert np.all(np.abs(table['azimuth_error_deg'][1:]) <= 3.0 * table['azimuth_std_deg'][1:])


def delivered_errors(incl_range_deg, azimuth_deg, wells=40):
    """
    Return (raw, delivered, accepted) azimuth errors [deg] of ``wells`` WMM-grade MSAs.

    Each well: 30 stations at inclinations ``incl_range_deg``, azimuth +-2 deg about
    ``azimuth_deg``, eps_x, eps_y known (the axial solve); its reference off by a draw of the
    WMM 1 sigma.  Delivered: the corrected azimuth where MSA accepted, the raw one where it
    refused (what a user then has).
    """
    rng = np.random.default_rng(5)
    limits = MsaLimits(qc=magnetics.QcLimits(1000.0, 1.0, 0.019))  # the reference is off
    raw, delivered, accepted = [], [], 0
    for k in range(wells):
        G, B, truth = stations(np.linspace(*incl_range_deg, STATIONS),
                               azimuth_deg + np.linspace(-2.0, 2.0, STATIONS),
                               (np.arange(STATIONS) * GOLDEN_DEG) % 360.0, seed=300 + k)
        B = B - (*EPS_ISCWSA_NT[:2], 0.0)
        reference = (REFERENCE[0] + rng.normal(0.0, 138.0), REFERENCE[1] + rng.normal(0.0, 0.2))
        before = azimuth_difference_deg(magnetics.azimuth_deg(G, B), truth)
        raw.append(before)
        try:
            result = solve_msa_axial(G, B, *reference, limits=limits)
        except MsaRefused:
            delivered.append(before)
            continue
        accepted += 1
        delivered.append(azimuth_difference_deg(result.azimuth_deg, truth))
    rms = [float(np.sqrt(np.mean(np.square(v)))) for v in (raw, delivered)]
    return rms[0], rms[1], accepted


def test_msa_near_east_west_horizontal_is_decided_from_its_sigma():
    """
    Horizontal east-west wells, WMM-grade reference: MSA is refused, not worse than raw.

    Issue 19 item 9: at inclination 85-90 deg, azimuth 90, the reference's error moves eps_z
    by thousands of nT (azimuth 1 sigma 3-4 deg) while the axial sensitivity passes: main
    accepted 30 of 40 wells and delivered RMS 4.71 deg against 4.57 raw.  Decided from the
    interference's azimuth 1 sigma (``MsaLimits.max_azimuth_std_deg``): none accepted.  A
    well that turns to 30 deg inclination keeps every MSA (0.5 deg RMS against 3.8 raw).
    """
    raw, delivered, accepted = delivered_errors((85.0, 90.0), 90.0)
    assert accepted == 0 and delivered <= raw, (raw, delivered, accepted)
    raw, delivered, accepted = delivered_errors((30.0, 90.0), 90.0)
    assert accepted == 40 and delivered < 0.2 * raw, (raw, delivered, accepted)
