"""Objective evaluation (thesis §4.3, ch. 3 statistics; paper §4.3).

* :mod:`.metrics` — the one implementation of every metric (NMSE, global/local CCA, Forced CCA,
  SD, jerk/acceleration, distribution statistics).
* :mod:`.realism` — does motion look like a head (band shares, amplitude, drift, speed/acceleration
  Hellinger, limit cycles, saturation, pauses, diversity, beat consistency, pooled coupling);
  :mod:`.realism_figures` draws them.
* :mod:`.chance` — chance levels of CCA-type scores by circular shifts; the paper's chance score.
* :mod:`.protocols` — cross-validation (leave-one-recording-out, the paper split) of systems and
  of the :mod:`.anchors` (evaluation conditions: ground truth, desync, other speaker, shaped
  noise, still).
* :mod:`.parallel` — runs folds and per-recording work on joblib or a Dask cluster;
  :mod:`.feature_table` — corpus features and the paper's Table 1 on it.
* :mod:`.report`, :mod:`.figures` — metrics.csv, report.md and PNG figures in the seeds' layouts.
* :mod:`.corpus_stats` — thesis §3.5 dataset statistics (lengths, speaking rate, cross-entropy
  distance, MDS, speaker/task dependency); :mod:`.stats_report` writes them.

Only :mod:`.metrics` is imported here; the rest is imported on use.
"""

from .metrics import (  # noqa: F401
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
