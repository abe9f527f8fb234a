"""Shipped floating-turbine presets (TOML + mooring JSON); sources in ../README.md."""
