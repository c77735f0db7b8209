"""
The virtual bench: a physical inclinometer (``sim.sensor_model``) read at known attitudes.

Every reading comes from ``sensor_model.read`` of a ``sensor_model.Tool``:
the tool's attitude turns gravity and the Earth's field into the tool frame,
the drill string adds its field, the board's mount (gamma, beta, roll) turns
both vectors into the sensor frames, the magnetometer sees hard and soft
iron, each triad applies its 3x3 matrix, bias, temperature drift and noise.
Nothing here is built from the correction chain or inverts it: a test that
corrects these readings finds the chain's model errors.

Scenarios, each holding attitudes still one after the other:

- ``simulate(Scenario)``: the level segment (seed 000's bench, inclination
  0), then tilted stations with a magnetic azimuth each, and optionally a
  rotation segment (the tool turning about its axis at one attitude, for
  seed 002's ellipse fit).  Accelerometer and magnetometer are read together.
- ``simulate_stand(StandRun)``: seed 001's nine stand positions at one
  temperature.
- ``simulate_heating(StandRun)``: the temperature ramping at one attitude,
  or at several in turn (``TURNED_OVER_HEATING_ATTITUDES_DEG``: what a
  bias drift needs to be told from a scale drift).

Default tools (``make_tool``; what each scenario simulates unless told
otherwise):

- ``DEMO_TOOL`` (bench): ideal triads on a board mounted gamma 0.8 deg,
  beta -1.2 deg (both triads on the board: the magnetometer turns with it),
  noise 0.002 m/s^2 and 5 nT per sample, 25 deg C.  The error sources are
  the mount and the noise: what seed 000's level calibration is for.
- ``STAND_TOOL`` (stand and heating): the MEMS preset (3x3 K with scale
  errors up to 0.4 % and misalignment ~5 mrad, biases up to 18 mg, bias
  drift ~0.5 mg/degC, scale drift ~200 ppm/degC, its own noise 2 mg per
  sample; seed 001's sensor is of that class) on the same mount.  At 25 deg C
  (the stand) drift does not act; on the heating ramp it does.
  ``make_tool('quartz', ...)`` is ~10x better.

Pure numpy; truth records are JSON-ready and hold ``sensor_model.truth_dict``
of the tool (every error source).
"""

from dataclasses import dataclass, replace
import math

from inclino_ros.sim import sensor_model as sm
import numpy as np

#: The physical presets by their command-line name.
PRESETS = {'ideal': sm.IDEAL, 'mems': sm.MEMS, 'quartz': sm.QUARTZ_FLUXGATE}

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
#: Two heating attitudes where every axis reads the opposite: 55/45 deg and turned over,
#: 125/225 deg (-0.58, -0.58, -0.57) g.  At one attitude a bias drift cannot be told from
#: a scale drift; here each axis reads differently and both are fitted.
TURNED_OVER_HEATING_ATTITUDES_DEG = (HEATING_ATTITUDE_DEG, (125.0, 225.0))

#: The demo's mount: seed 000's installation angles [deg].
DEMO_GAMMA_DEG = 0.8
DEMO_BETA_DEG = -1.2
#: The demo's per-sample noise with the ideal preset: accelerometer [m/s^2], magnetometer [nT].
DEMO_NOISE_MPS2 = 0.002
DEMO_MAG_NOISE_NT = 5.0

#: Drill-string interference of seed 002 §3, in the TOOL frame [nT]: 80 nT on each
#: cross-axial axis, 2000 nT axial toward the bit (tool z points away from it).  In
#: ISCWSA axes (x, -y, -z) this is (80, -80, 2000), the eps ``inclino msa`` reports.
DEFAULT_INTERFERENCE_TOOL_NT = (80.0, 80.0, -2000.0)


def tool_from_iscwsa(vector):
    """
    Return a vector given in ISCWSA axes in the z-up tool frame: ``(x, -y, -z)``.

    The ISCWSA frame is the tool frame turned 180 deg about x
    (``sensor_model`` docstring), so the map is its own inverse.
    """
    x, y, z = (float(v) for v in vector)
    return (x, -y, -z)


#: The map back from the tool frame to ISCWSA axes: the same 180 deg turn.
iscwsa_from_tool = tool_from_iscwsa


