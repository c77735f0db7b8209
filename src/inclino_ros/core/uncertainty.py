"""
First-order uncertainty of every angle: sensor noise and calibration through the formulas.

Each angle is a smooth function of the corrected specific force f (tool frame,
seed 000 / REP 145) and, for the azimuth, of the field B: its variance is
``grad^T C grad`` with C the covariance of the inputs (first-order
propagation, exact for small noise).  Gradients are written out from the
formulas they differentiate:

* inclination ``I = atan2(h, f_z)``, ``h = hypot(f_x, f_y)`` (seed 000
  Eq. 10): ``dI/df = (f_x f_z / h, f_y f_z / h, -h) / |f|^2``;
* toolface ``TF = atan2(f_y, f_x)`` (seed 000 Eq. 16; the high-side toolface
  differs by a constant): ``dTF/df = (-f_y, f_x, 0) / h^2``;
* roll ``atan2(f_y, f_z)`` and pitch ``atan2(-f_x, r)``, ``r = hypot(f_y,
  f_z)`` (``attitude.roll_pitch``);
* azimuth ``A = atan2(N, D)`` (seed 001 Eq. 4, ISCWSA frame):
  ``N = (G_x B_y - G_y B_x) |G|``, ``D = B_z (G_x^2 + G_y^2) - G_z (G_x B_x
  + G_y B_y)``, ``dA = (D dN - N dD) / (N^2 + D^2)``.

A calibration's own tilt uncertainty (the level capture's standard error, the
stand fit's residual) is an isotropic error of the direction of f, variance
``tilt_var`` [rad^2]: it adds ``tilt_var`` to the inclination, roll and
pitch, ``tilt_var / sin^2 I`` to the toolface (a tilt across the tool axis
turns the high side by tilt / sin I), and ``tilt_var |G|^2`` per tangential
axis of G to the azimuth.  A two-axis sensor's axial component
``f_z = sqrt(g^2 - f_x^2 - f_y^2)`` (``attitude.complete_two_axis``) carries
the noise of x and y with ``df_z / df_(x, y) = -f_(x, y) / f_z``.

A temperature stage's own uncertainty (``core.temperature``, seed 001 Eqs.
5-7 with a bias drift) is its fit's parameter covariance C_p per axis,
propagated to the compensation at the operating temperature T: compensating
to T_s errs by ``dK A + dB`` with ``dK = sum dc_k (u^k - u_s^k)``, ``dB = sum
dd_k (u^k - u_s^k)`` (u the normalised temperature), so the variance of axis
i is ``g^T C_p g`` with ``g = ((u^k - u_s^k) A_i, (u^k - u_s^k))`` (zero at T_s:
the stage's reference is where the later stages were captured).

A fit's own error (``CalibrationModel.parameter_blocks``: the reference-free
shot fit, the magnetometer stand, the rotation fit) is its parameter
covariance C_p (from the fit's Jacobian and residuals) with the Jacobians of
the corrected vectors to those parameters: an affine stage ``y = M (x - o)``
has ``dy = dM (x - o) - M do`` (``affine_jacobian``, M row-major then o), a
seed-000 rotation ``y = C^-1(gamma, beta) x`` has ``dy = (dC^-1/dgamma x,
dC^-1/dbeta x)`` (``tilt_jacobian``).  A level bench read through a fitted
stage (seed 000 Eqs. 11-14 of the corrected reading ``v = |v| C e_z``) takes
that stage's error at vertical into gamma, beta: with ``n = v / |v| = (-sg,
-sb cg, cb cg)`` and ``D = dn/d(gamma, beta)``, whose columns are orthogonal
to n and to each other (``D^T D = diag(1, cg^2)``), ``d(gamma, beta) =
diag(1, 1 / cg^2) D^T dv / |v|`` (``level_angles_jacobian``).  One parameter moves G and B together
(a tool axis turns both), so the azimuth takes ``d^T C_p d`` with ``d =
dA/dG J_G + dA/dB J_B`` (``azimuth_std_rad``'s ``parameter_blocks``), the
inclination and toolface ``J_G C_p J_G^T`` added to the covariance of f.
"""

