"""
The calibration file's versions and how an older one is read.

Version 1 files hold the installation stage only, version 2 files no
magnetometer, tool-axis or magnetometer temperature stage and lack the fields
version 3 added to theirs (``VERSION_3_FIELDS``): ``upgraded`` gives an older
section those fields, with the value that says "unknown" or "none".
"""

from inclino_ros.calibration.corrections import STAGES

SCHEMA_VERSION = 3
#: Versions load_model reads.
READABLE_VERSIONS = (1, 2, 3)
#: Sections of each readable schema version.
SECTIONS = {1: ('installation',),
            2: ('temperature', 'stand', 'installation', 'magnetic'),
            3: STAGES + ('magnetometer_temperature', 'magnetometer', 'magnetometer_alignment',
                         'magnetic')}
#: Fields version 3 added, with the value an older file's section gets.
VERSION_3_FIELDS = {
    'installation': {'temperature_c': None},
    'stand': {'temperature_c': None},
    'temperature': {'bias_coefficients_mps2': None, 'attitudes': 1},
    'magnetic': {'interference_std_nT': None, 'rotation_temperature_c': None},
}


def upgraded(section, name, version):
    """Return a section of an older file with the fields version 3 added (``VERSION_3_FIELDS``)."""
    if version >= 3 or not isinstance(section, dict):
        return section
    return {**VERSION_3_FIELDS.get(name, {}), **section}
