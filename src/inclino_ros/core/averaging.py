"""
Averaged survey output: the mean of every N accepted samples, or of each output period.

An MWD tool sends stations, not every sample of a fast sensor: the mean of the
readings over a window, whose noise is the per-sample noise / sqrt(n_eff): each
window keeps its readings' own noise and effective sample size
(``stillness.own_noise``; ``stillness.floored_count`` puts the configured noise
under it, issue 19 item 4).  The
readings are averaged before the correction and the angles are those of the
mean reading (the captures of seed 000 and 001 do the same).  Windows are cut
over the accepted samples of a stream, across batches (the rows of an open
window wait for the next batch):

- by count: every ``samples`` accepted samples;
- by time: the samples whose stamps fall in one period of ``rate_hz``, the
  periods aligned to multiples of 1 / rate on the stamp clock; a window
  closes when a sample of a later period arrives, or one whose stamp goes
  back (a clock reset: a new run of periods starts there).

A window also says how far its readings scatter (the largest per-axis sample
standard deviation): a tool that moved within it has no meaningful mean, and
``pipeline.average`` drops such a window.  A magnetometer slower than the
accelerometer pairs one reading with several samples: the magnetometer's
noise averages over the distinct readings of the window only
(``field_samples``).
"""

from dataclasses import dataclass

from inclino_ros.core.stillness import own_noise
import numpy as np


@dataclass(frozen=True)
class Windows:
    """Closed windows of a stream, in the order they closed."""

    stamps_ns: np.ndarray      # (W,) int64 mean stamp of the window's samples
    frame_ids: np.ndarray      # (W,) frame_id of each window's last sample
    raw_mps2: np.ndarray       # (W, 3) mean reading (tool axes, before correction)
    temperature_c: np.ndarray  # (W,) mean temperature, NaN where no sample had one
    field_nT: np.ndarray       # (W, 3) mean of the paired field readings, NaN: none paired
    samples: np.ndarray        # (W,) accelerometer samples averaged
    field_samples: np.ndarray  # (W,) distinct magnetometer readings averaged
    scatter_mps2: np.ndarray   # (W,) largest per-axis sample std of the readings (0 for one)
    noise: np.ndarray = None          # (W,) own per-sample noise [m/s^2], NaN: too few
    effective_samples: np.ndarray = None    # (W,) n_eff of the accelerometer's mean
    field_noise: np.ndarray = None    # (W,) of the distinct field readings [nT], NaN: too few
    field_effective_samples: np.ndarray = None

    @property
    def count(self):
        """Return the number of windows."""
        return self.stamps_ns.size


def _group_sums(index, values, count):
    """Return per-group sums (count, k) of ``values`` (N, k) for group ``index`` (N,)."""
    return np.stack([np.bincount(index, weights=column, minlength=count)
                     for column in values.T], axis=1)


def _groups(index, count):
    """Return the rows of each group 0 .. count-1 of ``index``, each in its original order."""
    order = np.argsort(index, kind='stable')
    return np.split(order, np.cumsum(np.bincount(index, minlength=count))[:-1])