import math

import numpy as np


def _outer_sum(grad, covariance):
    """Return ``grad^T C grad`` per sample for grad (M, n), C (M, n, n)."""
    return np.einsum('mi,mij,mj->m', grad, covariance, grad)


def specific_force_covariance(f_sensor, noise_std, axes, linear_map=None):
    """
    Return the covariance (M, 3, 3) of corrected specific force from per-axis white noise.

    ``f_sensor`` (M, 3) the sensor vectors (two-axis: z completed), ``noise_std``
    the per-axis 1 sigma (scalar), ``linear_map`` the 3x3 matrix the
    calibration applies to them (None: identity).  Two axes: the completion
    Jacobian ``[[1, 0], [0, 1], [-f_x / f_z, -f_y / f_z]]``.
    """
    f = np.asarray(f_sensor, dtype=float)
    count = f.shape[0]
    linear_map = np.eye(3) if linear_map is None else np.asarray(linear_map)
    if axes == 2:
        jacobian = np.zeros((count, 3, 2))
        jacobian[:, 0, 0] = jacobian[:, 1, 1] = 1.0
        with np.errstate(divide='ignore', invalid='ignore'):   # f_z = 0: unbounded
            jacobian[:, 2, :] = -f[:, :2] / f[:, 2:3]
        jacobian = linear_map @ jacobian
        return noise_std ** 2 * jacobian @ jacobian.transpose(0, 2, 1)
    # Three axes: one matrix for all samples (a read-only broadcast).
    return np.broadcast_to(noise_std ** 2 * linear_map @ linear_map.T, (count, 3, 3))


