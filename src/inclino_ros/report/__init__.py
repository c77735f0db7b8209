"""
The reports of the fits, ROS-free: text lines, residual rows and figures.

One module per fit (level, stand, temperature, magnetometer, rotation, msa)
builds what its command prints and writes beside the calibration file: the
summary lines, the ``io.report.Residual`` rows of its residual table and its
PNG figure (matplotlib, loaded only when a figure is drawn).  The commands
(``cli/``) only parse, call the fit and hand these to the reader.
"""
