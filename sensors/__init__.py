"""Sensor models between the true plant state and the frames a controller sees.

``NoiseSpec`` / ``SensorSuite`` (:mod:`sensors.models`) are the noise-only models the plant
uses today; :mod:`sensors.channel` adds full channel models (delay, sample-and-hold,
dropout, saturation), whose suite is exported here as ``ChannelSuite``.
"""

from sensors.channel import (
    ChannelSpec,
    ChannelState,
    channel_init,
    channel_step,
    default_floating_suite,
)
from sensors.channel import SensorSuite as ChannelSuite
from sensors.models import NoiseSpec, SensorSuite

__all__ = [
    "ChannelSpec",
    "ChannelState",
    "ChannelSuite",
    "NoiseSpec",
    "SensorSuite",
    "channel_init",
    "channel_step",
    "default_floating_suite",
]
