"""The demo's own ROS domain: one where no other ROS node is seen, unless it is told one."""

import os

from inclino_ros.cli.demo import choose_private_domain, isolate_dds
import rclpy


def test_a_domain_with_another_node_on_it_is_not_taken(ros):
    """A node on the shell's domain (this test's): the demo does not take that domain."""
    domain = int(os.environ['ROS_DOMAIN_ID'])
    foreign = rclpy.create_node('someone_elses_node')
    try:
        assert choose_private_domain(candidates=[domain]) is None
    finally:
        foreign.destroy_node()
    assert choose_private_domain(candidates=[domain]) == domain
    assert choose_private_domain(exclude={domain}, candidates=[domain]) is None


def test_told_a_domain_the_demo_takes_it_and_says_so(tmp_path, monkeypatch, capsys):
    """--domain-id N: that domain, this host only, and the demo prints which."""
    monkeypatch.setenv('ROS_DOMAIN_ID', '7')
    monkeypatch.delenv('ROS_AUTOMATIC_DISCOVERY_RANGE', raising=False)
    monkeypatch.setenv('ROS_LOG_DIR', os.environ['ROS_LOG_DIR'])
    assert isolate_dds(str(tmp_path), domain_id=45) == 45
    assert os.environ['ROS_DOMAIN_ID'] == '45'
    assert os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    assert 'ROS domain 45 (given with --domain-id)' in capsys.readouterr().out
