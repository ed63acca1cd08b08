"""Figures of the realism measures (the seeds draw none of these).

* :func:`spectra_figure` — per-axis power spectra (Welch, pooled over recordings by averaging the
  per-recording PSDs interpolated on a common 0–10 Hz grid) of every condition drawn over the
  ground truth's, log power, with the band edges of :data:`~headmotion.evaluation.measures.realism.BANDS`.
* :func:`speed_histogram_figure` — histograms of the angular speed (°/s) of every condition over
  the ground truth's, on the ground truth's bins.
* :func:`realism_coupling_scatter` — one point per condition: x = spectral L1 distance to the
  ground truth (or speed Hellinger), y = pooled FCCA excess over chance, from
  :func:`~headmotion.evaluation.measures.realism.realism_rows` rows (``recording == "ALL"``).

Inputs are ``{condition: [Motion per recording]}``; ``"ground-truth"`` is the reference.
Library: matplotlib (Agg backend); PNGs written atomically.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ...io.atomic import atomic_path
from ..measures import realism as R

GROUND_TRUTH = "ground-truth"
GRID = np.linspace(0.0, 10.0, 201)


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    _plt().close(fig)
    return path


def _order(conditions: Mapping) -> list[str]:
    names = list(conditions)
    return ([GROUND_TRUTH] if GROUND_TRUTH in names else []) + [n for n in names if n != GROUND_TRUTH]


def mean_psd(motions: Sequence) -> np.ndarray:
    """Mean per-axis PSD ``(len(GRID), 3)`` of several motions on the common grid."""
    acc = []
    for m in motions:
        f, p = R.psd(m)
        acc.append(np.stack([np.interp(GRID, f, p[:, j], right=np.nan) for j in range(p.shape[1])], 1))
    return np.nanmean(np.stack(acc), axis=0)


def spectra_figure(conditions: Mapping[str, Sequence], *, path, title: str = "") -> Path:
    plt = _plt()
    names = _order(conditions)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4), sharey=True)
    cmap = plt.get_cmap("tab10")
    floor = None
    for i, n in enumerate(names):
        p = mean_psd(conditions[n])
        if n == GROUND_TRUTH or floor is None:
            pos = p[1:][p[1:] > 0]
            if len(pos):  # the y range follows the ground truth (a still head's ~0 power would squash it)
                floor = float(np.nanmin(pos)) * 1e-2
        for j, ax in enumerate(axes):
            ax.semilogy(GRID[1:], p[1:, j], color="black" if n == GROUND_TRUTH else cmap(i % 10),
                        lw=2.5 if n == GROUND_TRUTH else 1.3, label=n)
    for j, ax in enumerate(axes):
        for lo, _hi in R.BANDS[1:]:
            ax.axvline(lo, color="0.8", lw=0.8, zorder=0)
        ax.set_title(f"{R.AXES[j]}")
        ax.set_xlabel("Hz")
        ax.set_xlim(0, 10)
    if floor is not None and np.isfinite(floor):
        axes[0].set_ylim(bottom=floor)
    axes[0].set_ylabel("power (deg²/Hz)")
    axes[-1].legend(fontsize=8)
    fig.suptitle(f"Per-axis motion spectra {title}".strip())
    return _save(fig, path)


def speed_histogram_figure(conditions: Mapping[str, Sequence], *, path, title: str = "", bins: int = 50) -> Path:
    plt = _plt()
    names = _order(conditions)
    speeds = {n: np.concatenate([R.speed(m) for m in conditions[n]]) for n in names}
    ref = speeds.get(GROUND_TRUTH, speeds[names[0]])
    edges = R.histogram_edges(ref, bins=bins)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    cmap = plt.get_cmap("tab10")
    centres = 0.5 * (edges[1:] + edges[:-1])
    for i, n in enumerate(names):
        h = R.histogram(speeds[n], edges)
        hd = R.hellinger(R.histogram(ref, edges), h)
        ax.plot(centres, h, color="black" if n == GROUND_TRUTH else cmap(i % 10),
                lw=2.5 if n == GROUND_TRUTH else 1.3, label=f"{n} (H={hd:.2f})", drawstyle="steps-mid")
    top = 2.5 * float(R.histogram(ref, edges).max())
    if top > 0:  # a still head's single spike would squash every other curve
        ax.set_ylim(0, min(1.0, top))
    ax.set_xlabel("angular speed (°/s); the last bin holds everything faster")
    ax.set_ylabel("share of frames")
    ax.legend(fontsize=8)
    ax.set_title(f"Speed histograms {title}".strip())
    return _save(fig, path)


def realism_coupling_scatter(rows: Sequence[Mapping], *, path, x: str = "spectral_l1", y: str = "fcca_excess",
                             title: str = "") -> Path:
    plt = _plt()
    summ = [r for r in rows if r.get("recording") == "ALL" and np.isfinite(r.get(x, np.nan))
            and np.isfinite(r.get(y, np.nan))]
    fig, ax = plt.subplots(figsize=(6.5, 5))
    for r in summ:
        p = r.get("fcca_p_pooled", np.nan)
        ax.scatter(r[x], r[y], s=50, marker="o" if (np.isfinite(p) and p < 0.05) else "x")
        ax.annotate(f"{r['condition']}" + (f"\np={p:.2g}" if np.isfinite(p) else ""), (r[x], r[y]),
                    fontsize=8, xytext=(4, 4), textcoords="offset points")
    ax.axhline(0, color="0.6", lw=0.8)
    ax.set_xlabel(f"{x} to the ground truth (lower = more realistic)")
    ax.set_ylabel(f"pooled {y} over chance (higher = more tied to speech)")
    ax.set_title(f"Realism vs coupling {title}  (o: pooled p<0.05)".strip())
    return _save(fig, path)


__all__ = ["spectra_figure", "speed_histogram_figure", "realism_coupling_scatter", "mean_psd"]
