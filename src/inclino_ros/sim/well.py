"""
A simulated well for multi-station analysis (seed 002): stations with drill-string interference.

Each station lies on a trajectory whose inclination and magnetic azimuth go
linearly from a start to an end value; the gravity toolfaces turn by the
golden angle (137.5 deg) from station to station by default, so that any
run of four stations spreads them over the circle.  Readings follow the ISCWSA forward
model (``magnetics.forward``, survey frame: x, y cross-axial, z toward the
bit, G the gravity vector) in the reference field, plus the drill string's
magnetisation: a constant vector in the TOOL frame (``interference_nT``:
axial eps_z and cross-axial hard iron eps_x, eps_y, all turning with the
tool), plus independent Gaussian noise of the station-averaged readings.

Optional rotation captures (``rotation_samples`` per station) read the tool
turned through a full revolution at the station's inclination and azimuth,
as seed 002 §2.1 assumes (depth drilled in one turn neglected): the cross-axial
readings then lie on a circle centred on (eps_x, eps_y).
"""

import csv
from dataclasses import dataclass

from inclino_ros.core import magnetics
import numpy as np

#: The golden angle [deg]: toolfaces k * 137.5 deg never repeat and spread evenly.
GOLDEN_ANGLE_DEG = 180.0 * (3.0 - np.sqrt(5.0))
#: Columns of the station CSV (the ``inclino msa`` input, plus the truth).
STATION_COLUMNS = ('md', 'gx', 'gy', 'gz', 'bx', 'by', 'bz', 'true_inclination_deg',
                   'true_azimuth_deg', 'true_toolface_deg')


@dataclass(frozen=True)
class WellScenario:
    """What the simulated well looks like; gravity in g, field in nT."""

    stations: int = 30
    inclination_deg: tuple = (30.0, 90.0)   # first and last station
    azimuth_deg: tuple = (85.0, 95.0)       # first and last station (east: the hard case)
    toolface_start_deg: float = 0.0
    toolface_step_deg: float = GOLDEN_ANGLE_DEG   # from station to station (0: never turns)
    reference_total_nT: float = 50000.0
    reference_dip_deg: float = 60.0
    g: float = 1.0
    interference_nT: tuple = (80.0, -80.0, 2000.0)   # (eps_x, eps_y, eps_z), ISCWSA tool axes
    gravity_noise: float = 1e-4   # per axis, 1 sigma, unit of g
    field_noise_nT: float = 5.0   # per axis, 1 sigma
    rotation_samples: int = 0     # readings of one rotation capture per station (0: none)
    md_start_m: float = 1000.0
    md_step_m: float = 30.0
    seed: int = 2


@dataclass(frozen=True)
class SimulatedWell:
    """The readings of a simulated well and their truth (station arrays of length N)."""

    scenario: WellScenario
    md_m: np.ndarray
    inclination_deg: np.ndarray   # true
    azimuth_deg: np.ndarray       # true magnetic azimuth
    toolface_deg: np.ndarray      # true gravity (high-side) toolface
    gravity: np.ndarray           # (N, 3) measured G
    field_nT: np.ndarray          # (N, 3) measured B: truth + interference + noise
    rotation_gravity: np.ndarray  # (N, M, 3) or None
    rotation_field_nT: np.ndarray  # (N, M, 3) or None

    @property
    def interference_nT(self):
        """Return the true interference (eps_x, eps_y, eps_z) [nT] as an array."""
        return np.asarray(self.scenario.interference_nT, dtype=float)

    @property
    def floor_azimuth_deg(self):
        """
        Return the azimuth of the noisy readings with the TRUE interference removed [deg].

        The best any correction can do: what is left is the noise alone.
        """
        return magnetics.azimuth_deg(self.gravity, self.field_nT - self.interference_nT)


def simulate_well(scenario=WellScenario()):
    """Return the SimulatedWell of ``scenario`` (deterministic for its seed)."""
    s = scenario
    rng = np.random.default_rng(s.seed)
    step = np.linspace(0.0, 1.0, s.stations)
    inclination = s.inclination_deg[0] + step * (s.inclination_deg[1] - s.inclination_deg[0])
    azimuth = np.mod(s.azimuth_deg[0] + step * (s.azimuth_deg[1] - s.azimuth_deg[0]), 360.0)
    toolface = np.mod(s.toolface_start_deg + s.toolface_step_deg * np.arange(s.stations), 360.0)
    gravity, field = _read(scenario, rng, inclination, azimuth, toolface)
    rotation_gravity = rotation_field = None
    if s.rotation_samples:
        turn = np.arange(s.rotation_samples) * 360.0 / s.rotation_samples
        rotation_gravity, rotation_field = _read(
            scenario, rng, inclination[:, None], azimuth[:, None], toolface[:, None] + turn)
    return SimulatedWell(
        scenario=scenario, md_m=s.md_start_m + s.md_step_m * np.arange(s.stations),
        inclination_deg=inclination, azimuth_deg=azimuth, toolface_deg=toolface,
        gravity=gravity, field_nT=field, rotation_gravity=rotation_gravity,
        rotation_field_nT=rotation_field)


def _read(scenario, rng, inclination_deg, azimuth_deg, toolface_deg):
    """Return noisy (G, B) at the given attitudes, the interference added to B."""
    s = scenario
    gravity, field = magnetics.forward(inclination_deg, azimuth_deg, toolface_deg, s.g,
                                       s.reference_total_nT, s.reference_dip_deg)
    return (gravity + rng.normal(0.0, s.gravity_noise, gravity.shape),
            field + np.asarray(s.interference_nT) + rng.normal(0.0, s.field_noise_nT,
                                                               field.shape))


def write_stations_csv(path, well):
    """Write the stations of ``well`` as the ``inclino msa`` input CSV (STATION_COLUMNS)."""
    table = np.column_stack([well.md_m, well.gravity, well.field_nT, well.inclination_deg,
                             well.azimuth_deg, well.toolface_deg])
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(STATION_COLUMNS)
        writer.writerows([[repr(float(v)) for v in row] for row in table])
