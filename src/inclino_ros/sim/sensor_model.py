"""
Physical model of a drilling-tool inclinometer: a known truth in, raw readings out.

One tool carries an accelerometer triad and a magnetometer triad on a common
board.  The readings are built forward from the physics, in the order the
signal travels: the Earth's gravity and magnetic field are expressed in the
tool frame by the tool's attitude, the drill string adds its own field, the
board's mounting turns both vectors into the sensor frames, the magnetometer
sees hard and soft iron, and each triad applies its axis sensitivities,
bias, temperature drift and noise.  Nothing here is taken from the
correction chain: this module imports nothing from inclino_ros.

Frames (shared/notes/formulas.md, "Frames and signs")
-----------------------------------------------------
* Earth: NED (north, east, down), north = magnetic north.  Gravity pulls
  along +down; an accelerometer at rest reads the specific force
  ``f = (0, 0, -g)`` in NED (REP 145: the up axis reads +g).  The Earth
  field is ``B (cos D, 0, sin D)`` with dip D positive downward.
* Tool: z along the tool axis pointing AWAY from the bit (up the hole), x
  and y cross-axial, right-handed (seed 000 / REP 145).  At rest::

      f = g (sin I cos TF, sin I sin TF, cos I)

  with I the inclination and TF the seed-000 gravity toolface (seed 000
  Eq. 16: the high side seen from the tool x axis toward y).
* ISCWSA survey frame: the tool frame turned 180 deg about x,
  ``(x, y, z) -> (x, -y, -z)``, z toward the bit.

Attitude (``tool_to_ned``)
--------------------------
The hole direction toward the bit, at inclination I from the downward
vertical and magnetic azimuth A clockwise from north, is
``d = (sin I cos A, sin I sin A, cos I)`` in NED.  Writing R_a(t) for the
right-hand rotation by t about axis a (``transforms3d.axangles.axangle2mat``)::

    R_ned_from_tool = Rz(A) Ry(I) Rz(TF) Rx(180 deg)

Read left to right as turns of a frame that starts as NED: turn about down
by A (heading), tilt the down axis toward that heading by I (about the new
east), roll by TF about the new down axis (the hole direction toward the
bit), and last turn 180 deg about x so that z points away from the bit.
This is ``transforms3d.euler.euler2mat(A, I, TF, 'rzyz') @ Rx(180 deg)``.
Its third column is ``-d`` and ``R^T (0, 0, -g)`` is exactly the seed-000
specific force above, so TF is the seed-000 toolface.

Toolface conventions.  The ISCWSA frame's axes in NED are the columns of
``R_ned_from_tool Rx(180 deg) = Rz(A) Ry(I) Rz(TF)``, the classic
survey Euler sequence with its third angle equal to GTF - 90 deg, where GTF
is the ISCWSA gravity (high-side) toolface of formulas.md
(``Gx = -g sinI sinGTF``, ``Gy = -g sinI cosGTF``).  Hence::

    GTF = TF + 90 deg        (``highside_toolface_deg``)

Check by geometry: a horizontal tool (I = 90) drilling east (A = 90) with
TF = 0 has tool x straight up (f = (g, 0, 0)), z pointing west (away from
the bit) and y = z x x = north, so it reads ``B = (-B sinD, B cosD, 0)``;
in ISCWSA axes ``(-B sinD, -B cosD, 0)``, the forward model's value at
GTF = 90 deg.

Mounting (``Mount``, seed 000 Fig. 1 and Eq. 1)
-----------------------------------------------
Seed 000 turns the ideal tool frame OXYZ by gamma about Y, then by beta
about the new X', to get the sensor frame OX1Y1Z1, and writes the
coordinate map (Eq. 1)::

    v_sensor = C v_tool,   C = [[1, 0, 0], [0, cb, -sb], [0, sb, cb]]
                               @ [[cg, 0, -sg], [0, 1, 0], [sg, 0, cg]]

The paper calls both turns "clockwise" for drawing convenience, seen from
opposite sides; the matrices fix the signs.  The first factor is the
right-hand Ry(-gamma) acting on coordinates, i.e. the frame turned by
+gamma about Y (right hand); the second is Rx(beta) on coordinates, i.e.
the frame turned by -beta about X'.  So, physically::

    R_tool_from_board = Rz(roll) Ry(gamma) Rx(-beta),   C = R^T

(roll: the board turned about the tool axis first, seed 000's two turns
are then taken from the rolled frame).  On a level bench (I = 0) the
sensor reads ``g (-sin gamma, -sin beta cos gamma, cos beta cos gamma)``
whatever the roll (Eq. 2): gamma > 0 tips the sensor x axis below the
horizontal by gamma (theta'_x1 = -gamma, Eq. 13), beta > 0 tips its y axis
down (sin theta'_y1 = -sin beta cos gamma, Eq. 14).  A correct seed-000
implementation recovers gamma and beta; the roll only shifts the toolface
by -roll.  Both triads sit on the board and see this rotation; the
magnetometer triad may be turned further relative to it
(``Mount.magnetometer_deg``).

Triads (``Triad``, seed 001 Eqs. 5-10)
--------------------------------------
Per axis i, for the vector x at the triad (sensor frame) and temperature T::

    reading_i = (1 + s_i(T)) (u_i + c_i u_i^3) + b_i + db_i(T) + n_i,   u = K x
    s_i(T) = sum_k scale_drift[i, k] (T - T_ref)^(k+1)
    db_i(T) = sum_k bias_drift[i, k] (T - T_ref)^(k+1)

K (``matrix``) is seed 001's 3x3 K of Eq. 10: row i is the sensitivity
vector of sensing axis i in the sensor frame (scale factor on the
diagonal, non-orthogonality off it).  ``1 + s_i(T)`` is seed 001's K_T(T)
(Eqs. 6-7) normalised to 1 at T_ref, applied to the sensitivity; the bias
drifts on its own (real-sensors.md: a scale-only model cannot absorb a
bias drift).  n_i is Gaussian noise of ``noise_std`` per sample (below).
``c_i`` (``cubic`` [1 / unit^2]) is the axis's odd non-linearity, the first
term of a sensing element's saturating response (a fluxgate's core, an AMR
or Hall element's transfer curve): a sensitivity that falls (c_i < 0) or
rises with the field along the axis itself; zero: a linear sensor.

Noise in time (``Triad.read``)
------------------------------
Samples are read in order, one every ``1 / rate_hz``; the noise n_i of one
axis is the sum of:

* white or AR(1) noise w of stationary 1 sigma ``noise_std`` per sample:
  ``w_k = rho w_(k-1) + sqrt(1 - rho^2) noise_std e_k`` with ``rho =
  noise_rho`` (e_k independent unit Gaussians, w before the first sample
  drawn from the stationary law): ``corr(w_k, w_(k+j)) = rho^|j|`` and the
  mean of n samples has the variance
  ``noise_std^2 / n^2 (n + 2 sum_(j=1)^(n-1) (n - j) rho^j)``;
* flicker (1/f, bias instability) noise of IEEE Std 952's coefficient B
  (``bias_instability``): one-sided power spectral density
  ``S(f) = B^2 / (pi f)`` (IEEE's two-sided ``B^2 / (2 pi |f|)``), whose
  Allan deviation is flat, ``B sqrt(2 ln 2 / pi) = 0.664 B`` at every
  averaging time.  It is drawn by spectral synthesis over ``FLICKER_SPAN``
  times the record (random Gaussian Fourier coefficients of variance from
  S), so a capture's mean wanders with the flicker of scales up to that
  span (slower ones are a bias a calibration takes up).

A first-order low-pass filter of corner ``lowpass_hz`` below the output rate
(an RC or the sensor's digital filter; 0: none) acts on the whole signal,
sensed vector plus white noise: the exact discrete form of ``tau dy/dt = x -
y``, ``tau = 1 / (2 pi lowpass_hz)``, for an input held over each sample
interval, ``y_k = a y_(k-1) + (1 - a) x_k``, ``a = exp(-2 pi lowpass_hz /
rate_hz)``, started at rest (y before the first sample: its sensed vector
and stationary noise).  White noise of variance v in gives ``v (1 - a) /
(1 + a)`` out, so the noise before the filter is scaled up to leave
``noise_std`` per sample at the output, now correlated: lag-1 correlation a
(an AR(1) of rho = a); a step of the input reaches ``1 - a^(k+1)`` of its
size k samples after it.

Magnetometer chain
------------------
The field around the tool is the Earth's plus the drill string's
magnetisation ``interference_nT``, a constant vector in the TOOL frame
(seed 002 §3: about 2000 nT axial, 80 nT cross-axial).  Being fixed to the
tool, its cross-axial part turns with the toolface while the Earth field's
does not: over a full roll the cross-axial readings lie on a circle
centred on the interference (seed 002 Eqs. 15-16).  Near the sensor, soft
iron (magnetisation induced by that field, a 3x3 matrix S ~ I in the
magnetometer frame) and hard iron (permanent magnetisation of the board,
a constant h in that frame) give the field the triad sees::

    x_mag = S R_mag_from_tool (B_earth_tool + interference) + h

Units: specific force in m/s^2, fields in nT, angles in degrees, T in deg C.
Every function is vectorised over N samples.
"""

