"""Objective evaluation (thesis §4.3, ch. 3 statistics; paper §4.3), grouped by concern:

* :mod:`.measures` — what is measured on a motion: the one implementation of every seed metric
  (NMSE, global/local CCA, Forced CCA, SD, jerk; :mod:`.measures.metrics`), chance levels by
  circular shifts (:mod:`.measures.chance`), realism (:mod:`.measures.realism`), cross-speaker
  coupling (:mod:`.measures.cross_coupling`) and waiting through silence (:mod:`.measures.waiting`);
* :mod:`.detection` — the classifier two-sample test against recorded heads, its floor, the 3 Hz
  test and ``reversal_rate`` (:mod:`.detection.detectability`);
* :mod:`.protocol` — :func:`~.protocol.protocols.evaluate`, cross-validation of every condition:
  folds, the conditions and anchors, running them per fold on joblib or Dask, per-recording and
  pooled scores, the feature table, the result;
* :mod:`.reporting` — metrics.csv, report.md and PNG figures in the seeds' layouts, and the
  dataset statistics' report;
* :mod:`.corpus_stats` — thesis §3.5 dataset statistics (lengths, speaking rate, cross-entropy
  distance, MDS, speaker/task dependency).

Only :mod:`.measures.metrics` is imported here; the rest is imported on use.
"""

from .measures.metrics import (  # noqa: F401
    CCAFit,
    NMSE,
    SDStats,
    cca,
    cca_fit,
    deltas,
    distribution_stats,
    fcca,
    global_cca,
    jerk_accel,
    local_cca,
    nmse,
    sd_stats,
)
