"""
Virtual bench and well: physical sensor models that produce readings from a known truth.

Used by the CLI, tests and benchmarks, never by core or calibration.
"""
