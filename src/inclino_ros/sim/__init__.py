"""
The physical sensor model and, on it, the virtual bench and well: readings from a known truth.

``sensor_model`` reads a tool (mount, triads, drift, hard/soft iron, drill string, noise) at
given attitudes; ``bench`` and ``well`` hold the scenarios.  Used by the CLI, tests and
benchmarks, never by core or calibration.
"""
