"""
A maximum-likelihood reference of the reference-free shot calibration (issue 19 item 10).

Written apart from ``core.shots`` (errors in variables, not its invariants): every shot
is a rotation Q_i of the world, whose specific force is ``(0, 0, g)`` (z up) and field
``F (cos D, 0, -sin D)`` (x north); the raw readings are ``a_i = T_a^-1 Q_i (0, 0, g) +
b_a`` and ``m_i = M^-1 Q_i F (cos D, 0, -sin D) + o`` with white noise of known sigma,
T_a upper triangular (the accelerometer frame's convention), M the magnetometer's full
map into that frame.  A roll group holds the tool axis u (accelerometer frame) on one
world direction w_k: ``Q_i = Rot(u, phi_i) Align(w_k -> u)``.  The likelihood's maximum is
``least_squares`` of the readings' residuals over their sigma, over every calibration
parameter and every shot's attitude, started from the fit under test (the optimum does
not depend on the start).

``angle_errors`` evaluates a calibration (T_a, b_a, M, o, u) the same way for both: the
corrected vectors turned so that u is z, azimuth and inclination of seed 001 Eq. 4 /
seed 000 Eq. 10 against the truth, at noise-free random attitudes.
"""

from inclino_ros.core.magnetics import azimuth_deg, gravity_from_specific_force, iscwsa_from_tool
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

_UPPER = np.triu_indices(3)


def _unit(theta, phi):
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def _angles(vector):
    vector = vector / np.linalg.norm(vector)
    return np.array([np.arccos(np.clip(vector[2], -1.0, 1.0)), np.arctan2(vector[1], vector[0])])


def _align(source, target):
    """Return the smallest rotation (matrix) taking unit ``source`` onto unit ``target``."""
    axis = np.cross(source, target)
    sine, cosine = np.linalg.norm(axis), float(source @ target)
    if sine < 1e-15:
        return np.eye(3)
    return Rotation.from_rotvec(axis / sine * np.arctan2(sine, cosine)).as_matrix()


class Calibration:
    """(T_a, b_a, M, o, u): what both fits give, in the accelerometer frame."""

    def __init__(self, t_a, b_a, m, o, u):
        self.t_a, self.b_a, self.m, self.o, self.u = t_a, b_a, m, o, u / np.linalg.norm(u)

    @classmethod
    def of_shot_fit(cls, fit):
        """Return the Calibration of a ``core.shots.ShotFit``."""
        return cls(np.linalg.inv(fit.accel_matrix), fit.accel_bias_mps2,
                   fit.alignment @ np.linalg.inv(fit.mag_matrix), fit.mag_bias_nT,
                   fit.tool_axis)

    def vectors(self, accel, field):
        """Return corrected (f, B) turned so that the tool axis u is z."""
        turn = _align(self.u, np.array([0.0, 0.0, 1.0]))
        return ((accel - self.b_a) @ (turn @ self.t_a).T,
                (field - self.o) @ (turn @ self.m).T)


def fit(accel, field, group, start, g, field_nT, noise_a, noise_m):
    """Return the maximum-likelihood Calibration of shots, started from ``start``."""
    count = accel.shape[0]
    groups = int(group.max()) + 1
    free = np.flatnonzero(group < 0)
    f0, b0 = start.vectors(accel, field)
    back = _align(np.array([0.0, 0.0, 1.0]), start.u)     # tool frame -> accelerometer frame
    f0, b0 = f0 @ back.T, b0 @ back.T
    up = f0 / np.linalg.norm(f0, axis=1)[:, None]
    north = b0 - np.einsum('ij,ij->i', b0, up)[:, None] * up
    north /= np.linalg.norm(north, axis=1)[:, None]
    q0 = np.stack([north, np.cross(up, north), up], axis=2)   # columns: north, west, up
    dip = np.mean(np.arcsin(np.clip(-np.einsum('ij,ij->i', up, b0)
                                    / np.linalg.norm(b0, axis=1), -1.0, 1.0)))
    world_axes = [_angles(np.mean(np.einsum('nji,j->ni', q0[group == k], start.u), axis=0))
                  for k in range(groups)]
    rolls = []
    for i in np.flatnonzero(group >= 0):
        base = _align(_unit(*world_axes[group[i]]), start.u)
        rolls.append(float(Rotation.from_matrix(q0[i] @ base.T).as_rotvec() @ start.u))
    x0 = np.concatenate([start.t_a[_UPPER], start.b_a / g, start.m.ravel(),
                         start.o / field_nT, [dip], _angles(start.u), np.ravel(world_axes),
                         Rotation.from_matrix(q0[free]).as_rotvec().ravel(), rolls])
    # The start's magnetometer scale: M maps readings to fields of |B| = field_nT.
    scale = field_nT / np.median(np.linalg.norm(b0, axis=1))
    x0[9:18] *= scale

    def unpack(x):
        t_a = np.zeros((3, 3))
        t_a[_UPPER] = x[:6]
        return (t_a, x[6:9] * g, x[9:18].reshape(3, 3), x[18:21] * field_nT, x[21],
                _unit(*x[22:24]), x[24:24 + 2 * groups].reshape(-1, 2))

    def rotations(x):
        t_a, b_a, m, o, dip_rad, u, axes = unpack(x)
        i = 24 + 2 * groups
        q = np.empty((count, 3, 3))
        q[free] = Rotation.from_rotvec(x[i:i + 3 * free.size].reshape(-1, 3)).as_matrix()
        phis = x[i + 3 * free.size:]
        for j, shot in enumerate(np.flatnonzero(group >= 0)):
            base = _align(_unit(*axes[group[shot]]), u)
            q[shot] = Rotation.from_rotvec(u * phis[j]).as_matrix() @ base
        return q

    def residuals(x):
        t_a, b_a, m, o, dip_rad, u, _ = unpack(x)
        q = rotations(x)
        f = q @ np.array([0.0, 0.0, g])
        b = q @ (field_nT * np.array([np.cos(dip_rad), 0.0, -np.sin(dip_rad)]))
        predicted_a = np.linalg.solve(t_a, f.T).T + b_a
        predicted_m = np.linalg.solve(m, b.T).T + o
        return np.concatenate([((accel - predicted_a) / noise_a).ravel(),
                               ((field - predicted_m) / noise_m).ravel()])

    result = least_squares(residuals, x0, method='lm', x_scale='jac')
    t_a, b_a, m, o, _, u, _ = unpack(result.x)
    return Calibration(t_a, b_a, m, o, u)


def angle_errors(calibration, accel, field, inclination_deg, azimuth_deg_true):
    """Return (azimuth, inclination) errors [deg] of noise-free readings at known attitudes."""
    f, b = calibration.vectors(accel, field)
    azimuth = azimuth_deg(gravity_from_specific_force(f), iscwsa_from_tool(b))
    inclination = np.degrees(np.arctan2(np.hypot(f[:, 0], f[:, 1]), f[:, 2]))
    return ((azimuth - azimuth_deg_true + 180.0) % 360.0 - 180.0,
            inclination - inclination_deg)
