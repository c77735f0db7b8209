"""
The calibration file's versions and how an older one is read.

Version 1 files hold the installation stage only, version 2 files no
magnetometer, tool-axis or magnetometer temperature stage and lack the fields
version 3 added to theirs (``VERSION_3_FIELDS``), version 3 files the stand's
temperature polynomial (``VERSION_4_FIELDS``): ``upgraded`` gives an older
section those fields, with the value that says "unknown" or "none".  Version 4
files lack the temperature fits' parameter covariance (``VERSION_5_FIELDS``;
without it the residual stands for the fit's error, as before) and the
temperature the magnetometer, its alignment and the tool axis stood for;
version 5 files the magnetometer's temperature polynomial (``VERSION_6_FIELDS``).
Version 6 files lack the magnetometer fit's and the rotation fit's parameter
covariance (``VERSION_7_FIELDS``; without them the azimuth 1 sigma leaves those
fits' own error out, as before, and ``CalibrationModel.uncertainty_notes`` says so).
Version 7 files' temperature stages were fitted in the tool axes
(``VERSION_8_FIELDS``: no ``axes_map``, issue 19 item 7).  Version 8 files lack the
accelerometer stand fit's parameter covariance (``VERSION_9_FIELDS``; without it the
stand's residual stands for the fit's error as a tilt variance, as before, and
``CalibrationModel.uncertainty_notes`` says so).  Version 9 files have no
``magnetometer_nonlinear`` section (issue 18: the non-linear stage fitted from roll sets;
without it the chain is linear, as before).  Version 11 added the ``toolface_mark`` stage
(issue 19 item 6): an older file has none, its toolface zero is what its other stages give.
"""

SCHEMA_VERSION = 11
#: Versions load_model reads.
READABLE_VERSIONS = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11)
#: Sections of each readable schema version.
SECTIONS = {1: ('installation',),
            2: ('temperature', 'stand', 'installation', 'magnetic'),
            3: ('temperature', 'stand', 'installation', 'tool_axis', 'magnetometer_temperature',
                'magnetometer', 'magnetometer_alignment', 'magnetic')}
SECTIONS[4] = SECTIONS[5] = SECTIONS[6] = SECTIONS[7] = SECTIONS[8] = SECTIONS[9] = SECTIONS[3]
#: Version 10 added the magnetometer's non-linear stage (issue 18), 11 the toolface mark.
SECTIONS[10] = SECTIONS[3] + ('magnetometer_nonlinear',)
SECTIONS[11] = SECTIONS[10] + ('toolface_mark',)
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


#: Fields version 5 added: the temperature fits' own uncertainty and the temperature of
#: every magnetometer and mount stage (issue 19 items 2, 3, 8).
VERSION_5_FIELDS = {
    'temperature': {'parameter_covariance': None},
    'magnetometer_temperature': {'parameter_covariance': None},
    'magnetometer': {'temperature_c': None},
    'magnetometer_alignment': {'temperature_c': None},
    'tool_axis': {'temperature_c': None},
}
#: Fields version 6 added: the magnetometer's K_m(T), b_m(T) of a stand at several
#: temperatures (issue 18).
VERSION_6_FIELDS = {
    'magnetometer': {'scale_coefficients': None, 'bias_coefficients_nT': None, 't_min_c': None,
                     't_max_c': None},
}
#: Fields version 7 added: the magnetometer and rotation fits' parameter covariance
#: (issue 19 item 2).
VERSION_7_FIELDS = {
    'magnetometer': {'parameter_covariance': None, 'covariance_stages': None},
    'magnetic': {'rotation_covariance': None},
}
#: Fields version 8 added: the sensor axes a temperature drift is per (issue 19 item 7).
VERSION_8_FIELDS = {
    'temperature': {'axes_map': None},
    'magnetometer_temperature': {'axes_map': None},
}
#: Fields version 9 added: the accelerometer stand fit's parameter covariance (issue 19
#: item 0).
VERSION_9_FIELDS = {
    'stand': {'parameter_covariance': None},
}
#: The fields each version added, in order.
ADDED_FIELDS = ((3, VERSION_3_FIELDS), (4, VERSION_4_FIELDS), (5, VERSION_5_FIELDS),
                (6, VERSION_6_FIELDS), (7, VERSION_7_FIELDS), (8, VERSION_8_FIELDS),
                (9, VERSION_9_FIELDS))


def upgraded(section, name, version):
    """Return a section of an older file with the fields later versions added."""
    if not isinstance(section, dict):
        return section
    added = {}
    for since, fields in ADDED_FIELDS:
        if version < since:
            added.update(fields.get(name, {}))
    return {**added, **section}