def make_tool(sensor='ideal', gamma_deg=0.0, beta_deg=0.0, roll_deg=0.0,
              magnetometer_deg=(0.0, 0.0, 0.0), noise_mps2=None, mag_noise_nT=None, axes=3,
              gravity_mps2=sm.STANDARD_GRAVITY_MPS2):
    """
    Return the preset ``sensor`` (``PRESETS``) on a mount, with its noise optionally replaced.

    ``gamma_deg``, ``beta_deg``, ``roll_deg``, ``magnetometer_deg``: the
    ``sensor_model.Mount`` (both triads on the board; the magnetometer turned
    further by ``magnetometer_deg``).  ``noise_mps2`` and ``mag_noise_nT``
    (one sigma per sample and axis): None keeps the preset's own.
    """
    if sensor not in PRESETS:
        raise ValueError(f'sensor must be one of {sorted(PRESETS)}, not {sensor!r}')
    preset = PRESETS[sensor]
    accelerometer, magnetometer = preset.accelerometer, preset.magnetometer
    if noise_mps2 is not None:
        accelerometer = replace(accelerometer, noise_std=noise_mps2)
    if mag_noise_nT is not None:
        magnetometer = replace(magnetometer, noise_std=mag_noise_nT)
    return replace(preset, mount=sm.Mount(gamma_deg, beta_deg, roll_deg, magnetometer_deg),
                   accelerometer=accelerometer, magnetometer=magnetometer,
                   accelerometer_axes=axes, gravity_mps2=gravity_mps2)


def command_tool(sensor, mount_deg, noise_mps2, mag_noise_nT, ideal_noise, names, axes=3):
    """
    Return the tool of a simulating command (``make_tool``): the preset, mount and noise asked.

    ``mount_deg`` (gamma, beta, roll, magnetometer (3,)); ``noise_mps2``,
    ``mag_noise_nT`` None keep the preset's own noise, except for the ``ideal``
    preset (no noise of its own), which takes ``ideal_noise`` (m/s^2, nT);
    ValueError for a negative noise, ``names`` the two options as the message
    names them.
    """
    if sensor == 'ideal':
        noise_mps2 = ideal_noise[0] if noise_mps2 is None else noise_mps2
        mag_noise_nT = ideal_noise[1] if mag_noise_nT is None else mag_noise_nT
    if (noise_mps2 is not None and noise_mps2 < 0.0) or (
            mag_noise_nT is not None and mag_noise_nT < 0.0):
        raise ValueError(f'{names[0]} and {names[1]} must not be negative')
    gamma_deg, beta_deg, roll_deg, magnetometer_deg = mount_deg
    return make_tool(sensor, gamma_deg, beta_deg, roll_deg, tuple(magnetometer_deg), noise_mps2,
                     mag_noise_nT, axes)


#: The bench's default tool (module docstring).
DEMO_TOOL = make_tool('ideal', DEMO_GAMMA_DEG, DEMO_BETA_DEG, noise_mps2=DEMO_NOISE_MPS2,
                      mag_noise_nT=DEMO_MAG_NOISE_NT)
#: The stand and heating runs' default tool (module docstring).
STAND_TOOL = make_tool('mems', DEMO_GAMMA_DEG, DEMO_BETA_DEG)


@dataclass(frozen=True)
class Scenario:
    """
    What the bench does: a level segment, tilted stations, optionally a rotation.

    ``azimuth_deg``: magnetic azimuth of the first and last station, linear
    between; ``interference_tool_nT``: the drill string's field in the z-up
    tool frame; ``rotation_s`` > 0 appends a rotation segment of that length:
    ``rotation_turns`` turns of the toolface at ``rotation_attitude_deg``
    (inclination, azimuth).  The tool is at ``temperature_c`` throughout.
    """

    tool: sm.Tool = DEMO_TOOL
    stations_deg: tuple = DEFAULT_STATIONS_DEG
    azimuth_deg: tuple = (85.0, 95.0)
    field: sm.Field = sm.Field(50000.0, 60.0)
    interference_tool_nT: tuple = DEFAULT_INTERFERENCE_TOOL_NT
    rotation_s: float = 0.0
    rotation_turns: float = 2.0
    rotation_attitude_deg: tuple = (60.0, 90.0)
    temperature_c: float = 25.0
    rate_hz: float = 200.0
    level_s: float = 3.0
    station_s: float = 2.0
    seed: int = 0
    start_ns: int = SIM_EPOCH_NS

    def __post_init__(self):
        """Refuse a scenario that cannot be sampled."""
        if not self.rate_hz > 0 or min(self.level_s, self.station_s) * self.rate_hz < 1.0:
            raise ValueError('rate_hz, level_s and station_s must give every segment '
                             'at least one sample')
        if not self.rotation_s >= 0.0:
            raise ValueError('rotation_s must be >= 0')
        if not self.field.total_nT > 0.0:
            raise ValueError('the reference field must be positive')


