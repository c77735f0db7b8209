"""
``pipeline.run`` for a few samples in plain floats: the same numbers without numpy's fixed cost.

The vectorised chain pays ~0.1 ms of numpy calls per batch whatever its
size; the node's batches at low rates hold one sample.  ``run`` here gives
the ``pipeline.Survey`` of ``pipeline.run`` for batches of at most
``MAX_SAMPLES`` samples, and ``stream.correct_batch`` chooses it by batch size.

One definition of each rule, as far as can be:

- the calibration is not written again: ``Prepared.affine`` evaluates the
  model's own stages (``CalibrationModel.apply``, numpy) at four points and
  keeps the affine map they are (every stage is affine in the reading at one
  temperature: seed 000 Eq. 9, seed 001 Eqs. 6 and 11), once per model and
  temperature;
- the covariances come from ``uncertainty.specific_force_covariance`` and
  ``CalibrationModel.temperature_covariance`` (a constant matrix per model
  for three axes, computed once; per sample, numpy, otherwise);
- what is written in floats below (screening, angles, their 1 sigma, the
  quaternion, the roll/pitch covariance) cites the vectorised function it
  mirrors, operation for operation; ``test_sample_path`` holds the two
  equal to 1e-12 with every stage, NaN rule and 1 sigma.

A batch with magnetometer readings, several counts per row (``averaged``),
or a sample where float math would raise (a division by an exact zero, a
square root of a negative number; numpy gives inf or NaN there) is left to
the vectorised chain (``applies``, ``run`` returning None).
"""

import math

from inclino_ros.core.screening import ACCEPTED, DYNAMIC, TWO_AXIS_RANGE, ZERO_FRACTION
from inclino_ros.core.uncertainty import parameter_covariance, specific_force_covariance
from inclino_ros.pipeline import Survey, UNOBSERVED_YAW_VARIANCE
import numpy as np

#: Largest batch corrected here; larger ones are cheaper vectorised (bench_sample_path.py,
#: loaded host: 1 sample 38 us against 101, 5: 76 against 102, 8: 118 against 102).
MAX_SAMPLES = 6
#: Prepared models kept (the node has one at a time; a few for the command line's tests).
_KEPT = 8
_TAU = 2.0 * math.pi


class Prepared:
    """What the float chain needs of one (model, settings), computed once with numpy."""

    def __init__(self, model, settings):
        """Keep ``model`` and ``settings`` and what they give every sample."""
        self.model, self.settings = model, settings
        matrix = settings.accelerometer_matrix
        self.axes_map = None if np.array_equal(matrix, np.eye(3)) else matrix.tolist()
        self.tilt_var = model.tilt_std_rad ** 2
        self.with_temperature_covariance = (model.temperature is not None and
                                            model.temperature.parameter_covariance is not None)
        # Whether a fit's own error moves f (``CalibrationModel.parameter_blocks``).
        self.with_fit_blocks = parameter_covariance(
            model.parameter_blocks(np.zeros((1, 3))), 1) is not None
        # pipeline.correct at averaged=1: the noise is the per-sample noise / sqrt(1).
        self.noise = np.reshape(settings.noise_std_mps2 / np.sqrt(1), (-1, 1, 1))
        self.covariance = (specific_force_covariance(np.zeros((1, 3)), self.noise, 3,
                                                     model.linear_map)[0]
                           if settings.accelerometer_axes == 3 else None)
        self._affine = {}

    def affine(self, temperature_c):
        """
        Return (L, o) with ``model.apply(f, T) = L f + o`` (nested lists of floats).

        ``model.apply`` itself at f = 0 and f = g e_i (its scale); kept per temperature.
        """
        try:
            return self._affine[temperature_c]
        except KeyError:
            pass
        scale = self.settings.gravity_mps2
        points = np.vstack([np.zeros(3), scale * np.eye(3)])
        out = self.model.apply(points, temperature_c)
        offset = out[0]
        linear = ((out[1:] - offset) / scale).T
        if len(self._affine) >= 64:
            self._affine.clear()
        self._affine[temperature_c] = result = (linear.tolist(), offset.tolist())
        return result

    def sample_covariance(self, sensor, temperature_c):
        """
        Return the covariance (3, 3) of one corrected sample, as ``pipeline.correct``.

        ``uncertainty.specific_force_covariance`` (its constant for three
        axes) plus ``CalibrationModel.temperature_covariance`` (with a
        temperature stage and no temperature: its drift over the fitted range)
        plus the fits' own (``CalibrationModel.parameter_blocks``).
        """
        covariance = self.covariance
        if covariance is None:
            covariance = specific_force_covariance(np.array([sensor]), self.noise, 2,
                                                   self.model.linear_map)[0]
        unknown = self.model.temperature is not None and (
            temperature_c is None or not math.isfinite(temperature_c))
        if self.with_temperature_covariance or unknown:
            covariance = covariance + self.model.temperature_covariance(
                np.array([sensor]), temperature_c)[0]
        if self.with_fit_blocks:
            covariance = covariance + parameter_covariance(
                self.model.parameter_blocks(np.array([sensor]), None, temperature_c), 1)[0]
        return covariance.tolist()


