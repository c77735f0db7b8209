"""
A simulated well for multi-station analysis (seed 002): a physical tool read at survey stations.

Each station lies on a trajectory whose inclination and magnetic azimuth go
linearly from a start to an end value; the gravity (ISCWSA high-side)
toolfaces turn by the golden angle (137.5 deg) from station to station by
default, so that any run of four stations spreads them over the circle.

Every reading comes from ``sensor_model.read`` of the scenario's tool (see
``sim.bench.make_tool``): the reference field plus the drill string's
magnetisation ``interference_tool_nT`` (a constant vector in the z-up TOOL
frame: axial and cross-axial, turning with the tool), through the tool's
mount and triads.  A station is the mean of ``samples_per_station`` readings.
The default tool (``WELL_TOOL``) has ideal triads, no mount and 1e-4 g and
5 nT of noise per reading (one reading per station): the station noise of
seed 002's accuracy targets, and interference as its only error.  Another
tool (``make_tool('quartz', gamma_deg=...)``) adds its sensor and mount errors.

The stations are written as ``inclino msa`` reads them, in the ISCWSA survey
frame (x, y cross-axial, z toward the bit; the tool frame turned 180 deg
about x): ``G = (-f_x, f_y, f_z) / g`` in g and ``B = (B_x, -B_y, -B_z)`` in
nT, the sensor axes taken for the tool's (what the correction chain assumes).

Optional rotation captures (``rotation_samples`` per station) read the tool
turned through a full revolution at the station's inclination and azimuth,
as seed 002 §2.1 assumes (depth drilled in one turn neglected), one reading
each: with an ideal magnetometer the cross-axial readings lie on a circle
centred on the cross-axial interference.

The floor (``floor_azimuth_deg``): the azimuth an error-free tool would give
with the same noise draws (same seed) and no interference; what noise alone
leaves, the best any correction can do.
"""

from dataclasses import dataclass

from inclino_ros.core import magnetics
from inclino_ros.io.tables import write_csv
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import DEFAULT_INTERFERENCE_TOOL_NT, iscwsa_from_tool, make_tool
import numpy as np

#: The golden angle [deg]: toolfaces k * 137.5 deg never repeat and spread evenly.
GOLDEN_ANGLE_DEG = 180.0 * (3.0 - np.sqrt(5.0))
#: Columns of the station CSV (the ``inclino msa`` input, plus the truth).
STATION_COLUMNS = ('md', 'gx', 'gy', 'gz', 'bx', 'by', 'bz', 'true_inclination_deg',
                   'true_azimuth_deg', 'true_toolface_deg')
#: Per-reading noise of the default well tool: 1e-4 g and 5 nT (one reading a station).
WELL_GRAVITY_NOISE_G = 1e-4
WELL_FIELD_NOISE_NT = 5.0
#: The default well tool (module docstring).
WELL_TOOL = make_tool('ideal', noise_mps2=WELL_GRAVITY_NOISE_G * sm.STANDARD_GRAVITY_MPS2,
                      mag_noise_nT=WELL_FIELD_NOISE_NT)
