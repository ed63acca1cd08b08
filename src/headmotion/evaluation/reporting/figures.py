"""PNG figures of an evaluation (paper Fig 2; thesis Figs 4.8, 4.11) and of corpus statistics
(thesis Figs 3.2–3.6).

matplotlib (Agg backend, imported inside the functions so that importing this module is cheap).
Every figure is written atomically.

* :func:`sd_bars` — per-system SD of each rotation component and of its derivative (paper Fig 2).
* :func:`window_curve` — local vs global CCA between speech features and motion against window
  size, 2–100 s (thesis Fig 4.8).
* :func:`fcca_per_condition` — Forced CCA per recording for every condition, with the ground
  truth and the circular-shift chance level marked (thesis Fig 4.11).
* :func:`trajectories` — pitch / yaw / roll of the ground truth and every system for one recording.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...io.atomic import atomic_path
from ..protocol.protocols import GROUND_TRUTH, EvaluationResult


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    _plt().close(fig)
    return path


def _vals(result: EvaluationResult, system: str, metric: str, recordings=None) -> np.ndarray:
    v = np.array([r["value"] for r in result.rows if r["system"] == system and r["metric"] == metric
                  and (recordings is None or r["recording"] in recordings)], dtype=float)
    return v[np.isfinite(v)]


def _one(result: EvaluationResult, system: str, metric: str, recording: str) -> float:
    v = _vals(result, system, metric, [recording])
    return float(v[0]) if len(v) else float("nan")


def _colors(n):
    plt = _plt()
    cmap = plt.get_cmap("tab10")
    return [cmap(i % 10) for i in range(n)]


def sd_bars(result: EvaluationResult, path) -> Path:
    """Paper Fig 2: SD of rotation (°) and of its derivative (°/s) per axis and system."""
    plt = _plt()
    systems = result.systems
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    width = 0.8 / max(1, len(systems))
    cols = _colors(len(systems))
    for prefix, unit, ax in (("sd", "°", axes[0]), ("sdvel", "°/s", axes[1])):
        for i, s in enumerate(systems):
            means, sds = [], []
            for a in ("rx", "ry", "rz"):
                v = np.degrees(_vals(result, s, f"{prefix}_{a}"))
                means.append(np.mean(v) if len(v) else np.nan)
                sds.append(np.std(v) if len(v) > 1 else 0.0)
            x = np.arange(3) + (i - (len(systems) - 1) / 2) * width
            # an SD is never negative: the lower whisker stops at 0
            lower = np.minimum(np.nan_to_num(means), sds)
            ax.bar(x, means, width, yerr=[lower, sds], capsize=2, color=cols[i], label=s)
        ax.set_xticks(range(3))
        ax.set_xticklabels(["X (pitch)", "Y (yaw)", "Z (roll)"] if prefix == "sd" else ["ΔX", "ΔY", "ΔZ"])
        ax.set_ylabel(f"SD ({unit})")
        ax.set_title("rotation" if prefix == "sd" else "velocity")
        ax.grid(axis="y", alpha=0.3)
    axes[1].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.suptitle("SD of head rotation and its derivative, mean over held-out recordings (paper Fig 2)")
    return _save(fig, path)


def window_curve(result: EvaluationResult, path) -> Path | None:
    """Thesis Fig 4.8: local and global CCA (speech features ↔ motion + Δ) against window size."""
    plt = _plt()
    rows = [r for r in result.rows if r["system"] == GROUND_TRUTH and r["metric"].startswith("winlocal[")]
    if not rows:
        return None
    speakers = sorted({r["recording"] for r in rows})
    fig, ax = plt.subplots(figsize=(6.5, 4))
    cols = _colors(len(speakers))
    for c, sp in zip(cols, speakers):
        pts = []
        for r in rows:
            if r["recording"] != sp:
                continue
            ws = float(r["metric"][len("winlocal["):-2])
            g = _vals(result, GROUND_TRUTH, f"winglobal[{r['metric'][len('winlocal['):-1]}]", [sp])
            pts.append((ws, r["value"], g[0] if len(g) else np.nan))
        pts.sort()
        w = [p[0] for p in pts]
        name = sp.split(":", 1)[-1]
        ax.plot(w, [p[1] for p in pts], "o-", color=c, label=f"{name} local")
        ax.plot(w, [p[2] for p in pts], "s--", color=c, alpha=0.7, label=f"{name} global")
    ax.set_xscale("log")
    ticks = [2, 3, 5, 10, 20, 30, 50, 100]
    ax.set_xticks(ticks)
    ax.set_xticklabels([str(t) for t in ticks])
    ax.minorticks_off()
    ax.set_xlabel("window size (s)")
    ax.set_ylabel("first canonical correlation")
    ax.set_ylim(0, 1)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title(f"Local vs global CCA, {result.config.get('features')} ↔ head motion + Δ (thesis Fig 4.8)")
    return _save(fig, path)


def fcca_per_condition(result: EvaluationResult, path) -> Path:
    """Thesis Fig 4.11: Forced CCA per held-out recording, one panel per condition."""
    plt = _plt()
    conds = [s for s in result.systems if s != GROUND_TRUTH]
    recs = result.recordings
    n = max(1, len(conds))
    fig, axes = plt.subplots(n, 1, figsize=(max(6, 0.35 * len(recs) + 2), 2.2 * n), sharex=True, squeeze=False)
    x = np.arange(len(recs))
    gt = np.array([_one(result, GROUND_TRUTH, "fcca", r) for r in recs])
    for ax, s in zip(axes[:, 0], conds or [GROUND_TRUTH]):
        v = np.array([_one(result, s, "fcca", r) for r in recs])
        nul = np.array([_one(result, s, "fcca_null_p95", r) for r in recs])
        ax.bar(x, v, 0.7, color="tab:blue", label="condition")
        ax.plot(x, gt, "k_", markersize=14, mew=2, label="ground truth")
        ax.plot(x, nul, "r.", label="chance 95%")
        ax.set_ylabel("FCCA")
        ax.set_ylim(0, max(0.5, np.nanmax(np.concatenate([gt, v, nul, [0]])) * 1.1))
        ax.set_title(s, fontsize=9, loc="left")
        ax.grid(axis="y", alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=3, loc="lower right", bbox_to_anchor=(1.0, 1.0), frameon=False)
    axes[-1, 0].set_xticks(x)
    axes[-1, 0].set_xticklabels(recs, rotation=60, ha="right", fontsize=7)
    fig.suptitle(f"Forced CCA with {result.config.get('features')} per held-out recording (thesis Fig 4.11)")
    fig.tight_layout()
    return _save(fig, path)


def trajectories(result: EvaluationResult, path, *, seconds: float | None = 20.0) -> Path | None:
    """Pitch, yaw and roll (°) of the ground truth and every system for one recording."""
    if not result.trajectories:
        return None
    plt = _plt()
    fps = result.trajectory_fps
    order = [s for s in result.systems if s in result.trajectories]
    n = len(result.trajectories[order[0]])
    m = n if seconds is None else min(n, int(seconds * fps))
    t = np.arange(m) / fps
    fig, axes = plt.subplots(3, 1, figsize=(10, 6.5), sharex=True)
    cols = _colors(len(order))
    for c, s in zip(cols, order):
        rv = np.degrees(result.trajectories[s][:m])
        for k, ax in enumerate(axes):
            ax.plot(t, rv[:, k], color="k" if s == GROUND_TRUTH else c, lw=1.6 if s == GROUND_TRUTH else 1.0,
                    label=s, alpha=1.0 if s == GROUND_TRUTH else 0.8)
    for ax, name in zip(axes, ("pitch rx (°)", "yaw ry (°)", "roll rz (°)")):
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    axes[0].legend(fontsize=8, ncol=min(4, len(order)), loc="upper right")
    span = f"first {m / fps:.0f} s of {n / fps:.1f} s" if m < n else f"{n / fps:.1f} s"
    fig.suptitle(f"Head rotation, recording {result.trajectory_recording} ({span})")
    fig.tight_layout()
    return _save(fig, path)


def evaluation_figures(result: EvaluationResult, out_dir) -> list[Path]:
    """All evaluation figures into ``out_dir``; returns the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [sd_bars(result, out / "sd_bars.png"), window_curve(result, out / "cca_vs_window.png"),
             fcca_per_condition(result, out / "fcca_per_condition.png"), trajectories(result, out / "trajectories.png")]
    return [p for p in paths if p is not None]


__all__ = ["sd_bars", "window_curve", "fcca_per_condition", "trajectories", "evaluation_figures"]