_prepared = {}


def prepared(model, settings):
    """Return the Prepared of ``model`` and ``settings`` (the same objects: computed once)."""
    key = (id(model), id(settings))
    found = _prepared.get(key)
    if found is not None and found.model is model and found.settings is settings:
        return found
    if len(_prepared) >= _KEPT:
        _prepared.clear()
    _prepared[key] = found = Prepared(model, settings)
    return found


def applies(count, field_nT=None, averaged=1):
    """Return whether a batch of ``count`` samples is corrected here (``run``)."""
    return count <= MAX_SAMPLES and field_nT is None and np.ndim(averaged) == 0 and averaged == 1


def screen(raw, axes, range_mps2, gravity_mps2):
    """Return the code ``screening.screen`` gives one raw sample (3 floats)."""
    used = raw[:axes]
    if not all(math.isfinite(v) for v in used):
        return 0   # non_finite
    if any(abs(v) >= range_mps2 for v in used):
        return 1   # saturated
    magnitude = math.sqrt(sum(v * v for v in used))
    if axes == 3 and magnitude < ZERO_FRACTION * gravity_mps2:
        return 2   # zero
    if axes == 2 and magnitude > gravity_mps2:
        return 3   # over_g
    return ACCEPTED


def sensor_vector(tool, settings):
    """Return ``pipeline.sensor_vectors`` of one sample (``attitude.complete_two_axis``)."""
    if settings.accelerometer_axes == 3:
        return tool
    fx, fy = tool[0], tool[1]
    g = settings.gravity_mps2
    radicand = g * g - fx * fx - fy * fy
    return [fx, fy, math.sqrt(radicand) if radicand >= 0.0 else math.nan]


def inclination(f):
    """Return ``attitude.inclination`` of one vector [rad]."""
    return math.atan2(math.hypot(f[0], f[1]), f[2])


def screen_corrected(f, settings):
    """Return the code ``screening.screen_corrected`` gives one corrected sample."""
    if settings.accelerometer_axes == 3:
        offset = abs(math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) - settings.gravity_mps2)
        return DYNAMIC if offset > settings.g_total_tolerance_mps2 else ACCEPTED
    if math.degrees(inclination(f)) > settings.two_axis_max_inclination_deg:
        return TWO_AXIS_RANGE
    return ACCEPTED


#: (y, x) of ``atan2`` for each of ``attitude.TOOLFACE_CONVENTIONS`` (another: vectorised).
TOOLFACE_ARGUMENTS = {'seed000': lambda f: (f[1], f[0]),           # toolface_seed000
                      'iscwsa_highside': lambda f: (f[0], -f[1])}  # toolface_highside


def toolface(f, convention):
    """Return ``attitude.TOOLFACE_CONVENTIONS[convention]`` of one vector [rad], NaN vertical."""
    if f[0] == 0.0 and f[1] == 0.0:
        return math.nan
    angle = math.atan2(*TOOLFACE_ARGUMENTS[convention](f))
    angle %= _TAU                           # attitude._wrap_2pi: np.mod, 2 pi itself is 0
    return 0.0 if angle == _TAU else angle


def toolface_std(f, c, tilt_var):
    """Return ``uncertainty.toolface_std_rad`` of one vector and covariance [rad]; inf vertical."""
    fx, fy = f[0], f[1]
    h2 = fx * fx + fy * fy
    if not h2 > 0.0:
        return math.inf
    variance = ((fy * fy * c[0][0] - 2.0 * fx * fy * c[0][1] + fx * fx * c[1][1])
                / (h2 * h2) + tilt_var * (h2 + f[2] * f[2]) / h2)
    return math.sqrt(variance)


def orientation(f):
    """Return ``attitude.orientation_quaternion`` (w, x, y, z) of one vector."""
    roll = math.atan2(f[1], f[2])                         # attitude.roll_pitch
    pitch = math.atan2(-f[0], math.hypot(f[1], f[2]))
    cr, sr = math.cos(roll / 2.0), math.sin(roll / 2.0)
    cp, sp = math.cos(pitch / 2.0), math.sin(pitch / 2.0)
    return [cp * cr, cp * sr, sp * cr, -sp * sr]


