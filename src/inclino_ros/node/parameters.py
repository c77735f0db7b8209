"""
The node's parameters: one table of names, defaults, ranges and meanings.

Defaults here are the same as ``config/inclinometer.yaml``; doc/node-interfaces.md's
parameter table is made from this list (``python -m inclino_ros.node.parameters``).
No ROS types here: the offline commands take their defaults and ranges from
this table without importing rcl_interfaces; the node turns each entry into
its ParameterDescriptor (``inclinometer_node.descriptor``).
"""

from dataclasses import dataclass
import math

from inclino_ros.calibration.history import DEFAULT_KEEP
from inclino_ros.calibration.plausibility import EARTH_FIELD_NT
from inclino_ros.core.averaging import MIN_OUTPUT_RATE_HZ
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.core.stillness import StillLimits

GRAVITY_MPS2 = STANDARD_GRAVITY_MPS2
#: Longest frame_id [characters] the node stamps on its outputs.
MAX_FRAME_ID = 256


@dataclass(frozen=True)
class Parameter:
    """One declared parameter."""

    name: str
    default: object
    description: str
    low: float = None
    high: float = None
    read_only: bool = True
    choices: tuple = None


PARAMETERS = (
    Parameter('calibration_file', '~/.ros/inclino_ros/calibration.json',
              'Calibration file: loaded at start when present (a corrupt file stops the '
              'node), written atomically by the calibration services.'),
    Parameter('sensor_id', '',
              'The sensor this node reads (e.g. its serial number): written into the '
              'calibration file; a file of another sensor stops the node.'),
    Parameter('field_mode', False,
              'true: the calibration is locked for the job: every service that would change it '
              'and every parameter change is refused ("the calibration is locked (field '
              'mode)"); correction, outputs and read-only services go on. Read-only: set at '
              'start only, so it cannot be switched off remotely.'),
    Parameter('calibration.max_age_days', 180.0,
              'Diagnostics WARN when a calibration stage is older than this [days].',
              0.01, 36500.0, read_only=False),
    Parameter('calibration.history_keep', DEFAULT_KEEP,
              'Versions of the calibration file kept in its history (FILE.history): at each '
              'write the older ones are removed (and logged); never the newest, nor the one '
              'in use.', 1, 1_000_000, read_only=False),
    Parameter('accelerometer_axes', 3,
              'Accelerometer axes: 3, or 2 for a two-axis sensor (z completed from '
              'gravity_mps2, tool upright).', 2, 3),
    Parameter('accelerometer_axes_map', '+X+Y+Z',
              'Accelerometer mounting: for tool x, y, z in turn the sensor axis along it, '
              'e.g. -Y+X+Z (tool x = -sensor y), or rpy:ROLL,PITCH,YAW [deg] of the sensor '
              'in the tool frame; applied before any correction.'),
    Parameter('magnetometer_axes_map', '+X+Y+Z',
              'Magnetometer mounting, as accelerometer_axes_map (tool axes from imu/mag axes).'),
    Parameter('allow_left_handed_axes', False,
              'Accept an axes map of determinant -1 (only for a sensor whose own axes are '
              'left-handed; otherwise such a map is a typo and the node refuses to start).'),
    Parameter('gravity_mps2', GRAVITY_MPS2,
              'Local gravity [m/s^2]: v_g for two-axis sensors and the expected G-total.',
              9.7, 9.9),
    Parameter('accelerometer_range_mps2', 2.0 * GRAVITY_MPS2,
              'Sensor full scale [m/s^2]: a component at or beyond it is saturated and '
              'the sample dropped.', 1.0, 2000.0),
    Parameter('accelerometer_noise_std_mps2', 0.01,
              'Per-sample accelerometer noise, 1 sigma per axis [m/s^2]: sets the 1 sigma of '
              'every angle, the imu/data covariances and the per-sample QC limits.',
              1e-6, 10.0),
    Parameter('magnetometer_noise_std_nT', 100.0,
              'Per-sample magnetometer noise, 1 sigma per axis [nT]: enters the 1 sigma of '
              'the azimuth and the per-sample QC limits.', 1e-3, 10000.0),
    Parameter('accelerometer_bias_instability_mps2', 0.0,
              "Accelerometer bias instability B (IEEE Std 952, the datasheet's flicker floor) "
              "[m/s^2]: adds (1.6 B)^2 to the variance of every capture's and averaged "
              "window's mean (its flicker, which the capture's own noise cannot show). "
              '0: none.', 0.0, 10.0),
    Parameter('magnetometer_bias_instability_nT', 0.0,
              'Magnetometer bias instability B (IEEE Std 952) [nT]: as '
              'accelerometer_bias_instability_mps2, for the azimuth. 0: none.', 0.0, 10000.0),
    Parameter('toolface_convention', 'seed000',
              'Gravity toolface: seed000 (atan2(a_y, a_x), seed 000 Eq. 16) or '
              'iscwsa_highside (ISCWSA high-side, = seed000 + 90 deg).',
              choices=('seed000', 'iscwsa_highside')),
    Parameter('toolface_max_std_deg', 5.0,
              'A toolface whose 1 sigma (sensor noise and calibration, over sin I) exceeds '
              'this [deg] is published as NaN.', 0.01, 180.0),
    Parameter('g_total_tolerance_mps2', 3.0,
              'A three-axis sample whose corrected G-total is further than this [m/s^2] from '
              'gravity_mps2 is not gravity: dropped and counted (dynamic).', 0.01, 9.0),
    Parameter('two_axis_max_inclination_deg', 60.0,
              'Two-axis sensors: a sample steeper than this [deg] is dropped and counted '
              '(two_axis_range): beyond 90 deg it would read folded back (I as 180 - I).',
              1.0, 89.0),
    Parameter('frame_id', '',
              'frame_id of the corrected outputs (the ideal tool frame, at most 256 '
              'characters); empty: the input frame_id.'),
    Parameter('imu_queue_depth', 2000,
              'Depth of the sensor-data (best-effort) subscription queues on imu/data_raw and '
              'imu/mag: what waits while the node is held up (0.4 s at 5 kHz: another process '
              'on the CPU) before samples are lost.', 1, 10000),
    Parameter('input_batch_period_s', 0.0,
              'After a sample arrives, wait this long [s] for more before correcting what is '
              'queued as one batch (fewer, larger batches; the added latency, at most). 0: at '
              'once; every batch is still all that waits, so batches grow by themselves when '
              'the node is busy. imu_queue_depth must hold the samples of one period and one '
              'batch.', 0.0, 0.1),
    Parameter('output.average_samples', 1,
              'Publish the mean of every N accepted samples (a station: the angles of the mean '
              'reading, the standard error in the covariances) instead of every sample; '
              '1: every sample.', 1, 1000000),
    Parameter('output.rate_hz', 0.0,
              'Publish the mean of the accepted samples of each 1/rate of stamp time instead of '
              'every sample (not with output.average_samples); 0: every sample, else at least '
              '0.01 (a window of at most 100 s).', 0.0, 10000.0),
    Parameter('diagnostics_period_s', 1.0,
              'Period of the /diagnostics report [s], in wall time (under use_sim_time too: a '
              'ROS time standing still is reported).', 0.1, 60.0),
    Parameter('still.max_drift_deg_per_s', 0.02,
              'Every capture: a drift of its mean faster than this [deg/s] and significant '
              'against its own noise (chance below 1e-6 for a still tool) is motion, and '
              'refused.', 1e-4, 10.0, read_only=False),
    Parameter('still.max_motion_deg', StillLimits.max_motion_deg,
              'Every capture: a motion significant against its own noise (drift or unsteady '
              'means) that puts a part of the capture further than this [deg] from its mean '
              'is refused; a smaller one, or one the capture cannot tell from its noise, is '
              'added to the stated 1 sigma of its mean (the fitted drift at its ends).',
              1e-5, 10.0, read_only=False),
    Parameter('level_capture.samples', 500,
              'Samples a level capture collects after the service call.', 6, 1000000,
              read_only=False),
    Parameter('level_capture.timeout_s', 30.0,
              'Seconds a level capture waits for its samples before refusing.',
              0.1, 3600.0, read_only=False),
    Parameter('level_capture.max_sem_deg', 0.01,
              'Largest standard error [deg] of the mean axis tilts (noise / sqrt(samples)): '
              'beyond it the capture is refused as too noisy, with the samples needed.',
              1e-5, 10.0, read_only=False),
    Parameter('level_capture.max_tilt_deg', 5.0,
              'Largest false tilt theta [deg] accepted as an installation error on '
              'a level bench.', 0.0, 45.0, read_only=False),
    Parameter('level_capture.g_total_tolerance_mps2', 0.3,
              'Largest deviation [m/s^2] of the captured G-total from gravity_mps2 '
              '(three-axis sensors).', 1e-3, 5.0, read_only=False),
    Parameter('stand.inclination_deg', 0.0,
              'Stand attitude of the next ~/capture_position: inclination [deg].', 0.0, 180.0,
              read_only=False),
    Parameter('stand.toolface_deg', 0.0,
              'Stand attitude of the next ~/capture_position: seed000 toolface [deg].',
              0.0, 360.0, read_only=False),
    Parameter('stand.azimuth_deg', 0.0,
              'Stand attitude of the next ~/capture_position: magnetic azimuth of the hole '
              'direction [deg] (as survey.z); used with magnetic.reference_* for the '
              'magnetometer.', 0.0, 360.0, read_only=False),
    Parameter('stand.samples', 500,
              'Samples a stand position capture collects after the service call.',
              6, 1000000, read_only=False),
    Parameter('stand.timeout_s', 30.0,
              'Seconds a stand position capture waits for its samples before refusing.',
              0.1, 3600.0, read_only=False),
    Parameter('stand.max_sem_deg', 0.01,
              'Largest standard error [deg] of the mean direction of a stand position.',
              1e-5, 10.0, read_only=False),
    Parameter('stand.max_rms_deg', 0.05,
              'Largest inclination residual RMS [deg] of a stand fit over its own positions '
              '(of a sphere fit: its RMS |G| - g as an angle): beyond it the fit is refused.',
              1e-4, 10.0, read_only=False),
    Parameter('stand.attitude_sigma_deg', 0.0,
              "The positions' attitudes are known only to this [deg, 1 sigma per tilt axis]: a "
              'tool set on its faces by hand, not a stand. Each reading across gravity, which a '
              "tilt moves, is weighed by it and its mean's noise; along gravity a tilt moves it "
              'only to second order (generalised least squares). 0: a stand that sets its '
              'attitudes (unweighted). Not with positions at two or more temperature plateaus '
              '(refused).', 0.0, 10.0, read_only=False),
    Parameter('stand.max_field_rms_deg', 0.1,
              'Largest RMS angle [deg] between the corrected and the expected field over the '
              'stand positions: beyond it the fit is refused.', 1e-4, 10.0, read_only=False),
    Parameter('stations_file', '~/.ros/inclino_ros/stations.json',
              'Survey stations of ~/take_survey for ~/solve_msa: loaded at start (a corrupt '
              'file stops the node), written atomically.'),
    Parameter('magnetic.reference_total_nT', 0.0,
              'Reference field total [nT] (site model or IFR), an Earth field (20000 .. '
              '70000); 0: unknown, azimuth QC off and ~/solve_msa refused.', 0.0, 100000.0,
              read_only=False),
    Parameter('magnetic.reference_dip_deg', 0.0,
              'Reference dip [deg], positive down; short of +-90 (a vertical field has no '
              'horizontal part to point an azimuth or fit an MSA to).', -89.999, 89.999,
              read_only=False),
    Parameter('magnetic.reference_total_std_nT', 138.0,
              '1 sigma of the reference total field itself [nT] (WMM 2025: 138; an IFR model '
              'about half): enters the 1 sigma of the MSA interference and of every azimuth.',
              0.0, 10000.0, read_only=False),
    Parameter('magnetic.reference_dip_std_deg', 0.2,
              '1 sigma of the reference dip itself [deg] (WMM 2025: 0.20).', 0.0, 10.0,
              read_only=False),
    Parameter('magnetic.declination_deg', 0.0,
              'Declination [deg] added to the magnetic azimuth for the azimuth topic.',
              -180.0, 180.0, read_only=False),
    Parameter('magnetic.b_total_tolerance_nT', 300.0,
              'QC: largest deviation [nT] of B-total from the reference.', 1.0, 10000.0,
              read_only=False),
    Parameter('magnetic.dip_tolerance_deg', 0.25,
              'QC: largest deviation [deg] of the dip from the reference.', 0.01, 10.0,
              read_only=False),
    Parameter('magnetic.g_total_tolerance_mps2', 0.019,
              'QC: largest deviation [m/s^2] of G-total from gravity_mps2 (3 sigma of the '
              'ISCWSA MWD accelerometer terms); single samples: widened by 3 sigma of their '
              'noise, like the B-total and dip limits.', 1e-4, 5.0, read_only=False),
    Parameter('magnetic.azimuth_max_std_deg', 1.0,
              'An azimuth whose 1 sigma (sensor noise, calibration, MSA interference and its '
              'reference field) exceeds this [deg] is published as NaN.', 0.01, 180.0,
              read_only=False),
    Parameter('magnetic.interference_max_age_days', 3.0,
              'Diagnostics WARN when the MSA interference is older than this [days]: the drill '
              'string magnetisation changes with every trip.', 0.01, 3650.0, read_only=False),
    Parameter('magnetic.max_pairing_s', 0.05,
              'Largest stamp difference [s] between an accelerometer sample and the '
              'imu/mag reading paired with it; beyond it the azimuth is NaN.', 1e-4, 10.0,
              read_only=False),
    Parameter('rotation.duration_s', 10.0,
              'Seconds ~/capture_rotation records while the tool turns.', 1.0, 600.0,
              read_only=False),
    Parameter('survey.samples', 500,
              'Samples ~/take_survey averages into one station.', 6, 1000000, read_only=False),
    Parameter('survey.max_sem_deg', 0.01,
              'Largest standard error [deg] of the mean accelerometer direction of a station.',
              1e-5, 10.0, read_only=False),
    Parameter('survey.timeout_s', 30.0,
              'Seconds ~/take_survey waits for its samples before refusing.', 0.1, 3600.0,
              read_only=False),
    Parameter('msa.method', 'improved',
              'Multi-station analysis of ~/solve_msa: improved (seed 002), classic (Brooks '
              'eps x, y, z) or axial (eps z only).', read_only=False,
              choices=('improved', 'classic', 'axial')),
    Parameter('temperature.max_age_s', 5.0,
              'Age [s] beyond which the latest imu/temperature is reported stale (it is '
              'still used).', 0.1, 3600.0, read_only=False),
    Parameter('temperature.at_reference', False,
              'A model with a temperature stage and no temperature on imu/temperature yet: '
              'false refuses (no output published, diagnostics ERROR, logged); true '
              'compensates at the reference temperature with every 1 sigma widened by the '
              'drift over the fitted range (diagnostics WARN, logged): the '
              '--at-reference-temperature of inclino process and survey.', read_only=False),
    Parameter('temperature.max_stage_difference_c', 2.0,
              'Without a temperature stage, stages whose readings stood for temperatures '
              'further apart than this [deg C] are refused (their drift is not corrected).',
              0.01, 200.0, read_only=False),
)


