"""
Multi-station analysis (MSA): the drill string's magnetisation from many surveys (seed 002).

Liu, Di & Zhang, *High precision magnetic azimuth correction of horizontal
well by multi-station analysis*, Chinese J. Geophys. 62(7), 2019 ("seed
002"), after Brooks et al. (1998).  Frame and quantities as in
``inclino_ros.core.magnetics`` (ISCWSA survey frame: x, y cross-axial, z toward the
bit; G the gravity vector, B in nT).  The drill string adds a constant vector
``eps`` to B in the tool frame; the corrected field of station i is
``B_i - eps`` and its horizontal and vertical parts ``(Bh_i, Bv_i)``
(``magnetics.horizontal_vertical_nT``; seed 002 Eqs. 11-13) should equal
the reference ``(F cos D, F sin D)``.  MSA minimises (Eq. 10)::

    V(eps) = sum_i (Bh_i - Bh_ref)^2 + (Bv_i - Bv_ref)^2

- ``solve_msa_classic``: Brooks, eps = (eps_x, eps_y, eps_z) by Gauss-Newton
  on the residual vector; it needs toolfaces spread round the circle.
- ``solve_msa_axial``: eps_z only (the cross-axial part taken as zero).
- ``solve_msa_improved``: seed 002 §2.2, the cross-axial part known beforehand
  (per-rotation circle fit, Eqs. 15-22), then eps_z0 at the mean station
  (Eqs. 23-27, closed form), an interval eps_z0 +- d (Eqs. 28-32) and the
  bounded minimum of V inside it (Eq. 33).
- ``short_collar``: the single-station correction, Bz of each station alone
  (Bx, By assumed right); useless near east/west (flagged, azimuth NaN).

Derivation of the closed form (the seed's Eqs. 24-27 are lost in our copy;
this is our reconstruction, exact rather than linearised).  With
``B_c = B - eps_z z``: ``|B_c|^2 = |B|^2 - 2 Bz eps_z + eps_z^2`` and
``Bv = Bv(0) - u_z eps_z`` (u = G / |G|).  The mean station (averages over
the stations: M = mean |B|^2, Z = mean Bz, v = mean Bv, u = mean u_z) matches
the reference |B| (so the dip too) when
``M - 2 Z eps_z + eps_z^2 = F^2``, i.e. ``e_B = Z - sign(Z) sqrt(Z^2 - M + F^2)``
(the root of the smaller magnitude: the interference is smaller than the
field, seed 002 Fig. 5), and its vertical part when ``e_V = (v - Bv_ref) / u``.
Weighting each by its squared sensitivity (``d|B|/d eps_z = sqrt(Z^2 - M +
F^2) / F``, ``d Bv / d eps_z = -u``) gives the least-squares combination
``eps_z0 = (w_B e_B + w_V e_V) / (w_B + w_V)``: exact without noise, and stable
where one of the two loses its sensitivity (|B| near east/west, Bv near
horizontal).  Applied to one station it is the short-collar correction.

The interval (Eqs. 28-32, our reading).  With ``R_i`` the residual vector of
station i at eps_z0 and ``k_i = dR_i / d eps_z`` (the seed's k_l: the move of
station i for 1 nT of axial interference), linearised
``V(eps_z0 + delta) = sum |R_i + k_i delta|^2`` is least at
``delta* = -sum R_i . k_i / sum |k_i|^2``.  Splitting ``R_i = R0 + r_i``,
``k_i = k0 + (k_i - k0)`` about their means and Cauchy-Schwarz give
``|delta*| <= (|R0| |k0| + sigma_min sigma_k) / (|k0|^2 + sigma_k^2)`` with
``sigma_min`` the RMS spread of the r_i (the seed's sigma(eps_z0)) and
``sigma_k`` that of the k_i; for R0 = 0 and sigma_k >> |k0| it is the ratio
``sigma_min / sigma_k``, and the seed's r_xy (0.1-0.2, "negligible") is left
out.  ``d`` is that bound times ``MsaLimits.interval_margin`` (room for the
non-linearity), at least ``MsaLimits.min_interval_nT``.  This is a SEARCH
BRACKET, not a confidence interval: its width is set by the spread of the
stations, not by the precision of eps_z (typically +-17 nT around a 1 sigma
of 3 nT).  A minimum on its edge means the bracket missed the solution:
refused.

How well it solved (``MsaResult.eps_covariance_nT2``, ``azimuth_std_deg``).
At the solution, with J the Jacobian of the 2N residuals over the p solved
components and s^2 = V / (2N - p) the residual variance, the fit's own
covariance is ``s^2 (J^T J)^-1``.  The reference field is not exact (WMM
2025 1 sigma: F 138 nT, dip 0.20 deg, formulas.md): the solution moves with
it as ``d eps = -(J^T J)^-1 J^T (dR / d ref) d ref``, with ``dR/dF =
-(cos D, sin D)`` and ``dR/dD = F (sin D, -cos D)`` per station, which adds
``S diag(sigma_F^2, sigma_D^2) S^T``.  Each station's azimuth 1 sigma is
``grad_B A^T (C_eps + s^2 I) grad_B A + sigma_G^2 |grad_G A|^2``
(``uncertainty.azimuth_gradients``; sigma_G the scatter of the stations'
|G|): the interference's uncertainty, reference included, and the station's
own noise.  The geometry is judged again at the solution (its condition
number and axial sensitivity, ``MsaLimits``): a start at eps = 0 can look
well posed where the solution is not.
"""

