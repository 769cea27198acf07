"""The papers' result tables, reproduced with the FMUs in closed loop: one module per paper.

Each module runs the scenarios of its paper through the fmpy master (estimator FMUs next to
driver, plant and sensors; several runs in parallel on :mod:`sideslip.studies.jobs`), returns
the figures the paper reports next to the paper's own values and formats them as the Markdown
tables of the docs.  Every module has ``report(fmu_dir, workers, params, extra) -> (figures,
text)`` and ``ACCEPTS_PARAMS``; :data:`PAPERS` is the table ``python -m sideslip paper NAME``
dispatches from.
"""
from __future__ import annotations

from . import kim2016, nguyen2012, park2018, pi2011, yoon2014

__all__ = ["PAPERS"]

PAPERS = {"park2018": park2018, "kim2016": kim2016, "nguyen2012": nguyen2012, "pi2011": pi2011, "yoon2014": yoon2014}
"""Paper name -> module (Park 2018 Table 3, Kim 2016 Table 3, Nguyen 2012 Table III, Pi 2011 Table 4,
Yoon & Peng 2014 Section V)."""
