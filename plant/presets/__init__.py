"""Shipped turbine presets: TOML parameter files and ROSCO-format Cp/Ct/Cq tables (data only).

Read them with :func:`plant.turbine.load_turbine`; ``README.md`` here names every figure's source.
"""
