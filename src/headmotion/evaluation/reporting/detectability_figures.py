"""Figures and the report section of the detectability test (:mod:`.detectability`).

* :func:`statistics_figure` — for the window statistics that separate recorded from generated
  motion most (per-statistic AUC farthest from 0.5), their distributions over 4 s windows,
  recorded against generated, one panel per statistic.
* :func:`figures_for` — that figure for every condition of an evaluation that kept its motions.
* :func:`detectability_section` — the Markdown table of ``report.md``: per condition the
  detectability, both classifiers' balanced accuracy and AUC with 95 % intervals, and the three
  statistics that give it away (recorded vs generated medians).

Library: matplotlib (Agg backend); PNGs written atomically.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ...io.atomic import atomic_path
from ..detection import detectability as D

GROUND_TRUTH = "ground-truth"


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _stats_of(motions: Mapping, fps) -> np.ndarray:
    Ws, _ = D._windows_of(motions, fps, None)
    return D.window_statistics(np.concatenate(Ws)) if Ws else np.zeros((0, len(D.statistic_names())))


def top_statistics(real: Mapping, generated: Mapping, *, fps=None, k: int = 6) -> list[tuple[str, float, float, float]]:
    """``(statistic, AUC, recorded median, generated median)`` of the ``k`` statistics whose AUC
    (generated = positive) is farthest from 0.5."""
    Fr, Fg = _stats_of(real, fps), _stats_of(generated, fps)
    if not len(Fr) or not len(Fg):
        return []
    y = np.r_[np.zeros(len(Fr)), np.ones(len(Fg))]
    aucs = D.statistic_aucs(np.vstack([Fr, Fg]), y)
    names = D.statistic_names()
    order = sorted(range(len(names)), key=lambda j: -abs(aucs[names[j]] - 0.5))[:k]
    return [(names[j], aucs[names[j]], float(np.median(Fr[:, j])), float(np.median(Fg[:, j]))) for j in order]


def statistics_figure(real: Mapping, generated: Mapping, *, fps=None, k: int = 6, label: str = "generated",
                      path) -> Path:
    """Histograms of the ``k`` most separating window statistics, recorded vs ``label``."""
    plt = _plt()
    Fr, Fg = _stats_of(real, fps), _stats_of(generated, fps)
    top = top_statistics(real, generated, fps=fps, k=k)
    names = D.statistic_names()
    cols = 3
    rows = max(1, int(np.ceil(len(top) / cols)))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.9 * rows), squeeze=False)
    for ax in axes.ravel()[len(top):]:
        ax.axis("off")
    for ax, (name, auc, _, _) in zip(axes.ravel(), top):
        j = names.index(name)
        lo, hi = np.percentile(np.r_[Fr[:, j], Fg[:, j]], [1, 99])
        bins = np.linspace(lo, hi if hi > lo else lo + 1e-6, 25)
        ax.hist(np.clip(Fr[:, j], lo, hi), bins=bins, density=True, alpha=0.55, color="tab:blue", label="recorded")
        ax.hist(np.clip(Fg[:, j], lo, hi), bins=bins, density=True, alpha=0.55, color="tab:orange", label=label)
        ax.set_title(f"{name} (AUC {auc:.2f})", fontsize=9)
        ax.tick_params(labelsize=7)
    axes.ravel()[0].legend(fontsize=7)
    fig.suptitle(f"4 s windows: recorded ({len(Fr)}) vs {label} ({len(Fg)}) — the statistics that separate most",
                 fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def figures_for(result, out_dir) -> list[Path]:
    """:func:`statistics_figure` for every condition of an evaluation result that kept its motions."""
    if not result.motions or GROUND_TRUTH not in result.motions:
        return []
    real = result.motions[GROUND_TRUTH]
    out = []
    for cond, gen in result.motions.items():
        g = {r: m for r, m in gen.items() if r in real}
        if cond == GROUND_TRUTH or len(g) < 2:
            continue
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in cond)
        try:
            out.append(statistics_figure({r: real[r] for r in g}, g, fps=result.fps, label=cond,
                                         path=Path(out_dir) / f"detect_{safe}.png"))
        except (ValueError, KeyError):
            continue  # too little motion for one 4 s window
    return out


def _cell(d: dict, key: str) -> str:
    v, lo, hi = d.get(key, np.nan), d.get(f"{key}_lo", np.nan), d.get(f"{key}_hi", np.nan)
    return "–" if not np.isfinite(v) else f"{v:.2f} [{lo:.2f}, {hi:.2f}]"


def detectability_section(rows: Sequence[Mapping], systems: Sequence[str], *, top: int = 3) -> str:
    """Markdown: the detectability table (``recording == "ALL"`` rows of
    :func:`~headmotion.evaluation.detection.detectability.detectability_rows`), '' when there are none."""
    per: dict[str, dict[str, float]] = {}
    for r in rows:
        if r["recording"] == "ALL" and str(r["metric"]).startswith("detect"):
            per.setdefault(r["system"], {})[r["metric"]] = float(r["value"])
    if not per:
        return ""
    lines = ["## Detectability", "",
             "Classifier two-sample test of recorded against generated motion (4 s windows, 6 Hz low-pass, 25 fps; "
             "folds grouped by recording; out-of-fold balanced accuracy (BA) and AUC with 95 % bootstrap intervals "
             "over recordings). Detectability = the larger BA: 0.5 cannot be told apart, 1 always is. Where the "
             "folds allow, the classifiers are trained and tested within each evaluation fold (a system replaying "
             "recorded motion made one fold's motion from the other folds' recordings); *over all folds* is the "
             "statistics classifier's BA on every fold's windows at once. *Floor*: the detectability of the "
             "`floor` condition — other speakers' recorded heads (the training folds') against the held-out ones, "
             "the level the data allows; *above floor* = detectability − floor. *3 Hz*: the same test with both "
             "sides low-passed at 3 Hz, where a tracker's jitter decides nothing. *Reversals*: share of 25 fps "
             "frames where the angular velocity changes sign (6 Hz low-pass), pitch / yaw / roll; the "
             "ground truth's are the recorded heads'.", "",
             "| condition | detectability | floor | above floor | 3 Hz | 3 Hz above floor | reversals p / y / r | "
             "BA statistics | AUC statistics | BA CNN | AUC CNN | over all folds | gives it away (AUC) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    rev = {}
    for r in rows:
        if r["recording"] == "ALL" and str(r["metric"]).startswith("reversals_"):
            rev.setdefault(r["system"], {})[r["metric"]] = float(r["value"])

    def num(d, key, fmt="{:.2f}"):
        v = d.get(key, np.nan)
        return "–" if not np.isfinite(v) else fmt.format(v)

    for s in systems:
        d = per.get(s, {})
        rv = rev.get(s, {})
        revs = " / ".join(num(rv, f"reversals_{ax}") for ax in D.AXES) if rv else "–"
        if "detect" not in d:
            if s == GROUND_TRUTH and rv:
                lines.append(f"| {s} | – | – | – | – | – | {revs} | – | – | – | – | – | – |")
            continue
        stats = sorted(((k[len("detect_stat_auc["):-1], v) for k, v in d.items() if k.startswith("detect_stat_auc[")),
                       key=lambda kv: -abs(kv[1] - 0.5))[:top]
        give = ", ".join(f"{n} {v:.2f}" for n, v in stats)
        within = d.get("detect_within_folds", 0.0) == 1.0
        pooled = f"{d['detect_pooled']:.2f}" if "detect_pooled" in d else "–"
        lines.append(f"| {s} | {d['detect']:.2f} | {num(d, 'detect_floor')} | {num(d, 'detect_above_floor', '{:+.2f}')} | "
                     f"{num(d, 'detect_3hz')} | {num(d, 'detect_3hz_above_floor', '{:+.2f}')} | {revs} | "
                     f"{_cell(d, 'detect_ba_stats')} | {_cell(d, 'detect_auc_stats')} | "
                     f"{_cell(d, 'detect_ba_cnn')} | {_cell(d, 'detect_auc_cnn')} | {pooled if within else '–'} | "
                     f"{give} |")
    ruler = per.get(GROUND_TRUTH, {})
    if any(k.startswith("detect_reversed") for k in ruler):
        lines += ["", "Ruler (recorded heads against): " + "; ".join(
            f"{lab} {ruler.get(f'detect_{key}', np.nan):.2f}" for key, lab in
            (("reversed", "their time reversal"), ("phase_randomised", "phase-randomised copies"),
             ("still", "the still head")) if f"detect_{key}" in ruler) + "."]
    return "\n".join(lines) + "\n"


__all__ = ["statistics_figure", "figures_for", "top_statistics", "detectability_section"]