from dataclasses import dataclass, field, replace
import math

from inclino_ros.core import magnetics
from inclino_ros.core.attitude import as_vectors
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.core.refusal import Refused
from inclino_ros.core.uncertainty import azimuth_gradients, toolface_std_rad
import numpy as np

#: Largest interference accepted [nT]: a drill string's magnetisation stays well below
#: the Earth's field (seed 002 §3.2, Fig. 5 searches +-10000 nT).
MAX_INTERFERENCE_NT = 10000.0
#: Largest reference field [nT]: ten times the Earth's strongest, far from overflow.
MAX_REFERENCE_NT = 1e6
#: Largest | |B| - F | of a station [nT]: the interference on all three axes.
MAX_FIELD_OFFSET_NT = math.sqrt(3.0) * MAX_INTERFERENCE_NT
#: Gauss-Newton stops when a step changes eps by less than this [nT]...
STEP_TOLERANCE_NT = 1e-4
#: ...or after this many iterations (then refused: it does not converge); the bounded
#: minimum of the improved method takes ten times as many evaluations at most.
MAX_ITERATIONS = 50
#: 1 sigma of the World Magnetic Model 2025 (formulas.md): total field [nT], dip [deg].
#: An IFR model is roughly half; pass its own (``reference_std``).
WMM_REFERENCE_STD = (138.0, 0.20)


class MsaRefused(Refused):
    """Stations that cannot give a trustworthy correction; ``reason`` says why."""


@dataclass(frozen=True)
class MsaLimits:
    """
    When MSA refuses.

    - ``min_stations``: 5, so that even the full solve (3 unknowns, 2
      equations a station) has 10 equations, and 4 stations at least are
      needed to close every toolface gap to 100 deg anyway.
    - ``max_toolface_gap_deg``: the full solve frees eps_x, eps_y only when
      the largest gap between the stations' gravity toolfaces is at most this
      (formulas.md: one open-source implementation uses 100 deg).
    - ``min_inclination_deg``: when every station is nearer vertical than
      this, the azimuth is undefined and feels no axial error.
    - ``max_condition_number``: of the Gauss-Newton Jacobian (columns of
      order 1, entries per nT): above it, noise is amplified that much.
    - ``min_axial_sensitivity``: the RMS over stations of ``|k_i|`` (nT of
      residual per nT of eps_z) below which eps_z is not observable (all
      stations horizontal and east/west).
    - ``qc``: ``magnetics.QcLimits`` of the corrected survey (B-total 300 nT,
      dip 0.25 deg; its G-total tolerance in m/s^2 is applied relative to g,
      against the stations' median |G|, since G may be in any unit).
    - ``east_west_deg``: half-width of the bands about 90 and 270 deg where
      the short-collar correction must not be used (70-110, 250-290 deg).
    - ``interval_margin``, ``min_interval_nT``: the improved method's
      interval half-width d (module docstring).
    - ``max_azimuth_std_deg``: the RMS over the used stations of the azimuth
      1 sigma the solved interference alone gives (its covariance: fit and
      reference field, ``station_azimuth_std_deg``) above which the solution
      is refused (issue 19 item 9): the correction is then known no better
      than it moves the azimuth.  Near east/west horizontal stations a
      WMM-grade reference moves eps_z by thousands of nT: 1 sigma of 3-4 deg,
      and the corrected azimuths were worse than the raw ones (RMS 4.7 vs
      4.6 deg) while the axial sensitivity passed.  The same limit as the
      outputs' (``magnetic.azimuth_max_std_deg``, ``--azimuth-max-std-deg``).
    """

    min_stations: int = 5
    max_toolface_gap_deg: float = 100.0
    min_inclination_deg: float = 5.0
    max_condition_number: float = 100.0
    min_axial_sensitivity: float = 0.05
    qc: magnetics.QcLimits = field(default_factory=magnetics.QcLimits)
    east_west_deg: float = 20.0
    interval_margin: float = 2.0
    min_interval_nT: float = 5.0
    max_azimuth_std_deg: float = 1.0


@dataclass(frozen=True)
class MsaDiagnostics:
    """How well the stations pose the problem."""

    stations_used: int
    toolface_gap_deg: float        # largest gap between the used stations' toolfaces
    inclination_range_deg: tuple   # (min, max) of the used stations
    axial_sensitivity: float       # RMS |k_i| at the solution [nT per nT]
    condition_number: float        # of the Jacobian at the solution (1 for eps_z alone)


