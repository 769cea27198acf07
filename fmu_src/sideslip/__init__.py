"""sideslip-fmu: vehicle sideslip-angle estimators, an LQR direct-yaw-moment controller and an
8-DOF vehicle plant, usable as a plain Python library and as FMI 2.0 co-simulation FMUs.

The layers, each importing only those above it:

* the library core, which never imports pythonfmu or fmpy: :mod:`~sideslip.signals` (the
  signal catalogue), :mod:`~sideslip.units`, :mod:`~sideslip.constants`, :mod:`~sideslip.params`,
  :mod:`~sideslip.model`, :mod:`~sideslip.vehicles`, :mod:`~sideslip.bicycle`,
  :mod:`~sideslip.geomagnetic`, :mod:`~sideslip.plant`, :mod:`~sideslip.estimators`,
  :mod:`~sideslip.control`, :mod:`~sideslip.scenarios` and :mod:`~sideslip.recording` (recorded drives);
* :mod:`sideslip.fmi` - the FMU toolkit: the FMU catalogue, the slave base class, the builder;
* :mod:`sideslip.cosim` - co-simulation: assembly and wiring, the fmpy and libcosim masters, SSP;
* :mod:`sideslip.studies` - the job runner, the paper tables, the control evaluation, sweeps,
  the benchmark, metrics and plots;
* :mod:`sideslip.cli` - ``python -m sideslip``.
"""

__version__ = "0.1.0"