def refusal(name, value):
    """
    Return why ``value`` is not allowed for parameter ``name``, or None if it is.

    What the declared type and range (checked by rclpy) do not say: a choice
    among fixed ones, a finite number, a file name that is not empty, a
    bounded frame_id, a reference field that is unknown (0) or an Earth field.
    """
    if isinstance(value, float) and not math.isfinite(value):
        return f'{name} must be a finite number, not {value!r}'
    for parameter in PARAMETERS:
        if parameter.name == name and parameter.choices and value not in parameter.choices:
            return f'{name} must be one of {", ".join(parameter.choices)}, not {value!r}'
    if name in ('calibration_file', 'stations_file') and not str(value).strip():
        return f'{name} must name a file'
    if name == 'frame_id' and len(value) > MAX_FRAME_ID:
        return f'frame_id must be at most {MAX_FRAME_ID} characters, not {len(value)}'
    if name == 'output.rate_hz' and 0.0 < value < MIN_OUTPUT_RATE_HZ:
        return (f'output.rate_hz must be 0 (every sample) or at least {MIN_OUTPUT_RATE_HZ:g} Hz '
                f'(a window of at most {1.0 / MIN_OUTPUT_RATE_HZ:g} s: the samples of an open '
                f'window are held), not {value!r}')
    if name == 'magnetic.reference_total_nT' and value != 0.0 \
            and not EARTH_FIELD_NT[0] <= value <= EARTH_FIELD_NT[1]:
        return (f'magnetic.reference_total_nT must be 0 (unknown) or an Earth field, '
                f'{EARTH_FIELD_NT[0]:g} .. {EARTH_FIELD_NT[1]:g} nT, not {value!r}')
    return None