@dataclass(frozen=True)
class MsaResult:
    """A solved multi-station analysis; station arrays cover ALL the input stations."""

    method: str
    eps_nT: np.ndarray             # (3,) interference (eps_x, eps_y, eps_z) removed
    corrected_nT: np.ndarray       # (N, 3) B - eps
    azimuth_raw_deg: np.ndarray    # (N,) of the readings as they are
    azimuth_deg: np.ndarray        # (N,) of the corrected readings
    v_before_nT2: float            # V(0) over the used stations (Eq. 10)
    v_after_nT2: float             # V(eps)
    iterations: int
    qc: magnetics.SurveyQc         # of the corrected readings
    excluded: tuple                # 0-based stations left out of the solve (QC)
    diagnostics: MsaDiagnostics
    eps_covariance_nT2: np.ndarray = None  # (3, 3) fit and reference field; 0 where not solved
    residual_std_nT: float = math.nan      # s = sqrt(V / (2N - p))
    azimuth_std_deg: np.ndarray = None     # (N,) 1 sigma per station (NaN: undefined)
    reference_std: tuple = WMM_REFERENCE_STD  # (total [nT], dip [deg]) 1 sigma taken
    eps_z0_nT: float = math.nan    # improved: the mean-station value (Eq. 27)
    search_bracket_nT: tuple = None  # improved: (eps_z0 - d, eps_z0 + d) (Eq. 28)

    @property
    def eps_std_nT(self):
        """Return the 1 sigma of (eps_x, eps_y, eps_z) [nT]: fit and reference field."""
        return np.sqrt(np.diag(self.eps_covariance_nT2))

    @property
    def used(self):
        """Return whether each station took part in the solve (not ``excluded``)."""
        used = np.ones(self.azimuth_deg.shape[0], dtype=bool)
        used[list(self.excluded)] = False
        return used


@dataclass(frozen=True)
class ShortCollarResult:
    """Single-station corrections: each station's own axial interference."""

    eps_z_nT: np.ndarray          # (N,) per station
    corrected_nT: np.ndarray      # (N, 3)
    azimuth_raw_deg: np.ndarray   # (N,)
    azimuth_deg: np.ndarray       # (N,) NaN where ``east_west``
    east_west: np.ndarray         # (N,) bool: within the forbidden bands
    v_before_nT2: float
    v_after_nT2: float
    qc: magnetics.SurveyQc


def reference_nT(reference_total_nT, reference_dip_deg):
    """Return (Bh_ref, Bv_ref) [nT] of the reference field."""
    dip = math.radians(reference_dip_deg)
    return reference_total_nT * math.cos(dip), reference_total_nT * math.sin(dip)


def residual_nT(G, B, reference):
    """Return the residual vector ``[Bh_i - Bh_ref, Bv_i - Bv_ref]`` (2N,) of Eq. 10."""
    bh, bv = magnetics.horizontal_vertical_nT(G, B)
    return np.concatenate([bh - reference[0], bv - reference[1]])


def misfit_nT2(G, B, reference_total_nT, reference_dip_deg, eps_nT=(0.0, 0.0, 0.0)):
    """Return V(eps) of seed 002 Eq. 10 [nT^2] for the readings G, B (N, 3)."""
    reference = reference_nT(reference_total_nT, reference_dip_deg)
    return float(np.sum(residual_nT(G, np.asarray(B) - eps_nT, reference) ** 2))


def azimuth_difference_deg(azimuth_deg, other_deg):
    """Return ``azimuth - other`` wrapped to [-180, 180) [deg] (e.g. an error against truth)."""
    return np.mod(np.asarray(azimuth_deg) - other_deg + 180.0, 360.0) - 180.0


def toolface_gap_deg(G):
    """Return the largest gap [deg] between the gravity toolfaces of the stations (360: none)."""
    toolface = np.sort(magnetics.gravity_toolface_deg(G))
    if toolface.size == 0:
        return 360.0
    return float(np.max(np.diff(np.append(toolface, toolface[0] + 360.0))))


def solve_msa_classic(G, B, reference_total_nT, reference_dip_deg, limits=MsaLimits(),
                      exclude_failing_qc=False, reference_std=WMM_REFERENCE_STD):
    """
    Return Brooks' full MSA: eps = (eps_x, eps_y, eps_z) minimising V (Eq. 10).

    Gauss-Newton from eps = 0 with the analytic Jacobian of the residual
    vector.  Refused (MsaRefused) besides the common reasons (``MsaLimits``)
    when the toolfaces leave a gap above ``max_toolface_gap_deg``: eps_x and
    eps_y are then not separable from the Earth's field.  With
    ``exclude_failing_qc`` the stations failing QC (G-total before, B-total
    or dip after the correction) are left out and named in ``excluded``.
    ``reference_std`` (total [nT], dip [deg]) is the reference field's own
    1 sigma, carried into ``eps_covariance_nT2`` and ``azimuth_std_deg``.
    """
    return _solve('classic', G, B, reference_total_nT, reference_dip_deg, limits,
                  exclude_failing_qc, (0.0, 0.0), reference_std)


def solve_msa_axial(G, B, reference_total_nT, reference_dip_deg, limits=MsaLimits(),
                    exclude_failing_qc=False, reference_std=WMM_REFERENCE_STD):
    """Return the axial-only MSA: eps_z minimising V, eps_x = eps_y = 0 (see classic)."""
    return _solve('axial', G, B, reference_total_nT, reference_dip_deg, limits,
                  exclude_failing_qc, (0.0, 0.0), reference_std)


