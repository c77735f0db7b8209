"""
Nothing absurd accepted: the physical bounds of every stage and of the readings of a fit.

The hand-edited files of issue 10 (a stand bias of 1e300, K with 0.5 cross-coupling, a
hard iron of 1e300 nT, a G-total of 1e308) loaded before; each is refused now, at load
and before a write (``calibration.plausibility``, one place for both).  Unit mistakes
in the readings of a fit are named.
"""

from dataclasses import replace
import json

from calibration_files import load_refusal
from inclino_ros.calibration import plausibility
from inclino_ros.calibration.model import (
    CalibrationFileError, load_model, Magnetic, MagnetometerTemperature, NO_MAGNETIC_CORRECTION,
    save_model, ToolfaceMark)
from inclino_ros.calibration.plausibility import Implausible
from inclino_ros.calibration.stages import MagnetometerNonlinear
import numpy as np
import pytest
from test_model_stages import FULL, MAGNETOMETER, MODEL

G = 9.80665
MAGNETIC = Magnetic(hard_iron_nT=(80.0, -80.0), soft_iron=((1.01, 0.002), (0.002, 0.99)),
                    interference_nT=(0.0, 0.0, -2000.0), rotation_fitted_at=None,
                    msa_method='improved', msa_stations=20, msa_reference_total_nT=50000.0,
                    msa_reference_dip_deg=60.0, msa_fitted_at='2026-03-01T10:20:30+00:00')


GOOD = replace(MODEL, magnetic=MAGNETIC)


def edited(tmp_path, section, **fields):
    """Return the path of a valid file whose ``section`` has ``fields`` edited in by hand."""
    doc = GOOD.to_dict()
    doc[section].update(fields)
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps(doc))
    return path


HAND_EDITS = {
    'stand bias 1e300': ('stand', {'bias_mps2': [1e300, 0.0, 0.0]}, 'stand.bias_mps2'),
    'K cross-coupling 0.5': ('stand', {'scale_matrix': [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]},
                             'is not a sensor'),
    'K scale 1.45': ('stand', {'scale_matrix': [[1.45, 0, 0], [0, 1, 0], [0, 0, 1]]},
                     'is not a sensor'),
    'K element 0.4': ('stand', {'scale_matrix': [[1, 0.4, 0], [0, 1, 0], [0, 0, 1]]},
                      'cross terms at most 0.05'),
    'K mirrored': ('stand', {'scale_matrix': [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, 'mirrors'),
    'K tilted 60 deg': ('stand', {'scale_matrix': [[1, 0, 0], [0, 0.5, -0.866025],
                                                   [0, 0.866025, 0.5]]},
                        'turns the tool axis by 60'),
    'captured in 2100': ('installation', {'captured_at': '2100-01-01T00:00:00+00:00'},
                         'in the future'),
    'hard iron 1e300': ('magnetic', {'hard_iron_nT': [1e300, 0.0]}, 'magnetic.hard_iron_nT'),
    'soft iron ratio 1.9': ('magnetic', {'soft_iron': [[1.3, 0], [0, 0.7]]},
                            'magnetic.soft_iron'),
    'interference 50000': ('magnetic', {'interference_nT': [0, 0, 50000.0]},
                           'magnetic.interference_nT'),
    'MSA reference 5 nT': ('magnetic', {'msa_reference_total_nT': 5.0},
                           'msa_reference_total_nT'),
    'g_total 1e308': ('installation', {'g_total_mps2': 1e308}, 'installation.g_total_mps2'),
    'std 1e300': ('installation', {'std_deg': 1e300}, 'installation.std_deg'),
    'temperature range 1e6 C': ('temperature', {'t_max_c': 1e6}, 'temperature.t_max_c'),
    'K_T 1.4': ('temperature', {'coefficients': [[1.0 - 25 * 0.005, 0.005]] * 3},
                'scale factor outside 0.8 .. 1.2'),
}


@pytest.mark.parametrize('case', HAND_EDITS)
def test_hand_edited_absurd_stage_is_refused_on_load(tmp_path, case):
    """Each absurd value loaded before (every output 89.2 deg for the bias); refused now."""
    section, fields, reason = HAND_EDITS[case]
    with pytest.raises(CalibrationFileError, match=reason.replace('.', r'\.')):
        load_model(edited(tmp_path, section, **fields))


def test_the_untouched_file_loads(tmp_path):
    """The same file, not edited, is a plausible calibration."""
    assert load_model(edited(tmp_path, 'stand')).magnetic == MAGNETIC


def as_stage_value(value):
    """Return a JSON value as the tuples a stage holds."""
    return tuple(map(as_stage_value, value)) if isinstance(value, list) else value


@pytest.mark.parametrize('case', HAND_EDITS)
def test_an_absurd_stage_is_never_written(tmp_path, case):
    """save_model refuses the same values (every fit is written through it); no file made."""
    section, fields, reason = HAND_EDITS[case]
    stage = replace(getattr(GOOD, section),
                    **{key: as_stage_value(value) for key, value in fields.items()})
    target = tmp_path / 'new.json'
    with pytest.raises(ValueError, match=reason.replace('.', r'\.')):
        save_model(target, replace(GOOD, **{section: stage}))
    assert not target.exists()


#: The real MPU-9150 units of /work/shared/data/real/mpu9150_multiposition, as their
#: authors fitted them (real_imu.png, accelerometer): scale s [%], misalignment m [deg]
#: (yz, xy, xz), bias b [m/s^2], units #1 .. #5.
MPU9150_UNITS = (
    ((0.363, 0.315, 0.647), (0.123, 0.02, 0.317), (0.103, 0.097, 0.344)),
    ((0.471, 0.482, 0.932), (-0.284, -0.01, 0.145), (0.09, 0.07, 0.338)),
    ((0.382, 0.355, 0.78), (0.26, -0.012, 0.282), (0.096, 0.008, -0.045)),
    ((0.263, 0.448, 0.721), (-0.009, -0.028, -0.104), (0.065, 0.092, -0.009)),
    ((0.251, 0.286, 0.804), (0.056, 0.0, 0.191), (0.07, 0.036, 0.182)))


@pytest.mark.parametrize('unit', range(len(MPU9150_UNITS)))
def test_real_mpu9150_units_are_plausible(unit):
    """The datasheet-derived bounds leave real parts room: each unit's K, b loads, rolled too."""
    scale, (m_yz, m_xy, m_xz), bias = MPU9150_UNITS[unit]
    m_yz, m_xy, m_xz = np.radians([m_yz, m_xy, m_xz])
    k = np.diag(1.0 + np.array(scale) / 100.0) @ np.array(
        [[1.0, -m_xy, m_xz], [0.0, 1.0, -m_yz], [0.0, 0.0, 1.0]])
    roll = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])   # board turned 90 deg
    for matrix in (k, roll @ k):
        stand = replace(GOOD.stand, scale_matrix=as_stage_value(matrix.tolist()),
                        bias_mps2=tuple(bias), condition_number=float(np.linalg.cond(matrix)))
        plausibility.check_stand(stand, 2.0 * G)


