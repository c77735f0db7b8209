"""
Axes maps: a sensor mounted any way round reads, after its map, what a true-mounted one reads.

The expected matrices are written out by hand from the map's meaning (tool x, y, z in
turn: the signed sensor axis along it); the rotations against transforms3d.
"""

import math

from hypothesis import given, settings
from hypothesis import strategies as st
from inclino_ros.calibration.model import CalibrationModel
from inclino_ros.core.mounting import (
    axes_map_matrix, keeps_axial, to_sensor_axes, to_tool_axes)
from inclino_ros.pipeline import run, Settings
import numpy as np
import pytest
from transforms3d.euler import euler2mat

G = 9.80665


def test_signed_permutations_written_out():
    """-Y+X+Z: tool x = -sensor y, tool y = sensor x; +X-Z+Y: an IMU with y along the tool."""
    np.testing.assert_array_equal(axes_map_matrix('-Y+X+Z'),
                                  [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    np.testing.assert_array_equal(axes_map_matrix('+x-z+y'),
                                  [[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    # A robot IMU reading gravity on +y when the tool is vertical: tool z = sensor y.
    upright = to_tool_axes([[0.0, G, 0.0]], axes_map_matrix('+X-Z+Y'))
    np.testing.assert_array_equal(upright, [[0.0, 0.0, G]])
    np.testing.assert_array_equal(axes_map_matrix('+X+Y+Z'), np.eye(3))


@pytest.mark.parametrize('spec,words', [
    ('+X+X+Z', 'each sensor axis'), ('XYZ', 'neither'), ('+X+Y', 'neither'),
    ('+X+Y+W', 'neither'), ('rpy:0,90', 'neither'), ('rpy:a,0,0', 'three angles'),
    ('rpy:nan,0,0', 'finite'), ('rpy:1e308,0,0', r'within -360 \.\. 360'),
    ('rpy:0,0,-361', 'within'), ('+X+Y-Z', 'left-handed'), ('-Y-X+Z', 'left-handed')])
def test_invalid_maps_are_refused_with_the_reason(spec, words):
    """Each axis once, signs given, right-handed; the message says what is wrong."""
    with pytest.raises(ValueError, match=words):
        axes_map_matrix(spec)


def test_left_handed_only_when_asked():
    """A sensor whose own axes are left-handed: the map is taken when the caller insists."""
    matrix = axes_map_matrix('-Y-X+Z', allow_left_handed=True)
    assert np.linalg.det(matrix) == pytest.approx(-1.0)


@settings(max_examples=50, deadline=None)
@given(st.floats(-180, 180), st.floats(-89, 89), st.floats(-180, 180))
def test_rpy_is_the_rep103_rotation(roll, pitch, yaw):
    """rpy:R,P,Y = Rz(Y) Ry(P) Rx(R) (transforms3d 'sxyz'), and to_sensor_axes inverts it."""
    matrix = axes_map_matrix(f'rpy:{roll!r},{pitch!r},{yaw!r}')
    expected = euler2mat(*map(math.radians, (roll, pitch, yaw)), 'sxyz')
    np.testing.assert_allclose(matrix, expected, atol=1e-12)
    vectors = np.array([[1.0, 2.0, 3.0], [-4.0, 0.5, 9.0]])
    np.testing.assert_allclose(to_tool_axes(to_sensor_axes(vectors, matrix), matrix), vectors,
                               atol=1e-12)


def test_two_axis_sensor_needs_its_z_on_the_tool_axis():
    """A yaw turn keeps a two-axis sensor usable; a map moving its z off the axis does not."""
    assert keeps_axial(axes_map_matrix('rpy:0,0,30'))
    assert keeps_axial(axes_map_matrix('+X-Y-Z'))
    Settings(accelerometer_axes=2, accelerometer_axes_map='-Y+X+Z')
    with pytest.raises(ValueError, match='two-axis'):
        Settings(accelerometer_axes=2, accelerometer_axes_map='+Z+X+Y')
    with pytest.raises(ValueError, match='magnetometer_axes_map'):
        Settings(magnetometer_axes_map='+X+Y-Z')


@pytest.mark.parametrize('accelerometer,magnetometer', [
    ('+X-Z+Y', '+Y+X-Z'), ('-Y+X+Z', 'rpy:10,-20,135')])
def test_mapped_sensor_gives_the_true_mounted_result(accelerometer, magnetometer):
    """Readings in the sensor axes of a mounting, with its maps, give the tool-frame survey."""
    rng = np.random.default_rng(3)
    tool = rng.normal(0.0, 1.0, (50, 3))
    tool = G * tool / np.linalg.norm(tool, axis=1, keepdims=True)
    field = rng.normal(0.0, 30000.0, (50, 3))
    model = CalibrationModel(accelerometer_axes=3)
    expected = run(tool, model, Settings(), field_nT=field)
    mapped = Settings(accelerometer_axes_map=accelerometer, magnetometer_axes_map=magnetometer)
    survey = run(to_sensor_axes(tool, mapped.accelerometer_matrix), model, mapped,
                 field_nT=to_sensor_axes(field, mapped.magnetometer_matrix))
    np.testing.assert_allclose(survey.corrected_mps2, expected.corrected_mps2, atol=1e-12)
    np.testing.assert_allclose(survey.uncorrected_mps2, tool, atol=1e-12)
    np.testing.assert_allclose(survey.magnetic.uncorrected_nT, field, atol=1e-9)
    np.testing.assert_allclose(survey.magnetic.b_total_nT, expected.magnetic.b_total_nT,
                               rtol=1e-12)
    finite = np.isfinite(expected.magnetic.azimuth_deg)
    np.testing.assert_allclose(survey.magnetic.azimuth_deg[finite],
                               expected.magnetic.azimuth_deg[finite], atol=1e-9)
    # Without the maps the same readings are wrong (the check has teeth).
    unmapped = run(to_sensor_axes(tool, mapped.accelerometer_matrix), model, Settings())
    assert np.max(np.abs(unmapped.corrected_mps2 - expected.corrected_mps2)) > 5.0


def test_saturation_is_checked_on_the_sensor_axes():
    """A saturated sensor axis is dropped even when a rotation spreads it over two tool axes."""
    mapped = Settings(accelerometer_axes_map='rpy:0,0,45', accelerometer_range_mps2=10.0)
    survey = run([[10.0, 0.0, 1.0], [9.0, 0.0, 3.0]], CalibrationModel(3), mapped)
    assert survey.codes.tolist() == [1, -1]   # saturated, accepted
