"""
The calibration file's versions and how an older one is read.

Version 1 files hold the installation stage only, version 2 files no
magnetometer, tool-axis or magnetometer temperature stage and lack the fields
version 3 added to theirs (``VERSION_3_FIELDS``), version 3 files the stand's
temperature polynomial (``VERSION_4_FIELDS``): ``upgraded`` gives an older
section those fields, with the value that says "unknown" or "none".
"""

from inclino_ros.calibration.corrections import STAGES

SCHEMA_VERSION = 4
#: Versions load_model reads.
READABLE_VERSIONS = (1, 2, 3, 4)
#: Sections of each readable schema version.
SECTIONS = {1: ('installation',),
            2: ('temperature', 'stand', 'installation', 'magnetic'),
            3: STAGES + ('magnetometer_temperature', 'magnetometer', 'magnetometer_alignment',
                         'magnetic')}
SECTIONS[4] = SECTIONS[3]
#: Fields version 3 added, with the value an older file's section gets.
VERSION_3_FIELDS = {
    'installation': {'temperature_c': None},
    'stand': {'temperature_c': None},
    'temperature': {'bias_coefficients_mps2': None, 'attitudes': 1},
    'magnetic': {'interference_std_nT': None, 'rotation_temperature_c': None},
}


#: Fields version 4 added (a stand at several temperatures, issue 18).
VERSION_4_FIELDS = {
    'stand': {'scale_coefficients': None, 'bias_coefficients_mps2': None, 't_min_c': None,
              't_max_c': None},
}


def upgraded(section, name, version):
    """Return a section of an older file with the fields later versions added."""
    if version >= 4 or not isinstance(section, dict):
        return section
    added = {**VERSION_4_FIELDS.get(name, {})}
    if version < 3:
        added.update(VERSION_3_FIELDS.get(name, {}))
    return {**added, **section}
