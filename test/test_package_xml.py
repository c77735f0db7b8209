"""
package.xml is what rosdep and colcon read: well-formed, format 3, ament_python.

A manifest that is not well-formed XML makes colcon take the package for a plain
Python one (no ament index, ``ros2 run`` cannot find it) and stops rosdep; it is
parsed here the way catkin_pkg (colcon-ros, rosdep) parses it.
"""

import os
from xml.dom import minidom

from catkin_pkg.package import parse_package
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MANIFEST = os.path.join(ROOT, 'package.xml')


@pytest.fixture(scope='module')
def package():
    """Return the manifest as catkin_pkg parses it (with its warnings)."""
    warnings = []
    return parse_package(MANIFEST, warnings=warnings), warnings


def test_manifest_is_well_formed_xml():
    """The manifest parses as XML (no ``--`` inside a comment, for one)."""
    minidom.parse(MANIFEST)


def test_manifest_is_format_3_ament_python(package):
    """catkin_pkg reads it as format 3 of an ament_python package, without warnings."""
    manifest, warnings = package
    assert manifest.package_format == 3
    assert manifest.name == 'inclino_ros'
    assert manifest.get_build_type() == 'ament_python'
    assert warnings == []
    manifest.validate()


def test_manifest_and_setup_py_agree(package):
    """The version and the license are the same in package.xml and setup.py."""
    manifest, _ = package
    with open(os.path.join(ROOT, 'setup.py')) as stream:
        setup_py = stream.read()
    assert f"version='{manifest.version}'" in setup_py
    assert manifest.licenses == ['Apache-2.0']
    assert "license='Apache-2.0'" in setup_py


# Every rosdep key of the manifest, each found in rosdistro (rosdep/python.yaml for the
# python3-* keys, jazzy/distribution.yaml for the ROS packages; checked at rosdistro
# 8468e88, 2026-08).  A key rosdistro does not define stops ``rosdep install``: a
# dependency without one stays out of package.xml and is optional in the code.
ROSDISTRO_KEYS = {
    'rclpy', 'sensor_msgs', 'geometry_msgs', 'std_msgs', 'std_srvs', 'diagnostic_msgs',
    'rcl_interfaces', 'ament_flake8', 'ament_pep257', 'ament_index_python',
    'python3-numpy', 'python3-transforms3d', 'python3-matplotlib', 'python3-scipy',
    'python3-tqdm', 'python3-rosbags-pip', 'python3-catkin-pkg-modules', 'python3-pytest',
    'python3-hypothesis', 'python3-yaml',
}


def test_every_rosdep_key_is_one_rosdistro_defines(package):
    """No key of the manifest is missing from rosdistro (python3-pygeomag-pip was)."""
    manifest, _ = package
    keys = {dependency.name for dependency in (
        manifest.build_depends + manifest.buildtool_depends + manifest.build_export_depends
        + manifest.exec_depends + manifest.test_depends + manifest.doc_depends)}
    assert keys - ROSDISTRO_KEYS == set()
