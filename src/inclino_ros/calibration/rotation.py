"""
A rotation's cross-axial correction into the magnetic stage (seed 002 §2.1): one rule.

``~/capture_rotation`` and ``inclino fit-rotation`` both call
``solve_rotation``: readings without a value (NaN) are left out, the rest
must be Earth fields in nT (``plausibility.check_field_readings``); the
ellipse is fitted in the tool frame (after the magnetometer's own stages and
the shared mount, before seed 002's: ``cross_axial.fit_cross_axial``).

The magnetic stage gets the hard iron c, the soft iron W, the time and the
temperature the readings stood for (``provenance.readings_temperature_c``);
the multi-station interference is reset: it was solved on the field the old
cross-axial correction gave, which the new one changes (solve the MSA again).
A file without a magnetic stage starts from ``NO_MAGNETIC_CORRECTION``.
"""

from dataclasses import dataclass, replace

from inclino_ros.calibration.plausibility import check_field_readings
from inclino_ros.calibration.provenance import readings_temperature_c, utc_now_iso
from inclino_ros.calibration.stages import NO_MAGNETIC_CORRECTION
from inclino_ros.core.cross_axial import fit_cross_axial
import numpy as np


@dataclass(frozen=True)
class RotationSolution:
    """The model with the new rotation, its fit, the fitted readings, and what was left out."""

    model: object            # corrections.CalibrationModel
    fit: object              # cross_axial.CrossAxialFit
    readings_nT: np.ndarray  # (N, 3) the tool-frame readings fitted
    left_out: int            # readings without a value (NaN)


def with_rotation(model, fit, temperature_c):
    """
    Return ``model`` whose magnetic stage holds the rotation ``fit``, its interference reset.

    ``temperature_c``: what the rotation's readings stood for (None: unknown).
    """
    stage = replace(model.magnetic or NO_MAGNETIC_CORRECTION,
                    hard_iron_nT=tuple(fit.offset_nT.tolist()),
                    soft_iron=tuple(map(tuple, fit.correction.tolist())),
                    interference_nT=(0.0, 0.0, 0.0), interference_std_nT=None,
                    rotation_fitted_at=utc_now_iso(), msa_method=None, msa_stations=0,
                    msa_fitted_at=None, rotation_temperature_c=temperature_c,
                    rotation_covariance=tuple(map(tuple, fit.parameter_covariance.tolist())))
    return replace(model, magnetic=stage)


def solve_rotation(model, field_nT, temperatures_c=None,
                   what="the rotation's magnetometer readings"):
    """
    Return the RotationSolution of a rotation's raw magnetometer readings (N, 3) [nT].

    ``temperatures_c`` (N,) or None: each reading's temperature (the
    magnetometer temperature stage, if any, is applied at it).  Raises
    Implausible (``what`` names the readings) or RotationFitRefused.
    """
    field_nT = np.asarray(field_nT, dtype=float).reshape(-1, 3)
    valued = np.isfinite(field_nT).all(axis=1)
    if valued.any():
        field_nT = field_nT[valued]
        temperatures_c = None if temperatures_c is None else np.asarray(temperatures_c)[valued]
    check_field_readings(field_nT, what)
    readings = model.apply_magnetic(field_nT, temperatures_c, before='magnetic')
    fit = fit_cross_axial(readings)
    measured_c = None if temperatures_c is None else float(np.mean(temperatures_c))
    stood_for_c = readings_temperature_c(model.magnetometer_temperature, measured_c)
    return RotationSolution(model=with_rotation(model, fit, stood_for_c), fit=fit,
                            readings_nT=readings, left_out=int(np.count_nonzero(~valued)))
