"""metrics.csv and report.md in the seeds' table layouts (paper Tables 1–2, Fig 2; thesis Tables
5.3 / 5.8, Fig 4.8).

* ``metrics.csv`` — one row per system × recording × metric: ``system,recording,metric,value``
  (the recorded motion is the system ``ground-truth``; per-speaker rows use the recording
  ``speaker:<name>``).
* ``report.md`` — mean ± SD over recordings:
  paper Table 2 (NMSE and local CCA with the ground truth, per speaker, with the chance level),
  thesis Tables 5.3 / 5.8 (mean Forced CCA per condition, with its chance level),
  paper Table 1 (feature ↔ motion local CCA per feature set on every corpus recording, columns
  train / valid / test of the paper §4.1 split, and the excess over chance),
  paper Fig 2 (SD of rotation and velocity) and jerk / acceleration,
  the paper's chance score, and thesis Fig 4.8 (local vs global CCA against window size);
  realism: one table per condition (medians over held-out recordings of the measures of
  :mod:`.realism`), the anchors as the ruler, the realism targets checked per system
  (:func:`realism_targets`), and one line per system with its pooled speech coupling (mean FCCA
  excess and the Stouffer-pooled p).
* ``figures/*.png`` via :mod:`.figures` and :mod:`.realism_figures` (per-axis spectra over the
  ground truth's, speed histograms, realism vs coupling scatter).

Library considered: pandas (not a dependency; the tables are small and written by hand).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from ...io.atomic import atomic_write_text
from ..protocol.conditions import GROUND_TRUTH
from .md_tables import mean as _m
from .md_tables import mean_sd as _ms
from .md_tables import speakers as _speakers
from .md_tables import table as _table
from .md_tables import vals as _vals
from .realism_report import (REALISM_COLUMNS, RULER, coupling_line, realism_figures_for,  # noqa: F401
                             realism_md, realism_summary, realism_targets, ruler_anchor)
from ..protocol.results import EvaluationResult

#: paper Table 1 display names of feature sets
FEATURE_LABELS = {"f0e": "F0+Energy", "fbank": "FBank", "mfcc": "MFCC", "wav": "waveform", "lsp": "LSP",
                  "lar": "LAR", "prosody": "Pitch+Loudness"}
EMBED_LABELS = {"ae-dnn": "Wav_AE", "cccae": "Wav_CCCAE"}


def write_metrics_csv(result: EvaluationResult, path) -> Path:
    """``system,recording,metric,value`` — one row per system × recording × metric (values with 12
    significant digits)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["system", "recording", "metric", "value"])
    for r in result.rows:
        # 12 significant digits: last-bit differences of BLAS kernels do not change the file
        w.writerow([r["system"], r["recording"], r["metric"], f"{float(r['value']):.12g}"])
    atomic_write_text(Path(path), buf.getvalue())
    return Path(path)