def test_stand_bias_against_the_sensor_range():
    """An axis that reaches beyond the range at +-g could not have been fitted unsaturated."""
    plausibility.check_for_sensor(MODEL, 2.0 * G)
    with pytest.raises(Implausible, match='beyond the sensor range 9.8 m/s'):
        plausibility.check_for_sensor(MODEL, 9.8)


FIELD = np.array([[20000.0, 30000.0, 35000.0]] * 5)


@pytest.mark.parametrize('factor,named', [(1e-9, 'tesla'), (1e-5, 'gauss'),
                                          (1e-3, 'microtesla'), (0.0, 'dead magnetometer'),
                                          (40.0, 'not an Earth field')])
def test_field_readings_in_another_unit_are_named(factor, named):
    """A rotation or station in tesla, gauss or uT (or a dead sensor): refused, the unit named."""
    with pytest.raises(Implausible, match=named):
        plausibility.check_field_readings(FIELD * factor)


def test_one_field_reading_beyond_an_earth_field_is_refused():
    """One 2e6 nT reading among Earth fields: refused; Earth fields pass."""
    plausibility.check_field_readings(FIELD)
    with pytest.raises(Implausible, match='beyond 200000 nT'):
        plausibility.check_field_readings(np.vstack([FIELD, [[2e6, 0.0, 0.0]]]))
    np.testing.assert_array_equal(
        plausibility.field_reading_ok([[2e4, 3e4, 3.5e4], [2e6, 0, 0], [np.nan, 0, 0],
                                       [1e200, 1e200, 0], [0, 0, 0]]),
        [True, False, False, False, True])


@pytest.mark.parametrize('factor,named', [(1.0 / G, 'is it in g?'), (1000.0 / G, 'in mg?'),
                                          (0.1, 'not gravity')])
def test_accelerometer_readings_in_another_unit_are_named(factor, named):
    """A stand CSV in g or mg is refused with the unit named."""
    readings = np.array([[0.0, 0.0, G], [G, 0.0, 0.0], [0.0, -G, 0.0]])
    plausibility.check_accelerometer_readings(readings, G)
    with pytest.raises(Implausible, match=named):
        plausibility.check_accelerometer_readings(readings * factor, G)
    with pytest.raises(Implausible, match='beyond 2 g'):
        plausibility.check_accelerometer_readings(np.vstack([readings, [[1e155, 0, 0]]]), G)


def test_magnitude_neither_overflows_nor_underflows():
    """|v| of 1e200 and 1e-200 vectors, exactly where the squares would not be."""
    np.testing.assert_allclose(plausibility.magnitude([[3e200, 4e200], [3e-200, 4e-200],
                                                       [0.0, 0.0], [np.inf, 1.0]]),
                               [5e200, 5e-200, 0.0, np.inf])


def test_no_magnetic_correction_is_plausible():
    """The identity stage the first fit builds on passes."""
    plausibility.check_magnetic(NO_MAGNETIC_CORRECTION)