def solve_msa_improved(G, B, reference_total_nT, reference_dip_deg, cross_axial_nT=(0.0, 0.0),
                       limits=MsaLimits(), exclude_failing_qc=False,
                       reference_std=WMM_REFERENCE_STD, cross_axial_covariance_nT2=None):
    """
    Return seed 002's improved MSA (§2.2, Eqs. 23-33).

    ``cross_axial_nT`` = (eps_x, eps_y) is the cross-axial interference found
    beforehand (the per-rotation circle fit of §2.1); it is removed first.
    eps_z0 is the mean station's closed-form axial error (Eqs. 23-27), d the
    half-width of its interval (Eqs. 28-32), both as derived in the module
    docstring, and eps_z the bounded minimum of V in ``eps_z0 +- d``
    (Eq. 33, ``scipy.optimize.minimize_scalar``).  No toolface spread is
    needed.  Refused besides the common reasons when the minimum lies on the
    edge of that search bracket.  Refusals and QC exclusion as in
    ``solve_msa_classic``; ``improved_cross_axial`` says where (eps_x, eps_y)
    may come from, and ``cross_axial_covariance_nT2`` (2x2, None: not known)
    their uncertainty, carried into ``eps_covariance_nT2`` and the stations'.
    """
    result = _solve('improved', G, B, reference_total_nT, reference_dip_deg, limits,
                    exclude_failing_qc, tuple(float(v) for v in cross_axial_nT), reference_std)
    if cross_axial_covariance_nT2 is None:
        return result
    covariance = result.eps_covariance_nT2.copy()
    covariance[:2, :2] += cross_axial_covariance_nT2
    G = as_vectors(G, 'G')
    _refuse_imprecise(G[result.used], result.corrected_nT[result.used], covariance, limits)
    return replace(result, eps_covariance_nT2=covariance, azimuth_std_deg=station_azimuth_std_deg(
        G, result.corrected_nT, covariance, result.residual_std_nT,
        _gravity_noise(G[result.used])))


def improved_cross_axial(G, B, reference_total_nT, reference_dip_deg, given_nT=None,
                         rotation_fitted_at=None, limits=MsaLimits(), exclude_failing_qc=False,
                         reference_std=WMM_REFERENCE_STD):
    """
    Return ((eps_x, eps_y) [nT], where they come from, their 2x2 covariance or None).

    For ``solve_msa_improved``.
    In order: ``given_nT``; zero when a rotation fit (``rotation_fitted_at``)
    has already removed the cross-axial part from B (seed 002 §2.1); the
    classic solve's, when the toolfaces spread (largest gap at most
    ``limits.max_toolface_gap_deg``).  Otherwise MsaRefused: taking it as zero
    would leave its error in every azimuth (80 nT cost 0.23 deg on an
    east-west well); the axial method is the one that assumes it.
    """
    if given_nT is not None:
        return tuple(float(v) for v in given_nT), 'given', None
    if rotation_fitted_at is not None:
        return (0.0, 0.0), f'removed by the rotation fit of {rotation_fitted_at}', None
    gap_deg = toolface_gap_deg(G)
    if gap_deg <= limits.max_toolface_gap_deg or len(G) == 0:   # none: the count refuses
        classic = solve_msa_classic(G, B, reference_total_nT, reference_dip_deg, limits,
                                    exclude_failing_qc, reference_std)
        return (tuple(float(v) for v in classic.eps_nT[:2]),
                f'from the classic solve (toolfaces spread, largest gap {gap_deg:.1f} deg)',
                classic.eps_covariance_nT2[:2, :2])
    raise MsaRefused(
        f'improved needs the cross-axial interference, and there is no rotation fit to take '
        f'it from and the toolfaces do not spread (largest gap {gap_deg:.1f} deg, limit '
        f'{limits.max_toolface_gap_deg:g}) for the classic solve to find it: fit a rotation '
        '(~/capture_rotation, inclino fit-rotation), give it, or use the axial method, which '
        'takes it as zero')


def short_collar(G, B, reference_total_nT, reference_dip_deg, limits=MsaLimits()):
    """
    Return the single-station (short-collar) correction of every station.

    Bx and By are assumed right; each station's Bz is corrected by the
    closed form of the module docstring applied to that station alone.  A
    station whose raw or corrected azimuth lies within
    ``limits.east_west_deg`` of 90 or 270 deg is flagged ``east_west`` and
    gets a NaN azimuth: there the correction divides by a vanishing
    sensitivity (formulas.md; seed 002 §4), and so does a station whose
    sensitivity is below ``limits.min_axial_sensitivity`` (its eps_z NaN too).
    Refused for non-finite input.
    """
    G, B = as_vectors(G, 'G'), as_vectors(B, 'B')
    _refuse_non_finite(G, B)
    _refuse_implausible(G, B, reference_total_nT, reference_dip_deg, np.arange(G.shape[0]))
    reference = reference_nT(reference_total_nT, reference_dip_deg)
    with np.errstate(divide='ignore', invalid='ignore'):
        eps_z, weight = _closed_form_axial_nT(G, B, reference_total_nT, reference[1],
                                              average=False)
    insensitive = weight < limits.min_axial_sensitivity ** 2
    eps_z = np.where(insensitive, np.nan, eps_z)
    corrected = B - np.outer(eps_z, (0.0, 0.0, 1.0))
    raw_deg, azimuth = magnetics.azimuth_deg(G, B), magnetics.azimuth_deg(G, corrected)
    east_west = insensitive | _near_east_west(raw_deg, limits) | _near_east_west(azimuth, limits)
    return ShortCollarResult(
        eps_z_nT=eps_z, corrected_nT=corrected, azimuth_raw_deg=raw_deg,
        azimuth_deg=np.where(east_west, np.nan, azimuth), east_west=east_west,
        v_before_nT2=float(np.sum(residual_nT(G, B, reference) ** 2)),
        v_after_nT2=float(np.sum(residual_nT(G, corrected, reference) ** 2)),
        qc=_qc(G, corrected, reference_total_nT, reference_dip_deg, limits))


