"""
Still detection (issue 9, bullet 1): motion told from noise, in the core and the captures.

The truth comes from the physical sensor model (``sim.sensor_model``): a still tool whose
accelerometer has white noise sigma per axis and sample, or the same tool turning.

Closed forms used as tolerances:
- a still capture's per-sample tilt noise is sigma / g rad per component; estimated from
  k (N - B) = 2 * 490 degrees of freedom its relative sampling error is 1 / sqrt(2 * 980)
  = 2.3 % (1 sigma), so 10 % is > 4 sigma;
- the drift of N samples at rate r over T = (N - 1) / r has standard error
  (sigma / g) sqrt(12 / (N (N^2 - 1))) r: at 0.02 m/s^2, 500 samples, 100 Hz, 0.0036 deg/s;
  a turn of 0.05 deg/s is then 14 sigma from zero and 8 sigma above the 0.02 deg/s limit,
  and a still tool passes the 5 sigma test except with probability exp(-25 / 2) = 4e-6.
"""

import math

from inclino_ros.calibration.level_capture import CaptureRefused, LevelLimits, solve_level_capture
from inclino_ros.calibration.stand_capture import average_position
from inclino_ros.core.attitude import angle_between
from inclino_ros.core.stillness import (
    assess, FALSE_MOTION_P, judge, motion, StillLimits, tangent_angles, without_once_per_turn)
from inclino_ros.sim import sensor_model
import numpy as np
import pytest

G = sensor_model.STANDARD_GRAVITY_MPS2
RATE_HZ = 100.0
#: The issue's real MEMS IMU lying still: 0.014 m/s^2 per sample; the default must accept
#: 0.02 m/s^2 and the seed 001 ADXL345 reads ~4 mg per sample at 100 Hz.
MEMS_NOISE_MPS2 = 0.014
DEFAULT_NOISE_MPS2 = 0.02
ADXL345_NOISE_MPS2 = 4e-3 * G
SAMPLES = 500      # the captures' default (node parameters *.samples)
MOUNT = sensor_model.Mount(gamma_deg=0.8, beta_deg=-1.2, roll_deg=20.0)


def tool(noise_mps2):
    """Return a tool on MOUNT whose accelerometer has white noise ``noise_mps2``."""
    return sensor_model.Tool(mount=MOUNT, accelerometer=sensor_model.Triad(noise_std=noise_mps2))


def capture(noise_mps2, inclination_deg, toolface_deg, samples=SAMPLES, seed=0,
            turn_deg_per_s=0.0):
    """Return (readings, times_s) of a capture at 100 Hz, the inclination turning if asked."""
    times_s = np.arange(samples) / RATE_HZ
    readings = sensor_model.read(tool(noise_mps2), inclination_deg + turn_deg_per_s * times_s,
                                 toolface_deg, rng=seed).accel_mps2
    return readings, times_s


def test_still_mems_is_not_moving_and_its_noise_is_measured():
    """Per-sample spread 0.12 deg is noise: measured as sigma / g, the mean's as that / sqrt N."""
    readings, times_s = capture(MEMS_NOISE_MPS2, 35.0, 120.0)
    result = assess(tangent_angles(readings), times_s)
    per_sample_deg = math.degrees(MEMS_NOISE_MPS2 / G)                 # 0.082 deg
    assert result.noise_deg == pytest.approx(per_sample_deg, rel=0.1)
    assert result.sem_deg == pytest.approx(result.noise_deg / math.sqrt(SAMPLES), rel=1e-12)
    assert result.drift_p > FALSE_MOTION_P and result.scatter_p > FALSE_MOTION_P
    assert judge(result, StillLimits()) is None
    # What the old rule measured: the RMS spread about the mean direction, 0.116 deg here,
    # above the former max_std_deg of 0.1 deg: "tool is moving".
    spread_deg = math.degrees(math.sqrt(np.mean(np.sum(tangent_angles(readings) ** 2, 1))))
    assert spread_deg > 0.1


