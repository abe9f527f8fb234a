"""Scenarios: the validated schema of a scenario file, its generated key reference, and the shipped
presets."""
