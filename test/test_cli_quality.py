"""
Issue 9 on the command line: non-gravity runs, per-sample QC, temperature drift, sensor identity.

Readings come from the physical sensor model (``sim.sensor_model``); each test names the closed
form behind its tolerance.
"""

import csv

from inclino_ros.calibration.model import CalibrationModel, load_model, save_model
from inclino_ros.core.attitude import inclination
from inclino_ros.io import bag
from inclino_ros.sim import sensor_model
import numpy as np
import pytest
from test_msa_cli import quiet

G = sensor_model.STANDARD_GRAVITY_MPS2
MG = sensor_model.MILLI_G_MPS2
RATE_HZ = 100.0
#: A MEMS-class accelerometer drifting 0.8 mg/degC in bias (the issue's ADXL345-class figure)
#: and 200 ppm/degC in scale, per axis with different signs; no other error.
DRIFTING = sensor_model.Tool(accelerometer=sensor_model.Triad(
    bias_drift=((0.8 * MG,), (-0.8 * MG,), (0.6 * MG,)),
    scale_drift=((2e-4,), (-1.5e-4,), (2.2e-4,))))
#: Heating runs: 20 -> 100 degC every 10 degC (seed 001) and 25 degC, at two attitudes where
#: every axis reads differently (55 deg / 45 deg and turned over, 125 deg / 225 deg).
HEATING_C = np.r_[20.0, 25.0, np.arange(30.0, 101.0, 10.0)]
ATTITUDES_DEG = ((55.0, 45.0), (125.0, 225.0))


def summary_values(stdout):
    """Return the ``name: value`` lines of a process summary as a dict of strings."""
    return dict(line.split(': ', 1) for line in stdout.splitlines() if ': ' in line)


def write_bag(path, accel_mps2, mag_nT=None, temperature_c=None):
    """Write /imu/data_raw (and /imu/mag, /imu/temperature, same stamps) at 100 Hz."""
    stamps_ns = (np.arange(len(accel_mps2)) * 1e9 / RATE_HZ).astype(np.int64) + 10 ** 9
    series = {'/imu/data_raw': (bag.IMU, bag.raw_imu(stamps_ns, 'imu', accel_mps2, 0.01))}
    if mag_nT is not None:
        series['/imu/mag'] = (bag.MAGNETIC_FIELD,
                              bag.magnetometer(stamps_ns, 'imu', mag_nT, 100.0))
    if temperature_c is not None:
        series['/imu/temperature'] = (bag.TEMPERATURE, bag.TemperatureSeries(
            stamps_ns, bag.frame_id_array('imu', stamps_ns.size), np.asarray(temperature_c),
            np.zeros(stamps_ns.size)))
    with bag.BagWriter(str(path), 'mcap') as writer:
        for topic, (kind, data) in series.items():
            writer.add_topic(topic, kind)
            writer.write_series({topic: data})


