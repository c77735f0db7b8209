"""
The virtual bench: a misaligned inclinometer read at known attitudes.

A tool at inclination I and seed-000 gravity toolface TF feels, in its ideal
z-up tool frame (REP 145 specific force, seed 000 Eq. 2 generalised)::

    f = g (sin I cos TF, sin I sin TF, cos I)

and a sensor mounted with installation angles (gamma, beta) reads
``raw = C f + noise`` with C of seed 000 Eq. 1.  C is built here from
transforms3d's rotations, not from ``inclino_ros.core.installation``, so the bench
is an independent check of the core.  Pure numpy + transforms3d.

Seed 001's stand and heating runs use a fuller sensor, ``SensorErrors``.  Its
forward model, per axis i, at temperature T [deg C]::

    raw_i = K_T,i(T) * (K f + b)_i + noise_i,   K = M C(gamma, beta),
    K_T,i(T) = 1 + c1_i (T - 25) + c2_i (T - 25)^2

M holds the scale factors and cross-coupling of the sensing axes, C the
mounting (so K carries the installation error), b the bias [m/s^2].  The
calibration model undoes it stage by stage in its own order: temperature
(``A / K_T(T)`` gives ``K f + b`` exactly), then stand (``K^-1 (A - b)``
gives f exactly), so a perfect fit inverts it to round-off.  The temperature
reading itself is exact (no noise).
"""

from dataclasses import dataclass
import math

from inclino_ros.core.attitude import specific_force
from inclino_ros.core.temperature import REFERENCE_TEMPERATURE_C
import numpy as np
from transforms3d.axangles import axangle2mat

#: (inclination_deg, toolface_deg) of the default tilted stations: inclinations
#: 0.5..60 deg, toolfaces k * 150 deg mod 360 (every multiple of 30 deg once).
DEFAULT_STATIONS_DEG = (
    (0.5, 0.0), (1.0, 150.0), (2.0, 300.0), (3.0, 90.0), (5.0, 240.0), (8.0, 30.0),
    (12.0, 180.0), (18.0, 330.0), (25.0, 120.0), (35.0, 270.0), (45.0, 60.0), (60.0, 210.0))

#: First sample time of a simulated run: 2026-01-01T00:00:00Z [ns].
SIM_EPOCH_NS = 1_767_225_600 * 1_000_000_000

#: (inclination_deg, toolface_deg) of the nine stand positions: each axis up
#: and down (seed 001 Table 1 in this frame), then three oblique attitudes.
STAND_POSITIONS_DEG = (
    (0.0, 0.0), (180.0, 0.0), (90.0, 0.0), (90.0, 90.0), (90.0, 180.0), (90.0, 270.0),
    (45.0, 45.0), (135.0, 165.0), (60.0, 300.0))
#: Attitude of the heating run: every axis sees gravity, (0.58, 0.58, 0.57) g.
HEATING_ATTITUDE_DEG = (55.0, 45.0)


def sensor_matrix(gamma, beta):
    """
    Return seed 000's C (Eq. 1) as ``Rx(beta) @ Ry(-gamma)``, angles in radians.

    The seed turns the ideal frame "clockwise" by gamma about Y, then by beta
    about X'; written with standard right-hand rotation matrices that is
    ``Rx(beta) @ Ry(-gamma)``, mapping ideal-frame coordinates to sensor ones.
    """
    return axangle2mat((1.0, 0.0, 0.0), beta) @ axangle2mat((0.0, 1.0, 0.0), -gamma)


@dataclass(frozen=True)
class Scenario:
    """What the bench does: a level segment, then tilted stations, all held still."""

    gamma_deg: float = 0.8
    beta_deg: float = -1.2
    stations_deg: tuple = DEFAULT_STATIONS_DEG
    rate_hz: float = 200.0
    level_s: float = 3.0
    station_s: float = 2.0
    noise_std_mps2: float = 0.002
    gravity_mps2: float = 9.80665
    axes: int = 3
    seed: int = 0
    start_ns: int = SIM_EPOCH_NS

    def __post_init__(self):
        """Refuse a scenario that cannot be sampled."""
        if self.axes not in (2, 3):
            raise ValueError(f'axes must be 2 or 3, not {self.axes}')
        if self.rate_hz <= 0 or min(self.level_s, self.station_s) * self.rate_hz < 1.0:
            raise ValueError('rate_hz, level_s and station_s must give every segment '
                             'at least one sample')
        if self.noise_std_mps2 < 0:
            raise ValueError('noise_std_mps2 must be >= 0')


