"""Studies built on closed-loop runs.

* :mod:`~sideslip.studies.jobs` - the one job runner (process pool or Dask cluster), resumable CSV;
* :mod:`~sideslip.studies.runs` - one scenario run, many runs, the library loop without FMI;
* :mod:`~sideslip.studies.papers` - the papers' result tables, one module per paper;
* :mod:`~sideslip.studies.control_eval` - the closed-loop evaluation of the controller, tuning;
* :mod:`~sideslip.studies.speed` - microseconds per FMU step and real-time factor;
* :mod:`~sideslip.studies.accuracy`, :mod:`~sideslip.studies.leaderboard` - the estimator benchmark
  (scenarios under sensor errors and model mismatch, training and test sets) and its leaderboard;
* :mod:`~sideslip.studies.logs` - estimator FMUs on a recorded drive, with metrics and a plot;
* :mod:`~sideslip.studies.metrics`, :mod:`~sideslip.studies.plots` - errors against truth, figures.
"""
