"""Sensor models between the true plant state and the frames a controller sees."""

from sensors.models import NoiseSpec, SensorSuite

__all__ = ["NoiseSpec", "SensorSuite"]