@dataclass(frozen=True)
class SimulatedRun:
    """Samples of a scenario with the truth behind every one of them."""

    stamps_ns: np.ndarray        # (N,) int64
    raw_mps2: np.ndarray         # (N, 3) accelerometer readings; z is 0.0 for a 2-axis sensor
    mag_nT: np.ndarray           # (N, 3) magnetometer readings [nT, sensor axes]
    inclination_deg: np.ndarray  # (N,) true inclination of the tool
    toolface_deg: np.ndarray     # (N,) true seed-000 toolface; NaN on the level segment
    azimuth_deg: np.ndarray      # (N,) true magnetic azimuth; NaN where not defined
    temperature_c: np.ndarray    # (N,) sensor temperature [deg C]
    segment: np.ndarray          # (N,) 0 = level, k = station (or stand position) k
    truth: dict                  # scenario, tool and per-segment truth (JSON-ready)


def _stamps(start_ns, count, rate_hz):
    """Return ``count`` stamps [ns] from ``start_ns`` at ``rate_hz``, int64."""
    return start_ns + np.round(np.arange(count) * (1e9 / rate_hz)).astype(np.int64)


def _segments(attitudes, counts, kinds, first_index):
    """
    Return per-sample (segment, inclination, toolface, azimuth) of segments held in turn.

    ``attitudes`` are (inclination_deg, toolface_deg, azimuth_deg) triples
    (NaN where undefined), ``counts`` their samples; segments are numbered
    from ``first_index``.  Also returns the segment records (stamps added by
    ``_add_stamps``).
    """
    index = np.repeat(np.arange(len(attitudes)), counts)
    values = np.array(attitudes, dtype=float).reshape(-1, 3)[index]
    records = [
        {'index': k + first_index, 'kind': kind, 'samples': int(n),
         'inclination_deg': float(incl), 'toolface_deg': None if math.isnan(tf) else float(tf),
         'azimuth_deg': None if math.isnan(az) else float(az)}
        for k, ((incl, tf, az), n, kind) in enumerate(zip(attitudes, counts, kinds))]
    return index + first_index, values[:, 0], values[:, 1], values[:, 2], records


def _add_stamps(records, stamps_ns):
    """Write each record's first and last stamp, in sample order."""
    end = 0
    for record in records:
        start, end = end, end + record['samples']
        record['start_ns'], record['end_ns'] = int(stamps_ns[start]), int(stamps_ns[end - 1])


def _read(tool, inclination_deg, toolface_deg, azimuth_deg, temperature_c, field,
          interference_tool_nT, seed):
    """
    Return the ``sensor_model.Readings`` of the held attitudes.

    An undefined (NaN) toolface or azimuth is read as 0: on the level segment
    the tool is vertical, and any toolface and azimuth is as good as another.
    """
    return sm.read(tool, inclination_deg, np.nan_to_num(toolface_deg),
                   np.nan_to_num(azimuth_deg), temperature_c, field=field,
                   interference_nT=interference_tool_nT, rng=seed)


def _truth(tool, field, interference_tool_nT, seed, rate_hz, **entries):
    """Return the truth record shared by every scenario (the tool's ``truth_dict`` in it)."""
    interference = [float(v) for v in interference_tool_nT]
    return {'tool': sm.truth_dict(tool), 'seed': seed, 'rate_hz': rate_hz,
            'field': {'total_nT': field.total_nT, 'dip_deg': field.dip_deg},
            'interference_tool_nT': interference,
            'interference_iscwsa_nT': list(iscwsa_from_tool(interference)),
            **entries}


