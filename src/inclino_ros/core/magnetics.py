"""
Magnetic survey quantities in the ISCWSA survey frame (seed 002, seed 001 Eq. 4).

Frame (``shared/notes/formulas.md``, "Frames and signs"): x and y cross-axial,
z along the tool *toward the bit*; ``G`` is the gravity vector (``Gz = +g``
when the tool hangs vertical), ``B`` the magnetic field in nT.  Every function
takes arrays of shape ``(..., 3)`` and is vectorised over the leading axes;
angles are in degrees, azimuths and toolfaces in [0, 360).

The forward model maps inclination I, magnetic azimuth A, gravity (high-side)
toolface TF, dip D and the field magnitudes to the sensor readings; the
inverse functions recover each quantity from the readings (ISCWSA, as written
out in formulas.md, "ISCWSA forward model" and "Inverse").
"""

from dataclasses import dataclass

from inclino_ros.core.attitude import inclination, toolface_highside
import numpy as np


def iscwsa_from_tool(v):
    """
    Return a vector of the z-up ROS tool frame in ISCWSA axes.

    The tool frame of REP 145 / seed 000 has z along the tool pointing away
    from the bit; a 180 deg turn about x gives the ISCWSA frame, so
    ``(x, y, z) -> (x, -y, -z)`` (formulas.md, "Frames and signs").  This holds
    for that mounting only: a sensor mounted otherwise needs its own transform.
    """
    v = np.asarray(v, dtype=float)
    return np.stack([v[..., 0], -v[..., 1], -v[..., 2]], axis=-1)


def gravity_from_specific_force(f_tool):
    """
    Return the ISCWSA gravity vector G from REP 145 specific force.

    An accelerometer at rest reads the specific force ``f = -G`` (the up axis
    reads +g); in ISCWSA axes ``G = -iscwsa_from_tool(f) = (-f_x, f_y, f_z)``
    (formulas.md).  As for ``iscwsa_from_tool``, only for a z-up tool frame
    whose z points away from the bit: another mounting needs its own transform.
    """
    return -iscwsa_from_tool(f_tool)


def forward(inclination_deg, azimuth_deg, toolface_deg, g, b_total_nT, dip_deg):
    """
    Return (G, B), the sensor readings of the ISCWSA forward model.

    With I, A, TF (gravity high-side toolface) and D (formulas.md)::

        Gx = -g sinI sinTF,  Gy = -g sinI cosTF,  Gz = g cosI
        Bx = B [cosD (cosI cosA sinTF + sinA cosTF) - sinD sinI sinTF]
        By = B [cosD (cosI cosA cosTF - sinA sinTF) - sinD sinI cosTF]
        Bz = B [cosD sinI cosA + sinD cosI]

    The arguments broadcast against each other; G is in the unit of ``g``.
    """
    i, a, tf, d = (np.radians(np.asarray(x, dtype=float))
                   for x in (inclination_deg, azimuth_deg, toolface_deg, dip_deg))
    g = np.asarray(g, dtype=float)
    b = np.asarray(b_total_nT, dtype=float)
    si, ci, sa, ca = np.sin(i), np.cos(i), np.sin(a), np.cos(a)
    st, ct, sd, cd = np.sin(tf), np.cos(tf), np.sin(d), np.cos(d)
    gravity = np.stack(np.broadcast_arrays(-g * si * st, -g * si * ct, g * ci), axis=-1)
    field = np.stack(np.broadcast_arrays(
        b * (cd * (ci * ca * st + sa * ct) - sd * si * st),
        b * (cd * (ci * ca * ct - sa * st) - sd * si * ct),
        b * (cd * si * ca + sd * ci)), axis=-1)
    return gravity, field


def expected_field_tool_nT(inclination_deg, toolface_deg, azimuth_deg, b_total_nT, dip_deg):
    """
    Return the Earth field a true tool frame reads at an attitude, (..., 3) [nT].

    The z-up tool frame's view of the ISCWSA forward model (``forward``):
    seed-000 toolface TF is the high-side toolface GTF minus 90 deg, and the
    tool and ISCWSA axes differ by a turn about x (``iscwsa_from_tool``, its
    own inverse).  This is the truth of a magnetometer stand position (seed
    001 Eq. 12: the stand's INC, GTF, AZ and the site's field).
    """
    _, field = forward(inclination_deg, azimuth_deg, np.asarray(toolface_deg, dtype=float) + 90.0,
                       1.0, b_total_nT, dip_deg)
    return iscwsa_from_tool(field)


#: The Earth's field at the surface spans 22000 .. 67000 nT (real-sensors.md); readings
#: whose typical magnitude lies a factor of ten or more outside are a unit error or a
#: dead sensor, not a field.
EARTH_FIELD_RANGE_NT = (22000.0, 67000.0)
#: Units a magnetometer stream is often given in by mistake, and their size in nT.
FIELD_UNITS_NT = (('uT', 1e3), ('gauss', 1e5), ('mG', 1e2), ('T', 1e9))


