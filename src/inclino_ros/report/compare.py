"""
The comparison of a corrected run with its truth (``inclino compare``, ``inclino demo``).

Per station (a run of equal truth, or a simulated segment of
``OUT.truth.json``): the signed error of the mean inclination, toolface and
azimuth, and how many samples were compared; rendered as a text table.
"""

import json

from inclino_ros.core.msa import azimuth_difference_deg
from inclino_ros.io.bag import BagError, concatenate, read
import numpy as np

#: The corrected specific force ``inclino process`` writes.
IMU_TOPIC = '/imu/data'


def stations(truth):
    """Return (label, start, stop) of each run of equal rows of ``truth`` (N, 3), NaN = NaN."""
    marked = np.where(np.isnan(truth), np.inf, truth)
    change = np.flatnonzero(np.any(marked[1:] != marked[:-1], axis=1)) + 1
    bounds = np.concatenate([[0], change, [truth.shape[0]]])
    return [('', a, b) for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist())]


def simulated_segments(truth_path, stamps_ns):
    """
    Return (label, start, stop) of the segments in ``TRUTH.truth.json``, None without one.

    ``inclino simulate`` writes the file: each segment's kind (level, station,
    position, heating, rotation) and first and last stamp.
    """
    try:
        with open(f'{truth_path.rstrip("/")}.truth.json') as stream:
            records = json.load(stream)['segments']
    except (OSError, ValueError, KeyError):
        return None
    return [(record['kind'], int(np.searchsorted(stamps_ns, record['start_ns'])),
             int(np.searchsorted(stamps_ns, record['end_ns'], side='right')))
            for record in records]


def station_rows(truth, result, min_inclination_deg=5.0, segments=None, vectors=None):
    """
    Return one dict per station: its truth, the signed error of its mean, counts.

    ``truth`` and ``result`` are (N, 3) aligned rows of (inclination,
    toolface, azimuth) [deg]; NaN results (not received, not trusted) are
    left out and counted.  ``segments``: (label, start, stop) rows, by default
    the runs of equal truth.  Each sample is compared with its own truth (a
    rotation changes the toolface from sample to sample); the inclination
    error is that of the mean direction, the toolface and azimuth errors are
    means of the wrapped differences, NaN within ``min_inclination_deg`` of
    vertical (up or down: upside down they are as undefined).  A
    truth that varies within the station is given as None (and no mean value).
    ``vectors``: (N, 3) corrected specific forces aligned with ``result``
    (RESULT's ``/imu/data``, NaN where none): at a station whose true toolface
    does not turn, the inclination is that of their mean direction, which
    needs no toolface (NaN near vertical, ``toolface_max_std_deg``).
    """
    rows = []
    for label, start, stop in segments or stations(truth):
        true, got = truth[start:stop], result[start:stop]
        constant = np.all((true == true[0]) | np.isnan(true), axis=0)
        true_incl = float(np.mean(true[:, 0]))
        row = {'label': label, 'samples': int(np.count_nonzero(np.isfinite(got[:, 0]))),
               'azimuth_samples': int(np.count_nonzero(np.isfinite(got[:, 2])))}
        row.update({f'true_{name}_deg': float(true[0, k]) if constant[k] else None
                    for k, name in enumerate(('inclination', 'toolface', 'azimuth'))})
        # In the truth's toolface frame, a turning tool's samples line up for the mean.
        relative = np.column_stack([got[:, 0], got[:, 1] - np.nan_to_num(true[:, 1])])
        row['inclination_error_deg'] = mean_inclination_deg(relative) - true_incl
        if vectors is not None and constant[1]:
            row['inclination_error_deg'] = mean_vector_inclination_deg(
                vectors[start:stop][np.isfinite(got[:, 0])]) - true_incl
        for k, name in ((1, 'toolface'), (2, 'azimuth')):
            both = np.isfinite(got[:, k]) & np.isfinite(true[:, k])
            row[f'{name}_error_deg'] = float(
                np.mean(azimuth_difference_deg(got[both, k], true[both, k]))
                if both.any() and min_inclination_deg <= true_incl <= 180.0 - min_inclination_deg
                else np.nan)
        for k, name in enumerate(('inclination', 'toolface', 'azimuth')):
            if row[f'true_{name}_deg'] is not None:
                mean = row[f'true_{name}_deg'] + row[f'{name}_error_deg']
                row[f'{name}_deg'] = float(mean if k == 0 else mean % 360.0)
        rows.append(row)
    return rows


