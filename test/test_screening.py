"""
Sample screening: each defect gets its reason, the first reason wins, counts add up.

The checks are exact comparisons, so the expected codes are exact; samples sit on either
side of each threshold by a clear margin (or exactly on it where the rule says >=).
"""

from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from inclino_ros.core.screening import ACCEPTED, count_reasons, REASONS, screen, ZERO_FRACTION
import numpy as np
import pytest

G = 9.80665
RANGE = 2.0 * G
NAN, INF = float('nan'), float('inf')


def code(reason):
    """Return the integer code of a reason name."""
    return REASONS.index(reason)


def test_reason_table():
    """The reasons are the six documented ones, in the documented order."""
    assert REASONS == ('non_finite', 'saturated', 'zero', 'over_g', 'dynamic', 'two_axis_range')
    assert ACCEPTED == -1


def test_three_axis_reasons():
    """NaN, +-Inf, saturation and zero each get their reason; good samples pass."""
    raw = np.array([
        [0.0, 0.0, G],              # level, good
        [NAN, 0.0, G],
        [0.0, INF, G],
        [0.0, 0.0, -INF],
        [RANGE, 0.0, 0.0],          # exactly full scale counts as saturated (>=)
        [0.0, -RANGE * 1.5, 0.0],
        [0.0, 0.0, 0.0],            # dead sensor / free fall
        [1e-4 * G, 0.0, 0.0],       # below ZERO_FRACTION g
        [3e-3 * G, 0.0, 0.0],       # above it: a (strange but) usable direction
        [np.nextafter(RANGE, 0.0), 0.0, 0.0],   # just inside full scale
        [G, G, G],                  # over g in total is not a three-axis reason
    ])
    codes = screen(raw, 3, RANGE, G)
    assert codes.dtype.kind == 'i'
    assert codes.tolist() == [
        ACCEPTED, code('non_finite'), code('non_finite'), code('non_finite'),
        code('saturated'), code('saturated'), code('zero'), code('zero'),
        ACCEPTED, ACCEPTED, ACCEPTED]


def test_zero_threshold_is_a_fraction_of_gravity():
    """The zero limit scales with the configured gravity (ZERO_FRACTION g)."""
    assert ZERO_FRACTION == 1e-3
    raw = np.array([[0.0, 0.0, 0.9e-3 * G], [0.0, 0.0, 1.1e-3 * G]])
    assert screen(raw, 3, RANGE, G).tolist() == [code('zero'), ACCEPTED]
    # The same vectors against g = 1 (other units) are both far above 1e-3.
    assert screen(raw, 3, RANGE, 1.0).tolist() == [ACCEPTED, ACCEPTED]


def test_two_axis_reasons_and_ignored_z():
    """Two axes: z is never looked at; over-g is a reason, zero (vertical) is not."""
    raw = np.array([
        [0.0, 0.0, NAN],            # vertical two-axis tool: reads zero, accepted
        [0.3, -0.2, INF],           # z ignored
        [NAN, 0.0, 0.0],
        [0.0, -INF, 0.0],
        [RANGE, 0.0, 0.0],          # saturated and over g: saturated comes first
        [7.0, 7.0, 0.0],            # hypot 9.9 > g
        [G, 0.0, 0.0],              # exactly g: horizontal, completes to z = 0
        [6.0, 7.0, 0.0],            # hypot 9.22 < g
    ])
    codes = screen(raw, 2, RANGE, G)
    assert codes.tolist() == [
        ACCEPTED, ACCEPTED, code('non_finite'), code('non_finite'), code('saturated'),
        code('over_g'), ACCEPTED, ACCEPTED]


def test_first_reason_wins():
    """A sample failing several checks is counted once, under the first in REASONS order."""
    raw3 = np.array([[NAN, 5.0 * RANGE, 0.0],      # non_finite and saturated
                     [INF, 0.0, 0.0]])             # non_finite (and saturated by value)
    assert screen(raw3, 3, RANGE, G).tolist() == [code('non_finite')] * 2
    raw2 = np.array([[NAN, 2.0 * RANGE, 0.0],      # non_finite, saturated
                     [-RANGE, 0.0, 0.0]])          # saturated and over g
    assert screen(raw2, 2, RANGE, G).tolist() == [code('non_finite'), code('saturated')]


def test_count_reasons():
    """Counts have every reason as a key and add up to the rejected samples."""
    codes = np.array([ACCEPTED, 0, 0, 1, 3, ACCEPTED, 0, 2], dtype=np.int8)
    assert count_reasons(codes) == {'non_finite': 3, 'saturated': 1, 'zero': 1, 'over_g': 1,
                                    'dynamic': 0, 'two_axis_range': 0}
    assert count_reasons(np.full(4, ACCEPTED, dtype=np.int8)) == dict.fromkeys(REASONS, 0)
    assert count_reasons(np.array([], dtype=np.int8)) == dict.fromkeys(REASONS, 0)


def test_empty_batch():
    """An empty batch screens to an empty code array."""
    assert screen(np.zeros((0, 3)), 3, RANGE, G).shape == (0,)
    assert screen(np.zeros((0, 3)), 2, RANGE, G).shape == (0,)


# Values up to 1e308 overflow the squared norm to inf inside screen(): harmless (inf is not
# < the zero limit), so that numpy warning is not a failure here.
@pytest.mark.filterwarnings('ignore:overflow encountered:RuntimeWarning')
@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, st.tuples(st.integers(0, 20), st.just(3)),
                  elements=st.floats(allow_nan=True, allow_infinity=True, width=64)),
       st.sampled_from([2, 3]))
def test_codes_agree_with_a_per_sample_reference(raw, axes):
    """Vectorised codes equal a plain per-sample if/elif reference; counts add up."""
    codes = screen(raw, axes, RANGE, G)
    for row, got in zip(raw, codes):
        used = row[:axes]
        if not np.all(np.isfinite(used)):
            expected = code('non_finite')
        elif np.any(np.abs(used) >= RANGE):
            expected = code('saturated')
        elif axes == 3 and np.linalg.norm(used) < ZERO_FRACTION * G:
            expected = code('zero')
        elif axes == 2 and np.hypot(used[0], used[1]) > G:
            expected = code('over_g')
        else:
            expected = ACCEPTED
        assert got == expected
    counts = count_reasons(codes)
    assert sum(counts.values()) == int(np.sum(codes != ACCEPTED))
