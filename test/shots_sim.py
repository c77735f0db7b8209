"""
Shots and surveys of the physical sensor model (``sim.sensor_model``) for the magnetometer tests.

The truth comes from the physical model alone: a tool with every error source of the
foundation issue (mount gamma 0.8, beta -1.2, roll 30 deg, magnetometer turned a further
(0.5, -0.3, 1.0) deg on the board, each triad's 3x3 matrix and bias, hard and soft iron,
drill-string field fixed to the tool, noise), read at known attitudes.
"""

import csv
from dataclasses import replace

from inclino_ros.sim import sensor_model
import numpy as np

FIELD = sensor_model.Field(total_nT=50000.0, dip_deg=60.0)
INTERFERENCE_NT = (80.0, 80.0, -2000.0)
MOUNT = sensor_model.Mount(gamma_deg=0.8, beta_deg=-1.2, roll_deg=30.0,
                           magnetometer_deg=(0.5, -0.3, 1.0))
#: The two roll groups: (inclination, azimuth) of the tool axis held while it turns.
ROLL_AXES_DEG = ((60.0, 30.0), (35.0, 200.0))


def tool(preset):
    """Return ``preset`` (MEMS, QUARTZ_FLUXGATE, IDEAL) on the issue's mount."""
    return replace(preset, mount=MOUNT)


def read(the_tool, inclination_deg, toolface_deg, azimuth_deg, rng, samples=1,
         interference_nT=INTERFERENCE_NT, temperature_c=25.0):
    """
    Return (accel, field) of the tool at the attitudes, each a mean of ``samples`` readings.

    ``interference_nT``: (3,) for every shot, or (N, 3) one per shot; the tool at
    ``temperature_c`` [deg C].
    """
    n = np.size(inclination_deg)
    interference = np.asarray(interference_nT, dtype=float)
    if interference.ndim == 2:
        interference = np.repeat(interference, samples, axis=0)
    readings = sensor_model.read(
        the_tool, np.repeat(inclination_deg, samples), np.repeat(toolface_deg, samples),
        np.repeat(azimuth_deg, samples), temperature_c=temperature_c, field=FIELD,
        interference_nT=interference, rng=rng)
    return (readings.accel_mps2.reshape(n, samples, 3).mean(axis=1),
            readings.mag_nT.reshape(n, samples, 3).mean(axis=1))


def shot_attitudes(rng, free=8, per_group=8, axes_deg=ROLL_AXES_DEG):
    """
    Return (inclination, toolface, azimuth, group) of a shot set: ``free`` shots + roll groups.

    Free shots point the tool axis uniformly over the sphere; each roll group holds one
    axis and turns the tool through ``per_group`` toolfaces evenly spread, from a random start.
    """
    inclination = list(np.degrees(np.arccos(rng.uniform(-1.0, 1.0, free))))
    toolface = list(rng.uniform(0.0, 360.0, free))
    azimuth = list(rng.uniform(0.0, 360.0, free))
    group = [-1] * free
    for k, (incl, azim) in enumerate(axes_deg):
        toolface += list(np.arange(per_group) * 360.0 / per_group + rng.uniform(0.0, 45.0))
        inclination += [incl] * per_group
        azimuth += [azim] * per_group
        group += [k] * per_group
    return (np.array(inclination), np.array(toolface), np.array(azimuth), np.array(group))


def random_attitudes(rng, count, min_inclination_deg=10.0):
    """Return (inclination, toolface, azimuth) uniform in [min, 180 - min] x 360 x 360."""
    return (rng.uniform(min_inclination_deg, 180.0 - min_inclination_deg, count),
            rng.uniform(0.0, 360.0, count), rng.uniform(0.0, 360.0, count))


def write_shots(path, accel, field, group=None, scale_field=1.0):
    """Write a shots CSV (ax..bz, roll_group named A, B, C, ... or empty)."""
    with open(path, 'w', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(['ax', 'ay', 'az', 'bx', 'by', 'bz', 'roll_group'])
        for i in range(len(accel)):
            name = '' if group is None or group[i] < 0 else 'ABCDEFGH'[group[i]]
            writer.writerow([repr(float(v)) for v in accel[i]]
                            + [repr(float(v) * scale_field) for v in field[i]] + [name])


def angle_error_deg(measured, truth):
    """Return the signed difference of two angles in (-180, 180] [deg]."""
    return (np.asarray(measured) - np.asarray(truth) + 180.0) % 360.0 - 180.0
