"""
The axes-map options of the commands that read raw sensor data (the node's parameters).

``--accelerometer-axes-map`` and ``--magnetometer-axes-map`` say how the
sensors are mounted (``core.mounting``); readings are turned into the tool
axes before anything else looks at them.
"""

import re

from inclino_ros.cli.errors import CommandError
from inclino_ros.core.mounting import axes_map_matrix, IDENTITY

#: A signed permutation, which argparse would take for an option when it starts with '-'.
_MAP_VALUE = re.compile(r'^[+-][XYZ][+-][XYZ][+-][XYZ]$', re.IGNORECASE)

SENSORS = {'accelerometer': 'the Imu linear_acceleration', 'magnetometer': 'the MagneticField'}


def add_axes_map_arguments(parser, *sensors, writing=False):
    """Add ``--<sensor>-axes-map`` for each of ``sensors`` and ``--allow-left-handed-axes``."""
    group = parser.add_argument_group(
        'mounting' + (' of the simulated sensors' if writing else ''),
        'For tool x, y, z in turn, the sensor axis that points along it, signed: -Y+X+Z '
        'means tool x = -sensor y, tool y = sensor x, tool z = sensor z; or '
        'rpy:ROLL,PITCH,YAW [deg], the sensor turned in the tool frame.'
        + (' The bag then holds what such a board reads.' if writing else
           ' The readings are turned into the tool axes before any correction (a command '
           'that reads one sensor only takes both maps, so one set of options fits all).'))
    for sensor in sensors:
        group.add_argument(f'--{sensor}-axes-map', default=IDENTITY, metavar='MAP',
                           help=f'mounting of {SENSORS[sensor]} axes (default: %(default)s)')
    group.add_argument('--allow-left-handed-axes', action='store_true',
                       help='accept a map of determinant -1 (only for a sensor whose own axes '
                            'are left-handed)')


def axes_matrix(args, sensor):
    """Return M (``v_tool = M v_sensor``) of ``--<sensor>-axes-map``; CommandError if invalid."""
    try:
        return axes_map_matrix(getattr(args, f'{sensor}_axes_map'), args.allow_left_handed_axes)
    except ValueError as err:
        raise CommandError(f'--{sensor}-axes-map: {err}') from None


def settings_maps(args):
    """Return the axes-map fields of ``pipeline.Settings`` given on the command line."""
    return {'accelerometer_axes_map': args.accelerometer_axes_map,
            'magnetometer_axes_map': getattr(args, 'magnetometer_axes_map', IDENTITY),
            'allow_left_handed_axes': args.allow_left_handed_axes}


def attach_map_values(argv):
    """
    Return ``argv`` with ``--x-axes-map -Y+X+Z`` written ``--x-axes-map=-Y+X+Z``.

    argparse takes a value that starts with '-' for an option ("expected one
    argument"); a signed permutation after an axes-map option is its value.
    """
    argv = [str(a) for a in argv]
    out = []
    for arg in argv:
        if out and out[-1].endswith('-axes-map') and _MAP_VALUE.match(arg):
            out[-1] = f'{out[-1]}={arg}'
        else:
            out.append(arg)
    return out
