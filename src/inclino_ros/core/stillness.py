"""
Still detection: motion told from noise by the capture itself.

A still sensor's samples scatter about a stable mean; the spread of single
samples measures the sensor's noise, not motion (a MEMS accelerometer at
100 Hz spreads 0.10-0.13 deg lying still, real-sensors.md).  Motion shows as
a mean that moves.  So a capture of N samples (angles a_i, rad, k = 1 or 2
components; times t_i) is cut into B blocks of consecutive samples and:

* noise: the pooled within-block variance
  ``s^2 = sum_b sum_(i in b) |a_i - m_b|^2 / (k (N - B))`` (m_b the block
  means): a slow motion hardly enters it, white noise wholly;
* precision: the standard error of the mean, ``s / sqrt(N)`` per component;
  N_needed = N (SE / target)^2 samples reach a target;
* drift: the weighted least-squares slope of the block means m_b against
  the block times t_b (weights n_b), ``d = sum_b n_b (t_b - t) (m_b - a) / S``
  with standard error ``s / sqrt(S)``, ``S = sum_b n_b (t_b - t)^2`` (a, t the
  capture's means; with ten blocks this keeps 99 % of the information of a
  fit through every sample);
* unsteadiness (a knock, a step): the block means about that line,
  ``X = sum_b n_b |m_b - a - d (t_b - t)|^2``.

For a still sensor with white Gaussian noise sigma the block means are
independent of the within-block residuals, so ``s^2`` is ``sigma^2
chi^2(nu) / nu`` with ``nu = k (N - B)``, ``|d|^2 S / sigma^2`` is chi-square
with k degrees of freedom and ``X / sigma^2`` chi-square with ``k (B - 2)``:
the ratios ``F_drift = |d|^2 S / (k s^2)`` and ``F_steady = X / (k (B - 2)
s^2)`` follow Fisher's F(k, nu) and F(k (B - 2), nu) exactly, whatever N.
(The chi-square of the former rule took s for sigma: with 16 samples, nu =
16, a still capture was refused 3 times in 1000, ``bench/bench_stillness.py``.)
A test refuses when its statistic's tail probability under that law is below
FALSE_MOTION_P AND the motion is large enough to matter (``StillLimits``).
Angles are in radians in, degrees in the result.

Correlated noise (a low-pass filter below the output rate, issue 19 item 4):
the noise is measured from the capture's within-block residuals with its
autocorrelation (``correlated_noise.estimate``): sigma^2 is the per-sample
variance, a block mean's variance is ``sigma^2 F(n_b) / n_b`` and the mean's
standard error ``sigma sqrt(F(N) / N)`` (``n_eff = N / F(N)``; the mean's from
the fit over longer lags, ``correlated_noise.MEAN_LAGS``, n_eff in samples of
the still test's sigma).  Both F
ratios then take ``sigma^2 F(n_b)`` for the white ``sigma^2`` and the
degrees of freedom of the estimate (``correlated_noise.dof``): approximate
laws, exact again for white noise (rho = 0, which the estimate keeps in
~98 % of white captures).

Slow turns (issue 19 item 5): one rule, timed or untimed, for every caller
(``motion``, ``judge``, ``Stillness.stated_sem_deg``): the capture's mean
must lie within its stated precision of the attitude at every part of the
capture.  A drift d puts the attitude at the capture's ends ``h = |d| H``
from the mean (``turn_deg``; H = max |t_i - t|, half the capture for even
sampling, the same in samples when the capture has no times), known to
``sigma_h = H sqrt(sigma^2 F(n_b) / S)`` per component (``turn_sigma_deg``:
sqrt(3) times the mean's standard error for white noise, evenly sampled).
A turn too slow to be significant at FALSE_MOTION_P (a MEMS capture of 3 s
cannot tell 0.015 deg/s from stillness: h = 0.02 deg, sigma_h = 0.012 deg)
cannot be refused without refusing still captures, so:

* refused as moving: a significant drift with ``turn_deg`` beyond
  ``StillLimits.max_motion_deg`` (or faster than ``max_drift_deg_per_s``),
  or significantly unsteady block means one of which lies beyond it;
* accepted otherwise, with the stated precision ``stated_sem_deg =
  sqrt(sem^2 + max(0, turn_deg^2 - c k sigma_h^2))`` (c =
  MOTION_NOISE_FACTOR = 2; k components), the 1 sigma the level and stand
  captures write (``white_noise_deg``).  The fitted ``turn_deg^2``
  estimates ``h^2 + k sigma_h^2`` (c = 1 would be the unbiased estimate of
  the motion's square); with c = 2 a still capture keeps its noise's sigma
  in 86 % of draws (k = 2: chi-square(2) < 4), so still captures cover
  0.70-0.75 at 1 sigma (0.76-0.80 with c = 1, above the 0.76 the issue
  allows), while a MEMS turn of 0.015 deg/s over 5 s is covered at 2 sigma
  in 0.88 of the accepted (0.93 with c = 1, 0 before); a turn nearer
  the noise is partly covered (a still capture's fitted ends move as far as
  often: only more samples or a longer capture tell them apart).  The
  precision target ``max_sem_deg`` is on the noise alone, so no capture is
  refused as too noisy for motion it may not have.  Averaged windows of a
  stream (``own_noise``) are not captures judged still: their 1 sigma is the
  noise's.  Measured in
  bench/bench_stillness.py (bench/results/stillness.md).
"""

