"""
The correction stages of a calibration and their math, one dataclass each.

Each stage is frozen, holds what its file section holds, and applies its
correction to an array of readings; ``corrections.CalibrationModel`` runs
them in order, ``schema`` reads and validates them.
"""

from dataclasses import dataclass
from functools import cached_property
import math

from inclino_ros.core.cross_axial import apply_cross_axial
from inclino_ros.core.installation import (
    inverse_installation_matrix, pseudo_inclination, to_tool_frame)
from inclino_ros.core.mounting import axes_map_matrix, to_sensor_axes, to_tool_axes
from inclino_ros.core.nonlinear import apply_correction
from inclino_ros.core.stand import correct_stand, rotation_part
from inclino_ros.core.temperature import (
    compensate_temperature, in_range, normalised_temperature, TemperatureFit,
    unknown_temperature_covariance)
from inclino_ros.core.uncertainty import affine_jacobian, temperature_compensation_covariance
import numpy as np


#: The stages a magnetometer fit's covariance may cover, in its order, with their sizes
#: (the magnetometer's times the terms of K_m(T), b_m(T): ``coefficient_count``; the stand
#: it covers is the joint fit's sphere, one temperature): the one table of the file's reader
#: (``schema``) and of the model's use of it (``CalibrationModel.parameter_blocks``).
COVARIANCE_STAGE_SIZES = {'stand': 12, 'magnetometer': 12, 'tool_axis': 2}


class _SeedZeroRotation:
    """A rotation of seed 000's form (gamma about Y, beta about X', Eq. 1) from sensor to tool."""

    @property
    def theta_deg(self):
        """Return the false tilt of the sensor on a level bench (seed 000 Eq. 4)."""
        return math.degrees(float(pseudo_inclination(
            math.radians(self.gamma_deg), math.radians(self.beta_deg))))

    @cached_property
    def inverse_matrix(self):
        """Return C^-1 of seed 000 Eq. 8 for these angles (computed once)."""
        return inverse_installation_matrix(
            math.radians(self.gamma_deg), math.radians(self.beta_deg))

    def apply(self, f, temperature_c=None):
        """Return ``f`` (N x 3) in the ideal tool frame (seed 000 Eq. 9)."""
        return to_tool_frame(f, self.inverse_matrix)


@dataclass(frozen=True)
class Installation(_SeedZeroRotation):
    """Seed 000 installation angles with the provenance of their capture."""

    gamma_deg: float
    beta_deg: float
    captured_at: str
    sample_count: int
    std_deg: float             # per-sample noise of one axis tilt; std / sqrt(N): 1 sigma
    g_total_mps2: float
    temperature_c: float = None  # what the captured readings stood for; None: unknown

    @property
    def tilt_std_rad(self):
        """Return the 1 sigma of the captured tilt: the standard error of its mean [rad]."""
        return math.radians(self.std_deg) / math.sqrt(self.sample_count)


@dataclass(frozen=True)
class ToolAxis(_SeedZeroRotation):
    """
    The tool axis found from roll groups, as seed 000's gamma, beta (shared mount).

    Shots taken with the tool axis held in one direction and the tool turned
    about it keep the components of gravity and field along that axis
    constant (``core.shots``): the axis, in the frame after the installation
    stage, is the level-bench reading of a vertical tool (``u = C e_z``,
    seed 000 Eqs. 11-14), without a level bench.
    """

    gamma_deg: float
    beta_deg: float
    roll_groups: int
    shots: int
    axial_rms_deg: float       # what the fit leaves of the within-group axial spread
    fitted_at: str
    temperature_c: float = None  # what the fitted readings stood for; None: unknown