@dataclass(frozen=True)
class SimulatedRun:
    """Samples of a scenario with the truth behind every one of them."""

    stamps_ns: np.ndarray        # (N,) int64
    raw_mps2: np.ndarray         # (N, 3) sensor readings; z is 0.0 for a 2-axis sensor
    inclination_deg: np.ndarray  # (N,) true inclination of the ideal tool frame
    toolface_deg: np.ndarray     # (N,) true seed-000 toolface; NaN on the level segment
    segment: np.ndarray          # (N,) 0 = level, k = station (or stand position) k
    truth: dict                  # scenario parameters and per-segment truth (JSON-ready)
    temperature_c: np.ndarray = None  # (N,) sensor temperature; None: not simulated


def _held_attitudes(attitudes_deg, counts, kinds, rate_hz, start_ns, first_index):
    """
    Return the samples of attitudes held one after the other.

    ``attitudes_deg`` are (inclination_deg, toolface_deg) pairs, ``counts``
    the samples and ``kinds`` the kind of each; segments are numbered from
    ``first_index``.  Returns (stamps_ns, segment, inclination_deg,
    toolface_deg, the segments' records for the truth file).
    """
    index = np.repeat(np.arange(len(attitudes_deg)), counts)
    inclination_deg = np.array([a[0] for a in attitudes_deg])[index]
    toolface_deg = np.array([a[1] for a in attitudes_deg])[index]
    stamps_ns = start_ns + np.round(np.arange(index.size) * (1e9 / rate_hz)).astype(np.int64)
    ends = np.cumsum(counts)
    records = [
        {'index': k + first_index, 'kind': kind, 'start_ns': int(stamps_ns[end - n]),
         'end_ns': int(stamps_ns[end - 1]), 'samples': int(n), 'inclination_deg': incl_deg,
         'toolface_deg': None if math.isnan(tf_deg) else tf_deg}
        for k, ((incl_deg, tf_deg), n, end, kind) in enumerate(
            zip(attitudes_deg, counts, ends, kinds))]
    return stamps_ns, index + first_index, inclination_deg, toolface_deg, records


def _true_force(inclination_deg, toolface_deg, gravity_mps2):
    """Return the true specific force of attitudes in degrees (NaN toolface: 0)."""
    return specific_force(np.radians(inclination_deg), np.radians(np.nan_to_num(toolface_deg)),
                          gravity_mps2)


def simulate(scenario=Scenario()):
    """Return the samples of ``scenario``: ``raw = C(gamma, beta) f + noise`` (Eqs. 1, 2)."""
    segments_deg = ((0.0, math.nan),) + tuple(scenario.stations_deg)
    counts = [round(scenario.level_s * scenario.rate_hz)] + \
        [round(scenario.station_s * scenario.rate_hz)] * len(scenario.stations_deg)
    kinds = ['level'] + ['station'] * len(scenario.stations_deg)
    stamps_ns, segment, inclination_deg, toolface_deg, records = _held_attitudes(
        segments_deg, counts, kinds, scenario.rate_hz, scenario.start_ns, first_index=0)

    f = _true_force(inclination_deg, toolface_deg, scenario.gravity_mps2)
    c = sensor_matrix(math.radians(scenario.gamma_deg), math.radians(scenario.beta_deg))
    rng = np.random.default_rng(scenario.seed)
    raw = f @ c.T + rng.normal(0.0, scenario.noise_std_mps2, size=f.shape)
    if scenario.axes == 2:
        raw[:, 2] = 0.0

    truth = {
        'gamma_deg': scenario.gamma_deg, 'beta_deg': scenario.beta_deg,
        'noise_std_mps2': scenario.noise_std_mps2, 'rate_hz': scenario.rate_hz,
        'gravity_mps2': scenario.gravity_mps2, 'seed': scenario.seed, 'axes': scenario.axes,
        'segments': records,
    }
    return SimulatedRun(stamps_ns=stamps_ns, raw_mps2=raw, inclination_deg=inclination_deg,
                        toolface_deg=toolface_deg, segment=segment, truth=truth)


