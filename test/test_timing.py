"""Pairing by stamps: nearest in time, any arrival order, exact nanoseconds."""

from inclino_ros.io.bag import BagError, TemperatureSeries
from inclino_ros.io.timing import pair_nearest, pairing_tolerance
import numpy as np
import pytest

T0 = 1_767_225_600 * 10**9  # 2026-01-01 in ns: float64 would round these to 256 ns


def test_nearest_reading_in_any_order_with_an_inclusive_gap():
    """Each stamp takes the nearest reading; out-of-order readings; the limit is inclusive."""
    reading_stamps = np.array([T0 + 30, T0, T0 + 10])            # arrived out of order
    readings = np.array([[3.0], [1.0], [2.0]])
    values, paired = pair_nearest([T0 + 1, T0 + 14, T0 + 26, T0 + 35, T0 + 36, T0 + 5],
                                  reading_stamps, readings, max_gap_ns=5, tolerance=np.inf)
    np.testing.assert_array_equal(values[:, 0], [1.0, 2.0, 3.0, 3.0, np.nan, 1.0])
    np.testing.assert_array_equal(paired, [True, True, True, True, False, True])


def test_no_readings_pairs_nothing():
    """Without readings every stamp is unpaired, NaN."""
    values, paired = pair_nearest([T0], [], np.empty((0, 3)), 10, 1.0)
    assert values.shape == (1, 3) and np.isnan(values).all() and not paired.any()


def test_temperature_interpolation_skips_non_finite_messages():
    """A NaN temperature message is left out; none finite is a BagError."""
    series = TemperatureSeries(np.array([0, 10, 20]), np.array(['t'] * 3),
                               np.array([25.0, np.nan, 35.0]), np.zeros(3))
    np.testing.assert_allclose(series.at([0, 10, 20]), [25.0, 30.0, 35.0])
    empty = TemperatureSeries(np.array([0]), np.array(['t']), np.array([np.nan]), np.zeros(1))
    with pytest.raises(BagError):
        empty.at([0])


def test_non_finite_readings_are_never_paired():
    """A driver's NaN between two readings: the nearest finite reading is paired instead."""
    reading_stamps = np.array([T0, T0 + 4, T0 + 8, T0 + 12])
    readings = np.array([[1.0, 1.0], [np.nan, np.nan], [2.0, 2.0], [np.inf, 0.0]])
    values, paired = pair_nearest([T0 + 3, T0 + 5, T0 + 12], reading_stamps, readings,
                                  max_gap_ns=4, tolerance=np.inf)
    np.testing.assert_array_equal(values[:, 0], [1.0, 2.0, 2.0])
    assert paired.all()
    values, paired = pair_nearest([T0], [T0], np.array([[np.nan, 1.0]]), max_gap_ns=4,
                                  tolerance=1.0)
    assert np.isnan(values).all() and not paired.any()


def test_never_a_reading_across_a_change_between_the_readings_bracketing_a_sample():
    """
    10 Hz readings, 200 Hz samples, a station change at 0.5 s: no sample takes the other side's.

    Before: the last samples of the first station (nearer the 0.55 s reading) took it.
    """
    reading_stamps = T0 + np.arange(10) * 100_000_000 + 50_000_000       # 0.05, 0.15, ... s
    readings = np.where((reading_stamps < T0 + 500_000_000)[:, None], [[1000.0]], [[-3000.0]])
    readings = readings + np.random.default_rng(1).normal(0.0, 10.0, readings.shape)
    stamps = T0 + np.arange(200) * 5_000_000
    values, paired = pair_nearest(stamps, reading_stamps, readings, 100_000_000,
                                  pairing_tolerance(10.0))
    station = np.where(stamps < T0 + 500_000_000, 1000.0, -3000.0)
    assert np.all(np.abs(values[paired, 0] - station[paired]) < 100.0)
    # Unpaired: exactly the samples between the last reading of one station and the first of
    # the next (0.45 .. 0.55 s, both exclusive); every other one is paired.
    between = (stamps > T0 + 450_000_000) & (stamps < T0 + 550_000_000)
    np.testing.assert_array_equal(paired, ~between)
    assert pairing_tolerance(10.0) == pytest.approx(5.0 * np.sqrt(2.0) * 10.0)
