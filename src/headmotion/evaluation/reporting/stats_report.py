"""The corpus-statistics report: Markdown, CSV, JSON and figures of a
:class:`~headmotion.evaluation.corpus_stats.CorpusStats` (what ``headmotion stats`` writes; thesis
§3.5, §4.3 — the computation is in :mod:`.corpus_stats`).

Library considered: matplotlib (figures); the Markdown is written by hand.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Sequence

import numpy as np

from ...io.atomic import atomic_path, atomic_write_text
from ..corpus_stats import N_BINS, CorpusStats, speaker_means


# -- writing --------------------------------------------------------------------------------------
def _mmss(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 60}:{s % 60:02d}"


def _md_table(header, rows) -> str:
    return "\n".join(["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
                     + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]) + "\n"


def render_stats(st: CorpusStats, *, figures: Sequence[str] = ()) -> str:
    rows = st.recordings
    speakers = sorted({r["speaker"] for r in rows})
    tasks = sorted({r["task"] for r in rows})
    md = ["# Corpus statistics (thesis §3.5)\n",
          f"{len(rows)} recordings, {len(speakers)} speaker(s), tasks {', '.join(tasks)}; "
          f"{_mmss(sum(r['seconds'] for r in rows))} (min:sec) in total.\n"]
    # Table 3.2
    md.append("## Lengths of recordings, min:sec (Table 3.2)\n")
    t_rows = []
    for s in speakers:
        r = [s] + [_mmss(sum(x["seconds"] for x in rows if x["speaker"] == s and x["task"] == t)) for t in tasks]
        r.append(_mmss(sum(x["seconds"] for x in rows if x["speaker"] == s)))
        t_rows.append(r)
    t_rows.append(["**Total**"] + [_mmss(sum(x["seconds"] for x in rows if x["task"] == t)) for t in tasks]
                  + [_mmss(sum(x["seconds"] for x in rows))])
    md.append(_md_table(["Speaker"] + tasks + ["Total"], t_rows))
    # Table 3.3
    if rows and "speech_rate" in rows[0]:
        md.append("\n## Speaking rate, syllables/s from syllable nuclei (de Jong & Wempe 2009) (Table 3.3)\n")
        hdr = ["Speaker"]
        for t in tasks + ["Overall"]:
            hdr += [f"{t} mean", f"{t} SD"]
        r_rows = []
        for s in speakers:
            r = [s]
            for t in tasks + [None]:
                v = np.array([x["speech_rate"] for x in rows if x["speaker"] == s and (t is None or x["task"] == t)])
                r += [f"{v.mean():.2f}" if len(v) else "–", f"{v.std(ddof=1):.2f}" if len(v) > 1 else "–"]
            r_rows.append(r)
        md.append(_md_table(hdr, r_rows))
    # Table 3.4
    md.append("\n## Distribution of rotation-vector components, radians (Table 3.4)\n")
    cols = list(st.distribution)
    md.append(_md_table([""] + cols, [
        ["Skew"] + [f"{st.distribution[c]['skew']:.2f}" for c in cols],
        ["Kurtosis"] + [f"{st.distribution[c]['kurtosis']:.3g}" for c in cols],
        ["KS (fitted normal)"] + [f"{st.distribution[c]['ks']:.2f}" for c in cols],
        ["KS (N(0,1), as the thesis)"] + [f"{st.distribution[c]['ks_std_normal']:.2f}" for c in cols]]))
    # Table 3.5
    md.append(f"\n## Cross-entropy distance statistics (Table 3.5)\n\nRotation + Δ + ΔΔ, {N_BINS}-bin histograms on "
              "common edges, add-one smoothing, dimensions independent (eq 3.1). 'Between tasks' uses pairs of the "
              "same speaker only.\n\n")
    md.append(_md_table(["Condition", "pairs", "Mean", "Variance"],
                        [[p["condition"], p["pairs"], f"{p['mean']:.3e}", f"{p['variance']:.3e}"] for p in st.pairs]))
    md.append(f"\nMDS to 2-D: Kruskal stress-1 = {st.stress1:.3f} (eq 3.2 without the square root: "
              f"{st.stress_eq32:.3f}).\n")
    # Table 3.6
    if st.rate_correlation:
        md.append("\n## Pearson correlation between speaking-rate difference and motion distance (Table 3.6)\n")
        md.append(_md_table(["Task", "pairs", "Correlation", "p"],
                            [[c["task"], c["pairs"], f"{c['correlation']:.3f}", f"{c['p']:.3g}"]
                             for c in st.rate_correlation]))
    # paper Table 1 (thesis §5.7.1)
    if st.feature_config:
        from .report import feature_table_section

        fc = st.feature_config
        md.append(feature_table_section(st.feature_table, feature_sets=fc["feature_sets"], splits=fc["splits"],
                                        speakers=fc["speakers"], window_s=fc["window_s"], seed=fc["seed"],
                                        n_shifts=fc["n_shifts"]))
    # Appendix A tables
    names, H = speaker_means(st.distances, [r["speaker"] for r in rows])
    if len(names) > 1:
        md.append("\n## Mean distance between speakers (Appendix Table A.1; heat map Fig 3.4)\n")
        md.append(_md_table([""] + names, [[a] + [f"{v:.3f}" for v in H[i]] for i, a in enumerate(names)]))
    if figures:
        md.append("\n## Figures\n")
        md += [f"![{Path(f).stem}]({f})\n" for f in figures]
    md.append("\n## Timings (s)\n")
    md.append(_md_table(["step", "seconds"], [[k, f"{v:.1f}"] for k, v in st.timings.items()]))
    if st.warnings:
        md.append("\n## Warnings\n")
        md.append("".join(f"- {w}\n" for w in st.warnings))
    return "\n".join(md)


def _save_fig(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def stats_figures(st: CorpusStats, out_dir) -> list[Path]:
    """Fig 3.2 (distributions), Fig 3.3 (MDS), Figs 3.4–3.6 (heat maps overall and per task)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    # Fig 3.2
    fig, axes = plt.subplots(3, 3, figsize=(10, 7))
    for ax, (nm, (e, c)) in zip(axes.ravel(), st.histograms.items()):
        ax.bar(e[:-1], c, width=np.diff(e), align="edge", color="tab:blue")
        ax.set_title(nm, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.xaxis.set_major_locator(plt.MaxNLocator(4))
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-2, 2))
    fig.suptitle(f"Distribution of rotation-vector components and their Δ, ΔΔ ({N_BINS} bins, radians) — Fig 3.2")
    fig.tight_layout()
    paths.append(_save_fig(fig, out / "distributions.png"))
    # Fig 3.3
    rows = st.recordings
    speakers = sorted({r["speaker"] for r in rows})
    tasks = sorted({r["task"] for r in rows})
    markers = "osD^v<>P*X"
    cmap = plt.get_cmap("tab20" if len(speakers) > 10 else "tab10")
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    for i, s in enumerate(speakers):
        for j, t in enumerate(tasks):
            idx = [k for k, r in enumerate(rows) if r["speaker"] == s and r["task"] == t]
            if idx:
                ax.scatter(st.mds[idx, 0], st.mds[idx, 1], color=cmap(i % cmap.N), marker=markers[j % len(markers)],
                           s=40, label=f"{s} / {t}", edgecolors="k", linewidths=0.4)
    ax.set_title(f"MDS of cross-entropy distances (Fig 3.3), stress-1 = {st.stress1:.3f}")
    ax.set_xlabel("dimension 1")
    ax.set_ylabel("dimension 2")
    ax.grid(alpha=0.3)
    if len(speakers) * len(tasks) <= 30:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    else:  # too many for a legend: label the points
        for k, r in enumerate(rows):
            ax.annotate(r["speaker"][:12], st.mds[k], fontsize=5, alpha=0.8, xytext=(2, 2),
                        textcoords="offset points")
    paths.append(_save_fig(fig, out / "mds.png"))
    # Figs 3.4-3.6
    spk = [r["speaker"] for r in rows]
    tsk = np.array([r["task"] for r in rows])
    for label, mask in [("all", None)] + [(t, tsk == t) for t in tasks]:
        names, H = speaker_means(st.distances, spk, mask)
        if not names:
            continue
        fig, ax = plt.subplots(figsize=(1.0 + 0.55 * len(names) + 1.5, 1.0 + 0.55 * len(names)))
        im = ax.imshow(H, cmap="viridis_r")
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(names, rotation=60, ha="right", fontsize=8)
        ax.set_yticks(range(len(names)))
        ax.set_yticklabels(names, fontsize=8)
        if len(names) <= 12:
            for a in range(len(names)):
                for b in range(len(names)):
                    if np.isfinite(H[a, b]):
                        light = (H[a, b] - np.nanmin(H)) < 0.5 * (np.nanmax(H) - np.nanmin(H))
                        ax.text(b, a, f"{H[a, b]:.2f}", ha="center", va="center", fontsize=7,
                                color="k" if light else "w")
        fig.colorbar(im, ax=ax, label="mean cross-entropy distance")
        ax.set_title(f"Mean distance between speakers ({label})", fontsize=10)
        paths.append(_save_fig(fig, out / f"heatmap_{label}.png"))
    return paths


