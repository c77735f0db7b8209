"""
``inclino demo``: the whole loop on built-in simulated data, live and offline.

1. ``inclino simulate``: a tool misaligned by gamma, beta on a virtual bench;
2. starts ``inclinometer_node`` (uncalibrated) as a child process;
3. replays the tilted stations: the node's raw answers;
4. replays the level segment and calls ``~/calibrate_level`` meanwhile;
5. replays the stations again: the node's corrected answers;
6. ``inclino process`` of the same bag with the new calibration file;
7. prints raw vs corrected vs true per station and writes a PNG plot.

DDS stays on this host on a domain of the demo's own.
"""

import json
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

RATE = 2.0  # replay speed factor


def register(subparsers):
    """Add the ``demo`` subcommand."""
    parser = subparsers.add_parser(
        'demo', help='simulate, calibrate through the live node, correct, compare, plot')
    parser.add_argument('out', nargs='?', default='demo_output',
                        help='folder for the bag, calibration, results and plot '
                             '(default: %(default)s)')
    parser.set_defaults(func=run)


def isolate_dds(log_dir):
    """Keep DDS on this host, on a domain id of this run's own; logs under ``log_dir``."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.setdefault('ROS_DOMAIN_ID', str(1 + os.getpid() % 100))
    os.environ['ROS_LOG_DIR'] = log_dir


def start_node(calibration_file, log_path):
    """Start ``inclinometer_node`` (the console script beside this Python)."""
    executable = os.path.join(os.path.dirname(sys.executable), 'inclinometer_node')
    log = open(log_path, 'w')
    return subprocess.Popen(
        [executable, '--ros-args', '-p', f'calibration_file:={calibration_file}'],
        stdout=log, stderr=subprocess.STDOUT)


class LiveSession:
    """The demo's own rclpy node: replays bag segments, records the node's surveys."""

    def __init__(self):
        """Create the publisher, the survey recorder and the service client."""
        import rclpy
        from geometry_msgs.msg import Vector3Stamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import Imu
        from std_srvs.srv import Trigger

        rclpy.init()
        self.node = rclpy.create_node('inclino_demo')
        self.publisher = self.node.create_publisher(Imu, 'imu/data_raw', QoSProfile(depth=1000))
        self.surveys = {}
        self.survey_sub = self.node.create_subscription(
            Vector3Stamped, 'survey', self._on_survey, QoSProfile(depth=1000))
        self.client = self.node.create_client(Trigger, '/inclinometer/calibrate_level')
        self.trigger = Trigger.Request
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)

    def _on_survey(self, msg):
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.surveys[stamp_ns] = (msg.vector.x, msg.vector.y)

    def spin(self, seconds):
        """Process callbacks for ``seconds``."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self.executor.spin_once(timeout_sec=min(left, 0.01))

    def wait_for_node(self, timeout_s=30.0):
        """Wait until the node's subscription, survey and service are matched."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if (self.publisher.get_subscription_count() and self.client.service_is_ready()
                    and self.survey_sub.get_publisher_count()):
                self.spin(0.3)
                return
            self.spin(0.05)
        raise RuntimeError('inclinometer_node did not come up')

    def replay(self, series):
        """Publish an ImuSeries with its timing; return the node's surveys of it."""
        from inclino_ros.cli.play import publish_timed, Timeline
        from inclino_ros.io.bag import IMU
        self.surveys = {}
        publish_timed(Timeline.of([('imu/data_raw', IMU, series)]),
                      {'imu/data_raw': self.publisher}, RATE, lambda s: self.spin(min(s, 0.01)))
        self.spin(0.5)
        answers = [self.surveys.get(stamp, (np.nan, np.nan)) for stamp in series.stamps_ns]
        received = sum(not np.isnan(a[0]) for a in answers)
        print(f'   {received} of {series.stamps_ns.size} surveys received')
        return answers

    def calibrate_during(self, series):
        """Call ~/calibrate_level while the level segment plays; return the answer."""
        from inclino_ros.cli.play import publish_timed, Timeline
        from inclino_ros.io.bag import IMU
        future = self.client.call_async(self.trigger())
        publish_timed(Timeline.of([('imu/data_raw', IMU, series)]),
                      {'imu/data_raw': self.publisher}, RATE, lambda s: self.spin(min(s, 0.01)))
        end = time.monotonic() + 15.0
        while not future.done() and time.monotonic() < end:
            self.spin(0.05)
        return future.result() if future.done() else None

    def close(self):
        """Destroy the node and shut rclpy down."""
        import rclpy
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown()