#: A temperature stage of each triad with a bias drift (0 at the reference, 25 deg C).
DRIFT = replace(MODEL.temperature, bias_coefficients_mps2=((-25e-4, 1e-4),) * 3, attitudes=2)
MAGNETOMETER_DRIFT = MagnetometerTemperature(
    coefficients=((1.0 - 25e-5, 1e-5),) * 3, t_min_c=20.0, t_max_c=100.0,
    reference_temperature_c=25.0, rms_residual_nT=(5.0, 5.0, 5.0), samples=90,
    fitted_at='2026-03-01T09:00:00+00:00', bias_coefficients_nT=((-25.0, 1.0),) * 3,
    attitudes=2)
#: A gated non-linear magnetometer stage (issue 18): 3 RBF weights per cross axis, a few
#: hundred nT at most, as the real instruments' kept stages.
NONLINEAR = MagnetometerNonlinear(
    weights=((0.002, -0.004, 0.002), (-0.001, 0.003, -0.002)), scale_nT=50000.0,
    rms_residual_nT=40.0, roll_sets=2, shots=24, held_out_before_deg=0.39,
    held_out_after_deg=0.19, held_out_noise_deg=0.05, fitted_at='2026-03-01T10:00:00+00:00',
    parameter_covariance=tuple(tuple(1e-8 if i == j else 0.0 for j in range(6))
                               for i in range(6)))
#: A high-side mark (issue 19 item 6): the board rolled 20 deg, captured at 30 deg.
MARK = ToolfaceMark(offset_deg=-20.0, std_deg=0.005, inclination_deg=30.0,
                    toolface_convention='seed000', sample_count=600,
                    captured_at='2026-03-01T11:00:00+00:00')
#: Every stage of issues 8, 9, 18 and 19 present: magnetometer, alignment, tool axis, both
#: drifts, the non-linear magnetometer stage, the high-side mark.
ALL_STAGES = replace(FULL, magnetic=MAGNETIC, temperature=DRIFT,
                     magnetometer_temperature=MAGNETOMETER_DRIFT, magnetometer_nonlinear=NONLINEAR,
                     toolface_mark=MARK)

NEW_STAGE_EDITS = {
    'K_m scale 3': ('magnetometer', {'scale_matrix': [[3, 0, 0], [0, 1, 0], [0, 0, 1]]},
                    'not in nT'),
    'b_m 1e300 nT': ('magnetometer', {'bias_nT': [1e300, 0.0, 0.0]}, 'magnetometer.bias_nT'),
    'field in gauss': ('magnetometer', {'field_nT': 0.5}, 'is it in gauss?'),
    'alignment scaled': ('magnetometer_alignment',
                         {'rotation': [[2, 0, 0], [0, 2, 0], [0, 0, 2]]}, 'is not a rotation'),
    'alignment dip 95': ('magnetometer_alignment', {'dip_deg': 95.0}, 'dip_deg'),
    'tool axis beta 80': ('tool_axis', {'beta_deg': 80.0}, 'tool_axis.beta_deg'),
    'magnetometer K_T 1.5': ('magnetometer_temperature',
                             {'coefficients': [[1.0 - 25 * 0.01, 0.01]] * 3},
                             'magnetometer_temperature.coefficients'),
    'magnetometer bias drift 1e6 nT': ('magnetometer_temperature',
                                       {'bias_coefficients_nT': [[-25e4, 1e4]] * 3},
                                       'bias drift reaches'),
    'accelerometer bias drift 1 g': ('temperature',
                                     {'bias_coefficients_mps2': [[-25 * 0.2, 0.2]] * 3},
                                     'bias drift reaches'),
    'bias drift not 0 at 25 C': ('temperature', {'bias_coefficients_mps2': [[0.01, 1e-4]] * 3},
                                 'not 0 at the reference'),
    'stage temperature 1e6 C': ('stand', {'temperature_c': 1e6}, 'stand.temperature_c'),
    'interference 1 sigma -5 nT': ('magnetic', {'interference_std_nT': [-5.0, 0.0, 0.0]},
                                   'interference_std_nT'),
}


def test_every_stage_of_issues_8_and_9_loads(tmp_path):
    """The untouched file with every stage loads back equal."""
    path = tmp_path / 'calibration.json'
    save_model(path, ALL_STAGES)
    assert load_model(path) == ALL_STAGES


@pytest.mark.parametrize('case', NEW_STAGE_EDITS)
def test_hand_edited_new_stage_is_refused_on_load(tmp_path, case):
    """The checks cover the magnetometer, alignment, tool axis and both drift stages."""
    section, fields, named = NEW_STAGE_EDITS[case]
    doc = ALL_STAGES.to_dict()
    doc[section].update(fields)
    assert named in load_refusal(tmp_path, doc)


def test_an_implausible_magnetometer_stage_is_never_written(tmp_path):
    """save_model refuses a magnetometer K_m of readings in microtesla, before writing."""
    k = tuple(tuple(1e-3 * v for v in row) for row in MAGNETOMETER.scale_matrix)
    path = tmp_path / 'calibration.json'
    with pytest.raises(ValueError, match='not in nT'):
        save_model(path, replace(ALL_STAGES,
                                 magnetometer=replace(MAGNETOMETER, scale_matrix=k)))
    assert not path.exists()
