"""
``inclino demo``: the whole loop on built-in simulated data, live and offline.

1. ``inclino simulate``: a tool misaligned by gamma, beta on a virtual bench;
2. starts ``inclinometer_node`` (uncalibrated) as a child process;
3. replays the tilted stations: the node's raw answers;
4. replays the level segment and calls ``~/calibrate_level`` meanwhile;
5. replays the stations again: the node's corrected answers;
6. ``inclino process`` of the same bag with the new calibration file;
7. prints raw vs corrected vs true per station and writes a PNG plot.

DDS stays on this host, on a ROS domain of the demo's own: one on which no
other ROS node is seen (a node of the user's own domain would otherwise feed
the demo's node and change its answers), unless ``--domain-id`` names one.
The demo's files in OUT (the bag, its truth, the calibration file, the
processed bag, the results and the plot) are refused when they exist unless
``--force`` (``scripts/demo`` passes it for its own ``demo_output`` folder
only).
"""

import json
import os
import signal
import subprocess
import sys
import tempfile

from inclino_ros.calibration.model import load_model
from inclino_ros.cli.helptext import add_command
from inclino_ros.cli.options import add_force_argument
from inclino_ros.io.bag import concatenate, read
from inclino_ros.io.files import Outputs
from inclino_ros.node.domain import (  # noqa: F401 (choose_private_domain: public here too)
    choose_private_domain, isolate_dds)
from inclino_ros.node.session import DemoSession
from inclino_ros.report.demo import plot, station_table, table_lines
import numpy as np

RATE = 2.0  # replay speed factor
#: The demo's files in its folder.
DEMO_FILES = ('bench', 'bench.truth.json', 'calibration.json', 'processed', 'results.json',
              'demo.png')
#: Accuracy target of a corrected inclination [deg] (a tilt error of this size).
TARGET_DEG = 0.01


def register(subparsers):
    """Add the ``demo`` subcommand."""
    parser = add_command(
        subparsers, 'demo',
        'the whole loop on simulated data: calibrate the live node, correct, compare, plot',
        'Simulate a tool whose sensor is mounted 0.8 and -1.2 deg off, start the inclinometer '
        'node, replay the stations into it, calibrate it on the level segment through its '
        'service, replay the stations again, correct the same recording offline, and print '
        'and plot raw, corrected and true angles per station.',
        'Runs on a ROS domain of its own, one where no other ROS node is seen, on this host '
        'only (it says which), unless --domain-id names one. Exit 0 when the corrected '
        'answers beat the raw ones.')
    parser.add_argument('out', nargs='?', default='demo_output',
                        help='folder for the bag, calibration, results and plot '
                             '(default: %(default)s)')
    add_force_argument(parser)
    parser.add_argument('--domain-id', type=int, metavar='N',
                        help='run on ROS domain N (default: a free one of its own)')
    parser.set_defaults(func=run)


def accelerometer_noise_mps2(truth):
    """
    Return the simulated accelerometer noise [m/s^2] of a truth file (``inclino simulate``).

    The physical model's triad records it (``sensor_model.truth_dict``): one value, or one
    per axis, of which the largest.
    """
    return float(np.max(truth['tool']['accelerometer']['noise_std']))


def start_node(calibration_file, log_path, noise_std_mps2):
    """Start ``inclinometer_node`` (the console script beside this Python), told the noise."""
    executable = os.path.join(os.path.dirname(sys.executable), 'inclinometer_node')
    log = open(log_path, 'w')
    return subprocess.Popen(
        [executable, '--ros-args', '-p', f'calibration_file:={calibration_file}',
         '-p', f'accelerometer_noise_std_mps2:={noise_std_mps2}'],
        stdout=log, stderr=subprocess.STDOUT)


def segment(series, mask):
    """Return the messages of an ImuSeries selected by a boolean mask."""
    from dataclasses import fields
    return type(series)(*(getattr(series, f.name)[mask] for f in fields(series)))


