"""
Magnetometer temperature compensation targets the stage it feeds (issue 19 item 8).

On the physical simulator (``sim.sensor_model``): a MEMS magnetometer (its
sensitivities, bias and drift; a quartz-grade accelerometer) is calibrated on
a stand at STAND_C = 35 deg C (``fit_field_stand``: K_m, b_m, which record
35 deg C), then heated at two attitudes (``solve_temperature``); each draw
then surveys one station (mean of STATION_SAMPLES samples) at a random
attitude and temperature 20-100 deg C through ``pipeline.run``.  Before, the
temperature stage compensated to 25 deg C (the ``magnetometer`` stage recorded
no temperature): K_m, fitted on 35 deg C readings, got 25 deg C ones: azimuth
errors up to 0.57 deg (median 0.14) under a sigma of ~0.01 deg, coverage 0.04
/ 0.08 at 1 / 2 sigma; after: 0.65 / 0.96 (median error 0.006 deg).

DRAWS = 300 stand + heating calibrations: coverage of a right sigma is 0.683
+- 0.027 at 1 sigma and 0.954 +- 0.012 at 2 sigma (binomial), inside the
issue's bands 0.60-0.76 / 0.93-0.98 (seed fixed).  The stand's means are read
as one sample of a triad with noise / sqrt(STAND_SAMPLES) (the mean of that
many white samples); its K_m error (~1 nT a position) stays below the
station's noise, as its covariance is not yet in the sigma (item 2).
"""

from dataclasses import replace
import itertools

from inclino_ros import pipeline
from inclino_ros.calibration.corrections import CalibrationModel
from inclino_ros.calibration.magnetometer import fit_field_stand
from inclino_ros.calibration.schema import model_from_dict
from inclino_ros.calibration.temperature_fit import solve_temperature
from inclino_ros.sim import sensor_model as sm
from inclino_ros.sim.bench import TURNED_OVER_HEATING_ATTITUDES_DEG
import numpy as np

DRAWS = 300
STAND_C = 35.0
STAND_SAMPLES = 10000
HEATING_SAMPLES = 1601
STATION_SAMPLES = 1000
FIELD = sm.Field()
MAG = sm.MEMS.magnetometer
TOOL = sm.Tool(accelerometer=sm.Triad(noise_std=sm.QUARTZ_FLUXGATE.accelerometer.noise_std),
               magnetometer=MAG)
#: The stand's means: the mean of STAND_SAMPLES white samples.
STAND_TOOL = replace(TOOL, magnetometer=replace(MAG, noise_std=MAG.noise_std
                                                / np.sqrt(STAND_SAMPLES)))
#: 36 stand positions: inclination, seed-000 toolface, magnetic azimuth [deg].
POSITIONS_DEG = np.array([(incl, tf, (incl + tf + 90.0 * k) % 360.0) for k, (incl, tf) in
                          enumerate(itertools.product((30.0, 90.0, 150.0),
                                                      (0.0, 60.0, 120.0, 180.0, 240.0, 300.0)))]
                         + [(incl, tf, az + 180.0) for incl, tf, az in
                            itertools.product((60.0, 120.0), (30.0, 210.0, 120.0), (45.0,))])
ONE_SIGMA = (0.60, 0.76)
TWO_SIGMA = (0.93, 0.98)


def calibrated_model(rng):
    """Return the model of a stand fit at STAND_C and a heating run, through the file."""
    stand = sm.read(STAND_TOOL, *POSITIONS_DEG.T, temperature_c=STAND_C, field=FIELD, rng=rng)
    fit = fit_field_stand(stand.mag_nT, POSITIONS_DEG, FIELD.total_nT, FIELD.dip_deg, None,
                          1.0, temperatures_c=[STAND_C] * len(POSITIONS_DEG))
    model = CalibrationModel(3, magnetometer=fit.magnetometer,
                             magnetometer_alignment=fit.alignment)
    ramp = np.linspace(20.0, 100.0, HEATING_SAMPLES)
    temperature, readings, labels = [], [], []
    for label, (incl, tf) in enumerate(TURNED_OVER_HEATING_ATTITUDES_DEG):
        run = ramp if label % 2 == 0 else ramp[::-1]
        temperature.append(run)
        readings.append(sm.read(TOOL, incl, tf, temperature_c=run, field=FIELD, rng=rng).mag_nT)
        labels.append(np.full(run.size, label))
    stage, _, _ = solve_temperature(model, 'magnetometer', np.concatenate(temperature),
                                    np.concatenate(readings), np.concatenate(labels), 1)
    return model_from_dict(replace(model, magnetometer_temperature=stage).to_dict())


def test_magnetometer_stage_records_its_temperature_and_is_targeted():
    """The K_m stage says 35 deg C and the temperature stage compensates to it."""
    model = calibrated_model(np.random.default_rng(19080))
    assert model.magnetometer.temperature_c == STAND_C
    assert model.magnetometer_alignment.temperature_c == STAND_C
    assert model.magnetometer_temperature.reference_temperature_c == STAND_C


def test_azimuth_sigma_covers_after_a_stand_at_35_c():
    """1 and 2 sigma coverage of the azimuth within the issue's bands."""
    rng = np.random.default_rng(19008)
    settings = pipeline.Settings(noise_std_mps2=TOOL.accelerometer.noise_std)
    magnetic = pipeline.MagneticSettings(noise_std_nT=MAG.noise_std)
    z = []
    for _ in range(DRAWS):
        model = calibrated_model(rng)
        incl, tf, az = rng.uniform(30.0, 80.0), rng.uniform(-180.0, 180.0), rng.uniform(0, 360)
        operating_c = rng.uniform(20.0, 100.0)
        station = sm.read(TOOL, np.full(STATION_SAMPLES, incl), tf, az,
                          temperature_c=operating_c, field=FIELD, rng=rng)
        survey = pipeline.run(station.accel_mps2.mean(axis=0, keepdims=True), model, settings,
                              temperature_c=operating_c,
                              field_nT=station.mag_nT.mean(axis=0, keepdims=True),
                              magnetic_settings=magnetic, averaged=STATION_SAMPLES)
        error = (survey.magnetic.defined_azimuth_deg[0] - az + 180.0) % 360.0 - 180.0
        z.append(abs(error) / survey.magnetic.azimuth_std_deg[0])
    one, two = np.mean(np.array(z) <= 1.0), np.mean(np.array(z) <= 2.0)
    assert ONE_SIGMA[0] <= one <= ONE_SIGMA[1], (one, two)
    assert TWO_SIGMA[0] <= two <= TWO_SIGMA[1], (one, two)