def segment(series, mask):
    """Return the messages of an ImuSeries selected by a boolean mask."""
    from dataclasses import fields
    return type(series)(*(getattr(series, f.name)[mask] for f in fields(series)))


def angle_error_deg(a, b):
    """Return a - b wrapped to [-180, 180) degrees."""
    return (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0


def station_table(truth, stamps_ns, seg, raw, corrected, offline):
    """Return one row per station: truth and the mean raw/corrected/offline answers."""
    rows = []
    for entry in truth['segments'][1:]:
        k = entry['index']
        mask = seg == k
        row = {'station': k, 'true_inclination_deg': entry['inclination_deg'],
               'true_toolface_deg': entry['toolface_deg']}
        for name, values in (('raw', raw), ('corrected', corrected), ('offline', offline)):
            incl = np.array([v[0] for v, m in zip(values, mask) if m])
            tf = np.array([v[1] for v, m in zip(values, mask) if m])
            row[f'{name}_inclination_deg'] = float(np.nanmean(incl))
            row[f'{name}_toolface_deg'] = float(
                (entry['toolface_deg'] + np.nanmean(angle_error_deg(tf, entry['toolface_deg'])))
                % 360.0)
            row[f'{name}_samples'] = int(np.count_nonzero(~np.isnan(incl)))
        rows.append(row)
    return rows


def print_table(rows):
    """Print raw vs corrected vs true per station, and the worst errors."""
    print(f'{"st":>3} {"true I":>8} {"raw I":>8} {"corr I":>8} {"err raw":>8} '
          f'{"err corr":>9} | {"true TF":>8} {"raw TF":>8} {"corr TF":>8} {"err raw":>8} '
          f'{"err corr":>9}   [deg]')
    for r in rows:
        ti, tt = r['true_inclination_deg'], r['true_toolface_deg']
        print(f'{r["station"]:>3} {ti:8.3f} {r["raw_inclination_deg"]:8.3f} '
              f'{r["corrected_inclination_deg"]:8.3f} {r["raw_inclination_deg"] - ti:8.3f} '
              f'{r["corrected_inclination_deg"] - ti:9.4f} | {tt:8.2f} '
              f'{r["raw_toolface_deg"]:8.2f} {r["corrected_toolface_deg"]:8.2f} '
              f'{angle_error_deg(r["raw_toolface_deg"], tt):8.2f} '
              f'{angle_error_deg(r["corrected_toolface_deg"], tt):9.3f}')


def plot(rows, path):
    """Write the raw and corrected errors per station as a PNG."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    true_i = np.array([r['true_inclination_deg'] for r in rows])
    fig, (ax_i, ax_t) = pyplot.subplots(2, 1, figsize=(8, 7), sharex=True)
    for name, marker in (('raw', 'o'), ('corrected', 's')):
        err_i = np.array([r[f'{name}_inclination_deg'] for r in rows]) - true_i
        err_t = angle_error_deg([r[f'{name}_toolface_deg'] for r in rows],
                                [r['true_toolface_deg'] for r in rows])
        ax_i.plot(true_i, np.abs(err_i), marker, label=name)
        ax_t.plot(true_i, np.abs(err_t), marker, label=name)
    ax_i.set_ylabel('|inclination error| [deg]')
    ax_t.set_ylabel('|toolface error| [deg]')
    ax_t.set_xlabel('true inclination [deg]')
    for ax in (ax_i, ax_t):
        ax.set_xscale('log')
        ax.set_yscale('log')
        ax.grid(True, which='both', alpha=0.3)
        ax.legend()
    ax_i.set_title('inclino_ros demo: node output before and after ~/calibrate_level')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    pyplot.close(fig)


def run(args):
    """Run the demo; exit 0 when the corrected answers beat the raw ones."""
    from inclino_ros.io.bag import concatenate, read
    from inclino_ros.cli.main import main as inclino

    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    isolate_dds(tempfile.mkdtemp(prefix='log-', dir=out))
    bag_path = os.path.join(out, 'bench')
    calibration_file = os.path.join(out, 'calibration.json')
    for stale in (calibration_file,):
        if os.path.exists(stale):
            os.unlink(stale)
    if os.path.exists(bag_path):
        import shutil
        shutil.rmtree(bag_path)
    print('== 1. simulate')
    inclino(['simulate', bag_path])
    with open(f'{bag_path}.truth.json') as stream:
        truth = json.load(stream)
    series = concatenate(read(bag_path, '/imu/data_raw'))
    seg = np.repeat(np.arange(len(truth['segments'])),
                    [s['samples'] for s in truth['segments']])
    stations = segment(series, seg > 0)

    print(f'== 2. start inclinometer_node (ROS_DOMAIN_ID={os.environ["ROS_DOMAIN_ID"]})')
    node = start_node(calibration_file, os.path.join(out, 'node.log'))
    session = LiveSession()
    try:
        session.wait_for_node()
        print(f'== 3. replay {len(truth["segments"]) - 1} stations uncalibrated ({RATE}x)')
        raw = session.replay(stations)
        print('== 4. replay the level segment and call ~/calibrate_level')
        answer = session.calibrate_during(segment(series, seg == 0))
        print(f'   {answer.message if answer else "no answer"}')
        if answer is None or not answer.success:
            return 1
        print('== 5. replay the stations calibrated')
        corrected = session.replay(stations)
    finally:
        session.close()
        node.send_signal(signal.SIGINT)
        node.wait(timeout=10)
    print('== 6. inclino process (offline) with the new calibration')
    processed = os.path.join(out, 'processed')
    if os.path.exists(processed):
        import shutil
        shutil.rmtree(processed)
    inclino(['process', bag_path, processed, '--calibration', calibration_file])
    offline_series = concatenate(read(processed, '/survey'))
    offline_by_stamp = dict(zip(offline_series.stamps_ns.tolist(),
                                map(tuple, offline_series.vector[:, :2])))
    offline = [offline_by_stamp.get(s, (np.nan, np.nan)) for s in stations.stamps_ns.tolist()]

    rows = station_table(truth, stations.stamps_ns, seg[seg > 0], raw, corrected, offline)
    print('== 7. results (mean of each station)')
    print_table(rows)
    worst = {name: max(abs(r[f'{name}_inclination_deg'] - r['true_inclination_deg'])
                       for r in rows) for name in ('raw', 'corrected', 'offline')}
    live_vs_offline = max(abs(r['corrected_inclination_deg'] - r['offline_inclination_deg'])
                          for r in rows)
    print(f'worst inclination error: raw {worst["raw"]:.4f} deg, corrected '
          f'{worst["corrected"]:.4f} deg, offline {worst["offline"]:.4f} deg; '
          f'live vs offline differ by at most {live_vs_offline:.2e} deg')
    with open(os.path.join(out, 'results.json'), 'w') as stream:
        json.dump(rows, stream, indent=2)
    png = os.path.join(out, 'demo.png')
    plot(rows, png)
    print(f'wrote {png} and {os.path.join(out, "results.json")}')
    return 0 if worst['corrected'] < worst['raw'] else 1