def write_stats(st: CorpusStats, out_dir, *, figures: bool = True) -> dict:
    """``stats.md``, ``recordings.csv`` (lengths, speaking rates, MDS coordinates), ``distances.csv``,
    ``stats.json`` and the figures into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = stats_figures(st, out / "figures") if figures else []
    buf = io.StringIO()
    keys = list(st.recordings[0].keys()) + ["mds_x", "mds_y"]
    w = csv.DictWriter(buf, fieldnames=keys, lineterminator="\n")
    w.writeheader()
    for r, xy in zip(st.recordings, st.mds):
        w.writerow({**r, "mds_x": float(xy[0]), "mds_y": float(xy[1])})
    atomic_write_text(out / "recordings.csv", buf.getvalue())
    buf = io.StringIO()
    ids = [r["recording"] for r in st.recordings]
    cw = csv.writer(buf, lineterminator="\n")
    cw.writerow([""] + ids)
    for rid, row in zip(ids, st.distances):
        cw.writerow([rid] + [f"{v:.6g}" for v in row])
    atomic_write_text(out / "distances.csv", buf.getvalue())
    atomic_write_text(out / "stats.json", json.dumps({
        "distribution": st.distribution, "pairs": st.pairs, "rate_correlation": st.rate_correlation,
        "stress1": st.stress1, "stress_eq32": st.stress_eq32, "timings": st.timings,
        "feature_table": st.feature_table,
        "feature_config": {k: v for k, v in st.feature_config.items() if k != "speakers"},
        "warnings": st.warnings}, indent=2))
    atomic_write_text(out / "stats.md", render_stats(st, figures=[f"figures/{p.name}" for p in figs]))
    return {"report": out / "stats.md", "figures": figs}


__all__ = ["render_stats", "stats_figures", "write_stats"]