def _solve(method, G, B, reference_total_nT, reference_dip_deg, limits, exclude_failing_qc,
           cross_axial_nT, reference_std):
    """Check, solve, QC and (optionally) solve again; a numerical failure is a refusal."""
    G, B = as_vectors(G, 'G'), as_vectors(B, 'B')
    finite = _finite(G, B)
    if not exclude_failing_qc:
        _refuse_non_finite(G, B)
    _refuse_implausible(G[finite], B[finite], reference_total_nT, reference_dip_deg,
                        np.flatnonzero(finite))
    try:
        with np.errstate(all='ignore'):
            return _solve_checked(method, G, B, reference_total_nT, reference_dip_deg, limits,
                                  exclude_failing_qc, cross_axial_nT, reference_std, finite)
    except (np.linalg.LinAlgError, FloatingPointError) as err:
        raise MsaRefused(f'numerical failure of the solve ({err})') from None


def _solve_checked(method, G, B, reference_total_nT, reference_dip_deg, limits,
                   exclude_failing_qc, cross_axial_nT, reference_std, finite):
    """Return the MsaResult of stations whose magnitudes were checked (``_solve``)."""
    used = finite & _g_total_ok(G, finite, limits)
    _check_qc(used, finite, 'G-total off (tool moving?)', exclude_failing_qc)
    solution = _solve_used(method, G[used], B[used], reference_total_nT, reference_dip_deg,
                           limits, cross_axial_nT, reference_std)
    qc = _qc(G, B - solution['eps_nT'], reference_total_nT, reference_dip_deg, limits)
    passing = used & qc.b_total_ok & qc.dip_ok
    if not passing[used].all():
        _check_qc(passing, used, 'B-total or dip off after the correction',
                  exclude_failing_qc)
        used = passing
        solution = _solve_used(method, G[used], B[used], reference_total_nT,
                               reference_dip_deg, limits, cross_axial_nT, reference_std)
        qc = _qc(G, B - solution['eps_nT'], reference_total_nT, reference_dip_deg, limits)
    corrected = B - solution['eps_nT']
    return MsaResult(
        method=method, corrected_nT=corrected, azimuth_raw_deg=magnetics.azimuth_deg(G, B),
        azimuth_deg=magnetics.azimuth_deg(G, corrected), qc=qc,
        excluded=tuple(np.flatnonzero(~used).tolist()),
        azimuth_std_deg=station_azimuth_std_deg(
            G, corrected, solution['eps_covariance_nT2'], solution['residual_std_nT'],
            _gravity_noise(G[used])),
        reference_std=tuple(reference_std), **solution)


def _solve_used(method, G, B, reference_total_nT, reference_dip_deg, limits, cross_axial_nT,
                reference_std):
    """Return the MsaResult fields of a solve on the used stations only."""
    reference = reference_nT(reference_total_nT, reference_dip_deg)
    count = G.shape[0]
    if count < limits.min_stations:
        raise MsaRefused(f'only {count} usable station(s), need at least '
                         f'{limits.min_stations}')
    inclination = magnetics.inclination_deg(G)
    if np.all(inclination < limits.min_inclination_deg):
        raise MsaRefused(
            f'every station is within {limits.min_inclination_deg:g} deg of vertical: the '
            'azimuth is undefined there and feels no axial interference')
    gap_deg = toolface_gap_deg(G)
    if method == 'classic' and gap_deg > limits.max_toolface_gap_deg:
        raise MsaRefused(
            f'toolfaces not spread: largest gap {gap_deg:.1f} deg exceeds '
            f'{limits.max_toolface_gap_deg:g} deg, so the cross-axial eps_x, eps_y cannot be '
            'freed; use the axial or improved method (cross-axial from rotation captures)')
    start = np.array([*cross_axial_nT, 0.0])
    axes = [0, 1, 2] if method == 'classic' else [2]
    if method == 'improved':
        eps, iterations, extra = _improved(G, B - start, reference_total_nT, reference, limits)
        eps = eps + start
    else:
        eps, iterations = _gauss_newton(G, B, reference, axes, limits)
        extra = {}
    jacobian = _jacobian(G, B - eps, reference, axes)
    _refuse_ill_posed(G, B - eps, reference, jacobian, limits, 'at the solution')
    covariance, residual_std = _eps_covariance(G, B - eps, reference, reference_total_nT,
                                               reference_dip_deg, axes, reference_std)
    _refuse_imprecise(G, B - eps, covariance, limits)
    diagnostics = MsaDiagnostics(
        stations_used=count, toolface_gap_deg=gap_deg,
        inclination_range_deg=(float(inclination.min()), float(inclination.max())),
        axial_sensitivity=_axial_sensitivity(G, B - eps, reference),
        condition_number=float(np.linalg.cond(jacobian)))
    return dict(eps_nT=eps, v_before_nT2=float(np.sum(residual_nT(G, B, reference) ** 2)),
                v_after_nT2=float(np.sum(residual_nT(G, B - eps, reference) ** 2)),
                iterations=iterations, diagnostics=diagnostics, eps_covariance_nT2=covariance,
                residual_std_nT=residual_std, **extra)


