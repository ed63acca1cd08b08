"""The cross-speaker coupling of every condition beside its levels, per speech side (report.md).

A coupling excess is read against two levels: the recorded heads (the ground truth's excess over
the same held-out recordings) and, for a ``motion-match`` condition evaluated with ``level``, its
Praat-read library (:mod:`..protocol.levels`).  Per speech side (:mod:`..measures.speech_sides`)
each condition's pooled excess, its p, its ratio to its level and to the recorded heads; then,
per fold (a held-out source under ``--protocol sources``), the mean excess of every side.
"""

from __future__ import annotations

import numpy as np

from ..protocol.conditions import GROUND_TRUTH
from ..protocol.levels import ratio
from ..protocol.results import EvaluationResult
from .md_tables import table, vals

#: speech side → the coupling metric's name in metrics.csv
SIDE_METRICS = {"praat": "xcca", "own": "xcca_own", "energy": "xcca_energy"}


def _num(x: float, fmt: str = "+.3f") -> str:
    return f"{x:{fmt}}" if np.isfinite(x) else "–"


def _pooled(result: EvaluationResult, system: str, metric: str) -> float:
    v = vals(result, system, metric, ["ALL"])
    return float(v[0]) if len(v) else float("nan")


def levels_md(result: EvaluationResult) -> str:
    """The section, or "" when no condition has a cross-speaker coupling."""
    sides = [s for s in result.config.get("speech_sides") or ["praat"] if s in SIDE_METRICS]
    levels = dict(result.config.get("levels") or {})
    sides = [s for s in sides if any(np.isfinite(_pooled(result, c, f"{SIDE_METRICS[s]}_excess_pooled"))
                                     for c in result.systems)]
    if not sides:
        return ""
    rows = []
    for side in sides:
        m = SIDE_METRICS[side]
        heads = _pooled(result, GROUND_TRUTH, f"{m}_excess_pooled")
        for c in result.systems:
            ex, p = _pooled(result, c, f"{m}_excess_pooled"), _pooled(result, c, f"{m}_p_pooled")
            if not np.isfinite(ex):
                continue
            lv = levels.get(c)
            to_level = ratio(ex, _pooled(result, lv, f"{m}_excess_pooled")) if lv else float("nan")
            to_heads = ratio(ex, heads) if c != GROUND_TRUTH else float("nan")
            rows.append([side, c, _num(ex), _num(p, ".3g"), _num(to_level, ".2f"), _num(to_heads, ".2f")])
    md = ["\n## Coupling beside its levels\n",
          "Cross-speaker coupling (projections fitted on the fold's other recordings) per speech side: "
          + "; ".join(f"*{s}* (`{SIDE_METRICS[s]}`)" for s in sides)
          + ". Pooled excess over the held-out recordings and Stouffer's p; *ratio to level*: the excess over "
          "the level's (the same library read by Praat, same side and seeds; – without a level or when the level "
          "is not above its null); *ratio to recorded heads*: over the ground truth's excess.\n\n"]
    notes = result.config.get("level_notes") or []
    if notes:
        md.append("".join(f"- {n}\n" for n in notes) + "\n")
    md.append(table(["speech side", "condition", "excess", "p", "ratio to level", "ratio to recorded heads"], rows))
    folds = result.config.get("fold_tests") or {}
    if len(folds) > 1:
        md.append(f"\nPer fold: mean excess of the fold's held-out recordings, {' / '.join(sides)}.\n\n")
        frows = []
        for fold, recs in folds.items():
            cells = []
            for c in result.systems:
                v = [vals(result, c, f"{SIDE_METRICS[s]}_excess", recs) for s in sides]
                cells.append(" / ".join(_num(float(np.mean(x))) if len(x) else "–" for x in v))
            frows.append([fold, str(len(recs))] + cells)
        md.append(table(["fold", "n"] + list(result.systems), frows))
    return "".join(md)


__all__ = ["levels_md", "SIDE_METRICS"]