def run(args):
    """Run the demo; exit 0 when the corrected answers beat the raw ones."""
    from inclino_ros.cli.main import main as inclino

    out = os.path.abspath(args.out)
    outputs = Outputs(force=args.force)
    for name in DEMO_FILES:
        outputs.check(os.path.join(out, name))
    force = ['--force'] if args.force else []
    os.makedirs(out, exist_ok=True)
    try:
        isolate_dds(tempfile.mkdtemp(prefix='log-', dir=out), args.domain_id)
    except RuntimeError as err:
        print(f'inclino demo: error: {err}', file=sys.stderr)
        return 2
    bag_path = os.path.join(out, 'bench')
    calibration_file = os.path.join(out, 'calibration.json')
    processed = os.path.join(out, 'processed')
    if os.path.exists(calibration_file):  # --force: the node must start uncalibrated
        os.unlink(calibration_file)
    print('== 1. simulate')
    if inclino(['simulate', bag_path] + force) != 0:
        return 2
    with open(f'{bag_path}.truth.json') as stream:
        truth_doc = json.load(stream)
    segments = truth_doc['segments']
    series = concatenate(read(bag_path, '/imu/data_raw'))
    truth = concatenate(read(bag_path, '/truth/survey')).vector
    seg = np.repeat(np.arange(len(segments)), [s['samples'] for s in segments])
    stations = segment(series, seg > 0)

    print('== 2. start inclinometer_node')
    noise_std_mps2 = accelerometer_noise_mps2(truth_doc)
    node = start_node(calibration_file, os.path.join(out, 'node.log'), noise_std_mps2)
    try:
        with DemoSession(RATE) as session:
            session.wait_for_node()
            print(f'== 3. replay {len(segments) - 1} stations uncalibrated ({RATE}x)')
            raw = session.replay(stations)
            print('== 4. replay the level segment and call ~/calibrate_level')
            answer = session.calibrate_during(segment(series, seg == 0))
            print(f'   {answer.message if answer else "no answer"}')
            if answer is None or not answer.success:
                return 1
            print('== 5. replay the stations calibrated')
            corrected = session.replay(stations)
    finally:
        node.send_signal(signal.SIGINT)
        node.wait(timeout=10)
    print('== 6. inclino process (offline) with the new calibration')
    if inclino(['process', bag_path, processed, '--calibration', calibration_file,
                '--noise-mps2', str(noise_std_mps2)] + force) != 0:
        return 2
    offline_series = concatenate(read(processed, '/survey'))
    offline_by_stamp = dict(zip(offline_series.stamps_ns.tolist(),
                                map(tuple, offline_series.vector)))
    offline = np.array([offline_by_stamp.get(s, (np.nan,) * 3)
                        for s in stations.stamps_ns.tolist()])

    rows = station_table(truth[seg > 0], {'raw': raw, 'corrected': corrected,
                                          'offline': offline})
    print('== 7. results (mean of each station)')
    print('\n'.join(table_lines(rows)))
    worst = {name: max(abs(r[f'{name}_inclination_deg'] - r['true_inclination_deg'])
                       for r in rows) for name in ('raw', 'corrected', 'offline')}
    live_vs_offline = max(abs(r['corrected_inclination_deg'] - r['offline_inclination_deg'])
                          for r in rows)
    print(f'worst inclination error: raw {worst["raw"]:.4f} deg, corrected '
          f'{worst["corrected"]:.4f} deg, offline {worst["offline"]:.4f} deg; '
          f'live vs offline differ by at most {live_vs_offline:.2e} deg')
    # What the corrected toolfaces' zero is tied to (issue 19 item 6).
    print('\n'.join(load_model(calibration_file).toolface_zero_lines))
    png = os.path.join(out, 'demo.png')
    with outputs:
        with open(outputs.path(os.path.join(out, 'results.json')), 'x') as stream:
            json.dump(rows, stream, indent=2)
        plot(rows, outputs.path(png), TARGET_DEG)
    print(f'wrote {png} and {os.path.join(out, "results.json")}')
    return 0 if worst['corrected'] < worst['raw'] else 1