def write_csv(path, columns):
    """Write ``{name: values}`` as a CSV file."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        writer.writerows(np.column_stack(list(columns.values())).tolist())


def test_a_gravity_removed_stream_is_refused_loudly(tmp_path):
    """
    1040 samples of |a| ~ 0.6 m/s^2 (gravity removed by the driver): no inclination, exit 1.

    Formerly 1040 inclinations between 3.8 and 178.6 deg and exit 0.
    """
    rng = np.random.default_rng(1)
    write_bag(tmp_path / 'in', rng.normal(0.0, 0.35, (1040, 3)))
    calibration = tmp_path / 'cal.json'
    save_model(calibration, CalibrationModel(accelerometer_axes=3))
    code, out, err = quiet(['process', tmp_path / 'in', tmp_path / 'out', '--calibration',
                            calibration])
    assert code == 1
    assert 'ERROR: 1040 of 1040 samples dropped, most (1040) as dynamic' in err
    assert summary_values(out)['dropped_dynamic'] == '1040'
    assert not (tmp_path / 'out').exists()   # no empty output bag left behind


def test_drilling_vibration_passes(tmp_path):
    """
    A tool at 30 deg shaken by 1 m/s^2 (0.1 g) per axis: |f| moves by ~N(0, 1 m/s^2).

    The 3 m/s^2 limit is 3 sigma of that: 0.27 % dropped expected; at most 1 % asserted.
    """
    rng = np.random.default_rng(2)
    still = sensor_model.read(sensor_model.IDEAL, np.full(5000, 30.0), 70.0).accel_mps2
    write_bag(tmp_path / 'in', still + rng.normal(0.0, 1.0, still.shape))
    save_model(tmp_path / 'cal.json', CalibrationModel(accelerometer_axes=3))
    code, out, err = quiet(['process', tmp_path / 'in', tmp_path / 'out', '--calibration',
                            tmp_path / 'cal.json'])
    assert code == 0, err
    assert int(summary_values(out)['dropped_dynamic']) <= 50


def test_per_sample_qc_scales_with_the_sample_noise(tmp_path):
    """
    Still samples at the default noise (0.01 m/s^2, 100 nT per axis), exact reference.

    Station limits applied to single samples failed 5.6-5.9 % of them on G-total alone
    (0.019 m/s^2 is 1.9 sigma of one sample).  Widened by 3 sigma of the sample noise the
    G-total, B-total and dip tests fail 4e-4, 2e-5 and 3e-4 of them: at most 0.3 % asserted.
    """
    tool = sensor_model.Tool(accelerometer=sensor_model.Triad(noise_std=0.01),
                             magnetometer=sensor_model.Triad(noise_std=100.0))
    readings = sensor_model.read(tool, np.full(4000, 60.0), 20.0, 30.0, rng=3)
    write_bag(tmp_path / 'in', readings.accel_mps2, readings.mag_nT)
    save_model(tmp_path / 'cal.json', CalibrationModel(accelerometer_axes=3))
    code, out, err = quiet(['process', tmp_path / 'in', tmp_path / 'out', '--calibration',
                            tmp_path / 'cal.json', '--mag-topic', '/imu/mag',
                            '--reference-total-nT', '50000', '--reference-dip-deg', '60'])
    assert code == 0, err
    values = summary_values(out)
    assert values['mag_paired'] == '4000'
    assert int(values['qc_failed']) <= 12, out


def heating_table(tool, attitudes, samples_per_step=1, seed=5):
    """Return {temperature_c, ax, ay, az, attitude} of heating runs at ``attitudes``."""
    rows = [(t, k) for k in range(len(attitudes)) for t in HEATING_C
            for _ in range(samples_per_step)]
    temperature_c = np.array([t for t, _ in rows])
    label = np.array([k for _, k in rows], dtype=float)
    incl = np.array([attitudes[int(k)][0] for k in label])
    tf = np.array([attitudes[int(k)][1] for k in label])
    accel = sensor_model.read(tool, incl, tf, temperature_c=temperature_c, rng=seed).accel_mps2
    return {'temperature_c': temperature_c, 'ax': accel[:, 0], 'ay': accel[:, 1],
            'az': accel[:, 2], 'attitude': label}


def inclination_error_deg(model, tool, inclination_deg, toolface_deg, temperature_c):
    """Return the corrected inclination error [deg] of ``tool`` at attitudes and temperatures."""
    readings = sensor_model.read(tool, inclination_deg, toolface_deg, temperature_c=temperature_c)
    corrected = model.apply(readings.accel_mps2, readings.temperature_c)
    return np.degrees(inclination(corrected)) - readings.inclination_deg


def random_errors_deg(model, tool, seed, count=300):
    """Return the inclination errors at random attitudes and temperatures 20..100 degC."""
    random = np.random.default_rng(seed)
    return inclination_error_deg(model, tool, random.uniform(0.0, 180.0, count),
                                 random.uniform(0.0, 360.0, count),
                                 random.uniform(20.0, 100.0, count))


def test_bias_drift_is_fitted_from_two_attitudes(tmp_path):
    """
    0.8 mg/degC of bias drift: a one-attitude fit cannot see it, two attitudes fit it.

    One attitude (seed 001): K_T absorbs the bias drift exactly there (residual ~1e-15) and
    leaves degrees at 100 degC elsewhere.  Two attitudes: noise-free, bias and scale
    polynomials of order 2 hold the linear drifts exactly, so the error at a third attitude
    is round-off: 1e-6 deg asserted.
    """
    table = heating_table(DRIFTING, ATTITUDES_DEG)
    one = {name: values[table['attitude'] == 0] for name, values in table.items()}
    del one['attitude']
    write_csv(tmp_path / 'one.csv', one)
    code, out, err = quiet(['fit-temperature', tmp_path / 'one.csv', '--calibration',
                            tmp_path / 'one.json'])
    assert code == 0, err
    assert 'ONE attitude' in out and 'bias drift cannot be seen' in out
    one_model = load_model(tmp_path / 'one.json')
    assert max(one_model.temperature.rms_residual_mps2) < 1e-12
    third = (np.full(9, 10.0), np.linspace(0.0, 320.0, 9), np.full(9, 100.0))
    assert np.abs(inclination_error_deg(one_model, DRIFTING, *third)).max() > 1.0

    write_csv(tmp_path / 'two.csv', table)
    code, out, err = quiet(['fit-temperature', tmp_path / 'two.csv', '--calibration',
                            tmp_path / 'two.json'])
    assert code == 0, err
    assert '2 attitudes heated: bias and scale drift' in out
    model = load_model(tmp_path / 'two.json')
    assert model.temperature.attitudes == 2
    assert np.abs(inclination_error_deg(model, DRIFTING, *third)).max() < 1e-6
    assert np.abs(random_errors_deg(model, DRIFTING, 6)).max() < 1e-6


def test_a_stand_at_35_c_and_a_later_heating_fit_agree(tmp_path):
    """
    The stand captured at 35 degC records it; the later heating fit compensates to 35 degC.

    A MEMS sensor (K, bias, drifts; sensor_model.MEMS without noise): the stand's K and b
    absorb the 35 degC state, a stage compensating to 25 degC would feed them readings of
    another temperature (0.17 deg off before); compensating to 35 degC it is exact to the
    polynomials' round-off: 1e-4 deg asserted over 20-100 degC.
    """
    tool = sensor_model.Tool(accelerometer=sensor_model.Triad(
        **{**sensor_model.MEMS.accelerometer.__dict__, 'noise_std': 0.0}))
    positions = ((0.0, 0.0), (180.0, 0.0), (90.0, 0.0), (90.0, 90.0), (90.0, 180.0),
                 (90.0, 270.0), (45.0, 45.0), (135.0, 225.0), (60.0, 300.0))
    incl, tf = np.array(positions).T
    stand = sensor_model.read(tool, incl, tf, temperature_c=35.0).accel_mps2
    write_csv(tmp_path / 'stand.csv', {'inclination_deg': incl, 'toolface_deg': tf,
                                       'ax': stand[:, 0], 'ay': stand[:, 1],
                                       'az': stand[:, 2], 'temperature_c': np.full(9, 35.0)})
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-stand', tmp_path / 'stand.csv', '--calibration', calibration])
    assert code == 0, err
    assert load_model(calibration).stand.temperature_c == 35.0
    write_csv(tmp_path / 'heating.csv', heating_table(tool, ATTITUDES_DEG))
    code, out, err = quiet(['fit-temperature', tmp_path / 'heating.csv', '--calibration',
                            calibration])
    assert code == 0, err
    assert 'compensating to 35 C' in out
    model = load_model(calibration)
    assert np.abs(random_errors_deg(model, tool, 7)).max() < 1e-4


def test_magnetometer_temperature_is_fitted_the_same_way(tmp_path):
    """
    The magnetometer heated at two attitudes (--triad magnetometer): its drift removed.

    Bias 8 nT/degC and scale 300 ppm/degC per axis move the field by ~700 nT at 100 degC;
    compensated, noise-free, the reading equals the 25 degC one to round-off (1e-6 nT).
    """
    tool = sensor_model.Tool(magnetometer=sensor_model.Triad(
        bias_drift=((8.0,), (-6.0,), (10.0,)), scale_drift=((3e-4,), (-2.5e-4,), (3.5e-4,))))
    rows = [(t, k) for k in range(2) for t in HEATING_C]
    temperature_c = np.array([t for t, _ in rows])
    label = np.array([k for _, k in rows], dtype=float)
    incl = np.where(label == 0, 55.0, 125.0)
    tf = np.where(label == 0, 45.0, 225.0)
    field = sensor_model.read(tool, incl, tf, 30.0, temperature_c=temperature_c).mag_nT
    write_csv(tmp_path / 'mag.csv', {'temperature_c': temperature_c, 'bx': field[:, 0],
                                     'by': field[:, 1], 'bz': field[:, 2], 'attitude': label})
    code, out, err = quiet(['fit-temperature', tmp_path / 'mag.csv', '--triad', 'magnetometer',
                            '--calibration', tmp_path / 'cal.json'])
    assert code == 0, err
    model = load_model(tmp_path / 'cal.json')
    assert model.magnetometer_temperature.attitudes == 2 and model.temperature is None
    hot = sensor_model.read(tool, 10.0, 300.0, 200.0, temperature_c=100.0).mag_nT
    cold = sensor_model.read(tool, 10.0, 300.0, 200.0, temperature_c=25.0).mag_nT
    assert np.abs(hot - cold).max() > 300.0
    np.testing.assert_allclose(model.apply_magnetic(hot, 100.0), cold, atol=1e-6)


def test_the_file_names_its_sensor(tmp_path):
    """--sensor-id stamps the file; process of another (or no) sensor: exit 2, named."""
    table = heating_table(DRIFTING, ATTITUDES_DEG)
    write_csv(tmp_path / 'heating.csv', table)
    calibration = tmp_path / 'cal.json'
    code, _, err = quiet(['fit-temperature', tmp_path / 'heating.csv', '--calibration',
                          calibration, '--sensor-id', 'TOOL-A'])
    assert code == 0, err
    assert load_model(calibration).sensor_id == 'TOOL-A'
    write_bag(tmp_path / 'in', sensor_model.read(sensor_model.IDEAL, np.full(10, 5.0),
                                                 0.0).accel_mps2)
    for extra, expected in (([], 'an unnamed one'), (['--sensor-id', 'TOOL-B'], "'TOOL-B'")):
        code, _, err = quiet(['process', tmp_path / 'in', tmp_path / 'out', '--calibration',
                              calibration, *extra])
        assert code == 2 and "belongs to sensor 'TOOL-A'" in err and expected in err
    code, _, err = quiet(['process', tmp_path / 'in', tmp_path / 'out', '--calibration',
                          calibration, '--sensor-id', 'TOOL-A', '--at-reference-temperature'])
    assert code == 0, err
    code, _, err = quiet(['fit-temperature', tmp_path / 'heating.csv', '--calibration',
                          calibration, '--sensor-id', 'TOOL-B'])
    assert code == 2 and "belongs to sensor 'TOOL-A'" in err


@pytest.mark.parametrize('triad', ['accelerometer', 'magnetometer'])
def test_fit_temperature_bag_tells_the_attitudes_apart(tmp_path, triad):
    """A heating bag at two attitudes (no labels): the directions separate them."""
    rows = [(t, k) for k in range(2) for t in np.linspace(20.0, 100.0, 81)]
    temperature_c = np.array([t for t, _ in rows])
    label = np.array([k for _, k in rows])
    tool = sensor_model.Tool(
        accelerometer=DRIFTING.accelerometer,
        magnetometer=sensor_model.Triad(bias_drift=((8.0,), (-6.0,), (10.0,))))
    readings = sensor_model.read(tool, np.where(label == 0, 55.0, 125.0),
                                 np.where(label == 0, 45.0, 225.0), 30.0,
                                 temperature_c=temperature_c)
    heated = tmp_path / 'heated'
    write_bag(heated, readings.accel_mps2, readings.mag_nT, temperature_c=temperature_c)
    code, out, err = quiet(['fit-temperature', heated, '--triad', triad, '--calibration',
                            tmp_path / 'cal.json'])
    assert code == 0, err
    assert '2 attitudes heated' in out
    model = load_model(tmp_path / 'cal.json')
    stage = model.temperature if triad == 'accelerometer' else model.magnetometer_temperature
    assert stage.attitudes == 2