def markdown_table():
    """Return the parameter table of doc/node-interfaces.md."""
    rows = ['| parameter | default | range | live | meaning |',
            '|---|---|---|---|---|']
    for p in PARAMETERS:
        span = '' if p.low is None else f'{p.low} .. {p.high}'
        live = 'no' if p.read_only else 'yes'
        default = repr(p.default) if isinstance(p.default, str) else p.default
        rows.append(f'| `{p.name}` | `{default}` | {span} | {live} | {p.description} |')
    return '\n'.join(rows)


def parse_value(text, like):
    """
    Return ``text`` as the type of ``like`` (bool, int, float or str); ValueError if not.

    What ``inclino param set`` sends: the node checks it against the table.
    """
    if isinstance(like, bool):
        if text.lower() not in ('true', 'false'):
            raise ValueError(f'{text!r} is not true or false')
        return text.lower() == 'true'
    for kind, name in ((int, 'an integer'), (float, 'a number')):
        if isinstance(like, kind):
            try:
                value = kind(text)
            except ValueError:
                raise ValueError(f'{text!r} is not {name}') from None
            if kind is int and not -2 ** 63 <= value < 2 ** 63:
                raise ValueError(f'{text} is beyond a 64-bit integer (what a ROS integer '
                                 'parameter holds)')
            return value
    if isinstance(like, str):
        return text
    raise ValueError(f'cannot set a {type(like).__name__} parameter from the command line')


def format_value(value):
    """Return a parameter value as the YAML of the parameter file writes it (``inclino param``)."""
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return repr(value)
    return str(value)


if __name__ == '__main__':
    print(markdown_table())