from dataclasses import dataclass, replace
import functools
import math

from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
import numpy as np
from scipy.linalg import toeplitz
from scipy.signal import lfilter
from transforms3d.axangles import axangle2mat
from transforms3d.euler import euler2mat

#: One milli-g [m/s^2].
MILLI_G_MPS2 = 1e-3 * STANDARD_GRAVITY_MPS2

#: Flicker noise is synthesised over this many times the record's length (``Triad``).
FLICKER_SPAN = 16
#: IEEE Std 952: the Allan deviation of flicker noise of bias instability B is this times B.
FLICKER_ALLAN_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)

_X, _Y, _Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def _vector(value, name):
    """Return ``value`` as a tuple of three floats; ValueError naming ``name`` otherwise."""
    array = np.asarray(value, dtype=float)
    if array.shape != (3,):
        raise ValueError(f'{name} must have 3 elements, not shape {array.shape}')
    return tuple(float(v) for v in array)


def _matrix(value, name):
    """Return ``value`` as 3x3 nested tuples of floats; ValueError naming ``name`` otherwise."""
    array = np.asarray(value, dtype=float)
    if array.shape != (3, 3):
        raise ValueError(f'{name} must be 3x3, not shape {array.shape}')
    return tuple(tuple(float(v) for v in row) for row in array)