def temperature_compensation_covariance(readings, u, u_reference, parameter_covariance, bias):
    """
    Return the covariance (M, 3, 3) of temperature-compensated readings from the fit's own error.

    ``readings`` (M, 3) in the stage's unit, ``u`` (M,) the normalised
    operating temperature and ``u_reference`` that of the stage's reference
    (``temperature.normalised_temperature``), ``parameter_covariance`` (3, p,
    p): p = n scale coefficients, then (``bias``) n bias coefficients (module
    docstring).  Diagonal: each axis is fitted on its own.
    """
    readings = np.asarray(readings, dtype=float)
    parameter_covariance = np.asarray(parameter_covariance, dtype=float)
    order = np.arange(1, parameter_covariance.shape[-1] // (2 if bias else 1) + 1)
    difference = (np.asarray(u, dtype=float)[:, None] ** order
                  - float(u_reference) ** order)                     # (M, n)
    covariance = np.zeros(readings.shape + (3,))
    for axis in range(3):
        grad = difference * readings[:, axis:axis + 1]
        if bias:
            grad = np.hstack([grad, difference])
        covariance[:, axis, axis] = np.einsum('mi,ij,mj->m', grad, parameter_covariance[axis],
                                              grad)
    return covariance


def affine_jacobian(offset_inputs, matrix):
    """
    Return d y / d(M, o) (N, 3, 12) of ``y = M (x - o)`` at ``offset_inputs`` = x - o (N, 3).

    Parameters in the order M row-major (9), then o (3).
    """
    offset_inputs = np.asarray(offset_inputs, dtype=float)
    count = offset_inputs.shape[0]
    jacobian = np.zeros((count, 3, 12))
    for row in range(3):
        jacobian[:, row, 3 * row:3 * row + 3] = offset_inputs
    jacobian[:, :, 9:] = -np.asarray(matrix, dtype=float)
    return jacobian


def tilt_jacobian(vectors, gamma, beta):
    """
    Return d(C^-1 x) / d(gamma, beta) (N, 3, 2) of seed 000 Eq. 8's C^-1 [unit of x per rad].

    ``C^-1 = [[cg, -sb sg, sg cb], [0, cb, sb], [-sg, -sb cg, cb cg]]``
    (``installation.inverse_installation_matrix``) differentiated.
    """
    cg, sg, cb, sb = math.cos(gamma), math.sin(gamma), math.cos(beta), math.sin(beta)
    d_gamma = np.array([[-sg, -sb * cg, cg * cb], [0.0, 0.0, 0.0], [-cg, sb * sg, -cb * sg]])
    d_beta = np.array([[0.0, -cb * sg, -sg * sb], [0.0, -sb, cb], [0.0, -cb * cg, -sb * cg]])
    vectors = np.asarray(vectors, dtype=float)
    return np.stack([vectors @ d_gamma.T, vectors @ d_beta.T], axis=2)


def level_angles_jacobian(gamma, beta, g):
    """
    Return d(gamma, beta) / dv (2, 3) [rad per unit of v] of seed 000 Eqs. 11-14.

    At the level-bench reading ``v = g C e_z`` (``installation.installation_matrix``):
    ``diag(1, 1 / cos^2 gamma) D^T / g`` with ``D = dn/d(gamma, beta)`` of the unit
    reading ``n = (-sg, -sb cg, cb cg)`` (module docstring); the reading's length
    moves neither angle.
    """
    cg, sg, cb, sb = math.cos(gamma), math.sin(gamma), math.cos(beta), math.sin(beta)
    d_transposed = np.array([[-cg, sb * sg, -cb * sg], [0.0, -cb * cg, -sb * cg]])
    return d_transposed / (np.array([[1.0], [cg * cg]]) * g)


def parameter_covariance(blocks, which):
    """
    Return sum ``J C J^T`` (M, 3, 3) of ``blocks`` (C, J_f, J_B) for ``which`` (1: f, 2: B).

    None when no block moves that vector.
    """
    total = None
    for block in blocks:
        jacobian = block[which]
        if jacobian is not None:
            term = jacobian @ block[0] @ jacobian.transpose(0, 2, 1)
            total = term if total is None else total + term
    return total


def inclination_std_rad(f, covariance, tilt_var=0.0):
    """Return the 1 sigma [rad] of the inclination of ``f`` (M, 3)."""
    f = np.asarray(f, dtype=float)
    h = np.hypot(f[:, 0], f[:, 1])
    squared = np.einsum('ij,ij->i', f, f)
    # At h = 0 the inclination's noise is the cross-axial noise over |f| (any direction):
    # the gradient's limit along x.
    vertical = h == 0.0
    cos_tf = np.where(vertical, 1.0, f[:, 0] / np.where(vertical, 1.0, h))
    sin_tf = np.where(vertical, 0.0, f[:, 1] / np.where(vertical, 1.0, h))
    grad = np.stack([cos_tf * f[:, 2], sin_tf * f[:, 2], -h], axis=1) / squared[:, None]
    return np.sqrt(_outer_sum(grad, covariance) + tilt_var)


def toolface_std_rad(f, covariance, tilt_var=0.0):
    """Return the 1 sigma [rad] of the gravity toolface of ``f`` (M, 3); inf when vertical."""
    f = np.asarray(f, dtype=float)
    fx, fy = f[:, 0], f[:, 1]
    h2 = fx * fx + fy * fy
    c = covariance
    with np.errstate(all='ignore'):   # h -> 0: the sigma grows without bound (inf)
        # g^T C g for the gradient g = (-f_y, f_x, 0) / h^2, written out.
        variance = ((fy * fy * c[:, 0, 0] - 2.0 * fx * fy * c[:, 0, 1] + fx * fx * c[:, 1, 1])
                    / (h2 * h2) + tilt_var * (h2 + f[:, 2] * f[:, 2]) / h2)
    return np.where(h2 > 0.0, np.sqrt(variance), np.inf)


def roll_pitch_covariance(f, covariance, tilt_var=0.0):
    """Return the covariance (M, 2, 2) [rad^2] of (roll, pitch) of ``attitude.roll_pitch``."""
    f = np.asarray(f, dtype=float)
    fx, fy, fz = f[:, 0], f[:, 1], f[:, 2]
    r2 = fy * fy + fz * fz
    jacobian = np.zeros((f.shape[0], 2, 3))
    with np.errstate(all='ignore'):   # pointing along x: roll undefined (inf)
        r = np.sqrt(r2)
        squared = r2 + fx * fx
        jacobian[:, 0, 1] = fz / r2
        jacobian[:, 0, 2] = -fy / r2
        jacobian[:, 1, 0] = -r / squared
        jacobian[:, 1, 1] = fx * fy / (r * squared)
        jacobian[:, 1, 2] = fx * fz / (r * squared)
        return jacobian @ covariance @ jacobian.transpose(0, 2, 1) + tilt_var * np.eye(2)


def azimuth_gradients(G, B):
    """
    Return (dA/dG, dA/dB), each (M, 3) [rad per unit of G, rad per nT], ISCWSA frame.

    Derivatives of seed 001 Eq. 4 written out (module docstring); NaN where
    the azimuth is undefined (N = D = 0: a vertical tool).
    """
    G = np.asarray(G, dtype=float)
    B = np.asarray(B, dtype=float)
    gx, gy, gz = G.T
    bx, by, bz = B.T
    g = np.linalg.norm(G, axis=1)
    cross = gx * by - gy * bx
    num = cross * g
    den = bz * (gx * gx + gy * gy) - gz * (gx * bx + gy * by)
    d_num_g = np.stack([by * g + cross * gx / g, -bx * g + cross * gy / g, cross * gz / g], 1)
    d_num_b = np.stack([-gy * g, gx * g, np.zeros_like(g)], 1)
    d_den_g = np.stack([2.0 * bz * gx - gz * bx, 2.0 * bz * gy - gz * by, -(gx * bx + gy * by)], 1)
    d_den_b = np.stack([-gz * gx, -gz * gy, gx * gx + gy * gy], 1)
    with np.errstate(divide='ignore', invalid='ignore'):
        scale = 1.0 / (num * num + den * den)
        return ((den[:, None] * d_num_g - num[:, None] * d_den_g) * scale[:, None],
                (den[:, None] * d_num_b - num[:, None] * d_den_b) * scale[:, None])


def azimuth_std_rad(G, B, covariance_G, covariance_B, tilt_var=0.0, parameter_blocks=()):
    """
    Return the 1 sigma [rad] of the azimuth of G, B (M, 3) (ISCWSA frame).

    ``covariance_G`` (M, 3, 3) [unit of G ^2], ``covariance_B`` (3, 3) or
    (M, 3, 3) [nT^2]; ``tilt_var`` the calibration's tilt variance [rad^2]
    (tangential to G: the azimuth does not change with |G|, so the isotropic
    ``tilt_var |G|^2 I`` is exact); ``parameter_blocks``: (C_p, J_G, J_B) of
    each fit's own error, Jacobians (M, 3, p) in the ISCWSA frame (None: that
    vector does not move), with their G-B correlation (module docstring).
    NaN where the azimuth is undefined.
    """
    grad_g, grad_b = azimuth_gradients(G, B)
    g2 = np.einsum('ij,ij->i', np.asarray(G, dtype=float), np.asarray(G, dtype=float))
    covariance_G = covariance_G + (tilt_var * g2)[:, None, None] * np.eye(3)
    covariance_B = np.broadcast_to(covariance_B, covariance_G.shape)
    variance = _outer_sum(grad_g, covariance_G) + _outer_sum(grad_b, covariance_B)
    for covariance, jacobian_G, jacobian_B in parameter_blocks:
        d = 0.0
        for grad, jacobian in ((grad_g, jacobian_G), (grad_b, jacobian_B)):
            if jacobian is not None:
                d = d + np.einsum('mi,mip->mp', grad, jacobian)
        variance = variance + np.einsum('mp,pq,mq->m', d, covariance, d)
    return np.sqrt(variance)


def dip_std_rad(G, B, g_std, b_std_nT):
    """
    Return the 1 sigma [rad] of the dip from isotropic per-axis noise of G and B.

    The dip is 90 deg less the angle between G and B; each vector's noise
    across the plane they span turns it by noise / |vector|:
    ``var = (g_std / |G|)^2 + (b_std / |B|)^2``; infinite for a zero vector (a
    dead magnetometer: no dip), without a warning.
    """
    with np.errstate(divide='ignore'):
        return np.hypot(g_std / np.linalg.norm(G, axis=-1),
                        b_std_nT / np.linalg.norm(B, axis=-1))
