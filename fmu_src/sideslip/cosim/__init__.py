"""Co-simulation of the FMUs in closed loop.

* :mod:`~sideslip.cosim.assembly` - components, interfaces, connection resolution and the
  wiring of a scenario's loop (one wiring for every master and the SSP export);
* :mod:`~sideslip.cosim.master` - the fmpy master (Gauss-Seidel or Jacobi, fixed step);
* :mod:`~sideslip.cosim.libcosim_master` - the same loop on DNV's libcosim;
* :mod:`~sideslip.cosim.ssp` - SSP 1.0 packages of a loop: write and read;
* :mod:`~sideslip.cosim.replay` - estimator FMUs driven by a recorded drive instead of a loop;
* :mod:`~sideslip.cosim.results` - the recorded results every master returns.
"""
