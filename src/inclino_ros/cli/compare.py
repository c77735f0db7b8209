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
not compared.  Then the toolface zero RESULT's metadata states
(``stream.TOOLFACE_ZERO_KEYS``, ``unknown`` when it states none): a
toolface relative to the sensor board is off the truth by the board's roll.
"""

import sys

from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import between, inclination_deg
from inclino_ros.io.bag import (
    BagError, concatenate, custom_data, read, topic_info, VECTOR3_STAMPED)
from inclino_ros.report.compare import (
    corrected_vectors, number, simulated_segments, station_rows, table_lines, worst)
from inclino_ros.stream import TOOLFACE_ZERO_KEYS
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
        metadata = custom_data(args.result)
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
    zero, meaning = (metadata.get(key) for key in TOOLFACE_ZERO_KEYS)
    print(f'toolface_zero: {zero or "unknown"}\ntoolface_zero_meaning: '
          + (meaning or f'{args.result} does not say (not written by inclino process)'))
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