def _eps_covariance(G, B, reference, reference_total_nT, reference_dip_deg, axes,
                    reference_std):
    """
    Return (3x3 covariance of eps [nT^2], residual 1 sigma s [nT]) at the solution B.

    ``s^2 (J^T J)^-1`` of the fit plus ``S diag(sigma_F^2, sigma_D^2) S^T``
    of the reference field (module docstring), on the solved ``axes``.
    """
    jacobian = _jacobian(G, B, reference, axes)
    residual = residual_nT(G, B, reference)
    variance = float(residual @ residual) / max(residual.size - len(axes), 1)
    inverse = np.linalg.inv(jacobian.T @ jacobian)
    count = G.shape[0]
    dip = math.radians(reference_dip_deg)
    d_residual = np.column_stack([
        -np.concatenate([np.full(count, math.cos(dip)), np.full(count, math.sin(dip))]),
        reference_total_nT * np.concatenate([np.full(count, math.sin(dip)),
                                             np.full(count, -math.cos(dip))])])
    moves = -inverse @ jacobian.T @ d_residual           # d eps / d (F, D)
    reference_variance = np.diag([reference_std[0] ** 2, math.radians(reference_std[1]) ** 2])
    solved = variance * inverse + moves @ reference_variance @ moves.T
    covariance = np.zeros((3, 3))
    covariance[np.ix_(axes, axes)] = solved
    return covariance, math.sqrt(variance)


def _gravity_noise(G):
    """Return the per-axis noise of G estimated from the scatter of |G| (0 for < 2 stations)."""
    return float(np.std(magnetics.g_total(G), ddof=1)) if G.shape[0] > 1 else 0.0


def station_azimuth_std_deg(G, B, eps_covariance_nT2, field_std_nT, gravity_std):
    """
    Return each station's azimuth 1 sigma [deg] (module docstring): eps, B and G noise.

    ``G``, ``B`` (N, 3) corrected readings (ISCWSA), ``eps_covariance_nT2`` (3, 3),
    ``field_std_nT`` and ``gravity_std`` the per-axis noise of B and G.
    NaN where the azimuth is undefined (vertical).
    """
    grad_g, grad_b = azimuth_gradients(G, B)
    variance = (np.einsum('mi,ij,mj->m', grad_b, eps_covariance_nT2, grad_b)
                + field_std_nT ** 2 * np.sum(grad_b ** 2, axis=1)
                + gravity_std ** 2 * np.sum(grad_g ** 2, axis=1))
    return np.degrees(np.sqrt(variance))


def _gauss_newton(G, B, reference, axes, limits):
    """Return (eps (3,), iterations) minimising V over the components ``axes``."""
    eps = np.zeros(3)
    for iteration in range(1, MAX_ITERATIONS + 1):
        corrected = B - eps
        jacobian = _jacobian(G, corrected, reference, axes)
        if iteration == 1:
            _refuse_ill_posed(G, corrected, reference, jacobian, limits)
        step = np.linalg.lstsq(jacobian, -residual_nT(G, corrected, reference), rcond=None)[0]
        eps[axes] += step
        if np.max(np.abs(eps)) > MAX_INTERFERENCE_NT:
            break
        if np.max(np.abs(step)) < STEP_TOLERANCE_NT:
            return eps, iteration
    raise MsaRefused(f'the solve does not converge to an interference below '
                     f'{MAX_INTERFERENCE_NT:g} nT (last eps {np.round(eps, 1).tolist()} nT): '
                     'wrong reference field, or the readings are not of one tool')