from dataclasses import dataclass
import math

from inclino_ros.core import correlated_noise
from inclino_ros.core.attitude import angle_between
import numpy as np
from scipy.stats import f as fisher_f

#: Blocks a capture is cut into (at most; at least 2 samples a block).
BLOCKS = 10
#: Fewest samples a still test takes: 3 blocks of 2 (a line and a residual).
MIN_SAMPLES = 6
#: Tail probability under which a test statistic is motion, not noise: a still
#: capture (white noise) is refused by each of the two tests with at most this
#: probability, by either with at most twice it (2e-6 per capture: a suite of a
#: thousand captures refuses a still one with probability 0.2 %), before the
#: limits of ``StillLimits`` lower it further.  Measured in bench/bench_stillness.py.
FALSE_MOTION_P = 1e-6
#: The fitted motion at a capture's ends that its noise alone explains, in units of its
#: variance (``Stillness.stated_sem_deg``): 2, twice the noise's expected share, so that still
#: captures keep their noise's sigma (module docstring, "Slow turns").
MOTION_NOISE_FACTOR = 2.0


@dataclass(frozen=True)
class StillLimits:
    """
    When a capture is still enough and precise enough (``judge``).

    ``max_drift_deg_per_s``: a significant drift faster than this is refused
    whatever the capture's length;
    ``max_sem_deg``: the standard error of the mean (its noise) the capture
    must reach;
    ``max_motion_deg``: how far a significant motion (drift or unsteadiness)
    may put the attitude at a part of the capture from its mean: beyond it
    the capture is refused as moving, within it accepted with the motion in
    its stated precision (``Stillness.stated_sem_deg``; module docstring,
    "Slow turns").
    ``drift_name``, ``sem_name``, ``motion_name``: how the messages name the limits.
    """

    max_drift_deg_per_s: float = 0.02
    max_sem_deg: float = 0.01
    max_motion_deg: float = 0.01
    drift_name: str = 'max_drift_deg_per_s'
    sem_name: str = 'max_sem_deg'
    motion_name: str = 'max_motion_deg'


