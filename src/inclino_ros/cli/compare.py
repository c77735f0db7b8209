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

import sys

from inclino_ros.cli.helptext import add_command
from inclino_ros.io.bag import BagError, concatenate, read
import numpy as np

RESULT_TOPIC = '/survey'
TRUTH_TOPIC = '/truth/survey'


def register(subparsers):
    """Add the ``compare`` subcommand."""
    parser = add_command(
        subparsers, 'compare', 'corrected angles against the truth of a simulation, per station',
        'Compare the corrected angles of RESULT (/survey, what inclino process writes) with '
        'the truth of TRUTH (/truth/survey, what inclino simulate writes), sample by sample '
        '(same stamps), and print per station (samples of one true attitude) the truth and '
        'the signed error of the station mean, then the worst.',
        'Toolface and azimuth are compared where the true inclination is at least '
        '--min-inclination-deg (near vertical both are ill-defined); an azimuth that was not '
        'trusted (NaN) is counted, not compared.',
        'Exit 0, or 1 when a station mean inclination or azimuth is off by more than '
        '--max-error-deg.')
    parser.add_argument('result', metavar='RESULT', help='bag written by inclino process')
    parser.add_argument('truth', metavar='TRUTH', help='bag written by inclino simulate')
    parser.add_argument('--topic', default=RESULT_TOPIC,
                        help='Vector3Stamped topic of RESULT (default: %(default)s)')
    parser.add_argument('--truth-topic', default=TRUTH_TOPIC,
                        help='Vector3Stamped topic of TRUTH (default: %(default)s)')
    parser.add_argument('--min-inclination-deg', type=float, default=5.0, metavar='DEG',
                        help='compare toolface and azimuth from this true inclination on '
                             '(default: %(default)s)')
    parser.add_argument('--max-error-deg', type=float, metavar='DEG',
                        help='exit 1 when a station mean inclination, or azimuth, is off by '
                             'more (default: no limit)')
    parser.set_defaults(func=run)