def roll_pitch_covariance(f, c, tilt_var):
    """Return ``uncertainty.roll_pitch_covariance`` (2 x 2, rad^2) of one vector."""
    fx, fy, fz = f
    r2 = fy * fy + fz * fz
    r = math.sqrt(r2)
    squared = r2 + fx * fx
    jacobian = ((0.0, fz / r2, -fy / r2),
                (-r / squared, fx * fy / (r * squared), fx * fz / (r * squared)))
    product = [[sum(row[k] * c[k][j] for k in range(3)) for j in range(3)] for row in jacobian]
    return [[sum(product[i][k] * jacobian[j][k] for k in range(3)) + (tilt_var if i == j else 0.0)
             for j in range(2)] for i in range(2)]


def _corrected(prepared_chain, tool, temperature_c):
    """Return (sensor vector, corrected vector) of one sample in the tool axes."""
    sensor = sensor_vector(tool, prepared_chain.settings)
    linear, offset = prepared_chain.affine(temperature_c)
    return sensor, [row[0] * sensor[0] + row[1] * sensor[1] + row[2] * sensor[2] + o
                    for row, o in zip(linear, offset)]


def run(raw, model, settings, temperature_c=None):
    """
    Return the ``pipeline.Survey`` ``pipeline.run`` gives raw samples without a field.

    ``raw`` (N, 3) with N <= MAX_SAMPLES, ``temperature_c`` None, a scalar or
    (N,); no magnetometer readings (``applies``).  None where float math
    would raise, or for a toolface convention not written here (the caller then
    runs the vectorised chain).
    """
    if settings.toolface_convention not in TOOLFACE_ARGUMENTS:
        return None
    chain = prepared(model, settings)
    rows = np.asarray(raw, dtype=float).reshape(-1, 3).tolist()
    per_row = np.ndim(temperature_c) == 1
    temperatures = (np.asarray(temperature_c, dtype=float).tolist() if per_row
                    else [None if temperature_c is None else float(temperature_c)] * len(rows))
    codes, columns = [], ([] for _ in range(10))
    (tool_rows, corrected_rows, inclinations, toolfaces, quaternions, g_totals, covariances,
     toolface_stds, acceleration_covs, orientation_covs) = columns
    try:
        for raw_row, t in zip(rows, temperatures):
            code = screen(raw_row, settings.accelerometer_axes,
                          settings.accelerometer_range_mps2, settings.gravity_mps2)
            if code == ACCEPTED:
                tool = raw_row if chain.axes_map is None else [   # mounting.to_tool_axes
                    m[0] * raw_row[0] + m[1] * raw_row[1] + m[2] * raw_row[2]
                    for m in chain.axes_map]
                sensor, f = _corrected(chain, tool, t)
                code = screen_corrected(f, settings)
            codes.append(code)
            if code != ACCEPTED:
                continue
            c = chain.sample_covariance(sensor, t)
            std = math.degrees(toolface_std(f, c, chain.tilt_var))
            face = math.degrees(toolface(f, settings.toolface_convention))
            tool_rows.append(tool)
            corrected_rows.append(f)
            inclinations.append(math.degrees(inclination(f)))
            toolfaces.append(face if std <= settings.toolface_max_std_deg else math.nan)
            quaternions.append(orientation(f))
            g_totals.append(math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]))
            covariances.append(c)
            toolface_stds.append(std)
            acceleration_covs.append([v for row in c for v in row])
            rp = roll_pitch_covariance(f, c, chain.tilt_var)   # pipeline.imu_covariances
            orientation_covs.append([rp[0][0], rp[0][1], 0.0, rp[1][0], rp[1][1], 0.0,
                                     0.0, 0.0, UNOBSERVED_YAW_VARIANCE])
    except (ArithmeticError, ValueError):   # ZeroDivisionError, math domain: numpy's inf/NaN
        return None
    count = len(corrected_rows)
    return Survey(
        codes=np.array(codes, dtype=np.int8),
        uncorrected_mps2=np.array(tool_rows, dtype=float).reshape(count, 3),
        corrected_mps2=np.array(corrected_rows, dtype=float).reshape(count, 3),
        inclination_deg=np.array(inclinations, dtype=float),
        toolface_deg=np.array(toolfaces, dtype=float),
        orientation_wxyz=np.array(quaternions, dtype=float).reshape(count, 4),
        g_total_mps2=np.array(g_totals, dtype=float),
        covariance_mps2=np.array(covariances, dtype=float).reshape(count, 3, 3),
        tilt_var_rad2=chain.tilt_var, toolface_std_deg=np.array(toolface_stds, dtype=float),
        imu_covariance_rows=(np.array(acceleration_covs, dtype=float).reshape(count, 9),
                             np.array(orientation_covs, dtype=float).reshape(count, 9)))
