"""
``inclino compare``: corrected angles against the truth of a simulation, per station.

Reads ``/survey`` of RESULT (what ``inclino process`` writes: x inclination,
y toolface, z azimuth, in degrees) and ``/truth/survey`` of TRUTH (what
``inclino simulate`` writes), pairs them by stamp, splits the run into
stations (consecutive samples of the same true attitude) and prints, per
station, the truth and the signed error of the station mean; then the worst
of them.  The toolface and the azimuth are compared where the true
inclination is at least ``--min-inclination-deg`` (near vertical both are
ill-defined); an azimuth the chain withheld (NaN: not trusted) is counted,
not compared.
"""

import json
import sys

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import between, inclination_deg
from inclino_ros.io.bag import BagError, concatenate, read, topic_info, VECTOR3_STAMPED
import numpy as np

RESULT_TOPIC = '/survey'
TRUTH_TOPIC = '/truth/survey'
IMU_TOPIC = '/imu/data'


def register(subparsers):
    """Add the ``compare`` subcommand."""
    parser = add_command(
        subparsers, 'compare', 'corrected angles against the truth of a simulation, per station',
        'Compare the corrected angles of RESULT (/survey, what inclino process writes) with '
        'the truth of TRUTH (/truth/survey, what inclino simulate writes), sample by sample '
        '(same stamps), and print per station (samples of one true attitude) the truth and '
        'the signed error of the station mean, then the worst.',
        'Toolface and azimuth are compared where the tool is at least --min-inclination-deg '
        'off vertical (near vertical, up or down, both are ill-defined); an azimuth that was '
        'not trusted (NaN) is counted, not compared.',
        'Exit 0, or 1 when a station mean inclination or azimuth is off by more than '
        '--max-error-deg.')
    parser.add_argument('result', metavar='RESULT', help='bag written by inclino process')
    parser.add_argument('truth', metavar='TRUTH', help='bag written by inclino simulate')
    parser.add_argument('--topic', default=RESULT_TOPIC,
                        help='Vector3Stamped topic of RESULT (default: %(default)s)')
    parser.add_argument('--truth-topic', default=TRUTH_TOPIC,
                        help='Vector3Stamped topic of TRUTH (default: %(default)s)')
    parser.add_argument('--min-inclination-deg', type=inclination_deg, default=5.0,
                        metavar='DEG',
                        help='compare toolface and azimuth where the tool is this far off '
                             'vertical (default: %(default)s)')
    parser.add_argument('--max-error-deg', type=between(0.0, 180.0), metavar='DEG',
                        help='exit 1 when a station mean inclination, or azimuth, is off by '
                             'more (default: no limit)')
    parser.set_defaults(func=run)


def angle_error_deg(a, b):
    """Return a - b wrapped to [-180, 180) degrees."""
    return (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0


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
                np.mean(angle_error_deg(got[both, k], true[both, k]))
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


def run(args):
    """Compare RESULT with TRUTH; return the exit code."""
    try:
        for path, topic, option in ((args.truth, args.truth_topic, '--truth-topic'),
                                    (args.result, args.topic, '--topic')):
            msgtype = topic_info(path, topic)[0]
            if msgtype != VECTOR3_STAMPED:
                raise BagError(f'{topic} in {path} holds {msgtype}, not {VECTOR3_STAMPED} '
                               f'({option} names the angles: /survey)')
        truth = concatenate(read(args.truth, args.truth_topic))
        result = concatenate(read(args.result, args.topic))
    except (BagError, IndexError) as err:
        print(f'inclino compare: error: {err or "an empty topic"}', file=sys.stderr)
        return 2
    _, at_truth, at_result = np.intersect1d(truth.stamps_ns, result.stamps_ns,
                                            return_indices=True)
    if at_truth.size == 0:
        print(f'inclino compare: error: no stamp of {args.topic} in {args.result} is one of '
              f'{args.truth_topic} in {args.truth}: nothing compared (a RESULT of another '
              'TRUTH?)', file=sys.stderr)
        return 2
    aligned = np.full(truth.vector.shape, np.nan)   # a sample without a result: NaN
    aligned[at_truth] = result.vector[at_result]
    rows = station_rows(truth.vector, aligned, args.min_inclination_deg,
                        simulated_segments(args.truth, truth.stamps_ns),
                        corrected_vectors(args.result, truth.stamps_ns))
    print('\n'.join(table_lines(rows)))
    bad = {name: worst(rows, name) for name in ('inclination', 'toolface', 'azimuth')}
    print(f'{at_truth.size} of {truth.stamps_ns.size} truth samples have a result; worst station '
          f'mean error: inclination {number(bad["inclination"], 0, 4)} deg, toolface '
          f'{number(bad["toolface"], 0, 3)} deg, azimuth {number(bad["azimuth"], 0, 3)} deg '
          f'(toolface and azimuth {args.min_inclination_deg:g} deg or more off vertical)')
    limit = args.max_error_deg
    if limit is not None and not np.isfinite(bad['inclination']):
        print('inclino compare: error: no station mean was compared, so none is within '
              f'--max-error-deg {limit:g}', file=sys.stderr)
        return 2
    if limit is not None and not (bad['inclination'] <= limit
                                  and not bad['azimuth'] > limit):
        print(f'inclino compare: a station mean is off by more than {limit:g} deg',
              file=sys.stderr)
        return 1
    return 0
