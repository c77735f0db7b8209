"""
Test-wide setup: DDS stays on this host, on a domain of this run's own; node fixtures.

The environment is set here, before any test calls ``rclpy.init``; child
processes (the node under test) inherit it.
"""

import os
import tempfile

import pytest
import rclpy
from ros_harness import NodeProcess, Probe

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = os.environ.get('INCLINO_TEST_DOMAIN_ID', str(1 + os.getpid() % 100))
os.environ.setdefault('ROS_LOG_DIR', tempfile.mkdtemp(prefix='inclino-ros-log-'))


@pytest.fixture(scope='module')
def ros():
    """Initialise rclpy once for the module."""
    rclpy.init()
    yield
    rclpy.shutdown()


@pytest.fixture
def start_node(tmp_path, ros):
    """
    Return a starter of ``inclinometer_node`` processes, all stopped after the test.

    Its files go to ``tmp_path``; diagnostics come every 0.5 s.
    """
    started = []

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