@dataclass(frozen=True)
class Stillness:
    """What a capture shows about its noise and its motion (``assess``)."""

    samples: int
    duration_s: float           # NaN when the capture has no times
    noise_deg: float            # per-sample 1 sigma of one component (within blocks)
    sem_deg: float              # standard error of the mean, one component
    effective_samples: float    # n_eff: the white-noise samples the mean is worth
    drift_deg_per_s: float      # |slope|; per sample when the capture has no times
    drift_sigma: float          # |slope| / its standard error
    drift_p: float              # tail probability of F_drift for a still sensor
    scatter_ratio: float        # F_steady: X / (k (B - 2) s^2), about 1 for white noise
    scatter_p: float            # tail probability of F_steady for a still sensor
    motion_deg: float           # RMS of the block means' motion beyond the noise
    part_offset_deg: float = 0.0  # largest distance of a block's attitude from the mean
    turn_deg: float = 0.0         # the fitted drift at the capture's ends: |slope| max|t - t_mean|
    turn_sigma_deg: float = 0.0   # its standard error, one component
    components: int = 1           # k: the angles' components

    @property
    def stated_sem_deg(self):
        """
        Return the capture's stated precision: the 1 sigma of its mean for every part of it.

        ``sqrt(sem_deg^2 + max(0, turn_deg^2 - k turn_sigma_deg^2))``: the
        noise of the mean and the motion at the capture's ends beyond what
        its noise alone would fit (module docstring, "Slow turns").
        """
        noise_share = MOTION_NOISE_FACTOR * self.components * self.turn_sigma_deg ** 2
        excess = self.turn_deg ** 2 - noise_share
        return math.sqrt(self.sem_deg ** 2 + max(excess, 0.0))

    @property
    def white_noise_deg(self):
        """
        Return the white per-sample noise whose mean has this capture's stated precision.

        ``stated_sem_deg sqrt(samples)``: noise_deg for white noise, ``noise_deg
        sqrt(F(N))`` for correlated (``core.correlated_noise``), more by the
        motion the capture cannot exclude; a stage that keeps a per-sample
        noise and its sample count (``std / sqrt(N)``) keeps this one.
        """
        return self.stated_sem_deg * math.sqrt(self.samples)

    def samples_needed(self, max_sem_deg):
        """Return the samples that bring the standard error to ``max_sem_deg``."""
        return int(math.ceil(self.samples * (self.sem_deg / max_sem_deg) ** 2))


def without_once_per_turn(angle_rad, turn_rad):
    """
    Return ``angle`` less its least-squares part ``a cos(turn) + b sin(turn)``.

    A tool turned about its own axis reads an inclination that wobbles once
    per turn by any mounting error left (seed 000: the sensor axis off the
    tool axis by theta): removing that term leaves the axis' own motion.
    """
    angle = np.asarray(angle_rad, dtype=float)
    design = np.column_stack([np.ones_like(angle), np.cos(turn_rad), np.sin(turn_rad)])
    wobble = design[:, 1:] @ np.linalg.lstsq(design, angle, rcond=None)[0][1:]
    return angle - wobble


def tangent_angles(vectors):
    """
    Return the angles (N, 2) [rad] of each vector from the mean direction.

    Components along two unit vectors e1, e2 orthogonal to the mean
    direction u: ``atan2(v . e_j, v . u)``, the tilt of each sample about u.
    """
    vectors = np.asarray(vectors, dtype=float)
    mean = vectors.mean(axis=0)
    u = mean / np.linalg.norm(mean)
    helper = np.eye(3)[np.argmin(np.abs(u))]
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    along = vectors @ u
    return np.arctan2(vectors @ np.stack([e1, e2], axis=1), along[:, None])


