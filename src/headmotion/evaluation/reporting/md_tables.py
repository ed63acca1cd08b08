"""Markdown table helpers of the evaluation reports (:mod:`.report`, :mod:`.realism_report`):
a metric's finite values per condition, ``mean ± SD`` cells, tables, recordings per speaker."""

from __future__ import annotations

import numpy as np

from ..protocol.results import EvaluationResult


def vals(result: EvaluationResult, system: str, metric: str, recordings=None) -> np.ndarray:
    """The finite values of ``metric`` for ``system`` (over ``recordings``, default all)."""
    v = [r["value"] for r in result.rows if r["system"] == system and r["metric"] == metric
         and (recordings is None or r["recording"] in recordings)]
    v = np.array(v, dtype=float)
    return v[np.isfinite(v)]


def mean_sd(v: np.ndarray, digits: int = 3) -> str:
    """``mean ± SD`` (one value: the value; none: ``–``)."""
    if len(v) == 0:
        return "–"
    if len(v) == 1:
        return f"{v[0]:.{digits}f}"
    return f"{np.mean(v):.{digits}f} ± {np.std(v, ddof=1):.{digits}f}"


def mean(v: np.ndarray, digits: int = 3) -> str:
    """The mean (none: ``–``)."""
    return "–" if len(v) == 0 else f"{np.mean(v):.{digits}f}"


def table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out) + "\n"


def speakers(result: EvaluationResult) -> dict[str, list[str]]:
    """Held-out recordings per speaker."""
    by: dict[str, list[str]] = {}
    for rid in result.recordings:
        by.setdefault(result.speakers.get(rid, "?"), []).append(rid)
    return by


__all__ = ["vals", "mean_sd", "mean", "table", "speakers"]