def simulate(scenario=Scenario()):
    """Return the samples of ``scenario`` (level, stations, rotation) read by its tool."""
    s = scenario
    station_azimuth = np.mod(np.linspace(*s.azimuth_deg, len(s.stations_deg)), 360.0)
    attitudes = [(0.0, math.nan, math.nan)] + [
        (incl, tf, az) for (incl, tf), az in zip(s.stations_deg, station_azimuth)]
    counts = [round(s.level_s * s.rate_hz)] + [round(s.station_s * s.rate_hz)] * \
        len(s.stations_deg)
    kinds = ['level'] + ['station'] * len(s.stations_deg)
    segment, inclination, toolface, azimuth, records = _segments(attitudes, counts, kinds, 0)

    rotation_n = round(s.rotation_s * s.rate_hz)
    if rotation_n >= 1:
        index = len(attitudes)
        turn_deg = np.mod(np.arange(rotation_n) * 360.0 * s.rotation_turns / rotation_n, 360.0)
        segment = np.concatenate([segment, np.full(rotation_n, index)])
        inclination = np.concatenate(
            [inclination, np.full(rotation_n, s.rotation_attitude_deg[0])])
        toolface = np.concatenate([toolface, turn_deg])
        azimuth = np.concatenate([azimuth, np.full(rotation_n, s.rotation_attitude_deg[1])])
        records.append({'index': index, 'kind': 'rotation', 'samples': rotation_n,
                        'inclination_deg': float(s.rotation_attitude_deg[0]),
                        'toolface_deg': None, 'azimuth_deg': float(s.rotation_attitude_deg[1]),
                        'turns': s.rotation_turns})

    stamps_ns = _stamps(s.start_ns, segment.size, s.rate_hz)
    _add_stamps(records, stamps_ns)
    readings = _read(s.tool, inclination, toolface, azimuth, s.temperature_c, s.field,
                     s.interference_tool_nT, s.seed)
    truth = _truth(s.tool, s.field, s.interference_tool_nT, s.seed, s.rate_hz,
                   scenario='bench', temperature_c=s.temperature_c, segments=records)
    return SimulatedRun(stamps_ns=stamps_ns, raw_mps2=readings.accel_mps2,
                        mag_nT=readings.mag_nT, inclination_deg=inclination,
                        toolface_deg=toolface, azimuth_deg=azimuth,
                        temperature_c=readings.temperature_c, segment=segment, truth=truth)


@dataclass(frozen=True)
class StandRun:
    """
    How a stand or heating run is recorded: the tool, rate, seed and first stamp.

    The stand holds attitudes only (no azimuth, no drill string): the
    magnetometer is read at azimuth 0 in the Earth's field alone.
    """

    tool: sm.Tool = STAND_TOOL
    rate_hz: float = 200.0
    seed: int = 0
    start_ns: int = SIM_EPOCH_NS

    def sample(self, attitudes_deg, counts, sensor_temperature_c, kind, **entries):
        """
        Return the SimulatedRun of attitudes held in turn, numbered from 1.

        ``attitudes_deg``: (inclination, toolface) pairs, or triples with the
        magnetic azimuth (NaN: read at 0).  ``sensor_temperature_c`` is one
        temperature or one per sample; ``entries``
        add to the run's truth record.
        """
        attitudes = [(attitude[0], attitude[1], attitude[2] if len(attitude) > 2 else math.nan)
                     for attitude in attitudes_deg]
        segment, inclination, toolface, azimuth, records = _segments(
            attitudes, counts, [kind] * len(counts), first_index=1)
        stamps_ns = _stamps(self.start_ns, segment.size, self.rate_hz)
        _add_stamps(records, stamps_ns)
        temperature = np.broadcast_to(np.asarray(sensor_temperature_c, dtype=float),
                                      segment.shape)
        field, interference = sm.Field(), (0.0, 0.0, 0.0)
        readings = _read(self.tool, inclination, toolface, azimuth, temperature, field,
                         interference, self.seed)
        truth = _truth(self.tool, field, interference, self.seed, self.rate_hz,
                       scenario=kind, **entries, segments=records)
        return SimulatedRun(stamps_ns=stamps_ns, raw_mps2=readings.accel_mps2,
                            mag_nT=readings.mag_nT, inclination_deg=inclination,
                            toolface_deg=toolface, azimuth_deg=azimuth,
                            temperature_c=readings.temperature_c, segment=segment, truth=truth)


