"""The realism targets table from one or more ``headmotion evaluate`` report directories.

One row per (evaluation, condition): the realism medians of :func:`headmotion.evaluation.reporting.report.
realism_summary` with the targets of :func:`~headmotion.evaluation.reporting.report.realism_targets` marked
(✓ met, ✗ not; the spectral L1 and the speed Hellinger are shown per recording (median) and
pooled over the test set (and over all K samples of a stochastic system), the targets use the pooled ones), the pooled FCCA excess with its Stouffer p, the cross-speaker coupling and the beat alignment (excess, Stouffer p), the detectability beside the floor (other speakers' recorded heads) at 6 Hz and at 3 Hz, the direction reversals per frame, and the number of targets met.  With
several evaluations of the same corpus (seeds), ``--mean-over`` adds one row per condition with the
mean over them (p: Stouffer of the per-run pooled p-values is *not* valid for overlapping data, so
the row shows the largest p).  Usage::

    PYTHONPATH=src python scripts/targets_table.py LABEL=REPORT_DIR [LABEL=REPORT_DIR ...] [-o table.md]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from headmotion.evaluation.protocol.protocols import EvaluationResult
from headmotion.evaluation.reporting.report import read_metrics_csv, realism_summary, realism_targets, ruler_anchor

TARGETS = ("band", "l1", "sd", "speed", "lc", "sat", "pause")


def load(report_dir: Path) -> EvaluationResult:
    rows = read_metrics_csv(report_dir / "metrics.csv")
    cfg = json.loads((report_dir / "config.json").read_text()) if (report_dir / "config.json").is_file() else {}
    systems = list(dict.fromkeys(r["system"] for r in rows))
    recs = sorted({r["recording"] for r in rows if r["recording"] != "ALL" and not r["recording"].startswith("speaker:")})
    return EvaluationResult(rows=rows, config=cfg, systems=systems, recordings=recs)


def mark(v: float, ok, digits: int = 2) -> str:
    if not np.isfinite(v):
        return "–"
    return f"{v:.{digits}f}" + ("" if ok is None else (" ✓" if ok else " ✗"))


def fmt_p(p: float) -> str:
    return "–" if not np.isfinite(p) else ("<0.001" if p < 0.001 else f"{p:.3f}")


def _speed_cell(d: dict, ok) -> str:
    """Pooled speed Hellinger: of the first sample, and over all K samples (the target's, when
    evaluated) after a slash."""
    one, k = d.get("speed_hellinger_pooled", np.nan), d.get("speed_hellinger_pooled_k", np.nan)
    if not np.isfinite(k):
        return mark(one, ok, 3)
    return f"{one:.3f} / {mark(k, ok, 3)}"


def _pause_cell(d: dict, ok) -> str:
    """Pause/speech speed ratio: of the first sample, and over all K samples (the target's, when
    evaluated) after a slash."""
    one, k = d.get("pause_ratio", np.nan), d.get("pause_ratio_k", np.nan)
    if not np.isfinite(k):
        return mark(one, ok)
    return f"{one:.2f} / {mark(k, ok)}"


def _detect_cell(d: dict) -> str:
    """Detectability (the larger of the two classifiers' balanced accuracies; statistics / CNN)."""
    v = d.get("detect", np.nan)
    if not np.isfinite(v):
        return "–"
    return f"{v:.2f} ({mark(d.get('detect_ba_stats', np.nan), None)} / {mark(d.get('detect_ba_cnn', np.nan), None)})"


def _floor_cell(d: dict, key: str = "detect") -> str:
    """A detectability beside the floor's (other speakers' recorded heads): "value (+above floor)"."""
    v, above = d.get(key, np.nan), d.get(f"{key}_above_floor", np.nan)
    if not np.isfinite(v):
        return "–"
    return f"{v:.2f}" + ("" if not np.isfinite(above) else f" ({above:+.2f})")


def _test_cell(d: dict, m: str) -> str:
    """Pooled excess and Stouffer p of a shift-tested score."""
    ex = d.get(f"{m}_excess_pooled", np.nan)
    return "–" if not np.isfinite(ex) else f"{ex:+.3f} ({fmt_p(d.get(f'{m}_p_pooled', np.nan))})"


def _reversal_cell(d: dict) -> str:
    v = [d.get(f"reversals_{a}", np.nan) for a in ("pitch", "yaw", "roll")]
    return "–" if not np.any(np.isfinite(v)) else "/".join("–" if not np.isfinite(x) else f"{x:.2f}" for x in v)


def rows_for(label: str, summ: dict, targets: dict) -> list[str]:
    gt = summ.get("ground-truth", {})
    out = []
    for s, d in summ.items():
        t = targets[s]
        sd = "/".join("–" if not np.isfinite(d.get(f"sd_ratio_{a}", np.nan)) else f"{d[f'sd_ratio_{a}']:.2f}"
                      for a in ("pitch", "yaw", "roll"))
        met = sum(1 for k in TARGETS if t[k])
        n = sum(1 for k in TARGETS if t[k] is not None)
        out.append(
            f"| {label} | {s} | {mark(d.get('band_1.5_4', np.nan), t['band'])} ({gt.get('band_1.5_4', np.nan):.2f}) | "
            f"{d.get('spectral_l1', np.nan):.2f} / {mark(d.get('spectral_l1_pooled', np.nan), t['l1'], 3)} | "
            f"{sd}{'' if t['sd'] is None else (' ✓' if t['sd'] else ' ✗')} | "
            f"{d.get('speed_hellinger', np.nan):.2f} / {_speed_cell(d, t['speed'])} | "
            f"{mark(d.get('limit_cycle', np.nan), t['lc'])} ({gt.get('limit_cycle', np.nan):.2f}) | "
            f"{mark(100 * d.get('saturation', np.nan), t['sat'], 1)} | "
            f"{_pause_cell(d, t['pause'])} ({gt.get('pause_ratio', np.nan):.2f}) | "
            f"{mark(d.get('diversity', np.nan), None)} | {d.get('fcca_excess_pooled', np.nan):+.3f} | "
            f"{fmt_p(d.get('fcca_p_pooled', np.nan))} | {_test_cell(d, 'xcca')} | {_test_cell(d, 'bc')} | "
            f"{_detect_cell(d)} | {mark(d.get('detect_floor', np.nan), None)} | {_floor_cell(d)} | "
            f"{_floor_cell(d, 'detect_3hz')} | {_reversal_cell(d)} | {met}/{n} |")
    return out


HEADER = ("| set | condition | 1.5–4 Hz (gt) | L1 per recording / pooled | SD ratio p/y/r | H speed per rec. / pooled / pooled K samples | LC (gt) | sat % | pause first / K samples (gt) | "
          "diversity | FCCA excess | p | cross-speaker coupling excess (p) | BC excess (p) | detectability (stats / CNN) | "
          "floor | detectability (above floor) | 3 Hz (above floor) | reversals p/y/r | targets |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="LABEL=REPORT_DIR")
    ap.add_argument("-o", "--output", type=Path, default=None)
    a = ap.parse_args(argv)
    lines, rulers = [HEADER], []
    for spec in a.runs:
        label, _, d = spec.partition("=")
        summ = realism_summary(load(Path(d)))
        lines += rows_for(label, summ, realism_targets(summ))
        r = ruler_anchor(summ)
        if r:
            rd = summ[r]
            rulers.append(f"{label}: bars from {r} — pooled L1 ≤ {rd.get('spectral_l1_pooled', np.nan) + 0.1:.3f}, "
                          f"pooled speed H ≤ {rd.get('speed_hellinger_pooled', np.nan) + 0.05:.3f}")
    text = "\n".join(lines) + "\n\n" + "\n".join(rulers) + "\n"
    print(text)
    if a.output:
        a.output.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
