"""
Physical constants of the package, each defined once.

``STANDARD_GRAVITY_MPS2``: the standard acceleration of gravity (CGPM 1901,
ISO 80000-3), 9.80665 m/s^2 exactly: the default local gravity, the unit g
of the messages and of the ISCWSA station tables, and the gravity against
which a residual becomes an angle.
"""

#: Standard gravity [m/s^2] (exact by definition).
STANDARD_GRAVITY_MPS2 = 9.80665
