"""sideslip-fmu: vehicle sideslip-angle estimators, an LQR direct-yaw-moment controller and
an 8-DOF vehicle plant, usable as a plain Python library and as FMI 2.0 co-simulation FMUs.

Importing :mod:`sideslip` (or any algorithm subpackage) never imports pythonfmu or fmpy;
only :mod:`sideslip.fmi` (the FMU toolkit) and :mod:`sideslip.cosim` (the fmpy master) do.
"""

__version__ = "0.1.0"
