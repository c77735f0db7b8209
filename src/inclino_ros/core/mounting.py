"""
How a sensor is mounted: its axes turned into the tool axes, before any correction.

A real IMU is rarely mounted with its z along the tool axis, and a board's
magnetometer axes often differ from its accelerometer's.  An axes map says,
for the tool's x, y and z in turn, which sensor axis points along it, with its
sign: ``-Y+X+Z`` means tool x = -sensor y, tool y = +sensor x, tool z =
+sensor z.  A mounting that is not a quarter turn is written as a rotation,
``rpy:ROLL,PITCH,YAW`` in degrees: the sensor frame's orientation in the tool
frame (REP 103: roll about tool x, then pitch about tool y, then yaw about
tool z, fixed axes).  Either way ``v_tool = M v_sensor``.

A map whose determinant is -1 turns a right-handed sensor into a left-handed
tool frame: for a sensor with right-handed axes that is a typo or a wiring
error, and it is refused unless the caller says the sensor's own axes are
left-handed (some magnetometers' are, relative to their accelerometer).
"""

import math
import re

import numpy as np

IDENTITY = '+X+Y+Z'
_PERMUTATION = re.compile(r'^([+-])([XYZ])([+-])([XYZ])([+-])([XYZ])$')
_ROTATION = re.compile(r'^rpy:([^,]+),([^,]+),([^,]+)$')
_AXES = 'XYZ'


def axes_map_matrix(spec, allow_left_handed=False):
    """
    Return M (3x3, ``v_tool = M v_sensor``) of an axes map; ValueError if it is not one.

    ``spec``: a signed permutation such as ``-Y+X+Z`` (each axis once, signs
    required, case-insensitive) or ``rpy:ROLL,PITCH,YAW`` in degrees
    (``Rz(yaw) Ry(pitch) Rx(roll)``).  A left-handed permutation (determinant
    -1) is refused unless ``allow_left_handed``.
    """
    text = str(spec).strip().replace(' ', '')
    rotation = _ROTATION.match(text.lower())
    if rotation:
        try:
            roll, pitch, yaw = (math.radians(float(v)) for v in rotation.groups())
        except ValueError:
            raise ValueError(f'axes map {spec!r}: rpy takes three angles in degrees, '
                             'e.g. rpy:0,90,0') from None
        if not all(abs(angle) <= math.tau for angle in (roll, pitch, yaw)):
            raise ValueError(f'axes map {spec!r}: each angle must be finite, within -360 .. 360 '
                             'deg (beyond, its sine is rounding noise)')
        matrix = _rotation_z(yaw) @ _rotation_y(pitch) @ _rotation_x(roll)
        matrix[np.abs(matrix) < 1e-12] = 0.0  # quarter turns exact: cos(90 deg) is 6e-17
        return matrix
    permutation = _PERMUTATION.match(text.upper())
    if not permutation:
        raise ValueError(f'axes map {spec!r} is neither a signed permutation of the sensor '
                         'axes such as -Y+X+Z (tool x, y, z in turn) nor rpy:ROLL,PITCH,YAW '
                         '[deg]')
    signs, axes = permutation.groups()[::2], permutation.groups()[1::2]
    if sorted(axes) != list(_AXES):
        raise ValueError(f'axes map {spec!r} must name each sensor axis X, Y, Z once')
    matrix = np.zeros((3, 3))
    for row, (sign, axis) in enumerate(zip(signs, axes)):
        matrix[row, _AXES.index(axis)] = 1.0 if sign == '+' else -1.0
    if np.linalg.det(matrix) < 0 and not allow_left_handed:
        raise ValueError(
            f'axes map {spec!r} is left-handed (determinant -1): with right-handed sensor axes '
            'that is a typo or a wiring error (did you mean to flip one more axis, or swap '
            'two?); if the sensor itself has left-handed axes, allow left-handed axes maps')
    return matrix


def keeps_axial(matrix):
    """Return whether M maps the sensor z to the tool z (±) and nothing else onto it."""
    matrix = np.asarray(matrix, dtype=float)
    return bool(np.all(matrix[2, :2] == 0.0) and np.all(matrix[:2, 2] == 0.0))


def to_tool_axes(vectors, matrix):
    """Return sensor-axis vectors (N, 3) in the tool axes: ``v_tool = M v_sensor`` row-wise."""
    vectors, matrix = np.asarray(vectors, dtype=float), np.asarray(matrix, dtype=float)
    if np.array_equal(matrix, np.eye(3)):
        return vectors  # mounted true: the readings as they are, to the last bit
    return vectors @ matrix.T


def to_sensor_axes(vectors, matrix):
    """Return tool-axis vectors (N, 3) as the sensor of axes map M reads them (``M^-1 v``)."""
    return to_tool_axes(vectors, np.linalg.inv(matrix))


def _rotation_x(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rotation_y(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rotation_z(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