def field_unit_problem(b_total_nT):
    """
    Return why readings of typical magnitude ``b_total_nT`` are no field in nT, or None.

    A magnitude a factor of ten or more outside EARTH_FIELD_RANGE_NT is
    refused; when it fits the Earth's field in another unit (uT, gauss, mG,
    tesla) the reason names that unit and the factor to nT.
    """
    low, high = EARTH_FIELD_RANGE_NT
    value = float(b_total_nT)
    if low / 10.0 < value < high * 10.0:
        return None
    for unit, nT in FIELD_UNITS_NT:
        if low / 2.0 <= value * nT <= high * 2.0:
            return (f'the field magnitude is {value:.6g}, which is the Earth field in {unit}, '
                    f'not in nT: multiply the readings by {nT:g}')
    return (f'the field magnitude {value:.6g} nT is no Earth field ({low:g} .. {high:g} nT): '
            'a dead sensor or a unit error')


def _wrap_360(angle_deg):
    """
    Return ``angle mod 360`` in [0, 360); NaN stays NaN.

    np.mod rounds ``-1e-15`` up to 360 itself, which is folded to 0.
    """
    angle_deg = np.mod(angle_deg, 360.0)
    return np.where(angle_deg == 360.0, 0.0, angle_deg)


def _dot(u, v):
    """Return the dot product along the last axis."""
    return np.sum(u * v, axis=-1)


def g_total(G):
    """Return G-total ``|G|``, in the unit of G."""
    return np.linalg.norm(np.asarray(G, dtype=float), axis=-1)


def b_total_nT(B):
    """Return B-total ``|B|`` [nT]."""
    return np.linalg.norm(np.asarray(B, dtype=float), axis=-1)


def inclination_deg(G):
    """
    Return the inclination ``I = atan2(sqrt(Gx^2 + Gy^2), Gz)`` [deg] (seed 001 Eq. 1).

    The same angle as ``attitude.inclination`` of the tool frame's specific
    force ``f = (-Gx, Gy, Gz)``, which computes it.
    """
    return np.degrees(inclination(specific_force_from_gravity(G)))


def gravity_toolface_deg(G):
    """
    Return the gravity high-side toolface ``GTF = atan2(-Gx, -Gy)`` in [0, 360) [deg].

    Computed by ``attitude.toolface_highside`` of ``f = (-Gx, Gy, Gz)``.
    """
    return np.degrees(toolface_highside(specific_force_from_gravity(G)))


def specific_force_from_gravity(G):
    """Return the z-up tool frame specific force of an ISCWSA gravity vector: (-Gx, Gy, Gz)."""
    return -iscwsa_from_tool(G)


def azimuth_deg(G, B):
    """
    Return the magnetic azimuth A in [0, 360) [deg].

    ``A = atan2((Gx By - Gy Bx) |G|, Bz (Gx^2 + Gy^2) - Gz (Gx Bx + Gy By))``
    (formulas.md, "Inverse"; seed 001 Eq. 4 with the quadrant from the signs).
    Undefined for a vertical tool (both arguments vanish): NaN there.
    """
    G = np.asarray(G, dtype=float)
    B = np.asarray(B, dtype=float)
    gx, gy, gz = G[..., 0], G[..., 1], G[..., 2]
    bx, by, bz = B[..., 0], B[..., 1], B[..., 2]
    num = (gx * by - gy * bx) * g_total(G)
    den = bz * (gx * gx + gy * gy) - gz * (gx * bx + gy * by)
    vertical = (gx == 0.0) & (gy == 0.0)
    return np.where(vertical, np.nan, _wrap_360(np.degrees(np.arctan2(num, den))))


def horizontal_vertical_nT(G, B):
    """
    Return (Bh, Bv) [nT]: the horizontal and vertical (downward) parts of B.

    ``Bv = G.B / |G|`` and ``Bh = sqrt(|B|^2 - Bv^2)`` (formulas.md, seed 002
    Eq. 10), the latter computed as ``|G x B| / |G|``, the same quantity
    without the cancellation of the difference when B is near vertical.
    """
    G = np.asarray(G, dtype=float)
    B = np.asarray(B, dtype=float)
    g = g_total(G)
    return np.linalg.norm(np.cross(G, B), axis=-1) / g, _dot(G, B) / g


def dip_deg(G, B):
    """
    Return the dip ``D = asin(G.B / (|G| |B|))`` [deg], positive downward.

    Computed as ``atan2(Bv, Bh)`` (``horizontal_vertical_nT``), the same angle
    as the asin of formulas.md but exact near +-90 deg.
    """
    bh, bv = horizontal_vertical_nT(G, B)
    return np.degrees(np.arctan2(bv, bh))


