"""
The corrected outputs of a batch as message series: one place for the node and ``inclino process``.

For the accepted samples (or averaged windows) of a ``pipeline.Survey``:
``survey`` (Vector3Stamped: x inclination_deg, y toolface_deg, z magnetic
azimuth_deg, NaN without a trusted azimuth) and ``imu/data`` (the corrected
specific force, the roll/pitch orientation and the covariances of
``pipeline.imu_covariances``; angular velocity not measured), plus the
scalar values of the node's ``inclination``, ``toolface`` and ``azimuth``
(true, declination added) topics; ``averaged_outputs`` those of the windows
an ``averaging.Averager`` closes.  The series are encoded to CDR by
``io.bag.encode`` (the node publishes those bytes, ``inclino process``
writes them to a bag).  No ROS here.
"""

from dataclasses import dataclass

import math

from inclino_ros.io.bag import ImuSeries, not_measured_covariance, Vector3Series
from inclino_ros.pipeline import average, imu_covariances
import numpy as np


@dataclass(frozen=True)
class Outputs:
    """What one batch publishes, topic by topic."""

    survey: Vector3Series
    imu: ImuSeries
    inclination_deg: np.ndarray
    toolface_deg: np.ndarray
    true_azimuth_deg: np.ndarray   # None without magnetometer readings


def outputs(stamps_ns, frame_ids, survey):
    """Return the Outputs of the accepted rows of ``survey``, stamped ``stamps_ns`` (M,)."""
    n = np.size(stamps_ns)
    acceleration_cov, orientation_cov = imu_covariances(survey)
    w, x, y, z = survey.orientation_wxyz.T
    magnetic = survey.magnetic
    azimuth_deg = np.full(n, np.nan) if magnetic is None else magnetic.azimuth_deg
    return Outputs(
        survey=Vector3Series(stamps_ns, frame_ids, np.stack(
            [survey.inclination_deg, survey.toolface_deg, azimuth_deg], axis=1)),
        imu=ImuSeries(
            stamps_ns, frame_ids, orientation_xyzw=np.stack([x, y, z, w], axis=1),
            orientation_covariance=orientation_cov, angular_velocity_radps=np.zeros((n, 3)),
            angular_velocity_covariance=not_measured_covariance(n),
            linear_acceleration_mps2=survey.corrected_mps2,
            linear_acceleration_covariance=acceleration_cov),
        inclination_deg=survey.inclination_deg, toolface_deg=survey.toolface_deg,
        true_azimuth_deg=None if magnetic is None else magnetic.true_azimuth_deg)


def averaged_outputs(averager, stamps_ns, frame_ids, survey, temperature_c, model, settings,
                     magnetic_settings=None):
    """
    Push the accepted samples of ``survey`` into ``averager``; return the windows it closes.

    ``stamps_ns``, ``frame_ids``: of the accepted samples; ``temperature_c``:
    None, one value, or one per input sample of the batch.  Returns (windows
    of a moving tool, windows whose mean reading was dropped by screening,
    [Outputs]): the angles of the kept windows (``pipeline.average``; with
    ``magnetic_settings``, their azimuths).
    """
    n = np.size(stamps_ns)
    if temperature_c is None:
        temperature_c = np.full(n, math.nan)
    elif np.ndim(temperature_c) == 0:
        temperature_c = np.full(n, float(temperature_c))
    else:
        temperature_c = np.asarray(temperature_c, dtype=float)[survey.accepted]
    field_nT = (np.full((n, 3), math.nan) if survey.magnetic is None
                else survey.magnetic.uncorrected_nT)
    windows = averager.push(stamps_ns, frame_ids, survey.uncorrected_mps2, temperature_c,
                            field_nT)
    if windows is None:
        return 0, 0, []
    kept, parts = average(windows, model, settings, magnetic_settings)
    published, dropped = [], 0
    for rows, averaged in parts:
        rows = rows[averaged.accepted]
        dropped += averaged.codes.size - rows.size
        published.append(outputs(windows.stamps_ns[rows], windows.frame_ids[rows], averaged))
    return windows.count - int(np.count_nonzero(kept)), dropped, published
