"""The calibration model, its versioned file, and the captures that turn samples into stages."""
