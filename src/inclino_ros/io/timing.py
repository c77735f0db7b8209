"""
Pairing of two sensor streams by their stamps.

The azimuth (seed 002) needs, for each accelerometer sample, the
magnetometer reading of the same moment; the node and ``inclino process``
pair them with the same function.
"""

import numpy as np


def pair_nearest(stamps_ns, reading_stamps_ns, readings, max_gap_ns):
    """
    Return (values (N, k), paired (N,)): for each stamp the reading nearest in time.

    ``reading_stamps_ns`` need not be sorted (a best-effort topic may deliver
    out of order); of two readings equally near, the earlier is taken.  A
    reading with a non-finite value is never paired (some drivers publish NaN
    between two measurements): the nearest finite one is.  A stamp with no
    reading within ``max_gap_ns`` (inclusive) gets a NaN row.  Stamps are
    int64 nanoseconds throughout, so no precision is lost.
    """
    stamps = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
    readings = np.asarray(readings, dtype=float)
    if readings.ndim == 1:
        readings = readings[:, None]
    unpaired = np.full((stamps.size, readings.shape[1]), np.nan)
    finite = np.isfinite(readings).all(axis=1)
    if not finite.any():
        return unpaired, np.zeros(stamps.size, dtype=bool)
    reading_stamps = np.asarray(reading_stamps_ns, dtype=np.int64).reshape(-1)[finite]
    readings = readings[finite]
    order = np.argsort(reading_stamps, kind='stable')
    reading_stamps = reading_stamps[order]
    readings = readings[order]
    last = reading_stamps.size - 1
    after = np.clip(np.searchsorted(reading_stamps, stamps), 0, last)
    before = np.clip(after - 1, 0, last)
    nearest = np.where(np.abs(reading_stamps[after] - stamps)
                       < np.abs(stamps - reading_stamps[before]), after, before)
    paired = np.abs(reading_stamps[nearest] - stamps) <= max_gap_ns
    return np.where(paired[:, None], readings[nearest], unpaired), paired