def angle_error_deg(a, b):
    """Return a - b wrapped to [-180, 180) degrees."""
    return (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0


def stations(truth):
    """Return (start, stop) of each run of equal rows of ``truth`` (N, 3), NaN equal to NaN."""
    marked = np.where(np.isnan(truth), np.inf, truth)
    change = np.flatnonzero(np.any(marked[1:] != marked[:-1], axis=1)) + 1
    bounds = np.concatenate([[0], change, [truth.shape[0]]])
    return list(zip(bounds[:-1].tolist(), bounds[1:].tolist()))


def station_rows(truth, result, min_inclination_deg=5.0):
    """
    Return one dict per station: truth, station means of ``result`` and signed errors.

    ``truth`` and ``result`` are (N, 3) aligned rows of (inclination,
    toolface, azimuth) [deg]; NaN results (not received, not trusted) are
    left out of the means and counted.  The station inclination is that of
    the mean direction; the toolface and azimuth errors are means of the
    wrapped differences, NaN below ``min_inclination_deg`` of true inclination.
    """
    rows = []
    for start, stop in stations(truth):
        true = truth[start]
        got = result[start:stop]
        row = {'samples': int(np.count_nonzero(np.isfinite(got[:, 0]))),
               'true_inclination_deg': float(true[0]), 'true_toolface_deg': float(true[1]),
               'true_azimuth_deg': float(true[2]),
               'azimuth_samples': int(np.count_nonzero(np.isfinite(got[:, 2])))}
        for k, name in enumerate(('inclination', 'toolface', 'azimuth')):
            if k == 0:
                error = mean_inclination_deg(got[:, :2]) - true[0]
            else:
                finite = np.isfinite(got[:, k])
                error = (np.mean(angle_error_deg(got[finite, k], true[k]))
                         if finite.any() and np.isfinite(true[k])
                         and true[0] >= min_inclination_deg else np.nan)
            row[f'{name}_error_deg'] = float(error)
            mean = true[k] + error
            row[f'{name}_deg'] = float(mean if k == 0 else mean % 360.0)
        rows.append(row)
    return rows


def mean_inclination_deg(angles_deg):
    """
    Return the inclination of the mean direction of (inclination, toolface) rows [deg].

    Averaging the angles themselves would bias a near-vertical station: an
    inclination is never negative, so noise about 0 deg averages above it.
    A NaN toolface (undefined near vertical) counts as 0; NaN rows are left out.
    """
    rows = angles_deg[np.isfinite(angles_deg[:, 0])]
    if not rows.size:
        return np.nan
    incl, toolface = np.radians(rows[:, 0]), np.radians(np.nan_to_num(rows[:, 1]))
    x, y = (np.mean(np.sin(incl) * f(toolface)) for f in (np.cos, np.sin))
    return float(np.degrees(np.arctan2(np.hypot(x, y), np.mean(np.cos(incl)))))


def worst(rows, name):
    """Return the largest |station mean error| of ``name`` (NaN when none was compared)."""
    errors = [abs(r[f'{name}_error_deg']) for r in rows if np.isfinite(r[f'{name}_error_deg'])]
    return max(errors) if errors else np.nan


def number(value, width, decimals):
    """Return ``value`` right-aligned in ``width`` with ``decimals``, a dash for NaN."""
    return f'{value:{width}.{decimals}f}' if np.isfinite(value) else f'{"-":>{width}}'


def table_lines(rows):
    """Return the per-station table of ``station_rows`` as text lines."""
    lines = [f'{"st":>3} {"samples":>7} {"true I":>8} {"err I":>9} | {"true TF":>8} '
             f'{"err TF":>8} | {"true Az":>8} {"err Az":>8} {"trusted":>7}   [deg]']
    for k, r in enumerate(rows):
        lines.append(
            f'{k:>3} {r["samples"]:>7} {number(r["true_inclination_deg"], 8, 3)} '
            f'{number(r["inclination_error_deg"], 9, 4)} | '
            f'{number(r["true_toolface_deg"], 8, 2)} {number(r["toolface_error_deg"], 8, 3)} | '
            f'{number(r["true_azimuth_deg"], 8, 2)} {number(r["azimuth_error_deg"], 8, 3)} '
            f'{r["azimuth_samples"]:>7}')
    return lines


def run(args):
    """Compare RESULT with TRUTH; return the exit code."""
    try:
        truth = concatenate(read(args.truth, args.truth_topic))
        result = concatenate(read(args.result, args.topic))
    except (BagError, IndexError) as err:
        print(f'inclino compare: error: {err or "an empty topic"}', file=sys.stderr)
        return 2
    _, at_truth, at_result = np.intersect1d(truth.stamps_ns, result.stamps_ns,
                                            return_indices=True)
    aligned = np.full(truth.vector.shape, np.nan)   # a sample without a result: NaN
    aligned[at_truth] = result.vector[at_result]
    rows = station_rows(truth.vector, aligned, args.min_inclination_deg)
    print('\n'.join(table_lines(rows)))
    bad = {name: worst(rows, name) for name in ('inclination', 'toolface', 'azimuth')}
    print(f'{at_truth.size} of {truth.stamps_ns.size} truth samples have a result; worst station '
          f'mean error: inclination {bad["inclination"]:.4f} deg, toolface '
          f'{bad["toolface"]:.3f} deg, azimuth {bad["azimuth"]:.3f} deg (toolface and azimuth '
          f'where the true inclination >= {args.min_inclination_deg:g} deg)')
    limit = args.max_error_deg
    if limit is not None and not (bad['inclination'] <= limit
                                  and not bad['azimuth'] > limit):
        print(f'inclino compare: a station mean is off by more than {limit:g} deg',
              file=sys.stderr)
        return 1
    return 0
