"""
The virtual bench: a misaligned inclinometer read at known attitudes.

A tool at inclination I and seed-000 gravity toolface TF feels, in its ideal
z-up tool frame (REP 145 specific force, seed 000 Eq. 2 generalised)::

    f = g (sin I cos TF, sin I sin TF, cos I)

and a sensor mounted with installation angles (gamma, beta) reads
``raw = C f + noise`` with C of seed 000 Eq. 1.  C is built here from
transforms3d's rotations, not from ``inclino_ros.installation``, so the bench
is an independent check of the core.  Pure numpy + transforms3d.
"""

from dataclasses import dataclass
import math

import numpy as np
from transforms3d.axangles import axangle2mat

#: (inclination_deg, toolface_deg) of the default tilted stations: inclinations
#: 0.5..60 deg, toolfaces k * 150 deg mod 360 (every multiple of 30 deg once).
DEFAULT_STATIONS_DEG = (
    (0.5, 0.0), (1.0, 150.0), (2.0, 300.0), (3.0, 90.0), (5.0, 240.0), (8.0, 30.0),
    (12.0, 180.0), (18.0, 330.0), (25.0, 120.0), (35.0, 270.0), (45.0, 60.0), (60.0, 210.0))

#: First sample time of a simulated run: 2026-01-01T00:00:00Z [ns].
SIM_EPOCH_NS = 1_767_225_600 * 1_000_000_000


def sensor_matrix(gamma, beta):
    """
    Return seed 000's C (Eq. 1) as ``Rx(beta) @ Ry(-gamma)``, angles in radians.

    The seed turns the ideal frame "clockwise" by gamma about Y, then by beta
    about X'; written with standard right-hand rotation matrices that is
    ``Rx(beta) @ Ry(-gamma)``, mapping ideal-frame coordinates to sensor ones.
    """
    return axangle2mat((1.0, 0.0, 0.0), beta) @ axangle2mat((0.0, 1.0, 0.0), -gamma)


def specific_force(inclination, toolface, gravity_mps2):
    """Return ``g (sin I cos TF, sin I sin TF, cos I)``, shape (..., 3), angles in radians."""
    inclination = np.asarray(inclination, dtype=float)
    toolface = np.asarray(toolface, dtype=float)
    sin_i = np.sin(inclination)
    return gravity_mps2 * np.stack(
        [sin_i * np.cos(toolface), sin_i * np.sin(toolface), np.cos(inclination)], axis=-1)


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
    segment: np.ndarray          # (N,) 0 = level, k = station k
    truth: dict                  # scenario parameters and per-segment truth (JSON-ready)


def simulate(scenario=Scenario()):
    """Return the samples of ``scenario``: ``raw = C(gamma, beta) f + noise`` (Eqs. 1, 2)."""
    segments_deg = ((0.0, math.nan),) + tuple(scenario.stations_deg)
    counts = [round(scenario.level_s * scenario.rate_hz)] + \
        [round(scenario.station_s * scenario.rate_hz)] * len(scenario.stations_deg)
    segment = np.repeat(np.arange(len(segments_deg)), counts)
    inclination_deg = np.array([s[0] for s in segments_deg])[segment]
    toolface_deg = np.array([s[1] for s in segments_deg])[segment]
    stamps_ns = scenario.start_ns + np.round(
        np.arange(segment.size) * (1e9 / scenario.rate_hz)).astype(np.int64)

    f = specific_force(np.radians(inclination_deg), np.radians(np.nan_to_num(toolface_deg)),
                       scenario.gravity_mps2)
    c = sensor_matrix(math.radians(scenario.gamma_deg), math.radians(scenario.beta_deg))
    rng = np.random.default_rng(scenario.seed)
    raw = f @ c.T + rng.normal(0.0, scenario.noise_std_mps2, size=f.shape)
    if scenario.axes == 2:
        raw[:, 2] = 0.0

    ends = np.cumsum(counts)
    truth = {
        'gamma_deg': scenario.gamma_deg, 'beta_deg': scenario.beta_deg,
        'noise_std_mps2': scenario.noise_std_mps2, 'rate_hz': scenario.rate_hz,
        'gravity_mps2': scenario.gravity_mps2, 'seed': scenario.seed, 'axes': scenario.axes,
        'segments': [
            {'index': k, 'kind': 'level' if k == 0 else 'station',
             'start_ns': int(stamps_ns[end - n]), 'end_ns': int(stamps_ns[end - 1]),
             'samples': int(n), 'inclination_deg': incl_deg,
             'toolface_deg': None if math.isnan(tf_deg) else tf_deg}
            for k, ((incl_deg, tf_deg), n, end) in enumerate(zip(segments_deg, counts, ends))],
    }
    return SimulatedRun(stamps_ns=stamps_ns, raw_mps2=raw, inclination_deg=inclination_deg,
                        toolface_deg=toolface_deg, segment=segment, truth=truth)