@dataclass(frozen=True)
class ToolfaceMark:
    """
    The board's roll about the tool axis, tied to the tool's high-side mark (issue 19 item 6).

    A still capture with the mark up on a tilted bench reads the board's
    toolface ``offset_deg`` where the tool's is 0 by definition (in
    ``toolface_convention``); the stage turns both triads' tool-frame vectors
    back by it, ``R_z(-offset)``: the toolface moves by ``-offset``, the
    inclination and the azimuth (a turn of G and B together about the tool
    axis) do not.  ``std_deg``: the capture's standard error of the mean
    tilt over ``sin I`` (``calibration.toolface_mark``).
    """

    offset_deg: float
    std_deg: float
    inclination_deg: float       # of the tool in the capture
    toolface_convention: str     # the toolface whose zero the mark is
    sample_count: int
    captured_at: str
    temperature_c: float = None  # what the captured readings stood for; None: unknown

    @cached_property
    def matrix(self):
        """Return ``R_z(-offset)``, the turn the stage applies (computed once)."""
        angle = math.radians(self.offset_deg)
        c, s = math.cos(angle), math.sin(angle)
        return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])

    def apply(self, f, temperature_c=None):
        """Return the tool-frame vectors ``f`` (N x 3) turned to the mark's zero."""
        return to_tool_frame(f, self.matrix)

    @staticmethod
    def jacobian(turned):
        """Return d(R_z(-offset) v)/d offset [per rad] (N, 3, 1) at the turned vectors."""
        turned = np.asarray(turned, dtype=float)
        return np.stack([turned[:, 1], -turned[:, 0], np.zeros(len(turned))], axis=1)[..., None]


class _PolynomialOfTemperature:
    """
    A linear correction ``K^-1 (v - b)`` whose K and b may be polynomials of T (issue 18).

    One rule for both triads' stands (``Stand``, ``Magnetometer``): fitted at
    two or more temperature plateaus (``core.stand.fit_stand_plateaus``)
    every element of K and b is a polynomial of ``T - temperature_c``
    (``scale_coefficients`` (order + 1) x 3 x 3, the bias's (order + 1) x 3;
    ``arrays`` their values at ``temperature_c``), valid over ``t_min_c`` ..
    ``t_max_c``: ``apply`` takes K(T), b(T) at each reading's temperature,
    held at the nearer end of the range beyond it (``outside_range`` counts
    those).  Without the polynomials, constant K and b.
    """

    def apply(self, f, temperature_c=None):
        """
        Return ``K^-1 (f - b)`` (seed 001 Eq. 11) for ``f`` of shape (N, 3).

        With K(T), b(T) (a multi-temperature stand) at ``temperature_c``
        (scalar or (N,), clamped to the fitted range; None: at the stage's
        temperature).
        """
        if self.scale_coefficients is None or temperature_c is None:
            return correct_stand(f, self.arrays[0], self.arrays[1])
        f = np.asarray(f, dtype=float)
        flat = f.reshape(-1, 3)
        scale, bias = self.at(np.broadcast_to(np.asarray(temperature_c, dtype=float),
                                              flat.shape[:1]))
        return np.linalg.solve(scale, (flat - bias)[..., None])[..., 0].reshape(f.shape)

    def at(self, temperature_c):
        """Return (K, b) at ``temperature_c`` (clamped to the range): (..., 3, 3), (..., 3)."""
        if self.scale_coefficients is None:
            return self.arrays
        held = np.clip(np.asarray(temperature_c, dtype=float), self.t_min_c, self.t_max_c)
        powers = np.power.outer(held - self.temperature_c,
                                np.arange(len(self.scale_coefficients)))
        return (np.tensordot(powers, np.array(self.scale_coefficients), axes=1),
                np.tensordot(powers, np.array(self.bias_coefficients), axes=1))

    def coefficient_jacobian(self, inputs, temperature_c=None):
        """
        Return d(K(T)^-1 (x - b(T))) / d(the coefficients) (N, 3, 12 (order + 1)) at ``inputs``.

        The coefficients as stored, power by power: ``scale_coefficients[k]``
        row-major then the bias's ``[k]`` (the order of a multi-temperature
        stand's ``parameter_covariance``).  With ``g = K^-1 (x - b)``,
        ``dg = -K^-1 (dK g + db)``, times ``(T - temperature_c)^k`` at each
        reading's temperature as ``apply`` takes it (clamped to the range;
        None or NaN: the stage's own).
        """
        inputs = np.asarray(inputs, dtype=float).reshape(-1, 3)
        held = np.broadcast_to(np.asarray(self.temperature_c if temperature_c is None
                                          else temperature_c, dtype=float), inputs.shape[:1])
        held = np.where(np.isfinite(held), held, self.temperature_c)
        scale, bias = self.at(held)
        inverse = np.linalg.inv(scale)
        corrected = np.einsum('nij,nj->ni', inverse, inputs - bias)
        by_value = -inverse @ affine_jacobian(corrected, -np.eye(3))
        powers = np.power.outer(np.clip(held, self.t_min_c, self.t_max_c) - self.temperature_c,
                                np.arange(len(self.scale_coefficients)))
        return np.einsum('nk,nie->nike', powers, by_value).reshape(len(held), 3,
                                                                   self.coefficient_count)

    @property
    def coefficient_count(self):
        """Return the parameters of K and b: 12, times the terms of a polynomial of T."""
        return 12 * (1 if self.scale_coefficients is None else len(self.scale_coefficients))

    def outside_range(self, temperature_c):
        """Return which temperatures lie outside a multi-temperature stand's range (bool)."""
        temperature_c = np.asarray(temperature_c, dtype=float)
        if self.scale_coefficients is None:
            return np.zeros(temperature_c.shape, dtype=bool)
        return ~in_range(temperature_c, self)

    @property
    def temperature_dependent(self):
        """Return whether K and b are polynomials of T (a multi-temperature stand)."""
        return self.scale_coefficients is not None

    @property
    def reference_temperature_c(self):
        """Return the temperature K and b stand for without a temperature input (the centre)."""
        return self.temperature_c


