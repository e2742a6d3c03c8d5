"""Calibration: a model's parameters fitted to laboratory curves (``soilbin calibrate``)."""
