"""
Two-axis accelerometer installation error (seed 000, Shao et al. 2012).

The sensor frame ``OX1Y1Z1`` is the ideal tool frame ``OXYZ`` turned by
``gamma`` about Y, then by ``beta`` about X' (seed 000, Fig. 1).  All angles
here are in radians; vectors are specific force in a z-up tool frame
(REP 145), shape ``(..., 3)``.  Every function is vectorised over samples.
"""

import numpy as np


def installation_matrix(gamma, beta):
    """
    Return C mapping ideal-frame coordinates to sensor coordinates (Eq. 1).

    ``C = Rx(beta) @ Ry(gamma)`` with the seed's signs::

        [[ cos g,          0,      -sin g        ],
         [-sin b sin g,    cos b,  -sin b cos g  ],
         [ cos b sin g,    sin b,   cos b cos g  ]]
    """
    g = np.asarray(gamma, dtype=float)
    b = np.asarray(beta, dtype=float)
    cg, sg, cb, sb = np.cos(g), np.sin(g), np.cos(b), np.sin(b)
    zero = np.zeros_like(cg)
    return np.stack([
        np.stack([cg, zero, -sg], axis=-1),
        np.stack([-sb * sg, cb, -sb * cg], axis=-1),
        np.stack([cb * sg, sb, cb * cg], axis=-1),
    ], axis=-2)


def inverse_installation_matrix(gamma, beta):
    """
    Return C^-1 mapping sensor readings to the ideal tool frame (Eq. 8).

    C is a rotation, so C^-1 = C^T::

        [[ cos g,  -sin b sin g,  sin g cos b ],
         [ 0,       cos b,        sin b       ],
         [-sin g,  -sin b cos g,  cos b cos g ]]
    """
    return np.swapaxes(installation_matrix(gamma, beta), -1, -2)


def level_axis_angles(level_reading, g):
    """
    Return the axis tilts (theta'_x1, theta'_y1) on a level bench (Eqs. 11, 12).

    ``theta'_x1 = asin(v_x1 / v_g)``, ``theta'_y1 = asin(v_y1 / v_g)`` where
    ``level_reading`` is the (mean) sensor reading with the bench level and
    ``g`` the gravity magnitude ``v_g`` in the same unit.
    """
    v = np.asarray(level_reading, dtype=float)
    return (np.arcsin(np.clip(v[..., 0] / g, -1.0, 1.0)),
            np.arcsin(np.clip(v[..., 1] / g, -1.0, 1.0)))


def installation_angles(theta_x1, theta_y1):
    """
    Return (gamma, beta) from the level-bench axis tilts (Eqs. 13, 14).

    ``gamma = -theta'_x1``; ``beta = asin(-sin theta'_y1 / cos gamma)``.
    """
    gamma = -np.asarray(theta_x1, dtype=float)
    beta = np.arcsin(np.clip(-np.sin(theta_y1) / np.cos(gamma), -1.0, 1.0))
    return gamma, beta


def pseudo_inclination(gamma, beta):
    """
    Return the false tilt theta of the sensor on a level bench (Eq. 4).

    ``theta = acos(cos beta cos gamma)``, written as the equivalent
    ``atan2(hypot(sin g, sin b cos g), cos b cos g)`` (the sine is Eq. 5's,
    ``1 - cos^2 b cos^2 g = sin^2 g + sin^2 b cos^2 g``), which keeps full
    precision for the sub-degree angles of a real installation.
    """
    cg = np.cos(gamma)
    return np.arctan2(np.hypot(np.sin(gamma), np.sin(beta) * cg), np.cos(beta) * cg)


def correct_installation(reading, gamma, beta):
    """
    Return the readings in the ideal tool frame, ``v = C^-1 v1`` (Eqs. 9, 15).

    ``reading`` has shape ``(..., 3)``; the inclination of the result is the
    true inclination of Eq. 10.
    """
    return to_tool_frame(reading, inverse_installation_matrix(gamma, beta))


def to_tool_frame(reading, c_inverse):
    """
    Return ``C^-1 v1`` for readings ``(..., 3)`` and C^-1 of Eq. 8 (Eq. 9).

    For a fixed installation, C^-1 is computed once and passed here per sample.
    """
    v1 = np.asarray(reading, dtype=float)
    return np.einsum('...jk,...k->...j', c_inverse, v1)