def _coefficients(value, name):
    """Return per-axis polynomial coefficients as a (3, k) tuple of tuples of floats."""
    array = np.asarray(value, dtype=float)
    if array.ndim == 1 and array.size == 0:
        array = array.reshape(3, 0)
    if array.ndim != 2 or array.shape[0] != 3:
        raise ValueError(f'{name} must have shape (3, k), not {array.shape}')
    return tuple(tuple(float(v) for v in row) for row in array)


def _rotation(axis, angle):
    """
    Return right-hand rotations by ``angle`` [rad] about a coordinate axis, shape (N, 3, 3).

    ``axis`` is 0, 1 or 2 (x, y, z); sample n equals
    ``transforms3d.axangles.axangle2mat(e_axis, angle[n])``, vectorised.
    """
    angle = np.asarray(angle, dtype=float).reshape(-1)
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    i, j = [k for k in range(3) if k != axis]   # (y, z), (x, z) or (x, y)
    sign = -1.0 if axis == 1 else 1.0           # about y the right-hand turn takes z to x
    out[:, axis, axis] = 1.0
    out[:, i, i] = c
    out[:, j, j] = c
    out[:, i, j] = -sign * s
    out[:, j, i] = sign * s
    return out


def _samples(*arrays):
    """Return the arguments as float arrays broadcast to one common shape (N,)."""
    out = np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, dtype=float)) for a in arrays))
    if out[0].ndim != 1:
        raise ValueError(f'per-sample arguments must be scalars or 1-D, not shape {out[0].shape}')
    return [np.array(a) for a in out]


def highside_toolface_deg(toolface_deg):
    """
    Return the ISCWSA high-side toolface GTF of a seed-000 toolface TF, in [0, 360) [deg].

    ``GTF = TF + 90 deg`` for the z-up tool frame whose ISCWSA axes are
    ``(x, -y, -z)`` (module docstring, "Toolface conventions").
    """
    gtf = np.mod(np.asarray(toolface_deg, dtype=float) + 90.0, 360.0)
    return np.where(gtf == 360.0, 0.0, gtf)


def tool_to_ned(inclination_deg, toolface_deg, azimuth_deg=0.0):
    """
    Return ``R_ned_from_tool = Rz(A) Ry(I) Rz(TF) Rx(180 deg)``, shape (N, 3, 3).

    Columns are the tool axes in NED (module docstring, "Attitude"):
    I inclination, TF seed-000 gravity toolface, A magnetic azimuth of the
    hole direction toward the bit, clockwise from magnetic north.
    """
    incl, tf, az = _samples(inclination_deg, toolface_deg, azimuth_deg)
    flip = axangle2mat(_X, math.pi)
    return (_rotation(2, np.radians(az)) @ _rotation(1, np.radians(incl))
            @ _rotation(2, np.radians(tf)) @ flip)


def true_specific_force(inclination_deg, toolface_deg, gravity_mps2=STANDARD_GRAVITY_MPS2):
    """
    Return the ideal tool-frame specific force at rest, (N, 3) [m/s^2].

    ``f_tool = R_ned_from_tool^T (0, 0, -g)``: gravity pulls down, a still
    accelerometer reads the opposite (REP 145).  Equals
    ``g (sin I cos TF, sin I sin TF, cos I)`` (seed 000 Eq. 2 generalised).
    """
    rotation = tool_to_ned(inclination_deg, toolface_deg)
    return np.einsum('nji,j->ni', rotation, np.array([0.0, 0.0, -gravity_mps2]))


def hand_held(inclination_deg, toolface_deg, azimuth_deg, wander_deg, rng=None):
    """
    Return (inclination, toolface, azimuth) [deg] of shots a hand aims at the given attitudes.

    A hand-held instrument held "in one direction" for a roll set points a
    little elsewhere at every shot (real-sensors.md: 0.1-0.7 deg RMS on real
    instruments): the tool axis leaves the aimed direction by an independent
    Gaussian angle of ``wander_deg`` RMS in each of the two directions across
    it (up-down: inclination; sideways: the azimuth changes by that angle
    over sin I, never more than over sin 3 deg near vertical).  The toolface
    is what the hand turns, kept.
    """
    incl, tf, az = _samples(inclination_deg, toolface_deg, azimuth_deg)
    rng = np.random.default_rng(rng)
    up_down, sideways = rng.normal(0.0, wander_deg, (2, incl.size))
    across = np.maximum(np.abs(np.sin(np.radians(incl))), math.sin(math.radians(3.0)))
    return incl + up_down, tf, az + sideways / across


def iron_near(count, shots, magnitude_nT, rng=None):
    """
    Return (count, 3) fields [nT] of iron brought near some shots (an outlier shot).

    Each of ``shots`` (indices) gets a field of ``magnitude_nT`` in a random
    direction, fixed to the tool for that shot (a knife, a car, a rebar near
    the instrument); every other shot none.  Add it to the drill string's
    ``interference_nT`` of ``read``.
    """
    rng = np.random.default_rng(rng)
    fields = np.zeros((count, 3))
    directions = rng.normal(size=(len(shots), 3))
    fields[list(shots)] = magnitude_nT * directions / np.linalg.norm(directions, axis=1)[:, None]
    return fields