def assess(angles_rad, times_s=None):
    """
    Return the Stillness of a capture (module docstring).

    ``angles_rad`` (N,) or (N, k); ``times_s`` (N,) sample times, or None
    (then drift is per sample).  ValueError below MIN_SAMPLES samples.
    """
    angles = np.asarray(angles_rad, dtype=float)
    count = angles.shape[0]
    if count < MIN_SAMPLES:
        raise ValueError(f'{count} samples: a still test needs at least {MIN_SAMPLES}')
    angles = angles.reshape(count, -1)
    k = angles.shape[1]
    timed = times_s is not None
    t = np.asarray(times_s, dtype=float) if timed else np.arange(count, dtype=float)
    if timed and not (np.all(np.isfinite(t)) and np.ptp(t) > 0.0):
        t, timed = np.arange(count, dtype=float), False
    blocks = min(BLOCKS, count // 2)
    block = np.repeat(np.arange(blocks), [len(b) for b in np.array_split(np.arange(count),
                                                                         blocks)])
    n_b = np.bincount(block).astype(float)
    means = np.stack([np.bincount(block, weights=angles[:, j]) for j in range(k)], axis=1)
    means /= n_b[:, None]
    # The still test's noise (short lags), and the mean's variance from the longer lags
    # (``correlated_noise.MEAN_LAGS``), its n_eff in samples of that per-sample noise.
    noise, mean_noise = correlated_noise.estimate_spans(
        angles, block, (correlated_noise.LAGS, correlated_noise.MEAN_LAGS))
    noise_var = noise.variance
    mean_var = float(mean_noise.mean_variance(count))
    effective = noise_var / mean_var if mean_var > 0.0 else float(count)
    # Correlated noise: a block mean varies F(n_b) times a white one (the mean over the
    # blocks, nearly equal); the noise is known to ``correlated_noise.dof``.
    inflation = float(np.mean(noise.inflation(n_b)))
    noise_dof = correlated_noise.dof(noise, count)
    t_mean = t.mean()
    a_mean = angles.mean(axis=0)
    t_b = np.bincount(block, weights=t) / n_b - t_mean
    s_tt = np.sum(n_b * t_b ** 2)
    slope = (n_b * t_b) @ (means - a_mean) / s_tt
    slope_norm = float(np.linalg.norm(slope))
    off_line = means - a_mean - np.outer(t_b, slope)
    scatter = float(np.sum(n_b * np.sum(off_line ** 2, axis=1)))
    dof = k * (blocks - 2)
    sigma = math.sqrt(noise_var)
    block_var = noise_var * inflation
    with np.errstate(divide='ignore', invalid='ignore'):
        drift_f = slope_norm ** 2 * s_tt / (k * block_var) if sigma > 0 else (
            math.inf if slope_norm > 0 else 0.0)
        ratio = scatter / block_var / dof if sigma > 0 else (math.inf if scatter > 0 else 0.0)
    motion_var = np.mean(np.sum(off_line ** 2, axis=1) / k - noise.mean_variance(n_b))
    # Each block's attitude against the capture's mean, its noise taken out:
    # var(m_b - a) = var(m_b) (1 - n_b / N) per component for independent blocks.
    offset = (np.sum((means - a_mean) ** 2, axis=1)
              - k * noise.mean_variance(n_b) * (1.0 - n_b / count))
    # The drift's line at the capture's ends, from its mean (module docstring, "Slow turns").
    half_span = float(np.max(np.abs(t - t_mean)))
    return Stillness(
        samples=count, duration_s=float(np.ptp(t)) if timed else math.nan,
        noise_deg=math.degrees(sigma),
        sem_deg=math.degrees(math.sqrt(mean_var)), effective_samples=effective,
        drift_deg_per_s=math.degrees(slope_norm), drift_sigma=math.sqrt(k * drift_f),
        drift_p=float(fisher_f.sf(drift_f, k, noise_dof)), scatter_ratio=float(ratio),
        scatter_p=float(fisher_f.sf(ratio, dof, noise_dof)),
        motion_deg=math.degrees(math.sqrt(max(motion_var, 0.0))),
        part_offset_deg=math.degrees(math.sqrt(max(float(offset.max()), 0.0))),
        turn_deg=math.degrees(slope_norm * half_span),
        turn_sigma_deg=math.degrees(math.sqrt(block_var / s_tt) * half_span), components=k)


def motion(stillness, limits, steady=True):
    """
    Return why a capture moves, or None for a still one.

    One rule, timed or not (issue 19 item 5; module docstring, "Slow
    turns"): the capture's mean must lie within its stated precision of the
    attitude at every part of it.  Moving: a drift significant (tail
    probability below FALSE_MOTION_P) whose line puts the capture's ends
    further than ``limits.max_motion_deg`` from the mean (``turn_deg``), or
    (timed) faster than ``limits.max_drift_deg_per_s`` whatever the
    capture's length; or (``steady``) block means off their trend,
    significant likewise, one of them further than that from the mean
    (``part_offset_deg``, the largest, its noise taken out).  A motion not
    refused is in the capture's ``stated_sem_deg``.
    """
    s = stillness
    target = f'{limits.motion_name} {limits.max_motion_deg} deg'
    if math.isnan(s.duration_s):
        fast = False
        rate = f'{s.drift_deg_per_s * s.samples:.4f} deg over the capture'
    else:
        fast = s.drift_deg_per_s > limits.max_drift_deg_per_s
        rate = f'{s.drift_deg_per_s:.4f} deg/s'
    turned = s.turn_deg > limits.max_motion_deg
    if s.drift_p < FALSE_MOTION_P and (turned or fast):
        return (f'tool is moving (drift {rate}, {s.drift_sigma:.0f} sigma of the noise; '
                + (f'its ends {s.turn_deg:.4f} deg from its mean, beyond {target}' if turned
                   else f'{limits.drift_name} {limits.max_drift_deg_per_s} deg/s') + ')')
    if steady and s.scatter_p < FALSE_MOTION_P and s.part_offset_deg > limits.max_motion_deg:
        return (f'tool is moving (not steady: the means of its blocks scatter '
                f'{math.sqrt(s.scatter_ratio):.1f}x the noise about their trend, '
                f'{s.motion_deg:.4f} deg RMS; a part of the capture is '
                f'{s.part_offset_deg:.4f} deg from its mean, beyond {target})')
    return None


def judge(stillness, limits):
    """
    Return why a capture cannot be used (moving, or too noisy), or None.

    Motion first (``motion``), then precision: the standard error of the mean
    above ``limits.max_sem_deg`` is refused with the samples that would reach it.
    """
    reason = motion(stillness, limits)
    if reason is None and stillness.sem_deg > limits.max_sem_deg:
        reason = (f'too noisy for the target: {stillness.samples_needed(limits.max_sem_deg)} '
                  f'samples needed (standard error {stillness.sem_deg:.4f} deg from '
                  f'{stillness.samples} samples of noise {stillness.noise_deg:.3f} deg exceeds '
                  f'{limits.sem_name} {limits.max_sem_deg} deg)')
    return reason


@dataclass(frozen=True)
class SegmentLimits:
    """
    How still segments are found in a stream (``find_still_segments``): the one rule.

    Used alike for a continuous log (``calibration.continuous_log``: the
    fits' CSV logs) and a bag's shots (``inclino fit-magnetometer``).
    ``window_s``: the stream is judged in windows of this length; a window is
    still when the direction of its accelerometer readings does not move
    (``motion`` with ``still``, the same test every capture passes), nor
    that of its magnetometer readings when they are given, and, with a gyro,
    its RMS turn rate about the stream's median rate (the gyro's bias: a
    still log is mostly still) stays below ``max_rate_deg_per_s``: a turn
    about the vertical, which gravity does not show, is seen there.
    Consecutive still windows join into a run, except where two neighbours
    together move (``motion`` of both windows' readings: the tool turned
    between two still windows is two attitudes, not one mean of both); the
    first and last window of a run are left out (the tool settling after the
    hand lets go, the hand taking it); what is left, at least ``min_s`` long
    and still as a whole (``motion``: a slow settling that no window shows
    shows there), is a segment.  With ``whole`` False (a heating run, whose
    readings drift with the temperature) neither the neighbours nor the whole
    are tested, only each window.
    """

    window_s: float = 0.5
    min_s: float = 1.0
    max_rate_deg_per_s: float = 2.0
    still: StillLimits = StillLimits()
    whole: bool = True


def _still_span(streams, times_s, start, end, limits):
    """Return whether every stream's direction over samples start..end is still (``motion``)."""
    return all(motion(assess(tangent_angles(vectors[start:end]), times_s[start:end]),
                      limits.still) is None for vectors in streams)


def find_still_segments(times_s, vectors, gyro_radps=None, limits=SegmentLimits(),
                        fields=None):
    """
    Return [(start, end)] sample ranges of the still segments of a stream (``SegmentLimits``).

    ``times_s`` (N,) increasing sample times, ``vectors`` (N, 3) the
    accelerometer readings, ``gyro_radps`` (N, 3) or None, ``fields`` (N, 3)
    the magnetometer readings at the same samples or None.  Each window of
    ``limits.window_s`` (at least MIN_SAMPLES samples, else not still) is
    judged by ``assess`` and ``motion`` on the directions of its readings
    (``tangent_angles``), and by the gyro's RMS rate.
    """
    times_s = np.asarray(times_s, dtype=float).reshape(-1)
    streams = [np.asarray(vectors, dtype=float).reshape(-1, 3)]
    if fields is not None:
        streams.append(np.asarray(fields, dtype=float).reshape(-1, 3))
    if times_s.size < MIN_SAMPLES:
        return []
    if gyro_radps is not None:
        gyro_radps = np.asarray(gyro_radps, dtype=float).reshape(-1, 3)
        gyro_radps = gyro_radps - np.nanmedian(gyro_radps, axis=0)
    window = np.floor((times_s - times_s[0]) / limits.window_s).astype(int)
    edges = np.flatnonzero(np.diff(window)) + 1
    starts, ends = np.append(0, edges), np.append(edges, times_s.size)
    still = np.zeros(starts.size, dtype=bool)
    for k, (start, end) in enumerate(zip(starts, ends)):
        if end - start < MIN_SAMPLES or not all(np.all(np.isfinite(v[start:end]))
                                                for v in streams):
            continue
        if gyro_radps is not None:
            rate = np.degrees(np.sqrt(np.mean(np.sum(gyro_radps[start:end] ** 2, axis=1))))
            if not rate < limits.max_rate_deg_per_s:
                continue
        still[k] = _still_span(streams, times_s, start, end, limits)
    # A run breaks where two still neighbours together move: another attitude.
    joined = still[1:] & still[:-1]
    if limits.whole:
        joined &= [_still_span(streams, times_s, starts[k], ends[k + 1], limits)
                   for k in range(starts.size - 1)]
    segments = []
    first = None
    for k in range(starts.size + 1):
        if first is not None and (k == starts.size or not joined[k - 1]):
            # The tool settles after the hand lets go, the hand takes it before it turns: a
            # run's first and last window are left out.
            start, end = (starts[first + 1], ends[k - 2]) if k - first > 2 else (None, None)
            if start is not None and times_s[end - 1] - times_s[start] >= limits.min_s and (
                    not limits.whole or _still_span(streams, times_s, start, end, limits)):
                segments.append((int(start), int(end)))
            first = None
        if first is None and k < starts.size and still[k]:
            first = k
    return segments


def label_attitudes(readings, separation_deg):
    """
    Return an attitude label per reading (N, 3): directions within ``separation_deg`` share one.

    Greedy: the first unlabelled reading opens an attitude that takes every
    unlabelled reading within ``separation_deg`` of its direction.
    """
    readings = np.asarray(readings, dtype=float)
    labels = np.full(readings.shape[0], -1)
    label = 0
    while (labels < 0).any():
        first = np.flatnonzero(labels < 0)[0]
        near = np.degrees(angle_between(readings, readings[first])) <= separation_deg
        labels[(labels < 0) & near] = label
        label += 1
    return labels


def own_noise(vectors, times_s=None):
    """
    Return (sigma, n_eff) of still readings' own noise; (NaN, M) below MIN_SAMPLES.

    ``vectors`` (M, 3) readings of one sensor, ``times_s`` (M,) or None:
    ``assess`` of their tangent angles gives the per-sample sigma of the
    direction (times the mean's length: the unit of the readings) and the
    white samples n_eff the mean is worth with its correlation
    (``core.correlated_noise``): the mean's 1 sigma is ``sigma / sqrt(n_eff)``
    (a window of a stream, not a capture judged still: without the motion
    of ``Stillness.stated_sem_deg``).
    """
    vectors = np.asarray(vectors, dtype=float).reshape(-1, 3)
    if vectors.shape[0] < MIN_SAMPLES:
        return math.nan, float(vectors.shape[0])
    try:
        stillness = assess(tangent_angles(vectors), times_s)
    except ValueError:
        return math.nan, float(vectors.shape[0])
    return (math.radians(stillness.noise_deg) * float(np.linalg.norm(vectors.mean(axis=0))),
            stillness.effective_samples)


def floored_count(sigma, effective, samples, noise_floor, bias_instability=0.0):
    """
    Return the count of white samples of noise ``noise_floor`` a mean is worth (issue 19 item 4).

    The one rule of every averaged 1 sigma (captures, averaged output
    windows): the readings' own noise ``sigma`` with ``effective`` (n_eff,
    ``own_noise``) gives the mean's 1 sigma ``sigma / sqrt(n_eff)``; the
    configured per-sample noise is its floor: ``n_eff min(1, (noise_floor /
    sigma)^2)``, so that ``noise_floor / sqrt(count)`` is the larger of the
    two.  A NaN ``sigma`` (too few readings to tell): ``samples`` (white
    noise at the floor).  A configured ``bias_instability`` B (IEEE Std 952,
    the unit of ``noise_floor``; 0: none) adds the flicker that moves the
    whole capture, which its own noise cannot show: ``(c B)^2`` to the mean's
    variance (``correlated_noise.flicker_mean_factor``), the count becomes
    ``1 / (1 / count + (c B / noise_floor)^2)``.  Element-wise.
    """
    sigma, effective, samples = (np.asarray(v, dtype=float) for v in (sigma, effective, samples))
    with np.errstate(invalid='ignore', divide='ignore'):
        ratio = np.where(sigma > noise_floor, (noise_floor / sigma) ** 2, 1.0)
    count = np.where(np.isfinite(sigma), effective * ratio, samples)
    if not bias_instability:
        return count
    flicker = (correlated_noise.flicker_mean_factor() * bias_instability / noise_floor) ** 2
    return 1.0 / (1.0 / count + flicker)


#: The configured per-sample noise is checked against the measured one: a measured noise
#: more than this many times the configured is said (issue 19 item 4: the configured
#: noise is a floor and a check).
NOISE_CHECK_FACTOR = 2.0


def noise_check(measured, configured, name, unit):
    """
    Return the warning when the ``measured`` per-sample noise exceeds ``configured``, or None.

    More than NOISE_CHECK_FACTOR times the configured ``name`` [``unit``]:
    every per-sample 1 sigma and QC limit taken from it is that much too
    tight (the averaged ones use the measured noise, ``floored_count``).
    A NaN ``measured`` (nothing measured) is no warning.
    """
    if not measured > NOISE_CHECK_FACTOR * configured:
        return None
    return (f'measured per-sample noise {measured:.4g} {unit} is {measured / configured:.1f} '
            f'times the configured {name} {configured:.4g} {unit} (more than '
            f'{NOISE_CHECK_FACTOR:g} times): per-sample 1 sigma and QC limits are too tight; '
            f'set {name} to the measured noise')
