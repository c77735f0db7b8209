"""
What ``inclino simulate`` records: a simulated run as a bag (and a CSV), and the run's limits.

The topics a simulated bag holds (the raw sensor, the truth, the stand
attitude, the temperature, the magnetometer), one message per sample on
each, and the checks a run's options must pass before it is simulated
(``check_run``); ``simulated_run`` simulates the run ``inclino simulate``
asks for and ``record`` writes it with its truth file.
"""

from dataclasses import replace
import json

from inclino_ros.core.mounting import to_sensor_axes
from inclino_ros.io import tables
from inclino_ros.io.bag import (
    BagWriter, IMU, MAGNETIC_FIELD, MagneticFieldSeries, magnetometer, raw_imu, TEMPERATURE,
    TemperatureSeries, VECTOR3_STAMPED, Vector3Series)
from inclino_ros.sim import sensor_model
from inclino_ros.sim.bench import (
    command_tool, DEMO_MAG_NOISE_NT, DEMO_NOISE_MPS2, HEATING_ATTITUDE_DEG, Scenario, simulate,
    simulate_heating, simulate_stand, STAND_POSITIONS_DEG, StandRun, tool_from_iscwsa)
import numpy as np

RAW_TOPIC = '/imu/data_raw'
TRUTH_TOPIC = '/truth/survey'
STAND_TOPIC = '/stand/attitude'
TEMPERATURE_TOPIC = '/imu/temperature'
MAG_TOPIC = '/imu/mag'
FRAME_ID = 'inclinometer'
#: Most samples of one run (1 000 000: 83 min of a 200 Hz bench).
MAX_SAMPLES = 1_000_000
#: Default samples: per stand position (--stand; the node's stand.samples, which a MEMS
#: at its own 2 mg needs), over the ramp at each attitude (--heating).
DEFAULT_SAMPLES = {'stand': 500, 'heating': 1601}
#: Default preset per scenario (None: the bench).
DEFAULT_SENSOR = {None: 'ideal', 'stand': 'mems', 'heating': 'mems'}


def check_run(mode, magnetic, axes, heating_attitudes, attitudes_given, samples, rate_hz,
              segments_s):
    """
    Refuse (ValueError) a run that cannot be simulated as asked.

    ``mode`` None (the bench), 'stand' or 'heating'; ``magnetic`` the bench's
    magnetometer; ``axes`` of the accelerometer; ``heating_attitudes`` the
    flat INCLINATION TOOLFACE list, ``attitudes_given`` whether the user gave
    it; ``samples`` per stand position or heating attitude; ``segments_s``
    (level, station, rotation) [s] of the bench.  A run of more than
    MAX_SAMPLES samples is refused before it is simulated.  Return the
    (inclination, toolface) pairs of the heating attitudes.
    """
    if mode is not None and magnetic:
        raise ValueError('--magnetic goes with the bench scenario, not --stand or --heating')
    if mode is not None and axes != 3:
        raise ValueError('--stand and --heating simulate a three-axis sensor')
    if attitudes_given and mode != 'heating':
        raise ValueError('--heating-attitudes goes with --heating')
    if len(heating_attitudes) % 2:
        raise ValueError('--heating-attitudes takes INCLINATION TOOLFACE pairs, '
                         f'not {len(heating_attitudes)} numbers')
    pairs = tuple(zip(heating_attitudes[::2], heating_attitudes[1::2]))
    if mode is None:
        level_s, station_s, rotation_s = segments_s
        total = rate_hz * (level_s + station_s * len(Scenario().stations_deg)
                           + (rotation_s if magnetic else 0.0))
    else:
        total = samples * (len(STAND_POSITIONS_DEG) if mode == 'stand' else len(pairs))
    if total > MAX_SAMPLES:
        raise ValueError(f'{total:.0f} samples asked for, at most {MAX_SAMPLES} are '
                         'simulated: shorten the segments or lower --rate-hz / --samples')
    return pairs