@dataclass(frozen=True)
class SensorErrors:
    """
    The errors of a three-axis accelerometer: seed 001's K, a bias and K_T(T).

    ``raw = K_T(T) * (K f + b)`` per axis with ``K = M C(gamma, beta)`` and
    ``K_T,i(T) = 1 + c1_i (T - 25) + c2_i (T - 25)^2`` (module docstring).
    """

    gamma_deg: float = 0.8          # mounting, seed 000 Eq. 1
    beta_deg: float = -1.2
    #: M: scale factors (diagonal) and cross-coupling of the sensing axes.
    axis_matrix: tuple = ((1.012, 0.004, -0.006), (-0.003, 0.991, 0.005),
                          (0.002, -0.004, 1.006))
    bias_mps2: tuple = (0.15, -0.22, 0.09)
    #: Temperature slope c1 [1/deg C] and curvature c2 [1/deg C^2] of each axis.
    temperature_c1_per_c: tuple = (5e-4, 4e-4, -3e-4)
    temperature_c2_per_c2: tuple = (2e-6, 1e-6, -2e-6)
    reference_temperature_c: float = REFERENCE_TEMPERATURE_C

    @property
    def scale_matrix(self):
        """Return the true K = M C(gamma, beta) of seed 001 Eq. 10."""
        return np.array(self.axis_matrix, dtype=float) @ sensor_matrix(
            math.radians(self.gamma_deg), math.radians(self.beta_deg))

    def temperature_scale(self, temperature_c):
        """Return K_T(T) per axis, shape (N, 3)."""
        dt = np.asarray(temperature_c, dtype=float).reshape(-1, 1) - self.reference_temperature_c
        return 1.0 + np.array(self.temperature_c1_per_c) * dt + \
            np.array(self.temperature_c2_per_c2) * dt * dt

    def read(self, f, temperature_c):
        """Return the noise-free readings ``K_T(T) * (K f + b)`` of specific force f (N, 3)."""
        linear = np.asarray(f, dtype=float) @ self.scale_matrix.T + np.array(self.bias_mps2)
        return self.temperature_scale(temperature_c) * linear

    def truth(self):
        """Return the true errors as a JSON-ready dict (K, b, K_T coefficients)."""
        return {'gamma_deg': self.gamma_deg, 'beta_deg': self.beta_deg,
                'axis_matrix': [list(row) for row in self.axis_matrix],
                'scale_matrix': self.scale_matrix.tolist(), 'bias_mps2': list(self.bias_mps2),
                'temperature_c1_per_c': list(self.temperature_c1_per_c),
                'temperature_c2_per_c2': list(self.temperature_c2_per_c2),
                'reference_temperature_c': self.reference_temperature_c}


@dataclass(frozen=True)
class SensorRun:
    """What a stand or heating run does with a ``SensorErrors`` sensor."""

    errors: SensorErrors = SensorErrors()
    noise_std_mps2: float = 0.002
    gravity_mps2: float = 9.80665
    rate_hz: float = 200.0
    seed: int = 0
    start_ns: int = SIM_EPOCH_NS

    def sample(self, attitudes_deg, counts, sensor_temperature_c, kind, **truth):
        """
        Return the SimulatedRun of attitudes held in turn, numbered from 1.

        ``sensor_temperature_c`` is one temperature or one per sample; ``truth``
        adds entries to the run's truth record.
        """
        stamps_ns, segment, inclination_deg, toolface_deg, records = _held_attitudes(
            attitudes_deg, counts, [kind] * len(counts), self.rate_hz, self.start_ns,
            first_index=1)
        temperature_c = np.broadcast_to(np.asarray(sensor_temperature_c, dtype=float),
                                        segment.shape)
        f = _true_force(inclination_deg, toolface_deg, self.gravity_mps2)
        rng = np.random.default_rng(self.seed)
        raw = self.errors.read(f, temperature_c) + rng.normal(
            0.0, self.noise_std_mps2, size=f.shape)
        truth = {'sensor': self.errors.truth(), 'noise_std_mps2': self.noise_std_mps2,
                 'rate_hz': self.rate_hz, 'gravity_mps2': self.gravity_mps2,
                 'seed': self.seed, 'axes': 3, **truth, 'segments': records}
        return SimulatedRun(stamps_ns=stamps_ns, raw_mps2=raw, inclination_deg=inclination_deg,
                            toolface_deg=toolface_deg, segment=segment, truth=truth,
                            temperature_c=np.array(temperature_c))


def simulate_stand(run=SensorRun(), positions_deg=STAND_POSITIONS_DEG, samples=100,
                   temperature_c=REFERENCE_TEMPERATURE_C):
    """
    Return a multi-position stand run: ``samples`` still readings per position.

    Positions are numbered 1..N in ``segment`` and in the truth's segments;
    the sensor is at ``temperature_c`` throughout (25 deg C: K_T = 1).
    """
    return run.sample(tuple(positions_deg), [samples] * len(positions_deg), temperature_c,
                      'position', temperature_c=temperature_c)


def simulate_heating(run=SensorRun(), attitude_deg=HEATING_ATTITUDE_DEG, t_start_c=20.0,
                     t_end_c=100.0, samples=1601):
    """
    Return a heating run: one still attitude, temperature ramping linearly.

    ``samples`` readings from ``t_start_c`` to ``t_end_c`` (the default 1601
    are 0.05 deg C apart, 41 of them within 1 deg C of 25 deg C).
    """
    temperature_c = np.linspace(t_start_c, t_end_c, samples)
    return run.sample((tuple(attitude_deg),), [samples], temperature_c, 'heating',
                      t_start_c=t_start_c, t_end_c=t_end_c)
