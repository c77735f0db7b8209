"""
Test-wide setup: DDS stays on this host, on a domain of this run's own; node fixtures.

The environment is set here, before any test calls ``rclpy.init``; child
processes (the node under test) inherit it.

Hypothesis runs the same examples on every run (``derandomize``) and keeps no
database: a failure reproduces anywhere, and a run never replays an example
an older run found (from ``.hypothesis/``) against a changed test.  To search
afresh, ``INCLINO_HYPOTHESIS=explore`` (random examples, still no database).
"""

import os
import tempfile

from hypothesis import settings
import pytest
import rclpy
from ros_harness import NodeProcess, Probe

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = os.environ.get('INCLINO_TEST_DOMAIN_ID', str(1 + os.getpid() % 100))
os.environ.setdefault('ROS_LOG_DIR', tempfile.mkdtemp(prefix='inclino-ros-log-'))

# Loaded before any test module builds its settings(...), which inherit these.
settings.register_profile('reproducible', derandomize=True, database=None, print_blob=True)
settings.register_profile('explore', derandomize=False, database=None, print_blob=True)
settings.load_profile(os.environ.get('INCLINO_HYPOTHESIS', 'reproducible'))


@pytest.fixture(scope='module')
def ros():
    """Initialise rclpy once for the module."""
    rclpy.init()
    yield
    rclpy.shutdown()


#: Characters of each node's log a failed test shows.
LOG_TAIL_CHARS = 4000


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Show, for a failed test, the end of each node's log and whether the node still ran."""
    outcome = yield
    report = outcome.get_result()
    if report.when == 'call' and report.failed:
        for node in getattr(item, 'inclino_nodes', ()):
            code = node.process.poll()
            report.sections.append((
                f'{node.log_path} ({"running" if code is None else f"exited {code}"})',
                node.log()[-LOG_TAIL_CHARS:]))


@pytest.fixture
def start_node(tmp_path, ros, request):
    """
    Return a starter of ``inclinometer_node`` processes, all stopped after the test.

    Its files go to ``tmp_path``; diagnostics come every 0.5 s.  A failed test
    shows the end of each node's log (``pytest_runtest_makereport``).
    """
    started = request.node.inclino_nodes = []

    def start(**parameters):
        parameters.setdefault('calibration_file', str(tmp_path / 'calibration.json'))
        parameters.setdefault('stations_file', str(tmp_path / 'stations.json'))
        parameters.setdefault('diagnostics_period_s', 0.5)
        node = NodeProcess(str(tmp_path / f'node{len(started)}.log'), **parameters)
        started.append(node)
        return node

    yield start
    for node in started:
        node.stop()


@pytest.fixture
def probe(ros):
    """Return a probe node, destroyed after the test."""
    probe = Probe()
    yield probe
    probe.destroy()
