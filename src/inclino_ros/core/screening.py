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
  axial component cannot be completed (``attitude.complete_two_axis``).
"""

import numpy as np

REASONS = ('non_finite', 'saturated', 'zero', 'over_g')
ACCEPTED = -1

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
    for code in reversed(range(len(REASONS))):
        codes[failing[code]] = code
    return codes


def count_reasons(codes):
    """Return ``{reason: count}`` for the rejected samples among ``codes``."""
    counts = np.bincount(codes[codes != ACCEPTED], minlength=len(REASONS))
    return {reason: int(n) for reason, n in zip(REASONS, counts)}