def describe(sensor, tool):
    """Return one line naming the preset, the mount and the noise of ``tool``."""
    mount = tool.mount
    noise = np.max(tool.accelerometer.noise_std)
    return (f'{sensor} sensor ({tool.accelerometer_axes}-axis accelerometer), mount '
            f'gamma {mount.gamma_deg:g} beta {mount.beta_deg:g} roll {mount.roll_deg:g} deg, '
            f'noise {noise:g} m/s^2')


def write_bag(path, storage, sim, noise_std_mps2, mode, magnetic=None):
    """
    Write the samples of ``sim`` to a new bag; return ``{role: topic}``.

    ``magnetic``: None, or the MagneticFieldSeries at the same stamps (the
    true azimuth then goes to the truth's z); ``mode`` 'stand' or 'heating'
    adds the temperature topic, 'stand' the stand attitude.
    """
    n = sim.stamps_ns.size
    frame_ids = np.full(n, FRAME_ID)
    azimuth_deg = np.full(n, np.nan) if magnetic is None else sim.azimuth_deg
    series = {
        RAW_TOPIC: raw_imu(sim.stamps_ns, FRAME_ID, sim.raw_mps2, noise_std_mps2),
        TRUTH_TOPIC: Vector3Series(sim.stamps_ns, frame_ids, np.stack(
            [sim.inclination_deg, sim.toolface_deg, azimuth_deg], axis=1))}
    topics = {'raw': RAW_TOPIC, 'truth': TRUTH_TOPIC}
    if magnetic is not None:
        series[MAG_TOPIC] = magnetic
        topics['magnetometer'] = MAG_TOPIC
    if mode == 'stand':
        series[STAND_TOPIC] = series[TRUTH_TOPIC]
        topics['stand_attitude'] = STAND_TOPIC
    if mode is not None:
        series[TEMPERATURE_TOPIC] = TemperatureSeries(sim.stamps_ns, frame_ids,
                                                      sim.temperature_c, np.zeros(n))
        topics['temperature'] = TEMPERATURE_TOPIC
    msgtypes = {Vector3Series: VECTOR3_STAMPED, TemperatureSeries: TEMPERATURE,
                MagneticFieldSeries: MAGNETIC_FIELD}
    with BagWriter(path, storage) as bag:
        for topic, values in series.items():
            bag.add_topic(topic, msgtypes.get(type(values), IMU))
        bag.write_series(series)
    return topics


def write_csv(path, sim, temperature, attitude=False):
    """Write one row per sample: stamp, true attitude, [temperature, attitude,] raw reading."""
    columns = {'stamp_ns': sim.stamps_ns, 'inclination_deg': sim.inclination_deg,
               'toolface_deg': sim.toolface_deg}
    if temperature:
        columns['temperature_c'] = sim.temperature_c
    if attitude:
        columns['attitude'] = sim.segment
    columns.update(zip(('ax', 'ay', 'az'), sim.raw_mps2.T))
    tables.write_csv(path, columns)


def tool_of(args, sensor):
    """Return the ``sensor_model.Tool`` of ``inclino simulate``'s options (``command_tool``)."""
    return command_tool(sensor, (args.gamma_deg, args.beta_deg, args.roll_deg,
                                 args.magnetometer_deg), args.noise_std_mps2,
                        getattr(args, 'mag_noise_nT', None), (DEMO_NOISE_MPS2, DEMO_MAG_NOISE_NT),
                        ('--noise-mps2', '--mag-noise-nT'), args.axes)


def bench_scenario(args, tool):
    """Return the bench Scenario of ``inclino simulate``'s options; ValueError if impossible."""
    if not args.reference_total_nT > 0.0 or args.rotation_s < 0.0:
        raise ValueError('--reference-total-nT must be positive, --rotation-s not negative')
    return Scenario(
        tool=tool, azimuth_deg=tuple(args.azimuth_deg),
        field=sensor_model.Field(args.reference_total_nT, args.reference_dip_deg),
        interference_tool_nT=tool_from_iscwsa(args.interference_nT),
        rotation_s=args.rotation_s if args.magnetic else 0.0,
        rotation_turns=args.rotation_turns,
        rotation_attitude_deg=tuple(args.rotation_attitude_deg), rate_hz=args.rate_hz,
        level_s=args.level_s, station_s=args.station_s, seed=args.seed)