#: ISCWSA axes of a z-up tool-frame vector: (x, -y, -z).
_ISCWSA = np.array([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class WellScenario:
    """What the simulated well looks like (module docstring); toolfaces are ISCWSA high side."""

    stations: int = 30
    inclination_deg: tuple = (30.0, 90.0)   # first and last station
    azimuth_deg: tuple = (85.0, 95.0)       # first and last station (east: the hard case)
    toolface_start_deg: float = 0.0
    toolface_step_deg: float = GOLDEN_ANGLE_DEG   # from station to station (0: never turns)
    reference_total_nT: float = 50000.0
    reference_dip_deg: float = 60.0
    tool: sm.Tool = WELL_TOOL
    interference_tool_nT: tuple = DEFAULT_INTERFERENCE_TOOL_NT   # z-up tool frame
    samples_per_station: int = 1   # readings averaged into one station
    rotation_samples: int = 0      # readings of one rotation capture per station (0: none)
    temperature_c: float = 25.0
    md_start_m: float = 1000.0
    md_step_m: float = 30.0
    seed: int = 2

    def __post_init__(self):
        """Refuse a well that cannot be simulated."""
        if self.stations < 1 or self.samples_per_station < 1 or self.rotation_samples < 0:
            raise ValueError('stations and samples_per_station must be >= 1, '
                             'rotation_samples >= 0')
        if not self.reference_total_nT > 0.0:
            raise ValueError('reference_total_nT must be positive')

    @property
    def interference_iscwsa_nT(self):
        """Return the interference in ISCWSA axes (eps_x, eps_y, eps_z) [nT]: what MSA solves."""
        return np.asarray(iscwsa_from_tool(self.interference_tool_nT))

    @property
    def field(self):
        """Return the reference field as a ``sensor_model.Field``."""
        return sm.Field(self.reference_total_nT, self.reference_dip_deg)


@dataclass(frozen=True)
class SimulatedWell:
    """The readings of a simulated well and their truth (station arrays of length N)."""

    scenario: WellScenario
    md_m: np.ndarray
    inclination_deg: np.ndarray   # true
    azimuth_deg: np.ndarray       # true magnetic azimuth
    toolface_deg: np.ndarray      # true gravity (ISCWSA high-side) toolface
    gravity: np.ndarray           # (N, 3) measured G [g], ISCWSA axes
    field_nT: np.ndarray          # (N, 3) measured B [nT], ISCWSA axes
    rotation_gravity: np.ndarray  # (N, M, 3) or None
    rotation_field_nT: np.ndarray  # (N, M, 3) or None
    floor_azimuth_deg: np.ndarray  # (N,) error-free tool, same noise, no interference

    @property
    def interference_iscwsa_nT(self):
        """Return the true interference (eps_x, eps_y, eps_z) in ISCWSA axes [nT]."""
        return self.scenario.interference_iscwsa_nT


def _noise_only(tool):
    """Return an error-free tool with the noise of ``tool`` (same draws for the same seed)."""
    return sm.Tool(accelerometer=sm.Triad(noise_std=tool.accelerometer.noise_std),
                   magnetometer=sm.Triad(noise_std=tool.magnetometer.noise_std),
                   gravity_mps2=tool.gravity_mps2)


def _stations(scenario, tool, interference, rng, inclination, azimuth, toolface_gtf, samples):
    """
    Return (G [g], B [nT]) in ISCWSA axes: per attitude the mean of ``samples`` readings.

    The attitude arrays have one entry per station (or per rotation reading);
    the high-side toolface GTF is the seed-000 toolface + 90 deg.
    """
    repeat = (lambda a: np.repeat(np.asarray(a, dtype=float).reshape(-1), samples))
    readings = sm.read(tool, repeat(inclination), repeat(toolface_gtf) - 90.0, repeat(azimuth),
                       scenario.temperature_c, field=scenario.field,
                       interference_nT=interference, rng=rng)
    shape = np.shape(inclination) + (samples, 3)
    accel = readings.accel_mps2.reshape(shape).mean(axis=-2)
    mag = readings.mag_nT.reshape(shape).mean(axis=-2)
    return -accel * _ISCWSA / tool.gravity_mps2, mag * _ISCWSA


def simulate_well(scenario=WellScenario()):
    """Return the SimulatedWell of ``scenario`` (deterministic for its seed)."""
    s = scenario
    step = np.linspace(0.0, 1.0, s.stations)
    inclination = s.inclination_deg[0] + step * (s.inclination_deg[1] - s.inclination_deg[0])
    azimuth = np.mod(s.azimuth_deg[0] + step * (s.azimuth_deg[1] - s.azimuth_deg[0]), 360.0)
    toolface = np.mod(s.toolface_start_deg + s.toolface_step_deg * np.arange(s.stations), 360.0)
    rng = np.random.default_rng(s.seed)
    gravity, field = _stations(s, s.tool, s.interference_tool_nT, rng, inclination, azimuth,
                               toolface, s.samples_per_station)
    rotation_gravity = rotation_field = None
    if s.rotation_samples:
        turn = np.arange(s.rotation_samples) * 360.0 / s.rotation_samples
        shape = (s.stations, s.rotation_samples)
        rotation_gravity, rotation_field = _stations(
            s, s.tool, s.interference_tool_nT, rng, np.broadcast_to(inclination[:, None], shape),
            np.broadcast_to(azimuth[:, None], shape), toolface[:, None] + turn, 1)
    floor_g, floor_b = _stations(s, _noise_only(s.tool), (0.0, 0.0, 0.0),
                                 np.random.default_rng(s.seed), inclination, azimuth, toolface,
                                 s.samples_per_station)
    return SimulatedWell(
        scenario=scenario, md_m=s.md_start_m + s.md_step_m * np.arange(s.stations),
        inclination_deg=inclination, azimuth_deg=azimuth, toolface_deg=toolface,
        gravity=gravity, field_nT=field, rotation_gravity=rotation_gravity,
        rotation_field_nT=rotation_field,
        floor_azimuth_deg=magnetics.azimuth_deg(floor_g, floor_b))


def well_truth(well):
    """Return the JSON-ready truth of ``well``: scenario and ``sensor_model.truth_dict``."""
    s = well.scenario
    return {
        'scenario': 'well', 'tool': sm.truth_dict(s.tool), 'seed': s.seed,
        'stations': s.stations, 'samples_per_station': s.samples_per_station,
        'inclination_deg': list(s.inclination_deg), 'azimuth_deg': list(s.azimuth_deg),
        'toolface_start_deg': s.toolface_start_deg, 'toolface_step_deg': s.toolface_step_deg,
        'field': {'total_nT': s.reference_total_nT, 'dip_deg': s.reference_dip_deg},
        'interference_tool_nT': [float(v) for v in s.interference_tool_nT],
        'interference_iscwsa_nT': s.interference_iscwsa_nT.tolist(),
        'temperature_c': s.temperature_c,
        'csv_frame': 'ISCWSA survey axes (x, -y, -z of the tool frame); G in g, B in nT'}


def write_stations_csv(path, well):
    """Write the stations of ``well`` as the ``inclino msa`` input CSV (STATION_COLUMNS)."""
    table = np.column_stack([well.md_m, well.gravity, well.field_nT, well.inclination_deg,
                             well.azimuth_deg, well.toolface_deg]).astype(float)
    write_csv(path, list(zip(STATION_COLUMNS, table.T)), mode='w')
