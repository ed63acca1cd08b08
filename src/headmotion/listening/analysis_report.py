"""The listening-test analysis report: figures (PNG) and Markdown tables of what
:func:`headmotion.listening.analysis.summarize` computed (thesis Figs 4.5–4.7, Tables 4.1, 4.3,
4.4, 5.4, 5.9; paper Fig 3)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def figures(res: dict, out: Path) -> dict[str, str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io.atomic import atomic_path

    figs: dict[str, str] = {}

    def save(fig, name):
        with atomic_path(out / name) as tmp:
            fig.savefig(tmp, dpi=110, bbox_inches="tight")
        plt.close(fig)
        figs[name.split(".")[0]] = name

    win = res.get("window")
    if win and win["curves"]:
        for name, band in (("window_difference.png", False), ("window_difference_std.png", True)):
            fig, ax = plt.subplots(figsize=(7, 4))
            for g, c in win["curves"].items():
                x = c["start"] + 1
                line, = ax.plot(x, c["mean"], label=g or "all")
                if band:
                    ax.fill_between(x, c["mean"] - c["std"], c["mean"] + c["std"], alpha=0.2,
                                    color=line.get_color())
            ax.axhline(0, color="k", lw=0.8)
            ax.set_xlabel(f"first trial of the {win['size']}-trial window (presentation order)")
            ax.set_ylabel(f"score difference ({win['reference']} − {win['compare']})")
            ax.set_title("Windowed score difference, normalised by participant and speaker"
                         + (" (± 1 s.d.)" if band else ""))
            ax.legend(title="group")
            save(fig, name)
    rated = res.get("rated_rows")
    if rated:
        ranking = res["ranking"]
        fig, ax = plt.subplots(figsize=(7, 4))
        bins = np.linspace(0, 1, 11)
        for c in ranking:
            ax.hist([r["norm"] for r in rated if r["condition"] == c], bins=bins, density=True,
                    histtype="step", lw=2, label=c)
        ax.set_xlabel("score normalised by participant and speaker")
        ax.set_ylabel("density")
        ax.set_title("Distribution of normalised scores")
        ax.legend()
        save(fig, "score_histogram.png")
        fig, ax = plt.subplots(figsize=(1.4 * len(ranking) + 2, 4))
        key = "value" if res.get("kind") == "mushra" else "norm"
        data = [[r[key] for r in rated if r["condition"] == c] for c in ranking]
        ax.boxplot(data, medianprops={"color": "k"})
        ax.set_xticks(range(1, len(ranking) + 1), ranking, rotation=20)
        if res.get("kind") == "mushra":
            ax.set_ylim(0, 100)
            ax.set_ylabel("MUSHRA score")
            for k, m in enumerate(("Bad", "Poor", "Fair", "Good", "Excellent")):
                ax.axhline(20 * (k + 1), color="0.85", lw=0.8, zorder=0)
                ax.text(len(ranking) + 0.55, 20 * k + 10, m, va="center", fontsize=8,
                        color="0.4")
            ax.set_title("MUSHRA scores (line = median)")
            save(fig, "mushra_boxplot.png")
        else:
            ax.set_ylabel("normalised score")
            ax.set_title("Scores per condition (line = median)")
            save(fig, "score_boxplot.png")
    ab = res.get("ab")
    if ab:
        s, w, n = ab["systems"], ab["wins"], ab["n"]
        with np.errstate(invalid="ignore", divide="ignore"):
            pct = np.where(n > 0, 100 * w / n, np.nan)
        fig, ax = plt.subplots(figsize=(1.2 * len(s) + 3, 1.0 * len(s) + 2))
        im = ax.imshow(pct, vmin=0, vmax=100, cmap="RdBu")
        for i in range(len(s)):
            for j in range(len(s)):
                if np.isfinite(pct[i, j]):
                    ax.text(j, i, f"{pct[i, j]:.0f}%", ha="center", va="center",
                            color="white" if abs(pct[i, j] - 50) > 30 else "black")
        ax.set_xticks(range(len(s)), s, rotation=20)
        ax.set_yticks(range(len(s)), s)
        ax.set_title("% of times the row system was preferred to the column system")
        fig.colorbar(im, ax=ax)
        save(fig, "ab_preferences.png")
    return figs


def _f(x, nd=2) -> str:
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.{nd}f}"


def _p(x) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return "<0.001" if x < 0.001 else f"{x:.3f}"


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def markdown(res: dict, figs: dict[str, str], source: str) -> str:
    t = res["test"]
    md = [f"# Listening test report: {t.get('name', source)}\n",
          f"Source: `{source}`; test type: {t.get('type', res.get('kind', '?'))}.\n",
          f"- participants: {len(res['participants'])}, analysed: {res['n_participants_kept']}",
          f"- excluded (rated everything the same{' / always the same side' if 'ab' in res else ''}):"
          f" {', '.join(map(str, res['excluded'])) or 'none'}",
          f"- training answers (stored, flagged, left out of the tables): "
          f"{res['n_training_answers']}",
          f"- ranking (best first): {', '.join(res.get('ranking', [])) or '–'}\n"]
    for w in res["warnings"]:
        md.append(f"> warning: {w}\n")
    if "attention" in res:
        md.append("## Attention checks\n")
        failed = {p: v for p, v in res["attention"].items() if v < 1}
        md.append(f"{len(res['attention']) - len(failed)} of {len(res['attention'])} participants "
                  "answered every attention check correctly.\n")
        if failed:
            md.append(_table(["participant", "fraction correct"],
                             [[p, _f(v)] for p, v in failed.items()]))
    if "mos_table" in res:
        ranking = res["ranking"]
        md.append("## Mean opinion scores per group (Tables 4.4, 5.9)\n")
        md.append("Raw scores per group; the last two rows are rescaled to [0, 1] per participant "
                  "and speaker (thesis §4.2.3.2) and per participant only (Table 5.9).\n")
        md.append(_table(["participants", "n"] + ranking,
                         [[name, n] + [_f(v[c]) for c in ranking] for name, n, v in
                          res["mos_table"]]))
        if res.get("group_ttests"):
            md.append("## Student's t-tests between participant groups (Table 4.3)\n")
            md.append("p values of two-sample Student's t-tests (equal variances) on the scores "
                      "normalised by participant and speaker; p > 0.05: no evidence that the "
                      "groups rate differently.\n")
            md.append(_table(["question", "groups"] + ranking,
                             [[f, f"{a} vs {b}"] + [_p(ps[c]) for c in ranking]
                              for f, a, b, ps in res["group_ttests"]]))
        md.append("## Pairwise comparisons between systems\n")
        md.append("Per-participant mean normalised scores; paired Student's t-test and Wilcoxon "
                  "signed-rank test; p values Holm-corrected over all pairs.\n")
        md.append(_table(["A", "B", "n", "mean A−B", "t", "p (t)", "p (t, Holm)", "p (Wilcoxon)",
                          "p (Wilcoxon, Holm)"],
                         [[r["a"], r["b"], r["n"], _f(r["mean_diff"], 3), _f(r["t"]), _p(r["p_t"]),
                           _p(r["p_t_holm"]), _p(r["p_wilcoxon"]), _p(r["p_wilcoxon_holm"])]
                          for r in res["pairwise"]]))
    if "mushra_screening" in res:
        s = res["mushra_screening"]
        md.append("## MUSHRA post-screening (reported, not enforced)\n")
        md.append(f"A participant passes when the hidden reference ({s['hidden_reference']!r}) is "
                  f"rated ≥ {s['threshold']:.0f} in at least {100 * s['fraction']:.0f}% of items."
                  "\n")
        md.append(_table(["participant", "items", "fraction ≥ threshold", "passes"],
                         [[r["participant"], r["items"], _f(r["fraction_ok"]),
                           "yes" if r["passes"] else "**no**"] for r in s["participants"]]))
        md.append("Mean raw MUSHRA score of the participants who pass: " + ", ".join(
            f"{c} {_f(v, 1)}" for c, v in res["mushra_after_screening"].items()) + "\n")
    if "mushra_boxplot" in figs:
        md.append("## MUSHRA scores (paper Fig 3)\n\n![MUSHRA box plot](mushra_boxplot.png)\n")
    if "score_boxplot" in figs:
        md.append("## Scores per condition\n\n![box plot](score_boxplot.png)\n")
    if "window" in res and "window_difference" in figs:
        w = res["window"]
        md.append("## Windowed score differences (Figs 4.5–4.6)\n")
        md.append(f"Mean over participants of the difference between {w['reference']!r} and "
                  f"{w['compare']!r} in a {w['size']}-trial window, by presentation order "
                  "(training included), scores normalised by participant and speaker.\n")
        md.append("![windowed difference](window_difference.png)\n\n"
                  "![windowed difference with standard deviation](window_difference_std.png)\n")
        md.append(f"Key statistics from trial {w['size'] + 1} on (Table 4.1):\n")
        md.append(_table(["group", "mean difference", "variance", "mean time for decision (s)",
                          "variance (s²)"],
                         [[k["group"], _f(k["mean_difference"]), _f(k["variance"]),
                           _f(k["mean_time_s"], 1), _f(k["variance_time"], 1)]
                          for k in res["window_stats"]]))
    if "score_histogram" in figs:
        md.append("## Distribution of normalised scores (Fig 4.7)\n\n"
                  "![histogram](score_histogram.png)\n")
    if "ab" in res:
        ab = res["ab"]
        s, w, n = ab["systems"], ab["wins"], ab["n"]
        md.append("## A/B preferences (Table 5.4)\n")
        md.append("Percentage of times the system in the row was preferred to the system in the "
                  "column.\n")
        rows = []
        for i, a in enumerate(s):
            rows.append([a] + ["" if i == j or n[i, j] == 0 else f"{100 * w[i, j] / n[i, j]:.0f}%"
                               for j in range(len(s))])
        md.append(_table(["condition"] + s, rows))
        md.append("Two-sided binomial tests against 50%, Holm-corrected:\n")
        md.append(_table(["A", "B", "comparisons", "A preferred", "p", "p (Holm)"],
                         [[r["a"], r["b"], r["n"], f"{100 * r['a_preferred']:.0f}%", _p(r["p"]),
                           _p(r["p_holm"])] for r in ab["tests"]]))
        md.append("Side balance (times each system of a pair was on the left): " + "; ".join(
            f"{k}: {v[0]}/{v[1]}" for k, v in ab["side_counts"].items()) +
            f". Left chosen in {100 * ab['left_fraction']:.0f}% of trials.\n")
        md.append("![A/B preferences](ab_preferences.png)\n")
    return "\n".join(md)


__all__ = ["figures", "markdown"]
