"""
Sample screening: which raw readings may become an angle, and why not.

A rejected sample is dropped and counted under one reason, never turned into
a published angle.  The reasons, in the order they are checked:

- ``non_finite``: a NaN or Inf component;
- ``saturated``: a component at or beyond the sensor's full-scale range;
- ``zero``: a three-axis reading of (near) zero magnitude: a dead sensor or a
  free fall, with no gravity direction in it (a two-axis sensor reads zero
  when vertical, so this check is for three axes only);
- ``over_g``: a two-axis reading whose cross-axial magnitude exceeds g, so the
  axial component cannot be completed (``attitude.complete_two_axis``);

and after the calibration (``screen_corrected``), what cannot be an angle:

- ``dynamic``: a three-axis reading whose corrected G-total is further from g
  than a tolerance: not gravity (a driver that removes gravity, |a| < 1 m/s^2;
  a unit error; a shock);
- ``two_axis_range``: a two-axis reading steeper than the sensor's valid
  range: a two-axis sensor cannot tell inclination I from 180 deg - I, so a
  tool past 90 deg reads as one short of it, folded back (true 120 deg reads
  60 deg); near 90 deg the completion has no precision left anyway.
"""

from inclino_ros.core.attitude import inclination
import numpy as np

REASONS = ('non_finite', 'saturated', 'zero', 'over_g', 'dynamic', 'two_axis_range')
ACCEPTED = -1
DYNAMIC = REASONS.index('dynamic')
TWO_AXIS_RANGE = REASONS.index('two_axis_range')

#: Magnitude below which a three-axis reading counts as zero, as a fraction of g.
ZERO_FRACTION = 1e-3


def screen(raw, axes, range_mps2, gravity_mps2):
    """
    Return one reason code per sample: an index into REASONS, or ACCEPTED.

    ``raw`` has shape ``(N, 3)`` in m/s^2; for ``axes == 2`` its z column is
    ignored.  Checks are vectorised and the first failing reason wins.
    """
    used = np.asarray(raw, dtype=float)[:, :axes]
    # |f| for three axes; for two the cross-axial magnitude hypot(x, y).
    magnitude = np.sqrt(np.einsum('ij,ij->i', used, used))
    none = np.zeros(used.shape[0], dtype=bool)
    failing = (~np.isfinite(used).all(axis=1),
               (np.abs(used) >= range_mps2).any(axis=1),
               magnitude < ZERO_FRACTION * gravity_mps2 if axes == 3 else none,
               magnitude > gravity_mps2 if axes == 2 else none)
    codes = np.full(used.shape[0], ACCEPTED, dtype=np.int8)
    for code in reversed(range(len(failing))):
        codes[failing[code]] = code
    return codes


def screen_corrected(f, axes, gravity_mps2, g_total_tolerance_mps2, max_inclination_deg):
    """
    Return one code per corrected sample (N, 3): DYNAMIC, TWO_AXIS_RANGE or ACCEPTED.

    Three axes: ``| |f| - g | > g_total_tolerance_mps2`` is DYNAMIC; two axes
    (|f| = g by construction): an inclination above ``max_inclination_deg``
    is TWO_AXIS_RANGE.
    """
    f = np.asarray(f, dtype=float)
    codes = np.full(f.shape[0], ACCEPTED, dtype=np.int8)
    if axes == 3:
        offset = np.abs(np.sqrt(np.einsum('ij,ij->i', f, f)) - gravity_mps2)
        codes[offset > g_total_tolerance_mps2] = DYNAMIC
    else:
        codes[np.degrees(inclination(f)) > max_inclination_deg] = TWO_AXIS_RANGE
    return codes


def count_reasons(codes):
    """Return ``{reason: count}`` for the rejected samples among ``codes``."""
    counts = np.bincount(codes[codes != ACCEPTED], minlength=len(REASONS))
    return {reason: int(n) for reason, n in zip(REASONS, counts)}