def close_windows(index, stamps_ns, frame_ids, raw, temperature_c, field_nT):
    """
    Return the Windows of rows grouped by ``index`` (N,) = 0 .. W-1, every group non-empty.

    ``temperature_c`` (N,) NaN where unknown; ``field_nT`` (N, 3) NaN rows
    where no reading was paired.
    """
    count = int(index.max()) + 1
    samples = np.bincount(index, minlength=count)
    base = stamps_ns[0]
    stamps = base + np.round(np.bincount(index, weights=(stamps_ns - base).astype(float))
                             / samples).astype(np.int64)
    mean = _group_sums(index, raw, count) / samples[:, None]
    deviation = raw - mean[index]
    variance = (_group_sums(index, deviation * deviation, count)
                / np.maximum(samples - 1, 1)[:, None])
    known = np.isfinite(temperature_c)
    with np.errstate(invalid='ignore', divide='ignore'):
        temperature = (np.bincount(index, weights=np.where(known, temperature_c, 0.0),
                                   minlength=count)
                       / np.bincount(index, weights=known.astype(float), minlength=count))
        paired = np.isfinite(field_nT).all(axis=1)
        field = (_group_sums(index, np.where(paired[:, None], field_nT, 0.0), count)
                 / np.bincount(index, weights=paired.astype(float), minlength=count)[:, None])
    # The distinct field readings in the order they came (a slow magnetometer repeats one).
    _, first = np.unique(np.column_stack([index[paired], field_nT[paired]]), axis=0,
                         return_index=True)
    came = np.flatnonzero(paired)[np.sort(first)]
    last = np.zeros(count, dtype=np.int64)
    np.maximum.at(last, index, np.arange(index.size))
    times_s = (stamps_ns - base) * 1e-9
    own = np.array([own_noise(raw[rows], times_s[rows]) for rows in _groups(index, count)])
    field_own = np.array([own_noise(field_nT[rows], times_s[rows])
                          for rows in (came[r] for r in _groups(index[came], count))])
    return Windows(stamps_ns=stamps, frame_ids=np.asarray(frame_ids, dtype=object)[last],
                   raw_mps2=mean, temperature_c=temperature, field_nT=field, samples=samples,
                   field_samples=np.bincount(index[came], minlength=count),
                   scatter_mps2=np.sqrt(variance.max(axis=1)), noise=own[:, 0],
                   effective_samples=own[:, 1], field_noise=field_own[:, 0],
                   field_effective_samples=field_own[:, 1])


#: Slowest output rate [Hz] averaging by time: a window of at most 100 s, its samples held
#: until it closes (1e6 samples at 10 kHz, as ``output.average_samples``' largest count);
#: a station is still for tens of seconds, not longer.
MIN_OUTPUT_RATE_HZ = 0.01


class Averager:
    """Cuts a stream of accepted samples into windows, by count or by time."""

    def __init__(self, samples=1, rate_hz=0.0):
        """Average every ``samples`` samples, or (``rate_hz`` > 0) each 1 / rate_hz of stamps."""
        if rate_hz < 0 or samples < 1 or (rate_hz > 0 and samples > 1):
            raise ValueError('average by a count of samples >= 1 or by an output rate > 0, '
                             f'not both (samples {samples}, rate_hz {rate_hz})')
        if 0 < rate_hz < MIN_OUTPUT_RATE_HZ:
            raise ValueError(f'an output rate of {rate_hz!r} Hz is below '
                             f'{MIN_OUTPUT_RATE_HZ:g} Hz (a window of over '
                             f'{1.0 / MIN_OUTPUT_RATE_HZ:g} s)')
        self.samples = int(samples)
        self.period_ns = round(1e9 / rate_hz) if rate_hz > 0 else None
        self._pending = None

    @property
    def pending(self):
        """Return how many samples wait in the open window."""
        return 0 if self._pending is None else self._pending[0].size

    def push(self, stamps_ns, frame_ids, raw, temperature_c, field_nT):
        """
        Add accepted samples (N rows); return the Windows this closes, or None.

        ``temperature_c``: (N,) NaN where unknown; ``field_nT``: (N, 3) NaN rows
        where none was paired.
        """
        rows = (np.asarray(stamps_ns, dtype=np.int64), np.asarray(frame_ids, dtype=object),
                np.asarray(raw, dtype=float).reshape(-1, 3),
                np.asarray(temperature_c, dtype=float).reshape(-1),
                np.asarray(field_nT, dtype=float).reshape(-1, 3))
        if self._pending is not None:
            rows = tuple(np.concatenate([old, new]) for old, new in zip(self._pending, rows))
        if rows[0].size == 0:
            return None
        if self.period_ns is None:
            key = np.arange(rows[0].size) // self.samples
            closed = key < rows[0].size // self.samples
        else:
            # A stamp earlier than the one before it (a clock reset, a replay) starts a new
            # run of periods: the open window closes there, instead of waiting for ever
            # for a later period while the samples pile up.
            run = np.concatenate([[0], np.cumsum(np.diff(rows[0]) < 0)])
            period = rows[0] // self.period_ns
            closed = (run < run[-1]) | (period < period[-1])
            key = np.column_stack([run, period])
        self._pending = tuple(column[~closed] for column in rows) if not closed.all() else None
        if not closed.any():
            return None
        _, index = np.unique(key[closed], axis=0, return_inverse=True)
        return close_windows(index.reshape(-1), *(column[closed] for column in rows))