def _improved(G, B, reference_total_nT, reference, limits):
    """
    Return (eps (3,), iterations, extra fields) of seed 002 Eqs. 23-33.

    MsaRefused when the minimum lies on the edge of the search bracket.
    """
    eps_z0, weight = _closed_form_axial_nT(G, B, reference_total_nT, reference[1],
                                           average=True)
    if weight < limits.min_axial_sensitivity ** 2:
        raise MsaRefused(
            f'singular geometry: the mean station feels eps_z by {math.sqrt(weight):.3g} nT '
            f'per nT (limit {limits.min_axial_sensitivity:g}); stations all horizontal and '
            'east/west?')
    axial = np.array([0.0, 0.0, 1.0])
    at_z0 = B - eps_z0 * axial
    jacobian = _jacobian(G, at_z0, reference, [2])
    _refuse_ill_posed(G, at_z0, reference, jacobian, limits)
    stations = residual_nT(G, at_z0, reference).reshape(2, -1).T
    slopes = jacobian.reshape(2, -1).T
    mean_r, mean_k = stations.mean(axis=0), slopes.mean(axis=0)
    sigma_min = math.sqrt(np.mean(np.sum((stations - mean_r) ** 2, axis=1)))
    sigma_k = math.sqrt(np.mean(np.sum((slopes - mean_k) ** 2, axis=1)))
    bound = ((np.linalg.norm(mean_r) * np.linalg.norm(mean_k) + sigma_min * sigma_k)
             / (mean_k @ mean_k + sigma_k ** 2))
    half_width = max(limits.interval_margin * bound, limits.min_interval_nT)
    interval = (eps_z0 - half_width, eps_z0 + half_width)
    # Imported here: scipy.optimize takes 0.5 s to import, which every ``inclino``
    # command would pay (the CLI registers all subcommands at start).
    from scipy.optimize import minimize_scalar
    found = minimize_scalar(
        lambda eps_z: np.sum(residual_nT(G, B - eps_z * axial, reference) ** 2),
        bounds=interval, method='bounded',
        options={'xatol': min(1e-3, 1e-4 * half_width), 'maxiter': 10 * MAX_ITERATIONS})
    # Brent's bounded search keeps ~sqrt(machine eps) |x| off the bounds: an edge is nearer.
    edge_nT = max(1e-2 * half_width, 1e-6 * max(1.0, abs(found.x)))
    if min(found.x - interval[0], interval[1] - found.x) < edge_nT:
        raise MsaRefused(
            f'the minimum of V lies on the edge of the search bracket [{interval[0]:.1f}, '
            f'{interval[1]:.1f}] nT (seed 002 Eqs. 28-32: a search range about eps_z0 '
            f'{eps_z0:.1f} nT, not a confidence interval): the solution may lie outside it; '
            'use the classic or axial method')
    return (found.x * axial, int(found.nit),
            {'eps_z0_nT': float(eps_z0), 'search_bracket_nT': tuple(map(float, interval))})


def _closed_form_axial_nT(G, B, reference_total_nT, reference_vertical_nT, average):
    """
    Return (eps_z, weight w_B + w_V) of the closed form (module docstring).

    ``average``: of the mean station (seed 002 Eqs. 23-27), else per station
    (short collar).
    """
    mean = (lambda values: float(np.mean(values))) if average else (lambda values: values)
    bz = B[:, 2]
    squared = mean(magnetics.b_total_nT(B) ** 2)
    z = mean(bz)
    vertical = mean(magnetics.horizontal_vertical_nT(G, B)[1])
    u_z = mean(G[:, 2] / magnetics.g_total(G))
    discriminant = np.maximum(z * z - squared + reference_total_nT ** 2, 0.0)
    e_b = z - np.sign(z) * np.sqrt(discriminant)
    w_b = discriminant / reference_total_nT ** 2
    weight = w_b + u_z * u_z
    # w_V e_V = u_z^2 (v - Bv_ref) / u_z: written without the division by u_z.
    return (w_b * e_b + u_z * (vertical - reference_vertical_nT)) / weight, weight


def _jacobian(G, B, reference, axes):
    """
    Return d residual / d eps (2N, len(axes)) at the corrected readings B.

    For ``B_c = B - eps``: ``dBv/d eps = -u`` (u = G / |G|) and
    ``dBh/d eps = -(B_c - Bv u) / Bh``, minus the unit horizontal field.
    """
    unit_g = G / magnetics.g_total(G)[:, None]
    bh, bv = magnetics.horizontal_vertical_nT(G, B)
    unit_h = (B - bv[:, None] * unit_g) / bh[:, None]
    return -np.concatenate([unit_h[:, axes], unit_g[:, axes]])


def _axial_sensitivity(G, B, reference):
    """Return the RMS over stations of ``|k_i|``, the residual's move per nT of eps_z."""
    return float(np.sqrt(2.0 * np.mean(_jacobian(G, B, reference, [2]) ** 2)))


def _refuse_ill_posed(G, B, reference, jacobian, limits, where='at the start'):
    """Raise MsaRefused for no axial sensitivity or an ill-conditioned Jacobian (``where``)."""
    sensitivity = _axial_sensitivity(G, B, reference)
    if sensitivity < limits.min_axial_sensitivity:
        raise MsaRefused(
            f'singular geometry {where}: eps_z moves the stations by {sensitivity:.3g} nT per '
            f'nT (RMS; limit {limits.min_axial_sensitivity:g}); stations all horizontal and '
            'east/west?')
    condition = float(np.linalg.cond(jacobian))
    if condition > limits.max_condition_number:
        raise MsaRefused(
            f'singular geometry {where}: the Jacobian has condition number {condition:.3g} '
            f'(limit {limits.max_condition_number:g}); the stations do not vary enough in '
            'attitude')


def _refuse_imprecise(G, B, eps_covariance_nT2, limits):
    """Raise MsaRefused when the interference's own azimuth 1 sigma exceeds the limit (RMS)."""
    std_deg = station_azimuth_std_deg(G, B, eps_covariance_nT2, 0.0, 0.0)
    rms_deg = float(np.sqrt(np.nanmean(std_deg ** 2)))
    if not rms_deg <= limits.max_azimuth_std_deg:
        raise MsaRefused(
            f'the solved interference is too uncertain: it alone gives every azimuth a 1 sigma '
            f'of {rms_deg:.3g} deg (RMS over the stations; limit max_azimuth_std_deg '
            f'{limits.max_azimuth_std_deg:g} deg), eps_z 1 sigma '
            f'{math.sqrt(eps_covariance_nT2[2, 2]):.0f} nT: the correction would be no better '
            'than the raw azimuth (stations near east/west and horizontal? a better reference '
            'field (IFR) or stations in other directions)')


