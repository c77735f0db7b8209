"""
Test-wide setup: DDS stays on this host, on a domain of this run's own.

Set before anything imports rclpy; child processes (the node under test) inherit it.
"""

import os
import tempfile

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = os.environ.get('INCLINO_TEST_DOMAIN_ID', str(1 + os.getpid() % 100))
os.environ.setdefault('ROS_LOG_DIR', tempfile.mkdtemp(prefix='inclino-ros-log-'))