def simulate_stand(run=StandRun(), positions_deg=STAND_POSITIONS_DEG, samples=100,
                   temperature_c=25.0, visits=1, azimuth_step_deg=0.0, setting_error_deg=0.0,
                   seating_error_deg=0.0):
    """
    Return a multi-position stand run: ``samples`` still readings per position.

    Positions are numbered 1..N in ``segment`` and in the truth's segments;
    the sensor is at ``temperature_c`` throughout.

    A factory sequence visits its attitudes again (``visits`` > 1: the whole
    sequence once more per visit, e.g. positions 1 and 10 one attitude).  A
    visit is set within the stand's setting error: its inclination and
    toolface land ``setting_error_deg`` (1 sigma each) from the nominal ones,
    and the stand's encoders read where it landed (the run's inclination_deg
    and toolface_deg: e.g. 0.012 deg apart).  Each visit turns the stand's
    azimuth by ``azimuth_step_deg`` (180: the same attitude at azimuth 0 and
    180; it changes the magnetometer's reading, not the accelerometer's).  The
    tool is seated anew each time: its gravity direction is tilted from the
    encoders' by ``seating_error_deg`` per component (1 sigma), which no encoder
    sees: what the visits' scatter (the stand's repeatability) shows.  The
    truth's ``repeats`` record the nominal, read and actual attitude of each.
    """
    rng = np.random.default_rng([run.seed, 1])
    nominal = np.tile(np.asarray(positions_deg, dtype=float).reshape(-1, 2), (visits, 1))
    visit = np.repeat(np.arange(visits), len(positions_deg))
    setting = rng.standard_normal(nominal.shape) * setting_error_deg * (visit > 0)[:, None]
    read_deg = nominal + setting
    seating = rng.standard_normal(nominal.shape) * seating_error_deg
    actual_deg = _tilted(read_deg, seating) if seating_error_deg > 0.0 else read_deg
    azimuth_deg = np.mod(visit * azimuth_step_deg, 360.0)
    sim = run.sample(tuple(zip(actual_deg[:, 0], actual_deg[:, 1], azimuth_deg)),
                     [samples] * len(nominal), temperature_c, 'position',
                     temperature_c=temperature_c,
                     repeats=[{'visit': int(v), 'nominal_deg': n.tolist(), 'read_deg': r.tolist(),
                               'actual_deg': a.tolist()}
                              for v, n, r, a in zip(visit, nominal, read_deg, actual_deg)])
    index = sim.segment - 1
    return replace(sim, inclination_deg=read_deg[index, 0], toolface_deg=read_deg[index, 1])


def _tilted(attitudes_deg, tilt_deg):
    """
    Return (inclination, toolface) [deg] of gravity directions tilted by small angles.

    ``tilt_deg`` (N, 2): the turn about the two axes perpendicular to each
    direction (the inclination's and the toolface's), a small-angle rotation
    of the unit vector ``(sin I cos TF, sin I sin TF, cos I)``.
    """
    incl, tf = np.radians(attitudes_deg).T
    unit = np.stack([np.sin(incl) * np.cos(tf), np.sin(incl) * np.sin(tf), np.cos(incl)], axis=1)
    along_incl = np.stack([np.cos(incl) * np.cos(tf), np.cos(incl) * np.sin(tf), -np.sin(incl)],
                          axis=1)
    along_tf = np.stack([-np.sin(tf), np.cos(tf), np.zeros_like(tf)], axis=1)
    tilt = np.radians(tilt_deg)
    moved = unit + tilt[:, :1] * along_incl + tilt[:, 1:] * along_tf
    moved /= np.linalg.norm(moved, axis=1)[:, None]
    inclination_deg = np.degrees(np.arctan2(np.hypot(moved[:, 0], moved[:, 1]), moved[:, 2]))
    return np.column_stack([inclination_deg, np.degrees(np.arctan2(moved[:, 1], moved[:, 0]))])


def simulate_heating(run=StandRun(), attitudes_deg=(HEATING_ATTITUDE_DEG,), t_start_c=20.0,
                     t_end_c=100.0, samples=1601):
    """
    Return a heating run: the tool still at each attitude in turn while the temperature ramps.

    ``attitudes_deg``: (inclination_deg, toolface_deg) pairs, segments 1..N
    in that order.  Each attitude gets ``samples`` readings over the whole
    ramp (the default 1601 are 0.05 deg C apart, 41 of them within 1 deg C
    of 25 deg C): the first heats from ``t_start_c`` to ``t_end_c``, the tool
    is turned and the second cools back, and so on, so the temperature is
    continuous over the run.
    """
    attitudes_deg = tuple(tuple(float(v) for v in attitude) for attitude in attitudes_deg)
    if not attitudes_deg or any(len(attitude) != 2 for attitude in attitudes_deg):
        raise ValueError('heating attitudes are (inclination_deg, toolface_deg) pairs, '
                         'at least one')
    ramp = np.linspace(t_start_c, t_end_c, samples)
    temperature_c = np.concatenate([ramp if k % 2 == 0 else ramp[::-1]
                                    for k in range(len(attitudes_deg))])
    return run.sample(attitudes_deg, [samples] * len(attitudes_deg), temperature_c, 'heating',
                      t_start_c=t_start_c, t_end_c=t_end_c)


