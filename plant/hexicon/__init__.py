"""Hexicon H3-18MW: a multi-turbine floating platform yawing about its turret (ayotte-2015)."""