@dataclass(frozen=True)
class Stand(_PolynomialOfTemperature):
    """
    Seed 001 scale/misalignment matrix K and bias b: ``G = K^-1 (A - b)``.

    K(T), b(T) of a stand at several temperature plateaus: ``_PolynomialOfTemperature``.
    """

    scale_matrix: tuple        # K, 3 rows of 3, dimensionless
    bias_mps2: tuple           # b, 3 values
    method: str                # 'stand' (known attitudes) or 'sphere' (|G| = g only)
    condition_number: float    # of the fit's design matrix
    rms_inclination_deg: float  # residual at the stand positions; None for 'sphere'
    positions: int             # positions (stand) or readings (sphere) fitted
    fitted_at: str
    temperature_c: float = None  # what the captured readings stood for; None: unknown
    scale_coefficients: tuple = None      # K(T): powers of (T - temperature_c); None: constant
    bias_coefficients_mps2: tuple = None  # b(T), likewise
    t_min_c: float = None                 # the plateaus' range; None: constant K, b
    t_max_c: float = None
    # The fit's parameter covariance.  One temperature: (12, 12) of (K^-1 row-major, b)
    # (``stand.fit_stand``).  K(T), b(T): (12 (order + 1)) square, of the coefficients as
    # stored, power by power: scale_coefficients[k] row-major (9) then
    # bias_coefficients_mps2[k] (3), k = 0 .. order (``stand.coefficient_covariance``).
    # None: a sphere fit, or a file before schema 9 or from before a multi-temperature
    # stand recorded it (then the residual stands for it).
    parameter_covariance: tuple = None

    @property
    def bias_coefficients(self):
        """Return the coefficients of b(T) (None: constant)."""
        return self.bias_coefficients_mps2

    @property
    def tilt_std_rad(self):
        """
        Return the stage's tilt 1 sigma [rad] added to every angle's variance.

        Zero when the fit's parameter covariance is known
        (``CalibrationModel.parameter_blocks`` propagates it, per reading);
        else the fit's own inclination residual.
        """
        if self.parameter_covariance is not None:
            return 0.0
        return math.radians(self.rms_inclination_deg or 0.0)

    @cached_property
    def arrays(self):
        """Return K and b as numpy arrays, built once."""
        return np.array(self.scale_matrix), np.array(self.bias_mps2)

    @cached_property
    def rotation(self):
        """
        Return the rotation ``K^-1`` gives the sensing axes (``stand.rotation_part``).

        The magnetometer, sitting on the accelerometer's axes, is turned by it
        too: for a stand fit it holds the mount, for a sphere fit the turn of
        its upper-triangular convention.
        """
        return rotation_part(np.linalg.inv(self.arrays[0]))


def covariance_sizes(magnetometer_count):
    """Return the size of each stage's block of a magnetometer fit's covariance (one place)."""
    return dict(COVARIANCE_STAGE_SIZES, magnetometer=magnetometer_count)