def tool_stand_truth(tool):
    """
    Return (K, b) of seed 001's stand model that ``tool``'s accelerometer obeys at T_ref.

    At its reference temperature the triad reads ``K_triad C f + b`` with C
    the mount's map of tool-frame vectors to the accelerometer axes
    (``Mount.accelerometer_from_tool``): a stand fit finds ``K = K_triad C``
    (the mount included) and b.  Physics of the model, not the chain.
    """
    k = np.array(tool.accelerometer.matrix) @ tool.mount.accelerometer_from_tool()
    return k, np.array(tool.accelerometer.bias)


def drifting_mount_tool(noise_mps2=2e-4 * sm.STANDARD_GRAVITY_MPS2):
    """
    Return the MEMS tool of a real borehole tool's heating: its mount turns with the temperature.

    The stand tool's MEMS triads on the board mounted gamma 0.8, beta -1.2 deg, whose mount
    tilts by 0.3 deg (gamma) between 28 and 60 deg C, and whose z bias drifts by 14 mg over that
    span (what a real tool showed, issue 18), on top of the preset's own drifts; ``noise_mps2``
    per sample.  A per-axis bias and scale drift cannot hold the turn.
    """
    base = make_tool('mems', DEMO_GAMMA_DEG, DEMO_BETA_DEG, noise_mps2=noise_mps2)
    drift = [list(row) for row in base.accelerometer.bias_drift]
    drift[2][0] = 14e-3 * sm.STANDARD_GRAVITY_MPS2 / 32.0
    return replace(base, mount=replace(base.mount, drift_deg_per_c=(0.3 / 32.0, 0.0, 0.0)),
                   accelerometer=replace(base.accelerometer,
                                         bias_drift=tuple(map(tuple, drift))))


def held_out_errors_deg(tool, correct, temperature_c, count=400, seed=9):
    """
    Return the angle [deg] between corrected and true gravity at ``count`` random attitudes.

    ``tool`` read noise-free (only the calibration's error shows) at attitudes uniform over
    the sphere, at ``temperature_c``; ``correct(readings (N, 3), temperatures (N,))`` is the
    calibration under test.  The truth is the attitude the readings were made at.
    """
    rng = np.random.default_rng(seed)
    incl = np.degrees(np.arccos(rng.uniform(-1.0, 1.0, count)))
    tf = np.radians(rng.uniform(0.0, 360.0, count))
    quiet = replace(tool, accelerometer=replace(tool.accelerometer, noise_std=0.0))
    readings = sm.read(quiet, incl, np.degrees(tf), temperature_c=temperature_c).accel_mps2
    corrected = correct(readings, np.full(count, float(temperature_c)))
    unit = corrected / np.linalg.norm(corrected, axis=1)[:, None]
    sin_i = np.sin(np.radians(incl))
    truth = np.column_stack([sin_i * np.cos(tf), sin_i * np.sin(tf), np.cos(np.radians(incl))])
    return np.degrees(np.arccos(np.clip(np.sum(unit * truth, axis=1), -1.0, 1.0)))


def plateau_stand(tool, plateaus_c, samples=100):
    """
    Return (mean readings (P, 3), attitudes (P, 2) [deg], temperatures (P,)) of stand plateaus.

    The nine stand positions (``simulate_stand``, ``samples`` each) at each temperature of
    ``plateaus_c`` in turn (seed k for the k-th plateau).
    """
    means, attitudes, temperatures = [], [], []
    for seed, temperature in enumerate(plateaus_c):
        run = simulate_stand(StandRun(tool, seed=seed), samples=samples,
                             temperature_c=temperature)
        for segment in np.unique(run.segment):
            mine = run.segment == segment
            means.append(run.raw_mps2[mine].mean(axis=0))
            attitudes.append((run.inclination_deg[mine][0], run.toolface_deg[mine][0]))
            temperatures.append(float(temperature))
    return np.array(means), np.array(attitudes), np.array(temperatures)