@dataclass(frozen=True)
class Field:
    """The Earth's magnetic field: total intensity [nT] and dip [deg, positive down]."""

    total_nT: float = 50000.0
    dip_deg: float = 60.0

    def ned_nT(self):
        """Return the field in NED, ``B (cos D, 0, sin D)`` [nT] (north = magnetic north)."""
        d = math.radians(self.dip_deg)
        return self.total_nT * np.array([math.cos(d), 0.0, math.sin(d)])


def true_field(inclination_deg, toolface_deg, azimuth_deg=0.0, field=Field()):
    """
    Return the ideal tool-frame Earth field, (N, 3) [nT]: ``R_ned_from_tool^T B_ned``.

    No interference, no sensor errors; see ``tool_to_ned`` for the angles.
    """
    rotation = tool_to_ned(inclination_deg, toolface_deg, azimuth_deg)
    return np.einsum('nji,j->ni', rotation, field.ned_nT())


@dataclass(frozen=True)
class Mount:
    """
    How the sensor board sits in the tool (module docstring, "Mounting").

    ``gamma_deg``, ``beta_deg``: seed 000's installation angles (Eq. 1);
    ``roll_deg``: the board turned about the tool axis (applied first);
    ``magnetometer_deg``: small extra turns (x, y, z) of the magnetometer
    triad relative to the board, ``euler2mat(x, y, z, 'rxyz')``: about the
    board's x, then the new y, then the new z.  ``drift_deg_per_c``: how
    gamma, beta and roll change with the temperature (a board whose mounting
    creeps as it warms: a few tenths of a degree over 30 deg C on a real
    borehole tool), linear from ``reference_temperature_c`` (``at``);
    ``magnetometer_drift_deg_per_c``: how the magnetometer triad's own turns
    (``magnetometer_deg``) change with it (its own bracket creeping: a turn
    the accelerometer does not see).
    """

    gamma_deg: float = 0.0
    beta_deg: float = 0.0
    roll_deg: float = 0.0
    magnetometer_deg: tuple = (0.0, 0.0, 0.0)
    drift_deg_per_c: tuple = (0.0, 0.0, 0.0)
    reference_temperature_c: float = 25.0
    magnetometer_drift_deg_per_c: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        """Store the magnetometer angles and the drifts as tuples of three floats."""
        for name in ('magnetometer_deg', 'drift_deg_per_c', 'magnetometer_drift_deg_per_c'):
            object.__setattr__(self, name, _vector(getattr(self, name), name))

    @property
    def drifts(self):
        """Return whether the mount (or the magnetometer on it) turns with the temperature."""
        return any(v != 0.0 for v in self.drift_deg_per_c + self.magnetometer_drift_deg_per_c)

    def at(self, temperature_c):
        """Return the mount at ``temperature_c`` [deg C] (no drift: itself)."""
        if not self.drifts:
            return self
        dt = float(temperature_c) - self.reference_temperature_c
        change = [v * dt for v in self.drift_deg_per_c]
        return replace(self, gamma_deg=self.gamma_deg + change[0],
                       beta_deg=self.beta_deg + change[1], roll_deg=self.roll_deg + change[2],
                       magnetometer_deg=tuple(a + v * dt for a, v in zip(
                           self.magnetometer_deg, self.magnetometer_drift_deg_per_c)),
                       drift_deg_per_c=(0.0, 0.0, 0.0),
                       magnetometer_drift_deg_per_c=(0.0, 0.0, 0.0))

    def maps(self, temperature_c):
        """
        Return, per sample, the map tool -> accelerometer and tool -> magnetometer (N, 3, 3).

        At each sample's temperature (``at``); without drift the same map for all.
        """
        temperature_c = np.asarray(temperature_c, dtype=float).reshape(-1)
        accel = np.empty((temperature_c.size, 3, 3))
        mag = np.empty_like(accel)
        for value in np.unique(temperature_c):
            mount = self.at(value)
            here = temperature_c == value
            accel[here] = mount.accelerometer_from_tool()
            mag[here] = mount.magnetometer_from_tool()
        return accel, mag

    def tool_from_board(self):
        """Return ``Rz(roll) Ry(gamma) Rx(-beta)``: the board's axes in tool coordinates."""
        return (axangle2mat(_Z, math.radians(self.roll_deg))
                @ axangle2mat(_Y, math.radians(self.gamma_deg))
                @ axangle2mat(_X, -math.radians(self.beta_deg)))

    def board_from_magnetometer(self):
        """Return the magnetometer triad's axes in board coordinates (identity by default)."""
        return euler2mat(*np.radians(self.magnetometer_deg), 'rxyz')

    def accelerometer_from_tool(self):
        """
        Return the map of tool-frame vectors to accelerometer axes, 3x3.

        ``C R_z(-roll)`` with C of seed 000 Eq. 1; without roll, exactly Eq. 1.
        """
        return self.tool_from_board().T

    def magnetometer_from_tool(self):
        """Return the map of tool-frame vectors to magnetometer axes, 3x3."""
        return self.board_from_magnetometer().T @ self.tool_from_board().T


def _flicker_amplitude(span):
    """Return the amplitude of the bins k / span, k >= 1, of flicker of B = 1 (``Triad``)."""
    frequency = np.fft.rfftfreq(span)[1:]               # cycles per sample, no DC
    return np.sqrt(1.0 / (math.pi * frequency) * span / 4.0)