@pytest.mark.parametrize('seed', range(40))
def test_defaults_accept_still_and_refuse_turning(seed):
    """At 0.02 m/s^2 and 100 Hz: still passes, 0.05 deg/s is 'moving (drift ... deg/s)'."""
    limits = StillLimits()
    still, times_s = capture(DEFAULT_NOISE_MPS2, 60.0, 300.0, seed=seed)
    assert judge(assess(tangent_angles(still), times_s), limits) is None
    turning, _ = capture(DEFAULT_NOISE_MPS2, 60.0, 300.0, seed=seed, turn_deg_per_s=0.05)
    result = assess(tangent_angles(turning), times_s)
    assert result.drift_deg_per_s == pytest.approx(0.05, abs=5 * 0.0036)
    assert judge(result, limits).startswith('tool is moving (drift 0.0')


def test_drift_standard_error_is_the_closed_form():
    """Over 400 still captures the drift / its standard error is Rayleigh: mean sqrt(pi / 2)."""
    sigmas = [assess(tangent_angles(capture(DEFAULT_NOISE_MPS2, 20.0, 10.0, seed=s)[0]),
                     np.arange(SAMPLES) / RATE_HZ).drift_sigma for s in range(400)]
    # Rayleigh(1): mean 1.2533, sd 0.655; the mean of 400 within 4 sd / 20 = 0.13.
    assert np.mean(sigmas) == pytest.approx(math.sqrt(math.pi / 2.0), abs=0.13)