#: Twelve stand positions (inclination, toolface, magnetic azimuth) [deg] that turn both
#: gravity and the Earth's field through every direction of the tool (seed 001 Eq. 12 needs
#: the field, not gravity, spread).
FIELD_STAND_POSITIONS_DEG = (
    (0, 0, 0), (180, 0, 90), (90, 0, 0), (90, 90, 90), (90, 180, 180), (90, 270, 270),
    (45, 45, 45), (135, 225, 315), (60, 300, 135), (120, 135, 225), (30, 200, 300),
    (150, 20, 60))


def drifting_magnetometer_tool(noise_mps2=2e-4 * sm.STANDARD_GRAVITY_MPS2, mag_noise_nT=20.0):
    """
    Return ``drifting_mount_tool`` whose magnetometer also turns and drifts on its own.

    The board tilts 0.3 deg over 28..60 deg C (both triads); the magnetometer's bracket turns
    a further 0.2 deg about its y axis and 0.1 deg about z over the same span (a turn the
    accelerometer does not see), and its z bias drifts 400 nT over it (on top of the
    preset's own drifts).  ``mag_noise_nT`` per sample.
    """
    base = drifting_mount_tool(noise_mps2)
    drift = [list(row) for row in base.magnetometer.bias_drift]
    drift[2][0] += 400.0 / 32.0
    return replace(base, mount=replace(base.mount, magnetometer_drift_deg_per_c=(
                       0.0, 0.2 / 32.0, 0.1 / 32.0)),
                   magnetometer=replace(base.magnetometer, noise_std=mag_noise_nT,
                                        bias_drift=tuple(map(tuple, drift))))


def field_plateau_stand(tool, plateaus_c, positions_deg=FIELD_STAND_POSITIONS_DEG, samples=100):
    """
    Return the stand run at each temperature of ``plateaus_c`` in turn: ``{column: (N,)}``.

    ``positions_deg`` (inclination, toolface, azimuth), ``samples`` each, seed k for the k-th
    plateau (``StandRun.sample``); the columns of ``inclino fit-stand``'s CSV:
    inclination_deg, toolface_deg, azimuth_deg, temperature_c, ax, ay, az, bx, by, bz.
    """
    runs = [StandRun(tool, seed=seed).sample(positions_deg, [samples] * len(positions_deg),
                                             temperature, 'position')
            for seed, temperature in enumerate(plateaus_c)]
    columns = {name: np.concatenate([getattr(run, name) for run in runs])
               for name in ('inclination_deg', 'toolface_deg', 'azimuth_deg', 'temperature_c')}
    for name, (source, axis) in {'ax': ('raw_mps2', 0), 'ay': ('raw_mps2', 1),
                                 'az': ('raw_mps2', 2), 'bx': ('mag_nT', 0),
                                 'by': ('mag_nT', 1), 'bz': ('mag_nT', 2)}.items():
        columns[name] = np.concatenate([getattr(run, source)[:, axis] for run in runs])
    return columns


def held_out_field_errors_deg(tool, correct, temperature_c, count=400, seed=9):
    """
    Return the angle [deg] between the corrected and the true field at ``count`` attitudes.

    As ``held_out_errors_deg`` for the magnetometer: ``tool`` read noise-free in the Earth's
    field (``sm.Field``) at attitudes uniform over the sphere and azimuths uniform, at
    ``temperature_c``; ``correct(fields (N, 3), temperatures (N,))`` gives tool-frame fields.
    """
    rng = np.random.default_rng(seed)
    incl = np.degrees(np.arccos(rng.uniform(-1.0, 1.0, count)))
    tf, az = rng.uniform(0.0, 360.0, count), rng.uniform(0.0, 360.0, count)
    quiet = replace(tool, magnetometer=replace(tool.magnetometer, noise_std=0.0))
    readings = sm.read(quiet, incl, tf, az, temperature_c=temperature_c)
    corrected = correct(readings.mag_nT, np.full(count, float(temperature_c)))
    truth = readings.earth_field_tool_nT
    cosine = np.sum(corrected * truth, axis=1) / (np.linalg.norm(corrected, axis=1)
                                                  * np.linalg.norm(truth, axis=1))
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