def mean_vector_inclination_deg(vectors):
    """Return the inclination of the mean unit direction of ``vectors`` (N, 3) [deg]."""
    vectors = vectors[np.all(np.isfinite(vectors), axis=1)]
    norms = np.linalg.norm(vectors, axis=1)
    if not np.any(norms > 0.0):
        return np.nan
    mean = np.mean(vectors[norms > 0.0] / norms[norms > 0.0, None], axis=0)
    return float(np.degrees(np.arctan2(np.hypot(mean[0], mean[1]), mean[2])))


def mean_inclination_deg(angles_deg):
    """
    Return the inclination of the mean direction of (inclination, toolface) rows [deg].

    Averaging the angles themselves would bias a near-vertical station: an
    inclination is never negative, so noise about 0 deg averages above it.
    A sample without a toolface (NaN: its 1 sigma too large that near
    vertical, ``toolface_max_std_deg``) still has its inclination: its
    direction across the axis is taken as that of the samples with a
    toolface (their mean), or any one when none has; a station without any
    toolface thus averages its inclinations.  NaN inclinations are left out.
    """
    rows = angles_deg[np.isfinite(angles_deg[:, 0])]
    if not rows.size:
        return np.nan
    incl, toolface = np.radians(rows[:, 0]), np.radians(rows[:, 1])
    known = np.isfinite(toolface)
    across = np.sin(incl)
    x = np.sum(across[known] * np.cos(toolface[known]))
    y = np.sum(across[known] * np.sin(toolface[known]))
    # the samples without a toolface lie along the known mean (their best guess)
    horizontal = np.hypot(x, y) + np.sum(across[~known])
    return float(np.degrees(np.arctan2(horizontal / rows.shape[0], np.mean(np.cos(incl)))))


def worst(rows, name):
    """Return the largest |station mean error| of ``name`` (NaN when none was compared)."""
    errors = [abs(r[f'{name}_error_deg']) for r in rows if np.isfinite(r[f'{name}_error_deg'])]
    return max(errors) if errors else np.nan


def number(value, width, decimals):
    """Return ``value`` right-aligned in ``width`` with ``decimals``, a dash for NaN."""
    return f'{value:{width}.{decimals}f}' if np.isfinite(value) else f'{"-":>{width}}'


def table_lines(rows):
    """Return the per-station table of ``station_rows`` as text lines ('var': truth varies)."""
    def true(value, decimals):
        return f'{"var":>8}' if value is None else number(value, 8, decimals)

    lines = [f'{"st":>3} {"kind":<8} {"samples":>7} {"true I":>8} {"err I":>9} | '
             f'{"true TF":>8} {"err TF":>8} | {"true Az":>8} {"err Az":>8} {"trusted":>7}'
             '   [deg]']
    for k, r in enumerate(rows):
        lines.append(
            f'{k:>3} {r["label"]:<8} {r["samples"]:>7} {true(r["true_inclination_deg"], 3)} '
            f'{number(r["inclination_error_deg"], 9, 4)} | '
            f'{true(r["true_toolface_deg"], 2)} {number(r["toolface_error_deg"], 8, 3)} | '
            f'{true(r["true_azimuth_deg"], 2)} {number(r["azimuth_error_deg"], 8, 3)} '
            f'{r["azimuth_samples"]:>7}')
    return lines


def corrected_vectors(path, stamps_ns):
    """
    Return RESULT's corrected specific forces aligned with ``stamps_ns``, or None.

    From ``/imu/data`` (what ``inclino process`` writes), NaN where a stamp
    has none; None when RESULT has no such topic.
    """
    try:
        imu = concatenate(read(path, IMU_TOPIC))
        acceleration = imu.linear_acceleration_mps2
    except (BagError, IndexError, AttributeError):
        return None
    _, at_truth, at_result = np.intersect1d(stamps_ns, imu.stamps_ns, return_indices=True)
    vectors = np.full((len(stamps_ns), 3), np.nan)
    vectors[at_truth] = acceleration[at_result]
    return vectors