def _g_total_ok(G, finite, limits):
    """Return G-total QC per station, relative to the median |G| of the finite ones."""
    g_expected = float(np.median(magnetics.g_total(G[finite]))) if finite.any() else 1.0
    tolerance = limits.qc.g_total_tolerance * g_expected / STANDARD_GRAVITY_MPS2
    return np.abs(magnetics.g_total(G) - g_expected) <= tolerance


def _qc(G, B, reference_total_nT, reference_dip_deg, limits):
    """Return ``magnetics.survey_qc`` of corrected readings, G-total relative to the median."""
    g_expected = float(np.nanmedian(magnetics.g_total(G)))
    qc_limits = magnetics.QcLimits(
        b_total_tolerance_nT=limits.qc.b_total_tolerance_nT,
        dip_tolerance_deg=limits.qc.dip_tolerance_deg,
        g_total_tolerance=limits.qc.g_total_tolerance * g_expected / STANDARD_GRAVITY_MPS2)
    return magnetics.survey_qc(G, B, reference_total_nT, reference_dip_deg, g_expected,
                               qc_limits)


def _check_qc(passing, among, what, exclude_failing_qc):
    """Raise MsaRefused for stations of ``among`` not ``passing`` unless excluding them."""
    failing = among & ~passing
    if failing.any() and not exclude_failing_qc:
        raise MsaRefused(f'station(s) {_numbers(failing)} fail QC: {what}; exclude them '
                         '(exclude_failing_qc / --exclude-failing) or fix the survey')


def _near_east_west(azimuth_deg, limits):
    """Return whether each azimuth lies within the east/west bands of ``limits``."""
    return np.abs(np.mod(azimuth_deg, 180.0) - 90.0) <= limits.east_west_deg


def _numbers(mask):
    """Return the 1-based station numbers where ``mask`` holds, as a list."""
    return (np.flatnonzero(mask) + 1).tolist()


def _finite(G, B):
    """Return whether each station's readings are all finite."""
    return np.isfinite(G).all(axis=1) & np.isfinite(B).all(axis=1)


def _refuse_implausible(G, B, reference_total_nT, reference_dip_deg, numbers):
    """
    Raise MsaRefused for a reference or stations no survey has, before any arithmetic.

    The reference is a field (positive, at most MAX_REFERENCE_NT) with a dip
    within +-90 deg;
    each station's |G| is within half of the median's, and its |B| within
    MAX_FIELD_OFFSET_NT of the reference's (the interference is below
    MAX_INTERFERENCE_NT on each axis).  ``numbers``: the 0-based station
    numbers of the rows, for the message.
    """
    if not (0.0 < reference_total_nT <= MAX_REFERENCE_NT and abs(reference_dip_deg) < 90.0):
        raise MsaRefused(f'the reference field {reference_total_nT!r} nT, dip '
                         f'{reference_dip_deg!r} deg is not a geomagnetic field')
    g = np.hypot(np.hypot(G[:, 0], G[:, 1]), G[:, 2])
    b = np.hypot(np.hypot(B[:, 0], B[:, 1]), B[:, 2])
    g_median = float(np.median(g)) if g.size else 0.0
    if g.size and not 0.0 < g_median < math.inf:
        raise MsaRefused(f"the stations' gravity is {g_median:.4g} (median |G|): not a "
                         'gravity vector')
    bad = (np.abs(g - g_median) > 0.5 * g_median) \
        | ~(np.abs(b - reference_total_nT) <= MAX_FIELD_OFFSET_NT)
    if bad.any():
        raise MsaRefused(
            f'station(s) {(numbers[bad] + 1)[:10].tolist()} read |B| = '
            f'{", ".join(f"{v:.4g}" for v in b[bad][:3])} nT or a |G| far from the others: the '
            f'reference {reference_total_nT:g} nT plus an interference below '
            f'{MAX_INTERFERENCE_NT:g} nT per axis is {MAX_FIELD_OFFSET_NT:.0f} nT away at '
            'most (a dead magnetometer, or B not in nT?)')


def _refuse_non_finite(G, B):
    """Raise MsaRefused naming the stations with non-finite readings."""
    finite = _finite(G, B)
    if not finite.all():
        raise MsaRefused(f'non-finite readings at station(s) {_numbers(~finite)}')


def station_toolface_deg(G, max_std_deg):
    """
    Return the stations' gravity toolface [deg], NaN where its 1 sigma exceeds ``max_std_deg``.

    The 1 sigma is ``sigma_G / (|G| sin I)`` (``toolface_std_rad``)
    with sigma_G the scatter of the stations' |G|; a vertical station has none.
    """
    noise = np.std(magnetics.g_total(G), ddof=1) if G.shape[0] > 1 else 0.0
    f = magnetics.specific_force_from_gravity(G)
    std_deg = np.degrees(toolface_std_rad(f, noise ** 2 * np.broadcast_to(np.eye(3), (len(f), 3,
                                                                                      3))))
    return np.where(std_deg <= max_std_deg, magnetics.gravity_toolface_deg(G), np.nan)
