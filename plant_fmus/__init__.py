"""The plant side's FMU wrappers: the vehicle plant, the sensors and the maneuver driver.

One thin wrapper per FMU of the catalogue (:mod:`sideslip.fmi.catalogue`) whose role is ``driver``,
``plant`` or ``sensors``; the estimator and controller FMUs' wrappers are in ``fmu_src/``.  Installed
as the package ``sideslip_plant_fmus``; inside an FMU each wrapper is a top-level module of its own
build's name (:mod:`sideslip.fmi.build`).
"""
