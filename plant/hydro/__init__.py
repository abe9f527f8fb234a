"""Linear potential-flow hydrodynamics of the floating platform.

Modules: :mod:`plant.hydro.wamit` (WAMIT ``.1``/``.3``/``.hst`` readers, dimensional SI data,
:class:`~plant.hydro.wamit.HydroData` with npz I/O and the shipped presets),
:mod:`plant.hydro.radiation` (Perez-Fossen frequency-domain fit of the radiation kernels and
their state-space realisation). Import from the modules; this package file stays empty so that
importing one module does not load the others.
"""
