"""The plant: turbine (and later platform) dynamics as pure ``f(t, x, u, params)`` cores.

Modules: :mod:`plant.aero` (Cp/Ct/Cq tables, ROSCO format), :mod:`plant.turbine` (rotor,
drivetrain, actuators, presets), :mod:`plant.integrate` (fixed-step RK4), :mod:`plant.wind`
(deterministic wind histories). Import from the modules; this package file stays empty so that
importing one module does not load the others.
"""