@functools.lru_cache(maxsize=8)
def _flicker_factor(count, span):
    """
    Return F (count, count), F z of unit Gaussians z the flicker (B = 1) of one record.

    x(t) = irfft(X)(t), X_k = a_k (g + i h) (``Triad._flicker``): cov(tau) =
    sum_k w_k a_k^2 2 cos(2 pi k tau / span) / span^2 with w_k = 2 but for the
    Nyquist bin (its real part only, w = 1), i.e. the irfft of Y_k = 2 a_k^2 /
    span (a_N^2 / span at Nyquist); F = V sqrt(L) of the eigenvectors V and
    values L of its Toeplitz matrix (F F^T = cov).
    """
    amplitude = _flicker_amplitude(span)
    power = 2.0 * amplitude ** 2 / span
    if span % 2 == 0:
        power[-1] = amplitude[-1] ** 2 / span
    autocovariance = np.fft.irfft(np.concatenate(([0.0], power)), n=span)[:count]
    values, vectors = np.linalg.eigh(toeplitz(autocovariance))
    return vectors * np.sqrt(np.clip(values, 0.0, None))


@dataclass(frozen=True)
class Triad:
    """
    Three sensing axes: sensitivities, bias, temperature drift and noise.

    ``reading_i = (1 + s_i(T)) (K x)_i + b_i + db_i(T) + n_i`` (module
    docstring, "Triads").  ``matrix`` is K (row i: axis i's sensitivity
    vector); ``bias`` b and ``noise_std`` (one sigma per sample, scalar or
    per axis) are in the unit of the measured vector; ``bias_drift[i, k]``
    [unit / degC^(k+1)] and ``scale_drift[i, k]`` [1 / degC^(k+1)] are the
    coefficients of ``(T - T_ref)^(k+1)``, shape (3, k), k >= 0; ``cubic``
    [1 / unit^2] each axis's odd non-linearity (zero: linear).  The noise
    in time (module docstring, "Noise in time"): ``noise_rho`` the AR(1)
    coefficient per sample (0: white), ``bias_instability`` B of the flicker
    noise [unit] synthesised over ``flicker_span`` times the record (slower
    flicker is a bias a calibration took up: the span is the time since the
    calibration in records), ``lowpass_hz`` the corner of a first-order
    low-pass filter (0: none) at the output rate ``rate_hz``.
    """

    matrix: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    bias: tuple = (0.0, 0.0, 0.0)
    bias_drift: tuple = ((), (), ())
    scale_drift: tuple = ((), (), ())
    noise_std: object = 0.0
    cubic: tuple = (0.0, 0.0, 0.0)
    reference_temperature_c: float = 25.0
    noise_rho: float = 0.0
    bias_instability: float = 0.0
    lowpass_hz: float = 0.0
    rate_hz: float = 100.0
    flicker_span: float = FLICKER_SPAN

    def __post_init__(self):
        """Check the shapes and store every array as (nested) tuples of floats."""
        object.__setattr__(self, 'matrix', _matrix(self.matrix, 'matrix'))
        object.__setattr__(self, 'bias', _vector(self.bias, 'bias'))
        object.__setattr__(self, 'bias_drift', _coefficients(self.bias_drift, 'bias_drift'))
        object.__setattr__(self, 'scale_drift', _coefficients(self.scale_drift, 'scale_drift'))
        object.__setattr__(self, 'cubic', _vector(self.cubic, 'cubic'))
        noise = np.asarray(self.noise_std, dtype=float)
        if noise.shape not in ((), (3,)) or np.any(noise < 0) or not np.all(np.isfinite(noise)):
            raise ValueError('noise_std must be one or three finite values >= 0')
        object.__setattr__(self, 'noise_std',
                           float(noise) if noise.shape == () else _vector(noise, 'noise_std'))
        if not -1.0 < self.noise_rho < 1.0:
            raise ValueError(f'noise_rho must lie in (-1, 1), not {self.noise_rho}')
        if not (0.0 <= self.bias_instability < math.inf and 0.0 <= self.lowpass_hz < math.inf
                and 0.0 < self.rate_hz < math.inf and 1.0 <= self.flicker_span < math.inf):
            raise ValueError('bias_instability and lowpass_hz must be finite and >= 0, '
                             'rate_hz finite and > 0, flicker_span finite and >= 1')

    @property
    def lowpass_pole(self):
        """Return a = exp(-2 pi lowpass_hz / rate_hz) of the low-pass filter (0: none)."""
        return math.exp(-2.0 * math.pi * self.lowpass_hz / self.rate_hz)

    def _white(self, shape, rng):
        """Return white (``noise_rho`` 0) or AR(1) noise of stationary 1 sigma noise_std."""
        rho = self.noise_rho
        std = np.asarray(self.noise_std)
        if rho == 0.0:
            return rng.standard_normal(shape) * std
        before = rng.standard_normal(shape[1:]) * std        # w before the first sample
        innovation = rng.standard_normal(shape) * std * math.sqrt(1.0 - rho * rho)
        return lfilter([1.0], [1.0, -rho], innovation, axis=0, zi=(rho * before)[None, :])[0]

    def _flicker(self, shape, rng):
        """
        Return flicker noise of one-sided PSD B^2 / (pi f) (f per sample), synthesised.

        ``shape`` (count, 3): one record, by spectral synthesis over
        ``flicker_span`` times it.  (count, R, 3): R independent records of the
        same law, drawn from its covariance over the record (the autocovariance
        of that synthesis at lags 0 .. count - 1, the inverse transform of its
        power per bin), so that a long span costs one transform, not one per record.
        """
        count = shape[0]
        span = max(int(round(self.flicker_span * count)), 2)
        if len(shape) == 2:
            amplitude = self.bias_instability * _flicker_amplitude(span)
            draws = rng.standard_normal((2, amplitude.size) + shape[1:])
            spectrum = np.zeros((amplitude.size + 1,) + shape[1:], dtype=complex)
            spectrum[1:] = amplitude[:, None] * (draws[0] + 1j * draws[1])
            return np.fft.irfft(spectrum, n=span, axis=0)[:count]
        factor = self.bias_instability * _flicker_factor(count, span)
        draws = rng.standard_normal((count, int(np.prod(shape[1:]))))
        return (factor @ draws).reshape(shape)

    def _lowpass(self, signal, noise, rng):
        """Return the low-pass filter's output of signal + white noise (module docstring)."""
        a = self.lowpass_pole
        gain = math.sqrt((1.0 + a) / (1.0 - a))   # leaves noise_std at the output
        before = signal[0] + rng.standard_normal(signal.shape[1:]) * np.asarray(self.noise_std)
        return lfilter([1.0 - a], [1.0, -a], signal + gain * noise, axis=0,
                       zi=(a * before)[None, :])[0]

    @staticmethod
    def _polynomial(coefficients, dt):
        """Return ``sum_k c[i, k] dt^(k+1)`` per axis, shape (N, 3)."""
        c = np.array(coefficients, dtype=float)   # (3, k), k >= 0
        powers = dt[:, np.newaxis] ** np.arange(1, c.shape[1] + 1)
        return powers @ c.T

    def scale_change(self, temperature_c):
        """Return ``s_i(T)`` per axis, shape (N, 3): the relative change of sensitivity."""
        dt = np.atleast_1d(np.asarray(temperature_c, dtype=float)) - self.reference_temperature_c
        return self._polynomial(self.scale_drift, dt)

    def bias_at(self, temperature_c):
        """Return ``b_i + db_i(T)`` per axis, shape (N, 3)."""
        dt = np.atleast_1d(np.asarray(temperature_c, dtype=float)) - self.reference_temperature_c
        return np.array(self.bias) + self._polynomial(self.bias_drift, dt)

    def read(self, x_sensor, temperature_c, rng=None, records=1):
        """
        Return the readings (N, 3) of vectors ``x_sensor`` (N, 3) at the triad.

        ``temperature_c`` is one value or one per sample; ``rng`` a numpy
        Generator, a seed or None (fresh entropy) for the noise.  ``records``:
        the N samples are that many independent records of N / records
        consecutive samples each (noise, filter and flicker started afresh).
        """
        x = np.asarray(x_sensor, dtype=float).reshape(-1, 3)
        temperature_c = np.broadcast_to(np.asarray(temperature_c, dtype=float), x.shape[:1])
        rng = np.random.default_rng(rng)
        if records < 1 or x.shape[0] % records:
            raise ValueError(f'{x.shape[0]} samples do not split into {records} records')
        # Time along axis 0, the records (if more than one) along axis 1.
        shape = x.shape if records == 1 else (x.shape[0] // records, records, 3)

        def in_time(values):
            return values if records == 1 else values.reshape(records, -1, 3).swapaxes(0, 1)

        noise = self._white(shape, rng)
        sensed = x @ np.array(self.matrix).T
        sensed = sensed + np.array(self.cubic) * sensed ** 3
        signal = in_time((1.0 + self.scale_change(temperature_c)) * sensed
                         + self.bias_at(temperature_c))
        reading = self._lowpass(signal, noise, rng) if self.lowpass_hz else signal + noise
        if self.bias_instability:
            reading = reading + self._flicker(shape, rng)
        return reading if records == 1 else reading.swapaxes(0, 1).reshape(-1, 3)

    def truth(self):
        """Return the triad's parameters as a JSON-ready dict."""
        return {'matrix': [list(row) for row in self.matrix], 'bias': list(self.bias),
                'bias_drift': [list(row) for row in self.bias_drift],
                'scale_drift': [list(row) for row in self.scale_drift],
                'cubic': list(self.cubic),
                'noise_std': (self.noise_std if isinstance(self.noise_std, float)
                              else list(self.noise_std)),
                'reference_temperature_c': self.reference_temperature_c,
                'noise_rho': self.noise_rho, 'bias_instability': self.bias_instability,
                'lowpass_hz': self.lowpass_hz, 'rate_hz': self.rate_hz,
                'flicker_span': self.flicker_span}


@dataclass(frozen=True)
class Tool:
    """
    One inclinometer: a board on a mount with an accelerometer and a magnetometer.

    ``accelerometer`` works in m/s^2, ``magnetometer`` in nT;
    ``hard_iron_nT`` and ``soft_iron`` act in the magnetometer frame
    (module docstring, "Magnetometer chain").  A two-axis accelerometer
    (``accelerometer_axes=2``) reports 0.0 on z.
    """

    mount: Mount = Mount()
    accelerometer: Triad = Triad()
    magnetometer: Triad = Triad()
    hard_iron_nT: tuple = (0.0, 0.0, 0.0)
    soft_iron: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    accelerometer_axes: int = 3
    gravity_mps2: float = STANDARD_GRAVITY_MPS2

    def __post_init__(self):
        """Check the parameters and store the arrays as (nested) tuples of floats."""
        object.__setattr__(self, 'hard_iron_nT', _vector(self.hard_iron_nT, 'hard_iron_nT'))
        object.__setattr__(self, 'soft_iron', _matrix(self.soft_iron, 'soft_iron'))
        if self.accelerometer_axes not in (2, 3):
            raise ValueError(f'accelerometer_axes must be 2 or 3, not {self.accelerometer_axes}')
        if not self.gravity_mps2 > 0:
            raise ValueError('gravity_mps2 must be > 0')


@dataclass(frozen=True, eq=False)
class Readings:
    """
    What the tool reads, with the truth behind every sample (arrays of length N).

    ``accel_mps2`` and ``mag_nT`` are the raw triad readings (N, 3);
    ``specific_force_tool_mps2``, ``earth_field_tool_nT`` and
    ``interference_nT`` the true vectors in the ideal tool frame (N, 3).
    """

    accel_mps2: np.ndarray
    mag_nT: np.ndarray
    inclination_deg: np.ndarray
    toolface_deg: np.ndarray
    azimuth_deg: np.ndarray
    temperature_c: np.ndarray
    specific_force_tool_mps2: np.ndarray
    earth_field_tool_nT: np.ndarray
    interference_nT: np.ndarray


def read(tool, inclination_deg, toolface_deg, azimuth_deg=0.0, temperature_c=25.0,
         field=Field(), interference_nT=(0.0, 0.0, 0.0), rng=None, records=1):
    """
    Return the Readings of ``tool`` at the given attitudes and temperatures.

    Per-sample arguments broadcast to N; ``interference_nT`` is the drill
    string's field in the tool frame, (3,) or (N, 3); ``rng`` a numpy
    Generator, a seed or None; ``records``: the N samples are that many
    independent records of N / records samples (``Triad.read``).  The
    accelerometer's noise is drawn before the magnetometer's from the same
    generator.  The chain::

        accel = accelerometer.read(R_acc f_tool, T)
        mag = magnetometer.read(S R_mag (B_tool + interference) + h, T)
    """
    incl, tf, az, temp = _samples(inclination_deg, toolface_deg, azimuth_deg, temperature_c)
    rotation = tool_to_ned(incl, tf, az)
    f_tool = np.einsum('nji,j->ni', rotation, np.array([0.0, 0.0, -tool.gravity_mps2]))
    b_tool = np.einsum('nji,j->ni', rotation, field.ned_nT())
    interference = np.array(np.broadcast_to(np.asarray(interference_nT, dtype=float),
                                            b_tool.shape))
    rng = np.random.default_rng(rng)

    if tool.mount.drifts:   # the mount turns with the temperature: a map per sample
        to_accel, to_mag = tool.mount.maps(temp)
        at_accel = np.einsum('nij,nj->ni', to_accel, f_tool)
        at_sensor = np.einsum('nij,nj->ni', to_mag, b_tool + interference)
    else:
        at_accel = f_tool @ tool.mount.accelerometer_from_tool().T
        at_sensor = (b_tool + interference) @ tool.mount.magnetometer_from_tool().T
    accel = tool.accelerometer.read(at_accel, temp, rng, records)
    if tool.accelerometer_axes == 2:
        accel[:, 2] = 0.0
    at_sensor = at_sensor @ np.array(tool.soft_iron).T + np.array(tool.hard_iron_nT)
    mag = tool.magnetometer.read(at_sensor, temp, rng, records)
    return Readings(accel_mps2=accel, mag_nT=mag, inclination_deg=incl, toolface_deg=tf,
                    azimuth_deg=az, temperature_c=temp, specific_force_tool_mps2=f_tool,
                    earth_field_tool_nT=b_tool, interference_nT=interference)


def truth_dict(tool):
    """
    Return a JSON-ready description of every error source of ``tool``.

    Mounting angles and the resulting sensor-from-tool matrices, both
    triads (accelerometer in m/s^2, magnetometer in nT), hard and soft iron,
    the number of accelerometer axes and gravity, with the model's equations.
    """
    mount = tool.mount
    return {
        'model': 'inclino_ros.sim.sensor_model',
        'equations': {
            'attitude': 'R_ned_from_tool = Rz(A) Ry(I) Rz(TF) Rx(180 deg); TF seed 000, '
                        'ISCWSA high-side toolface = TF + 90 deg',
            'accelerometer': 'accelerometer.read(R_acc R_ned_from_tool^T (0, 0, -g), T)',
            'magnetometer': 'magnetometer.read(S R_mag (B_tool + interference) + h, T)',
            'triad': 'reading_i = (1 + s_i(T)) (K x)_i + b_i + db_i(T) + noise, '
                     's_i, db_i polynomials in (T - T_ref) from the first power',
            'noise': 'AR(1) of coefficient noise_rho and stationary std noise_std, plus '
                     'flicker of one-sided PSD bias_instability^2 / (pi f); a first-order '
                     'low-pass of corner lowpass_hz at rate_hz on signal and white noise',
            'mount': 'R_tool_from_board = Rz(roll) Ry(gamma) Rx(-beta); '
                     'R_acc = R_tool_from_board^T (seed 000 Eq. 1 C when roll = 0); '
                     'R_mag = euler2mat(magnetometer_deg, rxyz)^T R_acc',
        },
        'mount': {
            'gamma_deg': mount.gamma_deg, 'beta_deg': mount.beta_deg,
            'roll_deg': mount.roll_deg, 'magnetometer_deg': list(mount.magnetometer_deg),
            'drift_deg_per_c': list(mount.drift_deg_per_c),
            'magnetometer_drift_deg_per_c': list(mount.magnetometer_drift_deg_per_c),
            'reference_temperature_c': mount.reference_temperature_c,
            'accelerometer_from_tool': mount.accelerometer_from_tool().tolist(),
            'magnetometer_from_tool': mount.magnetometer_from_tool().tolist(),
        },
        'accelerometer': {**tool.accelerometer.truth(), 'unit': 'm/s^2',
                          'axes': tool.accelerometer_axes},
        'magnetometer': {**tool.magnetometer.truth(), 'unit': 'nT'},
        'hard_iron_nT': list(tool.hard_iron_nT),
        'soft_iron': [list(row) for row in tool.soft_iron],
        'gravity_mps2': tool.gravity_mps2,
    }


def _misaligned(scale_errors, misalignment_rad):
    """Return ``I + diag(scale_errors) + off-diagonal terms`` for a preset's K or S."""
    (sxy, sxz), (syx, syz), (szx, szy) = misalignment_rad
    ex, ey, ez = scale_errors
    return ((1.0 + ex, sxy, sxz), (syx, 1.0 + ey, syz), (szx, szy, 1.0 + ez))


#: A consumer MEMS tool (real-sensors.md): accelerometer 2 mg noise per sample,
#: biases up to ~20 mg drifting ~0.5 mg/degC, scale drift ~200 ppm/degC, axes
#: ~0.3 deg (5 mrad) off orthogonal; magnetometer 100 nT noise, a few hundred nT
#: of bias and hard iron, ~1 % soft iron.  Mount: none (``dataclasses.replace``).
MEMS = Tool(
    accelerometer=Triad(
        matrix=_misaligned((4e-3, -3e-3, 2e-3),
                           ((5.2e-3, -3.5e-3), (-4.1e-3, 4.8e-3), (3.0e-3, -5.5e-3))),
        bias=(12.0 * MILLI_G_MPS2, -18.0 * MILLI_G_MPS2, 8.0 * MILLI_G_MPS2),
        bias_drift=((0.5 * MILLI_G_MPS2, 1e-3 * MILLI_G_MPS2),
                    (-0.6 * MILLI_G_MPS2, 0.0),
                    (0.4 * MILLI_G_MPS2, -1e-3 * MILLI_G_MPS2)),
        scale_drift=((2e-4, 1e-6), (-1.5e-4, 8e-7), (2.2e-4, -1e-6)),
        noise_std=2e-3 * STANDARD_GRAVITY_MPS2),
    magnetometer=Triad(
        matrix=_misaligned((8e-3, -6e-3, 1e-2),
                           ((4.5e-3, 5.0e-3), (-5.2e-3, -3.8e-3), (4.0e-3, 5.5e-3))),
        bias=(350.0, -220.0, 150.0),
        bias_drift=((8.0,), (-6.0,), (10.0,)),
        scale_drift=((3e-4,), (-2.5e-4,), (3.5e-4,)),
        noise_std=100.0),
    hard_iron_nT=(300.0, -150.0, 450.0),
    soft_iron=_misaligned((2e-2, -1.5e-2, 1e-2), ((5e-3, -3e-3), (5e-3, 4e-3), (-3e-3, 4e-3))))

#: A quartz-flex accelerometer and fluxgate magnetometer MWD tool: 1e-4 g and
#: 5 nT noise, ISCWSA MWD-size errors (formulas.md: bias 0.004 m/s^2 and
#: 70 nT, scale 5e-4 and 1.6e-3, misalignment 0.1 deg), drifts ~10x below MEMS.
QUARTZ_FLUXGATE = Tool(
    accelerometer=Triad(
        matrix=_misaligned((5e-4, -4e-4, 3e-4),
                           ((1.7e-3, -1.2e-3), (-1.5e-3, 1.6e-3), (1.0e-3, -1.7e-3))),
        bias=(0.004, -0.003, 0.0035),
        bias_drift=((0.05 * MILLI_G_MPS2,), (-0.06 * MILLI_G_MPS2,), (0.04 * MILLI_G_MPS2,)),
        scale_drift=((2e-5,), (-1.5e-5,), (2.2e-5,)),
        noise_std=1e-4 * STANDARD_GRAVITY_MPS2),
    magnetometer=Triad(
        matrix=_misaligned((1.6e-3, -1.2e-3, 1.4e-3),
                           ((1.5e-3, 1.7e-3), (-1.7e-3, -1.3e-3), (1.4e-3, 1.6e-3))),
        bias=(70.0, -50.0, 60.0),
        bias_drift=((0.8,), (-0.6,), (1.0,)),
        scale_drift=((3e-5,), (-2.5e-5,), (3.5e-5,)),
        noise_std=5.0),
    hard_iron_nT=(20.0, -15.0, 10.0),
    soft_iron=_misaligned((1e-3, -1e-3, 5e-4), ((3e-4, -2e-4), (3e-4, 2e-4), (-2e-4, 2e-4))))

#: A perfect tool: no mounting error, no sensor error, no noise.
IDEAL = Tool()