@dataclass(frozen=True)
class Magnetometer(_PolynomialOfTemperature):
    """
    The magnetometer's own correction ``B = K_m^-1 (m - b_m)`` (seed 001 Eq. 12) [nT].

    K_m holds the axis scales, their non-orthogonality and the soft iron,
    b_m the bias and hard iron (and any field fixed to the tool when it was
    fitted).  ``method``: ``stand`` (Eq. 12 against the field expected at
    known stand attitudes) or ``ellipsoid`` (``inclino fit-magnetometer``,
    no reference: K_m symmetric, scaled to ``field_nT``).  A stand at several
    temperature plateaus gives K_m(T), b_m(T) (``_PolynomialOfTemperature``):
    ``scale_matrix`` and ``bias_nT`` are their values at ``temperature_c``.
    """

    scale_matrix: tuple        # K_m, 3 rows of 3
    bias_nT: tuple             # b_m
    method: str
    condition_number: float
    rms_residual_nT: float     # stand: |corrected - expected|; ellipsoid: |B| - field_nT
    field_nT: float            # the total field the scale refers to
    positions: int             # stand positions or shots
    fitted_at: str
    temperature_c: float = None  # what the fitted readings stood for; None: unknown
    scale_coefficients: tuple = None   # K_m(T): powers of (T - temperature_c); None: constant
    bias_coefficients_nT: tuple = None  # b_m(T), likewise
    t_min_c: float = None              # the plateaus' range; None: constant K_m, b_m
    t_max_c: float = None
    # The fit's parameter covariance (None: not recorded, schema < 7): square, over the
    # stages of ``covariance_stages`` fitted with it, in this order: 'stand' (K^-1
    # row-major, b [m/s^2]: 12), 'magnetometer' (the map taking readings less b_m into the
    # accelerometer frame, Stand.rotation R K_m^-1 row-major, then b_m [nT]: 12; K_m(T),
    # b_m(T): their coefficients as stored, as Stand's, 12 (order + 1)), 'tool_axis'
    # (gamma, beta [rad]: 2).
    parameter_covariance: tuple = None
    covariance_stages: tuple = None

    @property
    def bias_coefficients(self):
        """Return the coefficients of b_m(T) (None: constant)."""
        return self.bias_coefficients_nT

    @property
    def covariance_blocks(self):
        """Return {covered stage: its rows' slice of ``parameter_covariance``} ({}: none)."""
        if self.covariance_stages is None:
            return {}
        sizes = covariance_sizes(self.coefficient_count)
        ends = np.cumsum([sizes[name] for name in self.covariance_stages])
        return {name: slice(end - sizes[name], end)
                for name, end in zip(self.covariance_stages, ends)}

    @cached_property
    def arrays(self):
        """Return K_m and b_m as numpy arrays, built once."""
        return np.array(self.scale_matrix), np.array(self.bias_nT)


@dataclass(frozen=True)
class MagnetometerAlignment:
    """
    The rotation R of the magnetometer's axes into the accelerometer's sensing axes.

    ``v_accelerometer = R v_magnetometer``.  ``method``: ``dip`` (from the
    constancy of the dip, ``inclino fit-magnetometer``), ``stand`` (the turn
    of the magnetometer's stand K_m, seed 001 Eq. 12) or ``given`` (a known
    mounting).  ``dip_deg`` and ``dip_rms_deg``: the constant dip the fit
    found and what it leaves (None otherwise).
    """

    rotation: tuple            # R, 3 rows of 3
    method: str
    dip_deg: float
    dip_rms_deg: float
    shots: int
    fitted_at: str
    temperature_c: float = None  # what the fitted readings stood for; None: unknown

    @cached_property
    def matrix(self):
        """Return R as a numpy array, built once."""
        return np.array(self.rotation)

    @property
    def angle_deg(self):
        """Return the angle of the rotation [deg]."""
        return math.degrees(math.acos(float(np.clip((np.trace(self.matrix) - 1.0) / 2.0,
                                                    -1.0, 1.0))))


@dataclass(frozen=True)
class MagnetometerNonlinear:
    """
    A smooth non-linear correction of the tool-frame field's x, y (``core.nonlinear``).

    Fitted from roll sets by ``inclino fit-magnetometer`` on top of its linear
    stages and kept only when it improved the roll sets' azimuth agreement on
    sets it was not fitted on (the gate): ``held_out_before_deg``,
    ``held_out_after_deg`` and ``held_out_noise_deg`` are that judgement.
    ``weights``: 2 rows (x, y) of Gaussian RBF weights, normalised by
    ``scale_nT``; ``parameter_covariance``: of the weights, x then y.
    """

    weights: tuple
    scale_nT: float
    rms_residual_nT: float
    roll_sets: int
    shots: int
    held_out_before_deg: float
    held_out_after_deg: float
    held_out_noise_deg: float
    fitted_at: str
    parameter_covariance: tuple = None
    temperature_c: float = None  # what the fitted readings stood for; None: unknown

    @cached_property
    def arrays(self):
        """Return the weights (2, centres) as an array, built once."""
        return np.array(self.weights)

    def apply(self, b_nT):
        """Return tool-frame fields (..., 3) [nT] with x, y corrected."""
        return apply_correction(b_nT, self.arrays, self.scale_nT)


