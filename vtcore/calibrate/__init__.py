"""Calibrating and validating the sensor model against real recordings (issue 27)."""