def magnetic_toolface_deg(G, B):
    """
    Return the magnetic toolface in [0, 360) [deg]: magnetic north seen across the tool.

    Definition chosen here: ``MTF = atan2(Hx, Hy)`` with ``H = B - Bv G / |G|``
    the horizontal field, i.e. the direction of the horizontal magnetic north
    in the cross-axial plane, measured from y toward x like GTF.  From the
    forward model, ``Hx = B cosD (cosI cosA sinTF + sinA cosTF)`` and
    ``Hy = B cosD (cosI cosA cosTF - sinA sinTF)``: free of the dip term
    ``sinD sinI`` that enters ``atan2(Bx, By)`` (seed 001 Eq. 3).  Both equal
    ``GTF + A`` as I -> 0 (formulas.md) and differ from it at inclination;
    undefined when the tool points along magnetic north (H axial).
    """
    G = np.asarray(G, dtype=float)
    B = np.asarray(B, dtype=float)
    unit_g = G / g_total(G)[..., np.newaxis]
    horizontal = B - _dot(unit_g, B)[..., np.newaxis] * unit_g
    return _wrap_360(np.degrees(np.arctan2(horizontal[..., 0], horizontal[..., 1])))


def true_azimuth_deg(azimuth_deg, declination_deg, grid_convergence_deg=0.0):
    """
    Return the azimuth referred to true (or grid) north, in [0, 360) [deg].

    ``A_true = A + declination - grid convergence`` (formulas.md); with the
    default convergence 0 the result is the true azimuth.
    """
    return _wrap_360(np.asarray(azimuth_deg, dtype=float) + declination_deg
                     - grid_convergence_deg)


def azimuth_sensitivity_deg(inclination_deg, azimuth_deg, dip_deg, b_total_nT, delta_bz_nT):
    """
    Return the azimuth error [deg] caused by an axial field error ``delta_bz_nT``.

    First order: ``dA = -sinI sinA dBz / (B cosD)`` (formulas.md; at I = 90,
    A = 90, B = 50 uT, D = 72 deg, 220 nT gives -0.82 deg).  East/west
    horizontal holes are the worst case (seed 002 §3.3).
    """
    i, a, d = (np.radians(np.asarray(x, dtype=float))
               for x in (inclination_deg, azimuth_deg, dip_deg))
    return np.degrees(-np.sin(i) * np.sin(a) * np.asarray(delta_bz_nT, dtype=float)
                      / (np.asarray(b_total_nT, dtype=float) * np.cos(d)))


@dataclass(frozen=True)
class QcLimits:
    """
    Survey QC tolerances (ISCWSA eBook §22.1, quoted in formulas.md).

    ``b_total_tolerance_nT`` and ``dip_tolerance_deg`` are the industry limits
    (300 nT, 0.25 deg).  ``g_total_tolerance`` is in the unit of G (m/s^2 on
    our topics): 3 sigma of the ISCWSA MWD accelerometer terms,
    ``3 sqrt(0.004^2 + (0.0005 g)^2) = 0.019 m/s^2`` (formulas.md table).
    """

    b_total_tolerance_nT: float = 300.0
    dip_tolerance_deg: float = 0.25
    g_total_tolerance: float = 0.019


@dataclass(frozen=True)
class SurveyQc:
    """Per-sample QC of a survey: deltas (measured - expected) and pass flags."""

    b_total_delta_nT: np.ndarray
    dip_delta_deg: np.ndarray
    g_total_delta: np.ndarray
    b_total_ok: np.ndarray
    dip_ok: np.ndarray
    g_total_ok: np.ndarray

    @property
    def ok(self):
        """Return True where all three tests pass."""
        return self.b_total_ok & self.dip_ok & self.g_total_ok


def survey_qc(G, B, reference_total_nT, reference_dip_deg, g_expected, limits=QcLimits()):
    """
    Return the SurveyQc of each sample against the reference field.

    A sample passes a test when ``|measured - expected|`` is within the limit
    (inclusive); non-finite readings fail every test they enter.
    """
    b_delta = b_total_nT(B) - reference_total_nT
    dip_delta = dip_deg(G, B) - reference_dip_deg
    g_delta = g_total(G) - g_expected
    return SurveyQc(
        b_total_delta_nT=b_delta, dip_delta_deg=dip_delta, g_total_delta=g_delta,
        b_total_ok=np.abs(b_delta) <= limits.b_total_tolerance_nT,
        dip_ok=np.abs(dip_delta) <= limits.dip_tolerance_deg,
        g_total_ok=np.abs(g_delta) <= limits.g_total_tolerance)


def survey_of(f_tool, b_tool_nT):
    """
    Return per-shot |g|, |B|, dip, inclination and azimuth of corrected readings.

    ``f_tool`` (N, 3) specific force [m/s^2] and ``b_tool_nT`` (N, 3) the
    field, both in the z-up tool frame (seed 002's input): a dict of arrays
    ``g_total_mps2``, ``b_total_nT``, ``dip_deg``, ``inclination_deg``,
    ``azimuth_deg``.
    """
    gravity, b_iscwsa = gravity_from_specific_force(f_tool), iscwsa_from_tool(b_tool_nT)
    return {'g_total_mps2': g_total(gravity), 'b_total_nT': b_total_nT(b_tool_nT),
            'dip_deg': dip_deg(gravity, b_iscwsa), 'inclination_deg': inclination_deg(gravity),
            'azimuth_deg': azimuth_deg(gravity, b_iscwsa)}