class _TemperatureStage:
    """
    What the temperature stages of both triads do (seed 001 Eqs. 5-7 with a bias drift).

    ``A = (A_T - B_T(T)) / K_T(T)`` per axis, T clamped to the fitted range;
    readings then stand for ``reference_temperature_c``.
    """

    @cached_property
    def fit(self):
        """Return the TemperatureFit of this stage (built once)."""
        bias = self._bias_coefficients
        return TemperatureFit(
            coefficients=np.array(self.coefficients), t_min_c=self.t_min_c,
            t_max_c=self.t_max_c, reference_temperature_c=self.reference_temperature_c,
            rms_residual=np.array(self._rms_residual),
            bias_coefficients=None if bias is None else np.array(bias),
            attitudes=self.attitudes,
            parameter_covariance=(None if self.parameter_covariance is None
                                  else np.array(self.parameter_covariance)))

    def clamp(self, temperature_c):
        """Return the temperatures clamped to the fitted range; NaN is the reference one."""
        temperature_c = np.asarray(temperature_c, dtype=float)
        return np.clip(np.where(np.isnan(temperature_c), self.reference_temperature_c,
                                temperature_c), self.t_min_c, self.t_max_c)

    @cached_property
    def axes_matrix(self):
        """
        Return the axes map M of the sensor the drift was fitted in (tool = M sensor).

        The drift is per SENSOR axis (issue 19 item 7): a stage fitted with an
        axes map (``axes_map``) turns tool-axis readings back into the
        sensor's axes, compensates there, and turns them forward again; a
        board mounted at 45 deg would otherwise spread one axis's drift over
        two.  None (older files: fitted in the tool axes): identity.
        """
        if self.axes_map is None:
            return np.eye(3)
        return axes_map_matrix(self.axes_map, allow_left_handed=True)

    def apply(self, f, temperature_c=None):
        """
        Return ``(A_T - B_T(T)) / K_T(T)`` per sensor axis (seed 001 Eq. 6), T clamped.

        ``f`` (N, 3) in the tool axes, per sensor axis through ``axes_matrix``.
        Without a temperature (None, or NaN for a sample), the reference
        temperature is used (no change).
        """
        f = np.asarray(f, dtype=float)
        if temperature_c is None:
            temperature_c = self.reference_temperature_c
        temperature_c = np.broadcast_to(self.clamp(temperature_c), f.shape[:1])
        matrix = self.axes_matrix
        return to_tool_axes(compensate_temperature(to_sensor_axes(f, matrix), temperature_c,
                                                   self.fit), matrix)

    def compensation_covariance(self, readings, temperature_c=None):
        """
        Return the covariance (M, 3, 3) of the compensated ``readings``: the fit's error, or none.

        ``readings`` in the tool axes; computed in the sensor's (``axes_matrix``)
        and turned into the tool axes.  At a known temperature:
        ``uncertainty.temperature_compensation_covariance`` at the clamped
        temperature (zero for a file without the fit's covariance: its error
        is the residual's, in ``residual_angle_rad``).  Without one (None, or
        NaN for a sample) the reading was compensated at the reference
        temperature: ``temperature.unknown_temperature_covariance``, the
        drift over the fitted range (``provenance.missing_temperature``: the
        rule that allows it).
        """
        matrix = self.axes_matrix
        readings = to_sensor_axes(np.asarray(readings, dtype=float), matrix)
        count = readings.shape[0]
        temperature_c = np.broadcast_to(
            np.nan if temperature_c is None else np.asarray(temperature_c, dtype=float),
            (count,))
        covariance = np.zeros(readings.shape + (3,))
        if self.parameter_covariance is not None:
            u, u_reference = (normalised_temperature(t, self.t_min_c, self.t_max_c)
                              for t in (self.clamp(temperature_c), self.reference_temperature_c))
            covariance = temperature_compensation_covariance(
                readings, u, u_reference, self.parameter_covariance,
                self._bias_coefficients is not None)
        unknown = np.isnan(temperature_c)
        if unknown.any():
            covariance[unknown] += unknown_temperature_covariance(readings[unknown], self.fit)
        return matrix @ covariance @ matrix.T

    def residual_angle_rad(self, magnitude):
        """Return the fit's RMS residual as an angle against a vector of ``magnitude``."""
        return float(np.sqrt(np.mean(np.square(self._rms_residual)))) / magnitude