def test_a_knock_is_not_steady():
    """A step of 0.2 deg in the middle of a still capture: block means off their trend."""
    readings, times_s = capture(DEFAULT_NOISE_MPS2, 40.0, 40.0)
    stepped, _ = capture(DEFAULT_NOISE_MPS2, 40.2, 40.0, seed=1)
    readings[SAMPLES // 2:] = stepped[SAMPLES // 2:]
    reason = judge(assess(tangent_angles(readings), times_s), StillLimits())
    assert reason.startswith('tool is moving (')


def test_too_noisy_says_how_many_samples():
    """An ADXL345 (4 mg) at 100 samples: the mean misses 0.01 deg; N (SE / 0.01)^2 needed."""
    readings, times_s = capture(ADXL345_NOISE_MPS2, 0.0, 0.0, samples=100)
    result = assess(tangent_angles(readings), times_s)
    reason = judge(result, StillLimits())
    needed = result.samples_needed(0.01)
    assert needed == pytest.approx(100 * (math.degrees(ADXL345_NOISE_MPS2 / G) / 10 / 0.01) ** 2,
                                   rel=0.3)
    assert reason.startswith(f'too noisy for the target: {needed} samples needed')
    more, times_s = capture(ADXL345_NOISE_MPS2, 0.0, 0.0, samples=int(needed * 1.3))
    assert judge(assess(tangent_angles(more), times_s), StillLimits()) is None


def test_level_capture_accepts_a_still_mems_and_refuses_a_turning_one():
    """The level bench, seed 000: a still MEMS gives gamma, beta; a tilting one is refused."""
    limits = LevelLimits(max_tilt_deg=5.0, gravity_mps2=G, g_total_tolerance_mps2=0.3)
    readings, times_s = capture(MEMS_NOISE_MPS2, 0.0, 0.0)
    installation = solve_level_capture(readings, 3, limits, times_s)
    bound_deg = 5 * math.degrees(MEMS_NOISE_MPS2 / G) / math.sqrt(SAMPLES)
    assert installation.gamma_deg == pytest.approx(0.8, abs=bound_deg)
    assert installation.beta_deg == pytest.approx(-1.2, abs=bound_deg)
    turning, _ = capture(MEMS_NOISE_MPS2, 0.0, 0.0, turn_deg_per_s=0.05)
    turning = sensor_model.read(tool(MEMS_NOISE_MPS2), 1.0 + 0.05 * times_s, 0.0,
                                rng=2).accel_mps2
    with pytest.raises(CaptureRefused, match=r'^tool is moving \(drift 0\.0'):
        solve_level_capture(turning, 3, limits, times_s)


def test_stand_position_accepts_still_and_refuses_turning_toolface():
    """A stand position turning in toolface at 0.05 deg/s is refused; still is averaged."""
    limits = StillLimits()
    readings, times_s = capture(DEFAULT_NOISE_MPS2, 90.0, 0.0)
    position = average_position(readings, 90.0, 0.0, limits, times_s, 25.0)
    # The stated 1 sigma: the noise's, and the motion the capture cannot exclude (slow turns).
    still = assess(tangent_angles(readings), times_s)
    assert still.noise_deg == pytest.approx(math.degrees(DEFAULT_NOISE_MPS2 / G), rel=0.1)
    assert position.std_deg == pytest.approx(still.stated_sem_deg * math.sqrt(SAMPLES))
    assert still.sem_deg <= still.stated_sem_deg <= math.hypot(still.sem_deg, still.turn_deg)
    assert position.temperature_c == 25.0
    turning = sensor_model.read(tool(DEFAULT_NOISE_MPS2), 90.0, 0.05 * times_s,
                                rng=3).accel_mps2
    with pytest.raises(CaptureRefused, match=r'^tool is moving \(drift 0\.0'):
        average_position(turning, 90.0, 0.0, limits, times_s)


def test_without_times_the_drift_is_over_the_capture():
    """No stamps: drift is judged by how far it moves the mean, said per capture."""
    readings, _ = capture(0.0, 30.0, 0.0, samples=100, turn_deg_per_s=1.0)
    reason = judge(assess(tangent_angles(readings)), StillLimits())
    assert reason.startswith('tool is moving (drift ') and 'over the capture' in reason


def test_rotation_wobble_is_not_motion():
    """
    A tool turned 1.2 times about its axis with 1.4 deg of mounting error.

    Its inclination wobbles once per turn, which a line through 1.2 turns takes for a drift
    of 0.24 deg/s; with the wobble removed (``without_once_per_turn``) the axis is still.
    The same rotation with the axis tilting at 0.1 deg/s is refused.
    """
    turns = np.linspace(0.0, 1.2 * 360.0, 600)
    times_s = np.arange(600) / RATE_HZ
    limits = StillLimits()

    def axis(readings):
        inclination = np.arctan2(np.hypot(readings[:, 0], readings[:, 1]), readings[:, 2])
        return inclination, np.arctan2(readings[:, 1], readings[:, 0])

    inclination, toolface = axis(sensor_model.read(tool(0.005), 60.0, turns, rng=4).accel_mps2)
    assert motion(assess(inclination, times_s), limits, steady=False).startswith(
        'tool is moving (drift 0.2')
    still = assess(without_once_per_turn(inclination, toolface), times_s)
    assert motion(still, limits, steady=False) is None
    inclination, toolface = axis(sensor_model.read(
        tool(0.005), 60.0 + 0.1 * times_s, turns, rng=5).accel_mps2)
    drifting = assess(without_once_per_turn(inclination, toolface), times_s)
    # Over 1.2 turns the wobble fit takes part of a drift (0.079 of the 0.1 deg/s here).
    assert motion(drifting, limits, steady=False).startswith('tool is moving (drift 0.0')


def still_survey_captures(count, seed):
    """Return ``count`` still captures of 16 samples (test_node_quality's survey stations)."""
    station_tool = sensor_model.Tool(accelerometer=sensor_model.Triad(noise_std=4e-4 * G))
    rng = np.random.default_rng(seed)
    times_s = np.arange(16) / RATE_HZ
    for _ in range(count):
        yield sensor_model.read(station_tool, np.full(16, 40.0), 85.0, rng=rng).accel_mps2, times_s


def test_short_still_captures_are_not_refused():
    """
    3000 still captures of 16 samples: none refused (expected 3000 * 2e-6 = 0.006).

    The former rule took the noise the capture estimates (16 degrees of freedom) for the
    true one and refused 3.5e-3 of them (bench/results/stillness.md): ~10 here.
    """
    refused = [reason for readings, times_s in still_survey_captures(3000, seed=7)
               if (reason := judge(assess(tangent_angles(readings), times_s), StillLimits()))]
    assert refused == []


def test_tail_probabilities_follow_the_f_law():
    """
    Over 3000 still 16-sample captures each gate's p < 0.01 in 1 % of them.

    Binomial: 30 expected, 1 sigma 5.4; within 5 sigma (3..57).  The former chi-square
    rule's steadiness tail below its 1e-2 point was ~5 times too frequent (bench).
    """
    results = [assess(tangent_angles(readings), times_s)
               for readings, times_s in still_survey_captures(3000, seed=8)]
    for p_values in ([r.drift_p for r in results], [r.scatter_p for r in results]):
        assert 3 <= np.count_nonzero(np.array(p_values) < 0.01) <= 57


def back_to_back(turn_accel=True):
    """Return (times_s, accel, field) of 6 s at 100 Hz turned at 3 s (a window boundary)."""
    rng = np.random.default_rng(21)
    turned = np.arange(600) >= 300
    accel = np.where(turned[:, None] & turn_accel, [0.0, 9.80665, 0.0], [0.0, 0.0, 9.80665])
    field = np.where(turned[:, None], [20000.0, 0.0, 40000.0], [20000.0, 40000.0, 0.0])
    accel = accel + rng.normal(0.0, 0.01, accel.shape)
    field = field + rng.normal(0.0, 10.0, field.shape)
    return np.arange(600) * 0.01, accel, field


def test_two_attitudes_back_to_back_are_two_segments():
    """
    A stream turned between two still windows gives two segments, not one mean of both.

    The one still rule of logs and bags (``find_still_segments``): each run's first and
    last 0.5 s window left out, so 50..250 and 350..550.  The former log rule refused the
    joined run as a whole (no segment at all).
    """
    from inclino_ros.core.stillness import find_still_segments
    times_s, accel, field = back_to_back()
    assert find_still_segments(times_s, accel) == [(50, 250), (350, 550)]
    assert find_still_segments(times_s, accel, fields=field) == [(50, 250), (350, 550)]


def test_a_turn_only_the_magnetometer_sees_splits_the_shots():
    """A turn about gravity moves only the field: with the field judged too, two shots."""
    from inclino_ros.core.stillness import find_still_segments
    times_s, accel, field = back_to_back(turn_accel=False)
    assert find_still_segments(times_s, accel) == [(50, 550)]
    assert find_still_segments(times_s, accel, fields=field) == [(50, 250), (350, 550)]


def correlated_captures(rho, count, samples, seed):
    """
    Yield (readings, times_s, truth) of still captures whose noise is an AR(1) of ``rho``.

    The physical simulator's AR(1) noise (``sensor_model.Triad.noise_rho``, stationary
    sigma = the issue's MEMS 0.02 m/s^2 per sample) on a tool at inclination 40 deg,
    toolface 85 deg, 100 Hz.
    """
    correlated = sensor_model.Tool(accelerometer=sensor_model.Triad(
        noise_std=DEFAULT_NOISE_MPS2, noise_rho=rho))
    rng = np.random.default_rng(seed)
    times_s = np.arange(samples) / RATE_HZ
    for _ in range(count):
        readings = sensor_model.read(correlated, np.full(samples, 40.0), 85.0, rng=rng)
        yield readings.accel_mps2, times_s, readings.specific_force_tool_mps2[0]


@pytest.mark.parametrize('rho', [0.5, 0.73, 0.9])
def test_correlated_still_captures_are_not_refused(rho):
    """
    Still captures of AR(1) noise (a low-pass filter below the output rate) are not moving.

    300 captures of 500 samples each rho.  The white-noise rule took the within-block
    noise for a block mean's and refused 25 / 89 / 100 % of them here (issue 19 item 4:
    21 / 90 / 100 %); the noise is now measured with its correlation
    (``core.correlated_noise``).
    """
    moving = [reason for readings, times_s, _ in correlated_captures(rho, 300, SAMPLES, 20)
              if (reason := motion(assess(tangent_angles(readings), times_s), StillLimits()))]
    assert moving == []


def direction_errors(mean, truth):
    """Return the two tangent angles [deg] of ``mean`` about the direction ``truth``."""
    u = truth / np.linalg.norm(truth)
    e1 = np.cross(u, (1.0, 0.0, 0.0))
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    return np.degrees(np.arctan2([mean @ e1, mean @ e2], mean @ u))


@pytest.mark.parametrize('rho', [0.0, 0.5, 0.73, 0.9])
def test_standard_error_of_a_correlated_mean_covers_its_error(rho):
    """
    The capture's standard error of the mean covers the error of the mean direction.

    400 captures of 2000 samples (20 s at 100 Hz: n_eff = 105 at rho 0.9), two tangent
    components each: 800 errors, binomial 1 sigma of a coverage 0.016 at 1 sigma and 0.0074
    at 2 sigma; the bands 0.60-0.76 and 0.93-0.98 (issue 19).  Measured: 0.70-0.71 / 0.96
    at every rho; the white-noise standard error covered 0.45 / 0.76, 0.33 / 0.57 and
    0.17 / 0.36 at rho 0.5, 0.73, 0.9.
    """
    ratios = []
    for readings, times_s, truth in correlated_captures(rho, 400, 2000, 21):
        stillness = assess(tangent_angles(readings), times_s)
        ratios += list(np.abs(direction_errors(readings.mean(axis=0), truth))
                       / stillness.sem_deg)
    ratios = np.array(ratios)
    one, two = np.mean(ratios <= 1.0), np.mean(ratios <= 2.0)
    assert 0.60 <= one <= 0.76 and 0.93 <= two <= 0.98, (one, two)


def test_level_capture_sigma_of_correlated_noise_covers_gamma_beta():
    """
    The level stage's tilt 1 sigma (std_deg / sqrt(N)) covers gamma and beta at rho 0.73.

    200 level captures (MOUNT: gamma 0.8, beta -1.2 deg) of 2000 samples of AR(1) noise
    0.014 m/s^2, max_sem loose: 400 errors, binomial 1 sigma of a coverage 0.023 / 0.010;
    bands 0.60-0.76 and 0.93-0.98; measured 0.68 / 0.96.  The white per-sample noise (the
    former std_deg) covered 0.30 at 1 sigma here (with the new still test; the old one
    refused these captures).
    """
    limits = LevelLimits(max_tilt_deg=5.0, gravity_mps2=G, g_total_tolerance_mps2=0.3,
                         still=StillLimits(max_sem_deg=1.0))
    correlated = sensor_model.Tool(mount=MOUNT, accelerometer=sensor_model.Triad(
        noise_std=MEMS_NOISE_MPS2, noise_rho=0.73))
    rng = np.random.default_rng(22)
    times_s = np.arange(2000) / RATE_HZ
    ratios = []
    for _ in range(200):
        readings = sensor_model.read(correlated, np.zeros(2000), 0.0, rng=rng).accel_mps2
        installation = solve_level_capture(readings, 3, limits, times_s)
        sigma_deg = math.degrees(installation.tilt_std_rad)
        ratios += [abs(installation.gamma_deg - 0.8) / sigma_deg,
                   abs(installation.beta_deg + 1.2) / sigma_deg]
    ratios = np.array(ratios)
    one, two = np.mean(ratios <= 1.0), np.mean(ratios <= 2.0)
    assert 0.60 <= one <= 0.76 and 0.93 <= two <= 0.98, (one, two)


@pytest.mark.parametrize('timed', [True, False])
def test_slow_turns_that_move_the_mean_beyond_its_precision_are_refused(timed):
    """
    One rule (issue 19 item 5): the mean must lie within max_sem_deg of every part's attitude.

    500 samples at 100 Hz of 0.005 m/s^2 noise (0.029 deg per sample: the drift's standard
    error 0.0009 deg/s, so 0.015 deg/s is 17 sigma, always significant): a 0.015 deg/s turn
    puts the ends 0.0375 deg from the mean, a 0.1 deg step at 4 s the last fifth 0.08 deg
    from it, both beyond the 0.01 deg target: refused, with or without times (the former
    rule took any drift below 0.02 deg/s, and without times compared another figure).  A
    settling of 0.003 deg/s (ends 0.0075 deg from the mean) is accepted, 17 sigma at 0.001
    m/s^2 noise (ends known to 0.0005 deg), as is a still tool.
    """
    times_s = np.arange(SAMPLES) / RATE_HZ
    limits = StillLimits()

    def verdict(inclination_deg, seed, noise_mps2=0.005):
        readings = sensor_model.read(tool(noise_mps2), inclination_deg, 30.0,
                                     rng=seed).accel_mps2
        return motion(assess(tangent_angles(readings), times_s if timed else None), limits)

    for seed in range(20):
        assert verdict(40.0 + 0.015 * times_s, seed).startswith('tool is moving (drift')
        assert verdict(40.0 + 0.1 * (times_s >= 4.0), 100 + seed).startswith('tool is moving')
        assert verdict(40.0 + 0.003 * times_s, 200 + seed, 0.001) is None
        assert verdict(np.full(SAMPLES, 40.0), 300 + seed) is None


def test_slow_turn_is_refused_or_in_the_stated_sigma():
    """
    A stand position turning 0.015 deg/s for 5 s (MEMS): refused, or its 2 sigma covers both ends.

    Issue 19 item 5: the turn moves the ends 0.0375 deg from the mean, 7x the
    mean's standard error (0.0052 deg) and below what the capture can tell
    from its noise at FALSE_MOTION_P.  The truth is the simulator's noiseless
    reading at the first and last sample.  Before the rule every capture was
    accepted with std_deg the noise's (17 of 20 beyond 2 sigma, failed first);
    bench/results/stillness.md: 0.93 of the accepted within 2 sigma, so at
    most 3 of 20 beyond it (binomial, expected 1.4; 1 measured).
    """
    rate = 0.015
    uncovered = 0
    for seed in range(20):
        readings, times_s = capture(DEFAULT_NOISE_MPS2, 30.0, 45.0, seed=seed,
                                    turn_deg_per_s=rate)
        try:
            position = average_position(readings, 30.0, 45.0, StillLimits(), times_s)
        except CaptureRefused as err:
            assert str(err).startswith('tool is moving')
            continue
        ends = sensor_model.read(tool(0.0), 30.0 + rate * times_s[[0, -1]], 45.0).accel_mps2
        error_deg = np.degrees(angle_between(ends, np.array(position.reading_mps2))).max()
        uncovered += error_deg > 2.0 * position.std_deg / math.sqrt(position.samples)
    assert uncovered <= 3, uncovered


def test_still_correlated_capture_is_accepted_with_its_sigma():
    """
    Still AR(1) captures (rho 0.5, 0.9: a low-pass filter) are accepted, their 2 sigma honest.

    Quartz-grade noise (1e-4 g) so that precision passes: none of 40 is
    refused (the drift test takes the correlation; the motion in the stated
    sigma is the fitted drift's excess over its noise, so no refusal), and
    the mean's direction lies within 2 stated sigma (of one component) of the
    simulator's noiseless reading in at least 30 of 40: an honest sigma
    covers 1 - exp(-2) = 0.865 of two-component errors, 34.6 +- 2.2 expected
    (37 measured).  Main accepted these too (item 4): this guards that the
    motion in the stated sigma refuses no still capture.
    """
    covered = 0
    for rho in (0.5, 0.9):
        source = sensor_model.Tool(mount=MOUNT, accelerometer=sensor_model.Triad(
            noise_std=1e-4 * G, noise_rho=rho))
        truth = sensor_model.read(tool(0.0), 20.0, 30.0).accel_mps2
        times_s = np.arange(SAMPLES) / RATE_HZ
        for seed in range(20):
            readings = sensor_model.read(source, np.full(SAMPLES, 20.0), 30.0,
                                         rng=seed).accel_mps2
            position = average_position(readings, 20.0, 30.0, StillLimits(), times_s)
            error_deg = np.degrees(angle_between(truth, np.array(position.reading_mps2)))
            covered += error_deg.max() <= 2.0 * position.std_deg / math.sqrt(SAMPLES)
    assert covered >= 30, covered


def test_slow_turn_rule_is_one_for_timed_and_untimed_captures():
    """
    Evenly sampled, a capture with times and one without state the same turn and sigma.

    The motion at the ends is the slope times the half-span, in seconds or in
    samples: the same number (``turn_deg``, its standard error, the stated
    sigma), and the same verdict on a turn the capture cannot tell (MEMS,
    0.015 deg/s over 5 s: accepted) and on one it can (quartz-grade noise:
    refused, its ends beyond max_motion_deg).
    """
    for noise_mps2, verdict in ((DEFAULT_NOISE_MPS2, None), (1e-4 * G, 'tool is moving')):
        readings, times_s = capture(noise_mps2, 30.0, 45.0, seed=4, turn_deg_per_s=0.015)
        angles = tangent_angles(readings)
        timed, untimed = assess(angles, times_s), assess(angles, None)
        assert untimed.turn_deg == pytest.approx(timed.turn_deg, rel=1e-9)
        assert untimed.turn_sigma_deg == pytest.approx(timed.turn_sigma_deg, rel=1e-9)
        assert untimed.stated_sem_deg == pytest.approx(timed.stated_sem_deg, rel=1e-9)
        # The fitted turn estimates the true one, 0.015 deg/s * 2.495 s, within 4 sigma.
        assert timed.turn_deg == pytest.approx(0.015 * times_s[-1] / 2,
                                               abs=4 * math.sqrt(2) * timed.turn_sigma_deg)
        for result in (timed, untimed):
            reason = judge(result, StillLimits())
            assert (reason if reason is None else reason[:14]) == verdict, reason
            if verdict:
                assert 'its ends' in reason and 'max_motion_deg 0.01 deg' in reason
