"""The result of an evaluation and its assembly from the folds' results (what :mod:`.report`
writes as ``metrics.csv``, ``report.md`` and figures).

:func:`assemble` merges the folds' results in fold order (whatever order they finished in), adds
the corpus-wide feature table (paper Table 1), thesis Fig 4.8 per speaker and the measures pooled
over each condition's held-out recordings (:data:`.scoring.POOLED_MEASURES`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ...types import Motion
from .conditions import GROUND_TRUTH
from . import scoring as S
from .scoring import PooledScoring, fig48_rows, rows_of


@dataclass
class EvaluationResult:
    """Rows ``{system, recording, metric, value}`` plus what the figures need."""

    rows: list[dict]
    config: dict
    systems: list[str]
    recordings: list[str]
    trajectories: dict[str, np.ndarray] = field(default_factory=dict)
    trajectory_recording: str | None = None
    trajectory_fps: float = 100.0
    timings: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    speakers: dict[str, str] = field(default_factory=dict)
    #: paper §4.1 split of every corpus recording (labels the paper Table 1 columns)
    splits: dict[str, str] = field(default_factory=dict)
    #: ``{condition: {recording: (T, 3) rotation vectors}}`` of every held-out recording (realism figures)
    motions: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    #: frame rate of each held-out recording's motion
    fps: dict[str, float] = field(default_factory=dict)

    def values(self, system: str, metric: str) -> np.ndarray:
        """All values of ``metric`` for ``system`` over recordings (NaNs kept)."""
        return np.array([r["value"] for r in self.rows if r["system"] == system and r["metric"] == metric],
                        dtype=float)

    def mean(self, system: str, metric: str) -> float:
        v = self.values(system, metric)
        v = v[np.isfinite(v)]
        return float(np.mean(v)) if len(v) else float("nan")

    def metrics(self) -> list[str]:
        seen: dict[str, None] = {}
        for r in self.rows:
            seen.setdefault(r["metric"], None)
        return list(seen)




def assemble(results: Sequence[dict], *, corpus, conditions: Sequence[str], table: dict, table_warnings: list[str],
             fig48: bool, n_shifts: int, trajectory_recording: str | None, config: dict, timings: dict,
             splits: dict[str, str], seed: int = 0, options: dict | None = None) -> EvaluationResult:
    """One :class:`EvaluationResult` from the folds' :func:`~.running.run_fold` results (in fold
    order) and the feature table (``{recording: {metric: value}}``); ``conditions`` = every
    condition's name, the ground truth first; ``options`` = settings of the pooled measures
    (:attr:`.scoring.PooledScoring.options`)."""
    rows: list[dict] = []
    traj: dict[str, np.ndarray] = {}
    gt: dict = {}
    warns: list[str] = []
    motions: dict[str, dict[str, np.ndarray]] = {}
    k_samples: dict[str, dict[str, list]] = {}
    fold_of: dict[str, int] = {}
    for k, res in enumerate(results):
        fold_of.update(dict.fromkeys(res["gt"], k))
        rows += res["rows"]
        for cond, d in res.get("motions", {}).items():
            motions.setdefault(cond, {}).update(d)
        for cond, d in res.get("samples", {}).items():
            k_samples.setdefault(cond, {}).update(d)
        traj.update(res["trajectories"])
        gt.update(res["gt"])
        warns += res["warnings"]
        for k, v in res["timings"].items():
            timings[k] = timings.get(k, 0.0) + v
    for rid in corpus.ids:
        if table.get(rid):
            rows += rows_of(GROUND_TRUTH, rid, table[rid])
    warns += table_warnings
    if fig48:
        rows += fig48_rows(gt)
    pooled = PooledScoring(rows=list(rows), conditions=list(conditions), motions=motions,
                           references={rid: Motion(g[0], g[3]) for rid, g in gt.items()}, samples=k_samples,
                           n_shifts=n_shifts, seed=int(seed), options=dict(options or {}),
                           folds=fold_of)
    for measure in S.POOLED_MEASURES:
        t0 = time.perf_counter()
        rows += measure.fn(pooled)
        timings[measure.name] = timings.get(measure.name, 0.0) + time.perf_counter() - t0
    recs = [rid for rid in corpus.ids if rid in gt]
    fps = gt[trajectory_recording][3] if trajectory_recording in gt else 100.0
    return EvaluationResult(rows=rows, config=config, systems=list(conditions), recordings=recs,
                            trajectories=traj, trajectory_recording=trajectory_recording, trajectory_fps=fps,
                            timings=timings, warnings=warns, speakers={e.recording: e.speaker for e in corpus.entries},
                            splits=splits, motions=motions, fps={rid: gt[rid][3] for rid in recs})


__all__ = ["EvaluationResult", "assemble"]