@dataclass(frozen=True)
class Temperature(_TemperatureStage):
    """Accelerometer temperature drift: K_T(T) per axis (1 at the reference) and B_T(T)."""

    coefficients: tuple          # 3 rows of a0..an, T in deg C (Eq. 7)
    t_min_c: float               # fitted range; T is clamped to it
    t_max_c: float
    reference_temperature_c: float
    rms_residual_mps2: tuple     # per axis
    samples: int
    fitted_at: str
    bias_coefficients_mps2: tuple = None  # 3 rows of b0..bn, 0 at the reference; None: none
    attitudes: int = 1           # 1: scale only (seed 001); >= 2: bias and scale
    # 3 per-axis covariances of the drift coefficients (core.temperature); None: not recorded
    parameter_covariance: tuple = None
    # The axes map of the sensor whose own axes the drift is per (tool = M sensor, as
    # core.mounting); None: fitted in the tool axes (files before schema 6).
    axes_map: str = None

    @property
    def _bias_coefficients(self):
        return self.bias_coefficients_mps2

    @property
    def _rms_residual(self):
        return self.rms_residual_mps2


@dataclass(frozen=True)
class MagnetometerTemperature(_TemperatureStage):
    """Magnetometer temperature drift, the same model in nT (seed 001 §3.2)."""

    coefficients: tuple
    t_min_c: float
    t_max_c: float
    reference_temperature_c: float
    rms_residual_nT: tuple
    samples: int
    fitted_at: str
    bias_coefficients_nT: tuple = None
    attitudes: int = 1
    parameter_covariance: tuple = None  # as Temperature's
    # The axes map of the sensor whose own axes the drift is per (tool = M sensor, as
    # core.mounting); None: fitted in the tool axes (files before schema 6).
    axes_map: str = None

    @property
    def _bias_coefficients(self):
        return self.bias_coefficients_nT

    @property
    def _rms_residual(self):
        return self.rms_residual_nT


@dataclass(frozen=True)
class Magnetic:
    """
    Seed 002 magnetometer corrections, all in the z-up tool frame, nT.

    ``B = W (m_xy - c)`` on the cross-axial axes (the per-rotation ellipse
    fit, seed 002 §2.1), then ``B - interference`` (the multi-station
    analysis, §2.2; solved in the ISCWSA frame and stored here turned into
    the tool frame).
    """

    hard_iron_nT: tuple        # c, tool x and y
    soft_iron: tuple           # W, 2 rows of 2 (identity without a rotation fit)
    interference_nT: tuple     # MSA eps in tool axes x, y, z
    rotation_fitted_at: str    # None until ~/capture_rotation
    msa_method: str            # None until ~/solve_msa, else improved/classic/axial
    msa_stations: int
    msa_reference_total_nT: float
    msa_reference_dip_deg: float
    msa_fitted_at: str
    interference_std_nT: tuple = None  # 1 sigma of the MSA interference (tool axes), None
    rotation_temperature_c: float = None  # what the rotation's readings stood for
    # The rotation fit's parameter covariance over (W row-major, c [nT]): 6 x 6; None: not
    # recorded (schema < 7, or no rotation fitted).
    rotation_covariance: tuple = None

    @property
    def offset_nT(self):
        """Return c as an array (``cross_axial.apply_cross_axial`` reads it)."""
        return np.array(self.hard_iron_nT)

    @property
    def correction(self):
        """Return W as an array (``cross_axial.apply_cross_axial`` reads it)."""
        return np.array(self.soft_iron)

    def apply(self, b_nT):
        """Return corrected tool-frame field readings (..., 3) [nT]."""
        return apply_cross_axial(b_nT, self) - np.asarray(self.interference_nT)

    @property
    def msa_reference(self):
        """Return (total nT, dip deg) the interference was solved against; None before an MSA."""
        if self.msa_method is None:
            return None
        return self.msa_reference_total_nT, self.msa_reference_dip_deg


#: A magnetic stage that changes nothing, to build the first correction on.
NO_MAGNETIC_CORRECTION = Magnetic(
    hard_iron_nT=(0.0, 0.0), soft_iron=((1.0, 0.0), (0.0, 1.0)),
    interference_nT=(0.0, 0.0, 0.0), rotation_fitted_at=None, msa_method=None,
    msa_stations=0, msa_reference_total_nT=0.0, msa_reference_dip_deg=0.0, msa_fitted_at=None)