def read_metrics_csv(path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as fh:
        return [{"system": r["system"], "recording": r["recording"], "metric": r["metric"], "value": float(r["value"])}
                for r in csv.DictReader(fh)]


SPLITS = ("train", "valid", "test")
#: at most this many speakers get their own rows in the paper Table 1 (the paper has 2 subjects)
MAX_SPEAKER_ROWS = 4


def _feature_table_md(result: EvaluationResult, *, held_out_note: bool = True) -> str:
    """Paper Table 1: local CCA of each feature set with the recorded motion, columns train / valid
    / test (the paper §4.1 split of every corpus recording, ``result.splits``), then the same as
    excess over the circular-shift chance level.  ``held_out_note`` says that the table covers more
    than the held-out recordings (an evaluation report; not ``headmotion stats``)."""
    feat_metrics = [m for m in result.metrics() if m.startswith("featcca_local[") and m.endswith("]")]
    embed = [s for s in result.systems if len(_vals(result, s, "embed_cca_local"))]
    # requested sets with no score at all (e.g. a window too short for their dimension)
    missing = [fs for fs in result.config.get("feature_sets", []) if f"featcca_local[{fs}]" not in feat_metrics]
    if not feat_metrics and not embed and not missing:
        return ""
    splits = dict(result.splits or result.config.get("splits") or {})
    scored = sorted({r["recording"] for r in result.rows if r["system"] == GROUND_TRUTH and r["metric"] in feat_metrics})
    if not splits:  # an older result: everything scored counts as held out
        splits = {rid: "test" for rid in scored}
    by_split = {sp: [rid for rid in splits if splits[rid] == sp] for sp in SPLITS}
    spk_of = result.speakers
    speakers = sorted({spk_of.get(rid, "?") for rid in splits})
    groups = [("all" if len(speakers) > 1 else speakers[0], None)]
    if 1 < len(speakers) <= MAX_SPEAKER_ROWS:
        groups += [(sp, sp) for sp in speakers]

    def recs(split, speaker):
        return [r for r in by_split[split] if speaker is None or spk_of.get(r) == speaker]

    def cell(system, metric, split, speaker, digits=3):
        rr = recs(split, speaker)
        if not rr:
            return "no recordings"
        v = _vals(result, system, metric, rr)
        return _ms(v, digits) + (f" (n={len(v)})" if len(v) != len(rr) else "")

    hdr_splits = [f"{sp} (n={len(by_split[sp])})" for sp in SPLITS]
    rows_cca, rows_ex = [], []
    for m in feat_metrics:
        fs = m[len("featcca_local["):-1]
        label = FEATURE_LABELS.get(fs, fs)
        for gname, g in groups:
            rows_cca.append([label, gname] + [cell(GROUND_TRUTH, m, sp, g) for sp in SPLITS]
                            + [_m(_vals(result, GROUND_TRUTH, f"{m}_null_mean",
                                        [r for sp in SPLITS for r in recs(sp, g)]))])
            p = _vals(result, GROUND_TRUTH, f"{m}_p", [r for sp in SPLITS for r in recs(sp, g)])
            rows_ex.append([label, gname] + [cell(GROUND_TRUTH, f"{m}_excess", sp, g) for sp in SPLITS]
                           + ["–" if len(p) == 0 else f"{np.mean(p < 0.05):.0%}"])
    for fs in missing:
        note = "left out"
        rows_cca.append([FEATURE_LABELS.get(fs, fs), "all", note, note, note, "–"])
        rows_ex.append([FEATURE_LABELS.get(fs, fs), "all", note, note, note, "–"])
    for s in embed:
        label = EMBED_LABELS.get(s, f"{s} embedding")
        v = _vals(result, s, "embed_cca_local")
        ve = _vals(result, s, "embed_cca_local_excess")
        p = _vals(result, s, "embed_cca_local_p")
        rows_cca.append([label, "all", "–", "–", _ms(v) + f" (n={len(v)}, held out)",
                         _m(_vals(result, s, "embed_cca_local_null_mean"))])
        rows_ex.append([label, "all", "–", "–", _ms(ve) + f" (n={len(ve)}, held out)",
                        "–" if len(p) == 0 else f"{np.mean(p < 0.05):.0%}"])
    out = ["\n## Speech features vs recorded head motion, local CCA (paper Table 1 layout)\n"]
    n_spk = len(speakers)
    out.append(
        f"Local CCA ({result.config.get('window_s')} s windows) between each feature set and the recorded motion on "
        f"every recording of the corpus ({len(splits)} recordings of {n_spk} speaker(s)"
        f"{', not only the held-out ones' if held_out_note else ''}), "
        f"grouped by the paper §4.1 split (per speaker 60 / 20 / 20 % of the recordings, seed "
        f"{result.config.get('seed')}, or the manifest's `split` column; a speaker with one recording is all train). "
        f"Mean ± SD over recordings; *chance* = mean over all splits of the same score with the motion circularly "
        f"shifted. High-dimensional features find spurious correlation in short windows, so read the excess table "
        f"below.\n\n")
    empty = [sp for sp in SPLITS if not by_split[sp]]
    if empty:
        out.append(f"No recordings in the {' or '.join(empty)} split: "
                   f"{'that column is' if len(empty) == 1 else 'those columns are'} empty.\n\n")
    if missing:
        out.append(f"Left out everywhere (see Warnings): {', '.join(FEATURE_LABELS.get(f, f) for f in missing)}.\n\n")
    if embed:
        out.append("Embedding rows (learnt features) are scored on held-out recordings only, by the model of their "
                   "fold, and shown under *test*.\n\n")
    out.append(_table(["Feature", "Speaker"] + hdr_splits + ["chance"], rows_cca))
    out.append("\nExcess over chance (local CCA − its circular-shift chance level); *p<.05* = share of the recordings "
               "(all splits) whose score beats the shifted motion at p < 0.05.\n\n")
    out.append(_table(["Feature", "Speaker"] + hdr_splits + ["p<.05"], rows_ex))
    return "\n".join(out)


def feature_table_section(table: dict[str, dict[str, float]], *, feature_sets, splits: dict[str, str],
                          speakers: dict[str, str], window_s: float, seed: int, n_shifts: int) -> str:
    """The paper Table 1 section (same layout as in ``report.md`` of ``headmotion evaluate``) from
    the output of :func:`.feature_table.feature_table`, for reports without an evaluation
    (``headmotion stats``).

    Parameters
    ----------
    table : ``{recording: {metric: value}}`` — :func:`.feature_table.feature_table`'s first return value
    feature_sets : the requested feature sets (names; sets with no score are listed as left out)
    splits : ``{recording: "train" | "valid" | "test"}`` (:func:`headmotion.corpus.paper_split`)
    speakers : ``{recording: speaker}``
    window_s, seed, n_shifts : the settings the table was computed with
    """
    rows = [{"system": GROUND_TRUTH, "recording": rid, "metric": k, "value": float(v)}
            for rid, vals in table.items() for k, v in vals.items()]
    result = EvaluationResult(
        rows=rows, config={"window_s": window_s, "seed": seed, "n_shifts": n_shifts,
                           "feature_sets": [str(f) for f in feature_sets]},
        systems=[GROUND_TRUTH], recordings=list(splits), speakers=dict(speakers), splits=dict(splits))
    return _feature_table_md(result, held_out_note=False)


def _intro_md(result: EvaluationResult) -> str:
    cfg = result.config
    return (f"Protocol **{cfg.get('protocol')}** ({cfg.get('folds')} folds), FCCA features **{cfg.get('features')}**, "
            f"local CCA window {cfg.get('window_s')} s, chance levels from {cfg.get('n_shifts')} circular shifts, "
            f"seed {cfg.get('seed')}. {len(result.recordings)} held-out recordings of {len(_speakers(result))} speaker(s). "
            f"Values are mean ± SD over held-out recordings. *chance* = mean of the score with the motion "
            f"shifted in time; *excess* and *p* compare the score with its shifted copies after the motion's "
            f"straight line from first to last frame is removed (so a shift adds no jump at the wrap point, "
            f"docs/decisions/coupling-test.md); *p<.05* = share of recordings whose score beats the shifted "
            f"motion at p < 0.05.\n")


def _table2_md(result: EvaluationResult) -> str:
    """Paper Table 2: NMSE and local CCA with the ground truth, per speaker."""
    rows = []
    for s in result.systems:
        for sp, recs in _speakers(result).items():
            p = _vals(result, s, "cca_local_p", recs)
            rows.append([s, sp, str(len(_vals(result, s, "cca_local", recs))), _ms(_vals(result, s, "nmse", recs), 2),
                         _ms(_vals(result, s, "cca_local", recs), 2),
                         _m(_vals(result, s, "cca_local_null_mean", recs), 2),
                         _ms(_vals(result, s, "cca_local_excess", recs), 2),
                         "–" if len(p) == 0 else f"{np.mean(p < 0.05):.0%}",
                         _ms(_vals(result, s, "cca_global", recs), 2)])
    return ("## Prediction vs ground truth (paper Table 2 layout)\n\n"
            + _table(["System", "Speaker", "n", "NMSE", "local CCA", "chance", "excess", "p<.05", "global CCA"], rows))


def _fcca_md(result: EvaluationResult) -> str:
    """Thesis Tables 5.3 / 5.8: Forced CCA per condition with its chance level."""
    rows = []
    for s in result.systems:
        p = _vals(result, s, "fcca_p")
        rows.append([s, str(len(_vals(result, s, "fcca"))), _ms(_vals(result, s, "fcca")), _m(_vals(result, s, "fcca_null_mean")),
                     _m(_vals(result, s, "fcca_null_p95")), _ms(_vals(result, s, "fcca_excess")),
                     "–" if len(p) == 0 else f"{np.mean(p < 0.05):.0%}", _ms(_vals(result, s, "fcca_local")),
                     _m(_vals(result, s, "fcca_local_null_mean"))])
    return ("\n## Forced CCA per condition (thesis Tables 5.3 / 5.8 layout)\n\n"
            + _table(["Condition", "n", "FCCA", "chance", "chance 95%", "excess", "p<.05", "local FCCA", "local chance"],
                     rows))


def _amplitude_md(result: EvaluationResult) -> str:
    """Paper Fig 2 (SD of rotation and velocity) and GENEA jerk / acceleration."""
    rows = []
    for s in result.systems:
        r = [s]
        for ax in ("rx", "ry", "rz"):
            r.append(_ms(np.degrees(_vals(result, s, f"sd_{ax}")), 2))
        for ax in ("rx", "ry", "rz"):
            r.append(_ms(np.degrees(_vals(result, s, f"sdvel_{ax}")), 1))
        r.append(_ms(_vals(result, s, "accel"), 2))
        r.append(_ms(_vals(result, s, "jerk"), 1))
        rows.append(r)
    return ("\n## Amplitude and smoothness (paper Fig 2; GENEA jerk / acceleration)\n\n"
            + _table(["System", "SD rx (°)", "SD ry (°)", "SD rz (°)", "SD Δrx (°/s)", "SD Δry (°/s)", "SD Δrz (°/s)",
                      "accel (rad/s²)", "jerk (rad/s³)"], rows))


def _chance_md(result: EvaluationResult) -> str:
    """The paper's chance score (§4.3.2) per speaker."""
    md = ["\n## Chance scores\n"]
    if len(_vals(result, GROUND_TRUTH, "paper_chance")):
        rows = [[sp, _ms(_vals(result, GROUND_TRUTH, "paper_chance", recs), 2),
                 _m(_vals(result, GROUND_TRUTH, "cca_local_null_mean", recs), 2)] for sp, recs in _speakers(result).items()]
        md.append("Paper §4.3.2: local CCA between the ground truth and another speaker's randomised motion; "
                  "next to it the circular-shift chance level of local CCA with the speaker's own motion.\n\n")
        md.append(_table(["Speaker", "paper chance score", "shift chance (own motion)"], rows))
    else:
        md.append("The paper's chance score needs a second speaker; this corpus has one. "
                  "The circular-shift chance levels in the tables above replace it.\n")
    return "\n".join(md)


def _fig48_md(result: EvaluationResult) -> str:
    """Thesis Fig 4.8: local vs global CCA of speech features and head motion against window size."""
    wl = [m for m in result.metrics() if m.startswith("winlocal[")]
    if not wl:
        return ""
    sp_rows = sorted({r["recording"] for r in result.rows if r["metric"] in wl})
    rows = []
    for m in wl:
        ws = m[len("winlocal["):-1]
        r = [ws]
        for sp in sp_rows:
            r.append(_m(_vals(result, GROUND_TRUTH, m, [sp])))
            r.append(_m(_vals(result, GROUND_TRUTH, f"winglobal[{ws}]", [sp])))
            r.append(_m(_vals(result, GROUND_TRUTH, f"winn[{ws}]", [sp]), 0))
        rows.append(r)
    hdr = ["window"]
    for sp in sp_rows:
        name = sp.split(":", 1)[-1]
        hdr += [f"{name} local", f"{name} global", f"{name} n"]
    return ("\n## Local vs global CCA of speech features and head motion against window size (thesis Fig 4.8)\n\n"
            + _table(hdr, rows))


#: the sections of report.md in order, each ``section(result) -> Markdown`` ("" = left out); a
#: section for a new per-condition measure goes in here
def _detectability_md(result: EvaluationResult) -> str:
    from .detectability_figures import detectability_section  # classifier two-sample test

    return detectability_section(result.rows, result.systems)


def _levels_md(result: EvaluationResult) -> str:
    from .levels_report import levels_md  # coupling per speech side beside its levels

    return levels_md(result)


REPORT_SECTIONS = (_intro_md, _table2_md, _fcca_md, realism_md, _levels_md, _detectability_md, _feature_table_md,
                   _amplitude_md, _chance_md, _fig48_md)


def _evaluation_figures(result: EvaluationResult, folder) -> list[Path]:
    from .figures import evaluation_figures  # matplotlib: imported when figures are drawn

    return evaluation_figures(result, folder)


#: the figure makers of the report, each ``make(result, folder) -> [paths]``; a figure for a new
#: per-condition measure goes in here
def _detectability_figures(result: EvaluationResult, folder) -> list[Path]:
    from .detectability_figures import figures_for

    return figures_for(result, folder)


REPORT_FIGURES = (_evaluation_figures, realism_figures_for, _detectability_figures)


def render_report(result: EvaluationResult, *, title: str = "headmotion evaluation", figures: list[str] = ()) -> str:
    """The Markdown report (see the module docstring): title, :data:`REPORT_SECTIONS`, figures,
    timings and warnings."""
    md = [f"# {title}\n"] + [section(result) for section in REPORT_SECTIONS]
    if figures:
        md.append("\n## Figures\n")
        for f in figures:
            md.append(f"![{Path(f).stem}]({f})\n")
    if result.timings:
        md.append("\n## Timings (s, summed over folds)\n")
        md.append(_table(["step", "seconds"], [[k, f"{v:.1f}"] for k, v in sorted(result.timings.items())]))
    if result.warnings:
        md.append("\n## Warnings\n")
        md.append("".join(f"- {w}\n" for w in result.warnings))
    return "\n".join(md)


def write_report(result: EvaluationResult, out_dir, *, figures: bool = True, title: str = "headmotion evaluation",
                 save_motions: bool = False) -> dict:
    """Write ``metrics.csv``, ``report.md``, ``config.json`` and the figures into ``out_dir``; with
    ``save_motions`` also every condition's held-out motion as ``motions/CONDITION/RECORDING.npz``
    (:func:`write_motions`).

    Returns ``{"metrics": path, "report": path, "figures": [paths], "motions": [paths]}``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_metrics_csv(result, out / "metrics.csv")
    saved = write_motions(result, out / "motions") if save_motions else []
    figs: list[Path] = []
    if figures:
        for make in REPORT_FIGURES:
            figs += make(result, out / "figures")
    rel = [f"figures/{p.name}" for p in figs]
    atomic_write_text(out / "report.md", render_report(result, title=title, figures=rel))
    cfg = dict(result.config)
    cfg["timings"] = result.timings
    cfg["recordings"] = result.recordings
    atomic_write_text(out / "config.json", json.dumps(cfg, indent=2, default=str))
    return {"metrics": out / "metrics.csv", "report": out / "report.md", "figures": figs, "motions": saved}


def write_motions(result: EvaluationResult, out_dir) -> list[Path]:
    """Every condition's held-out motion (the first sample, the one that is scored) as
    ``out_dir/CONDITION/RECORDING.npz`` (:func:`headmotion.io.native.save_npz`, readable by
    ``headmotion plot`` and ``render``); condition names are made safe as folder names."""
    import re

    from ...io.native import save_npz
    from ...types import Motion

    paths: list[Path] = []
    for cond, recs in result.motions.items():
        folder = Path(out_dir) / re.sub(r"[^A-Za-z0-9._=+-]+", "_", cond)
        folder.mkdir(parents=True, exist_ok=True)
        for rid, rv in recs.items():
            path = folder / f"{rid}.npz"
            save_npz(Motion(np.asarray(rv, dtype=np.float64), float(result.fps.get(rid, 100.0)),
                            meta={"system": cond, "recording": rid}), path)
            paths.append(path)
    return paths


__all__ = ["write_metrics_csv", "read_metrics_csv", "render_report", "REPORT_SECTIONS", "REPORT_FIGURES", "feature_table_section", "write_report", "write_motions",
           "realism_summary", "realism_targets", "ruler_anchor", "coupling_line", "realism_figures_for"]
