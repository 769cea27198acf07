"""The FMU toolkit: what turns a library model into an FMI 2.0 co-simulation FMU.

* :mod:`~sideslip.fmi.catalogue` - the table of every FMU (name, wrapper, model, config, role);
* :mod:`~sideslip.fmi.slave` - the pythonfmu slave base class declaring ports from the signal
  catalogue (runs inside every FMU);
* :mod:`~sideslip.fmi.variables` - values of FMI variables by type;
* :mod:`~sideslip.fmi.bundle` - which modules an FMU carries and the packages it needs;
* :mod:`~sideslip.fmi.build` - the builder (pythonfmu packaging and the native shim in ``native/``);
* :mod:`~sideslip.fmi.docs` - the per-FMU reference pages, generated from the catalogue.

Only :mod:`~sideslip.fmi.slave` imports pythonfmu at import time; only the builder needs fmpy
(its FMI headers).
"""
