"""The compiled plant, driver and LQR steps and SideslipFusion's tire pseudo-measurements
(sideslip/plant/native/*_kernel.c, sideslip/control/native/lqr_kernel.c,
sideslip/estimators/fusion/native/fusion_kernel.c) for the library; everything else is in pyproject.toml.
Optional: without a C compiler the install goes on and they run their pure-Python reference (sideslip.plant.kernel)."""
from setuptools import Extension, setup

setup(ext_modules=[Extension(
    "sideslip.plant._plant_kernel", ["fmu_src/sideslip/plant/native/plant_kernel.c",
                                     "fmu_src/sideslip/plant/native/driver_kernel.c",
                                     "fmu_src/sideslip/control/native/lqr_kernel.c",
                                     "fmu_src/sideslip/estimators/fusion/native/fusion_kernel.c"],
    depends=["fmu_src/sideslip/plant/native/python_math.h"],
    define_macros=[("SIDESLIP_PYTHON_EXTENSION", "1")],
    # the same doubles as the Python reference: no fused multiply-adds, no fast-math
    extra_compile_args=["-O2", "-ffp-contract=off", "-fno-fast-math"], optional=True)])