def simulated_run(args):
    """
    Return (preset, tool, the simulated run, what it is); ValueError if impossible.

    ``args``: the options of ``inclino simulate`` (its argparse namespace).
    The run's options are checked first (``check_run``).
    """
    sensor = args.sensor or DEFAULT_SENSOR[args.mode]
    samples = DEFAULT_SAMPLES.get(args.mode) if args.samples is None else args.samples
    pairs = check_run(args.mode, args.magnetic, args.axes,
                      tuple(args.heating_attitudes or HEATING_ATTITUDE_DEG),
                      args.heating_attitudes is not None, samples, args.rate_hz,
                      (args.level_s, args.station_s, args.rotation_s))
    tool = tool_of(args, sensor)
    if args.mode is None:
        sim = simulate(bench_scenario(args, tool))
    else:
        stand_run = StandRun(tool=tool, rate_hz=args.rate_hz, seed=args.seed)
        sim = (simulate_stand(stand_run, samples=samples) if args.mode == 'stand' else
               simulate_heating(stand_run, pairs, samples=samples))
    what = describe(sensor, tool)
    if args.mode is not None:
        what = f'{args.mode} run of a {what}'
    if args.mode == 'heating':
        what += '; attitudes ' + ', '.join(
            f'{segment["inclination_deg"]:g}/{segment["toolface_deg"]:g}'
            for segment in sim.truth['segments']) + ' deg'
    return sensor, tool, sim, what


def record(args, outputs, run, mounting):
    """
    Write the simulated ``run`` (``simulated_run``) as ``inclino simulate`` does; return topics.

    OUT (the bag), OUT.truth.json and the CSV (``args.csv``) go to their
    temporaries in ``outputs`` (``io.files.Outputs``).  ``mounting``: the
    pipeline Settings whose axes maps turn the tool-frame readings into the
    sensor axes the bag holds (sensor = M^-1 tool).  Returns
    (``{role: topic}``, what the magnetometer adds to the run's description).
    """
    sensor, tool, sim, _ = run
    magnetic, what = None, ''
    if args.magnetic:
        magnetic = magnetometer(sim.stamps_ns, FRAME_ID,
                                to_sensor_axes(sim.mag_nT, mounting.magnetometer_matrix),
                                np.max(tool.magnetometer.noise_std))
        what = (f'; magnetometer on {MAG_TOPIC}, interference '
                f'{", ".join(f"{v:g}" for v in args.interference_nT)} nT (ISCWSA x, y, z)')
    sim = replace(sim, raw_mps2=to_sensor_axes(sim.raw_mps2, mounting.accelerometer_matrix))
    topics = write_bag(outputs.path(args.out), args.storage, sim,
                       np.asarray(tool.accelerometer.noise_std), args.mode, magnetic)
    extra = {'sensor': sensor, 'bag': args.out, 'storage': args.storage, 'topics': topics,
             'frame_id': FRAME_ID, 'mounting': {
                 'accelerometer_axes_map': args.accelerometer_axes_map,
                 'magnetometer_axes_map': args.magnetometer_axes_map}}
    if args.magnetic:
        extra['magnetic'] = {
            'topic': MAG_TOPIC, 'frame': 'the magnetometer triad (tool frame turned by the '
                                         'mount), tesla on the topic',
            'pairing': 'one message per accelerometer sample, same stamp'}
    with open(outputs.path(f'{args.out}.truth.json'), 'x') as stream:
        json.dump(dict(sim.truth, **extra), stream, indent=2)
        stream.write('\n')
    if args.csv:
        write_csv(outputs.path(args.csv), sim, args.mode is not None, args.mode == 'heating')
    return topics, what
