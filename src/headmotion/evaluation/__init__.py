"""Objective evaluation (thesis §4.3, ch. 3 statistics; paper §4.3).

* :mod:`.metrics` — the one implementation of every metric (NMSE, global/local CCA, Forced CCA,
  SD, jerk/acceleration, distribution statistics).
* :mod:`.realism` — does motion look like a head (band shares, amplitude, drift, speed/acceleration
  Hellinger, limit cycles, saturation, pauses, diversity, beat consistency, pooled coupling);
  :mod:`.realism_figures` draws them.
* :mod:`.chance` — chance levels of CCA-type scores by circular shifts; the paper's chance score.
* :mod:`.cross_coupling` — speech ↔ motion coupling with projections fitted on other speakers'
  recorded heads (``CrossSpeakerCCA``, ``cross_speaker_coupling``); :mod:`.detectability` — the
  classifier two-sample test against recorded heads, its floor, the 3 Hz test and
  ``reversal_rate``.
* :mod:`.protocols` — :func:`~.protocols.evaluate`, cross-validation of every condition: folds
  (:mod:`.folds`, :mod:`.pause_folds`), fitting and running the conditions per fold
  (:mod:`.running`), per-recording and pooled scores (:mod:`.scoring`), the result
  (:mod:`.results`).
* :mod:`.conditions` — the one contract of what is evaluated: trained systems, model files and the
  :mod:`.anchors` (ground truth, desync, shifted, other speaker, shaped noise, still, floor);
  :mod:`.condition_specs` resolves the names ``--systems`` takes.
* :mod:`.parallel` — runs folds and per-recording work on joblib or a Dask cluster;
  :mod:`.feature_table` — corpus features and the paper's Table 1 on it.
* :mod:`.report`, :mod:`.realism_report`, :mod:`.figures` — metrics.csv, report.md and PNG figures
  in the seeds' layouts.
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
