"""Baseline-controller presets shipped as data (TOML); see README.md for their sources."""
