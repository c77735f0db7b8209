"""
Inclination, gravity toolface and orientation from specific force.

Input vectors are specific force ``f`` in the tool frame of seed 000 / REP 145:
z along the tool axis pointing up (away from the bit), so a tool at rest reads
``f = g (sin theta_x, sin theta_y, cos phi)``.  Angles are in radians, arrays
have shape ``(..., 3)`` and every function is vectorised over samples.
"""

import numpy as np


def complete_two_axis(fx, fy, g):
    """
    Return ``f`` with the axial component of a two-axis sensor filled in.

    A two-axis sensor measures only ``g sin theta_x`` and ``g sin theta_y``;
    seed 000 Eq. 9 needs ``cos phi_1`` as well, taken as
    ``sqrt(1 - sin^2 theta_x1 - sin^2 theta_y1)`` (tool upright, phi_1 < 90 deg).
    Readings whose cross-axial magnitude exceeds ``g`` give NaN.
    """
    fx = np.asarray(fx, dtype=float)
    fy = np.asarray(fy, dtype=float)
    radicand = g * g - fx * fx - fy * fy
    fz = np.sqrt(np.where(radicand >= 0.0, radicand, np.nan))
    return np.stack([fx, fy, fz], axis=-1)


def specific_force(inclination, toolface, gravity_mps2):
    """Return ``g (sin I cos TF, sin I sin TF, cos I)``, shape (..., 3), angles in radians."""
    inclination = np.asarray(inclination, dtype=float)
    toolface = np.asarray(toolface, dtype=float)
    sin_i = np.sin(inclination)
    return gravity_mps2 * np.stack(
        [sin_i * np.cos(toolface), sin_i * np.sin(toolface), np.cos(inclination)], axis=-1)


def as_vectors(values, name):
    """Return ``values`` as a float (N, 3) array; ValueError naming ``name`` for another shape."""
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[1] != 3:
        raise ValueError(f'{name} must have shape (N, 3), not {values.shape}')
    return values


def angle_between(u, v):
    """Return the angle [rad] between vectors along the last axis (atan2 form, exact near 0)."""
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def inclination(f):
    """
    Return the inclination phi: the angle between tool z and the vertical.

    Seed 000 Eq. 10 gives ``phi = acos(cos phi)`` from the corrected reading;
    the same angle is computed here as ``atan2(hypot(fx, fy), fz)``, which
    does not lose precision near vertical as ``acos`` does.
    """
    f = np.asarray(f, dtype=float)
    return np.arctan2(np.hypot(f[..., 0], f[..., 1]), f[..., 2])


def _wrap_2pi(angle):
    """Return ``angle mod 2 pi`` in [0, 2 pi): np.mod rounds ``-1e-17`` up to 2 pi itself."""
    angle = np.mod(angle, 2.0 * np.pi)
    return np.where(angle == 2.0 * np.pi, 0.0, angle)  # NaN stays NaN


def _toolface(f, x, y):
    """Return ``atan2(y, x) mod 2 pi``, NaN for a vertical tool (f_x = f_y = 0: undefined)."""
    vertical = (f[..., 0] == 0.0) & (f[..., 1] == 0.0)
    return np.where(vertical, np.nan, _wrap_2pi(np.arctan2(y, x)))


def toolface_seed000(f):
    """
    Return the gravity toolface of seed 000 Eq. 16, in [0, 2 pi).

    ``alpha = asin(v_y / sqrt(v_x^2 + v_y^2))`` with the quadrant taken from
    the signs of ``v_x`` and ``v_y``, i.e. ``atan2(v_y, v_x) mod 2 pi``: the
    direction of the high side measured from the tool x axis towards y.  NaN
    for a vertical tool (no high side).
    """
    f = np.asarray(f, dtype=float)
    return _toolface(f, f[..., 0], f[..., 1])


def toolface_highside(f):
    """
    Return the ISCWSA gravity (high-side) toolface, in [0, 2 pi).

    ISCWSA: ``GTF = atan2(-Gx, -Gy)`` with G the gravity vector in a frame
    whose z points toward the bit.  Turning the z-up tool frame 180 deg about
    x gives that frame, so ``G = (-f_x, f_y, f_z)`` and
    ``GTF = atan2(f_x, -f_y) = alpha + 90 deg`` (``shared/notes/formulas.md``).
    """
    f = np.asarray(f, dtype=float)
    return _toolface(f, -f[..., 1], f[..., 0])


TOOLFACE_CONVENTIONS = {
    'seed000': toolface_seed000,
    'iscwsa_highside': toolface_highside,
}


def roll_pitch(f):
    """
    Return (roll, pitch) of the tool frame, yaw taken as zero.

    With ``R = Rz(yaw) Ry(pitch) Rx(roll)`` taking tool to world (ENU, z up),
    the specific force at rest is ``R^T (0, 0, g)``, so
    ``roll = atan2(f_y, f_z)`` and ``pitch = atan2(-f_x, hypot(f_y, f_z))``.
    """
    f = np.asarray(f, dtype=float)
    return (np.arctan2(f[..., 1], f[..., 2]),
            np.arctan2(-f[..., 0], np.hypot(f[..., 1], f[..., 2])))


def orientation_quaternion(f):
    """
    Return the tool orientation (w, x, y, z) from specific force, yaw zero.

    Closed form of ``transforms3d.euler.euler2quat(roll, pitch, 0, 'sxyz')``
    (the tests check it against transforms3d), vectorised over samples:
    ``q = q_y(pitch) * q_x(roll)``.
    """
    roll, pitch = roll_pitch(f)
    cr, sr = np.cos(roll / 2.0), np.sin(roll / 2.0)
    cp, sp = np.cos(pitch / 2.0), np.sin(pitch / 2.0)
    return np.stack([cp * cr, cp * sr, sp * cr, -sp * sr], axis=-1)
