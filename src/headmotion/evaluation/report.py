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
  realism (issue 14 §1): one table per condition (medians over held-out recordings of the
  measures of :mod:`.realism`), the anchors as the ruler, the issue's targets checked per system
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

from ..io.atomic import atomic_write_text
from .protocols import GROUND_TRUTH, EvaluationResult

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


def _vals(result: EvaluationResult, system: str, metric: str, recordings=None) -> np.ndarray:
    v = [r["value"] for r in result.rows if r["system"] == system and r["metric"] == metric
         and (recordings is None or r["recording"] in recordings)]
    v = np.array(v, dtype=float)
    return v[np.isfinite(v)]


def _ms(v: np.ndarray, digits: int = 3) -> str:
    if len(v) == 0:
        return "–"
    if len(v) == 1:
        return f"{v[0]:.{digits}f}"
    return f"{np.mean(v):.{digits}f} ± {np.std(v, ddof=1):.{digits}f}"


def _m(v: np.ndarray, digits: int = 3) -> str:
    return "–" if len(v) == 0 else f"{np.mean(v):.{digits}f}"


def _table(header: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out) + "\n"


def _speakers(result: EvaluationResult) -> dict[str, list[str]]:
    by: dict[str, list[str]] = {}
    for rid in result.recordings:
        by.setdefault(result.speakers.get(rid, "?"), []).append(rid)
    return by


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


# -- realism (issue 14) -----------------------------------------------------------------------------
#: (metric, column header, digits) of the realism table
REALISM_COLUMNS = (
    ("band_1.5_4", "1.5–4 Hz", 2), ("band_0_0.5", "<0.5 Hz", 2), ("spectral_l1", "L1", 2),
    ("spectral_l1_pooled", "L1 pooled", 3),
    ("sd_ratio_pitch", "SD ratio p", 2), ("sd_ratio_yaw", "SD ratio y", 2), ("sd_ratio_roll", "SD ratio r", 2),
    ("speed_hellinger", "H speed", 2), ("speed_hellinger_pooled", "H speed pooled", 3),
    ("speed_hellinger_pooled_k", "H speed pooled, K samples", 3),
    ("accel_hellinger", "H accel", 2), ("limit_cycle", "LC", 2),
    ("saturation", "sat", 3), ("pause_ratio", "pause", 2), ("pause_ratio_k", "pause, K samples", 2), ("drift", "drift (°)", 2), ("bc", "BC", 2),
    ("diversity", "diversity", 2))
#: anchors: the ruler of the realism table (ground truth, uncoupled-but-real, unreal)
RULER = (GROUND_TRUTH, "shifted", "desync", "shaped-noise", "other-speaker", "still")


def realism_summary(result: EvaluationResult) -> dict[str, dict[str, float]]:
    """``{condition: {metric: median over held-out recordings}}`` of the realism measures, plus
    the pooled coupling (``fcca_excess_pooled``, ``fcca_p_pooled``, …) and ``n``."""
    pooled = ("speed_hellinger_pooled", "speed_hellinger_pooled_k", "accel_hellinger_pooled", "spectral_l1_pooled")
    keys = {k for k, _, _ in REALISM_COLUMNS if k not in pooled} | {"band_1.5_4_ref", "limit_cycle_ref", "pause_ratio_ref",
                                                 "drift_ref", "bc_ref", "band_0.5_1.5", "band_4_10", "sd_pitch",
                                                 "sd_yaw", "sd_roll", "speed_mean"}
    recs = set(result.recordings)
    out: dict[str, dict[str, float]] = {}
    for s in result.systems:
        d: dict[str, float] = {}
        for k in keys:
            v = _vals(result, s, k, recs)
            d[k] = float(np.median(v)) if len(v) else float("nan")
        d["n"] = float(len(_vals(result, s, "spectral_l1", recs)))
        for k in ("fcca_excess_pooled", "fcca_p_pooled", "fcca_local_excess_pooled", "fcca_local_p_pooled",
                  "fcca_n_pooled", "detect", "detect_ba_stats", "detect_ba_cnn") + pooled:
            v = _vals(result, s, k, ["ALL"])
            d[k] = float(v[0]) if len(v) else float("nan")
        if not np.isfinite(d["spectral_l1_pooled"]):  # metrics.csv written before it: the same mean shares
            d["spectral_l1_pooled"] = _pooled_l1_from_rows(result, s, recs)
        out[s] = d
    return out


def _pooled_l1_from_rows(result: EvaluationResult, system: str, recs) -> float:
    """``spectral_l1_pooled`` from the per-recording band shares of metrics.csv (the mean shares of
    the recordings scored, the system's and their ground truths'); nan when they are missing."""
    from .realism import BAND_NAMES, mean_shares_distance

    by_rec: dict = {}
    for r in result.rows:
        if r["system"] == system and r["recording"] in recs and r["metric"].startswith("band_"):
            by_rec.setdefault(r["recording"], {})[r["metric"]] = float(r["value"])
    keys = [f"band_{b}{x}" for x in ("", "_ref") for b in BAND_NAMES]
    full = [v for v in by_rec.values() if all(k in v and np.isfinite(v[k]) for k in keys)]
    if not full:
        return float("nan")
    nb = len(BAND_NAMES)
    return mean_shares_distance([[v[k] for k in keys[nb:]] for v in full], [[v[k] for k in keys[:nb]] for v in full])


def ruler_anchor(summary) -> str | None:
    """The anchor the realism targets measure against: ``desync`` when evaluated, else ``shifted``
    (None when neither is).

    The thesis's desynchronised condition (§4.2.4, §4.3.1) is motion capture from *another
    recording of the same speaker*: real motion of the right person, uncoupled from this speech;
    its distances to the ground truth are what a second real take scores, sampling included.
    ``shifted`` (the recording's own frames, circularly shifted) keeps the spectrum and the speed
    histogram almost exactly, so its distances sit near 0 (the ZEGGS take in four folds at pauses:
    pooled speed Hellinger 0.008 shifted, 0.057 desync; a perfect sampler of the take's speed
    distribution scores 0.057–0.074, ``scripts/diagnosis_i14/speed_hellinger_noise.py``).  Where
    the fold has no other recording of the speaker (held-out speakers of the video corpus) the
    desync anchor *is* the shift, so the two agree there.  Chosen in the ninth session; before, the
    shift was preferred whenever both were evaluated."""
    for name in ("desync", "shifted"):
        if name in summary:
            return name
    return None


def realism_targets(summary: dict[str, dict[str, float]]) -> dict[str, dict[str, bool | None]]:
    """Issue 14's targets per condition (None where the reference is missing):
    ``band`` 1.5–4 Hz share within ±0.05 of the ground truth's; ``l1`` spectral L1 ≤ desync's +
    0.1 (desync = the :func:`ruler_anchor`; between the test set's mean band shares when the
    summary has it, else the per-recording median); ``sd`` every SD ratio in 0.6–1.5; ``speed``
    speed Hellinger ≤ desync's + 0.05 (pooled over the test set, as GENEA computes it, when the
    summary has it — for a stochastic system over its K samples, ``speed_hellinger_pooled_k``, as
    GENEA averages a condition's runs; else the per-recording median); ``lc`` limit-cycle index ≤
    the ground truth's + 0.1; ``sat`` saturation ≤ 2 % (None when the system
    declares no range); ``pause`` pause/speech speed ratio within ±30 % of the ground truth's (for
    a stochastic system over its K samples, ``pause_ratio_k``, since the tenth session; else its
    one motion's)."""
    gt = summary.get(GROUND_TRUTH, {})
    ds = summary.get(ruler_anchor(summary) or "", {})

    def ok(cond):
        return None if not np.isfinite(cond[0]) or not np.isfinite(cond[1]) else bool(cond[2])

    out = {}
    for s, d in summary.items():
        b, bref = d.get("band_1.5_4", np.nan), gt.get("band_1.5_4", np.nan)
        lkey = "spectral_l1_pooled" if np.isfinite(d.get("spectral_l1_pooled", np.nan)) else "spectral_l1"
        l1, l1d = d.get(lkey, np.nan), ds.get(lkey, np.nan)
        # GENEA's form (one histogram per condition over the test set) when evaluated, over all K
        # samples of a stochastic system (``speed_hellinger_pooled_k``); else the per-recording median
        key = "speed_hellinger_pooled" if np.isfinite(d.get("speed_hellinger_pooled", np.nan)) else "speed_hellinger"
        hsd = ds.get(key, np.nan)
        hs = d.get("speed_hellinger_pooled_k", np.nan)
        if not np.isfinite(hs):
            hs = d.get(key, np.nan)
        lc, lcg = d.get("limit_cycle", np.nan), gt.get("limit_cycle", np.nan)
        pr, prg = d.get("pause_ratio_k", np.nan), gt.get("pause_ratio", np.nan)
        if not np.isfinite(pr):
            pr = d.get("pause_ratio", np.nan)
        sds = [d.get(f"sd_ratio_{a}", np.nan) for a in ("pitch", "yaw", "roll")]
        sat = d.get("saturation", np.nan)
        out[s] = {
            "band": ok((b, bref, abs(b - bref) <= 0.05)),
            "l1": ok((l1, l1d, l1 <= l1d + 0.1)),
            "sd": None if not all(np.isfinite(sds)) else all(0.6 <= x <= 1.5 for x in sds),
            "speed": ok((hs, hsd, hs <= hsd + 0.05)),
            "lc": ok((lc, lcg, lc <= lcg + 0.1)),
            "sat": None if not np.isfinite(sat) else bool(sat <= 0.02),
            "pause": ok((pr, prg, abs(pr - prg) <= 0.3 * abs(prg))),
        }
    return out


def _fmt_p(p: float) -> str:
    if not np.isfinite(p):
        return "–"
    return "< 0.001" if p < 0.001 else f"{p:.3f}"


def coupling_line(name: str, d: dict[str, float]) -> str:
    """One line: is the condition tied to speech across the corpus (pooled FCCA excess and p)?"""
    ex, p, n = d.get("fcca_excess_pooled", np.nan), d.get("fcca_p_pooled", np.nan), d.get("fcca_n_pooled", np.nan)
    if not np.isfinite(ex):
        return f"- **{name}**: no FCCA scores"
    verdict = "tied to speech across the corpus" if (ex > 0 and p < 0.05) else "not shown to be tied to speech"
    lx, lp = d.get("fcca_local_excess_pooled", np.nan), d.get("fcca_local_p_pooled", np.nan)
    return (f"- **{name}**: pooled FCCA excess {ex:+.3f}, Stouffer p {_fmt_p(p)} over {n:.0f} recordings — {verdict}"
            f" (local FCCA excess {lx:+.3f}, p {_fmt_p(lp)})")


def _realism_md(result: EvaluationResult) -> str:
    summ = realism_summary(result)
    if not any(np.isfinite(d.get("spectral_l1", np.nan)) for d in summ.values()):
        return ""
    md = ["\n## Realism (issue 14 §1)\n",
          "Medians over held-out recordings (`metrics.csv` has every recording). *1.5–4 Hz*, *<0.5 Hz*: share of "
          "motion power (< 10 Hz, all axes) in the band; *L1*: distance of the four band shares to the ground "
          "truth's, median over recordings (*L1 pooled*: between the mean band shares of all held-out recordings "
          "and the ground truths'; the target uses it — one clip's share below 0.5 Hz rests on 2–4 spectral bins); "
          "*SD ratio*: SD per axis over the ground truth's; *H speed / H accel*: Hellinger distance of the "
          "speed / acceleration histograms to the ground truth's, median over recordings (*H speed pooled*: one "
          "histogram per condition over all held-out recordings, as the GENEA numerical evaluations compute it; "
          "the target uses it); *LC*: limit-cycle index (highest velocity "
          "autocorrelation peak at 0.25–2 s); *sat*: share of frames within 1° of the range the model declares "
          "(– = none declared); *pause*: mean speed in pauses ≥ 0.5 s over mean speed in speech; *drift*: SD of the "
          "5 s running mean; *BC*: beat consistency (EMAGE, σ = 0.3 s); *diversity*: mean distance between "
          f"{result.config.get('samples', '–')} samples for the same speech in units of the ground truth's SD "
          "(– = deterministic or anchor).\n\n"]
    order = [s for s in RULER if s in summ] + [s for s in summ if s not in RULER]
    rows = []
    for s in order:
        d = summ[s]
        rows.append([s, f"{d['n']:.0f}"] + [("–" if not np.isfinite(d.get(k, np.nan)) else f"{d[k]:.{dg}f}")
                                           for k, _, dg in REALISM_COLUMNS])
    md.append(_table(["Condition", "n"] + [h for _, h, _ in REALISM_COLUMNS], rows))
    gt = summ.get(GROUND_TRUTH, {})
    dname = ruler_anchor(summ) or "desync"
    ds = summ.get(dname, {})
    md.append("\n**The ruler.** The ground truth (scored against itself) and the anchors desync and shaped noise "
              "look real and are uncoupled from the speech by construction (*shifted* = the recording's own "
              "motion circularly shifted by half its length; *desync* = another recording of the same speaker, or "
              "the shift when the fold has none); still is the unreal extreme. ")
    if gt:
        md.append(f"Recorded heads here: 1.5–4 Hz share {gt.get('band_1.5_4', np.nan):.2f}, limit-cycle index "
                  f"{gt.get('limit_cycle', np.nan):.2f}, pause/speech speed {gt.get('pause_ratio', np.nan):.2f}. ")
    if ds:
        md.append(f"{dname.capitalize()}: spectral L1 {ds.get('spectral_l1', np.nan):.2f} per recording, "
                  f"{ds.get('spectral_l1_pooled', np.nan):.3f} pooled, speed Hellinger "
                  f"{ds.get('speed_hellinger', np.nan):.2f} per recording, "
                  f"{ds.get('speed_hellinger_pooled', np.nan):.3f} pooled (the floor a real but uncoupled motion "
                  "reaches).")
    if "other-speaker" in summ:
        md.append(f" Other-speaker (a different person's recorded head): spectral L1 "
                  f"{summ['other-speaker'].get('spectral_l1', np.nan):.2f} per recording "
                  f"({summ['other-speaker'].get('spectral_l1_pooled', np.nan):.3f} pooled), speed Hellinger "
                  f"{summ['other-speaker'].get('speed_hellinger', np.nan):.2f} per recording — what a real head that "
                  "is not this speaker's scores.")
    md.append(f"\n\n**Targets (issue 14)**: 1.5–4 Hz share within ±0.05 of the ground truth's; L1 (pooled) ≤ {dname}'s + 0.1; "
              f"every SD ratio 0.6–1.5; H speed (pooled; over all K samples of a stochastic system) ≤ {dname}'s + 0.05; "
              "LC ≤ the ground truth's + 0.1; saturation ≤ 2 %; pause ratio within ±30 % of the ground truth's. "
              f"The bars come from {dname} (desync when evaluated: the thesis's desynchronised condition, another "
              "recording of the same speaker; else the shift). ✓ met, ✗ not, – not measurable.\n\n")
    tg = realism_targets(summ)
    names = ("band", "l1", "sd", "speed", "lc", "sat", "pause")
    trows = []
    for s in order:
        if s in RULER:
            continue
        t = tg[s]
        met = sum(1 for k in names if t[k])
        trows.append([s] + ["–" if t[k] is None else ("✓" if t[k] else "✗") for k in names]
                     + [f"{met}/{sum(1 for k in names if t[k] is not None)}"])
    if trows:
        md.append(_table(["System", "1.5–4 Hz", "L1", "SD", "H speed", "LC", "sat", "pause", "met"], trows))
    md.append("\n**Pooled speech coupling** (FCCA with the speech features, excess over the circular-shift chance "
              "level averaged over held-out recordings; their p-values combined by Stouffer's method):\n\n")
    md.append("".join(coupling_line(s, summ[s]) + "\n" for s in order))
    return "\n".join(md)


def realism_figures_for(result: EvaluationResult, out_dir) -> list[Path]:
    """Per-axis spectra, speed histograms and the realism-vs-coupling scatters of the realism
    measures (:mod:`.realism_figures`), if the result kept its motions."""
    if not result.motions or GROUND_TRUTH not in result.motions:
        return []
    from ..types import Motion
    from . import realism_figures as RF

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    recs = [r for r in result.recordings if r in result.motions[GROUND_TRUTH]]
    conds = {c: [Motion(np.asarray(d[r], dtype=float), result.fps.get(r, 100.0)) for r in recs if r in d]
             for c, d in result.motions.items()}
    conds = {c: v for c, v in conds.items() if v}
    figs = [RF.spectra_figure(conds, path=out / "realism_spectra.png"),
            RF.speed_histogram_figure(conds, path=out / "realism_speed.png")]
    summ = realism_summary(result)
    rows = [{"condition": c, "recording": "ALL", "spectral_l1": d.get("spectral_l1", np.nan),
             "speed_hellinger": d.get("speed_hellinger", np.nan), "fcca_excess": d.get("fcca_excess_pooled", np.nan),
             "fcca_p_pooled": d.get("fcca_p_pooled", np.nan)} for c, d in summ.items()]
    figs.append(RF.realism_coupling_scatter(rows, path=out / "realism_vs_coupling.png"))
    figs.append(RF.realism_coupling_scatter(rows, x="speed_hellinger", path=out / "realism_vs_coupling_speed.png"))
    return figs


def render_report(result: EvaluationResult, *, title: str = "headmotion evaluation", figures: list[str] = ()) -> str:
    """The Markdown report (see the module docstring)."""
    cfg = result.config
    systems = result.systems
    spk = _speakers(result)
    md = [f"# {title}\n"]
    md.append(f"Protocol **{cfg.get('protocol')}** ({cfg.get('folds')} folds), FCCA features **{cfg.get('features')}**, "
              f"local CCA window {cfg.get('window_s')} s, chance levels from {cfg.get('n_shifts')} circular shifts, "
              f"seed {cfg.get('seed')}. {len(result.recordings)} held-out recordings of {len(spk)} speaker(s). "
              f"Values are mean ± SD over held-out recordings. *chance* = mean of the score with the motion "
              f"circularly shifted; *excess* = score − chance; *p<.05* = share of recordings whose score beats "
              f"the shifted motion at p < 0.05.\n")

    # paper Table 2
    md.append("## Prediction vs ground truth (paper Table 2 layout)\n")
    rows = []
    for s in systems:
        for sp, recs in spk.items():
            p = _vals(result, s, "cca_local_p", recs)
            rows.append([s, sp, str(len(_vals(result, s, "cca_local", recs))), _ms(_vals(result, s, "nmse", recs), 2),
                         _ms(_vals(result, s, "cca_local", recs), 2),
                         _m(_vals(result, s, "cca_local_null_mean", recs), 2),
                         _ms(_vals(result, s, "cca_local_excess", recs), 2),
                         "–" if len(p) == 0 else f"{np.mean(p < 0.05):.0%}",
                         _ms(_vals(result, s, "cca_global", recs), 2)])
    md.append(_table(["System", "Speaker", "n", "NMSE", "local CCA", "chance", "excess", "p<.05", "global CCA"], rows))

    # thesis Tables 5.3 / 5.8
    md.append("\n## Forced CCA per condition (thesis Tables 5.3 / 5.8 layout)\n")
    rows = []
    for s in systems:
        p = _vals(result, s, "fcca_p")
        rows.append([s, str(len(_vals(result, s, "fcca"))), _ms(_vals(result, s, "fcca")), _m(_vals(result, s, "fcca_null_mean")),
                     _m(_vals(result, s, "fcca_null_p95")), _ms(_vals(result, s, "fcca_excess")),
                     "–" if len(p) == 0 else f"{np.mean(p < 0.05):.0%}", _ms(_vals(result, s, "fcca_local")),
                     _m(_vals(result, s, "fcca_local_null_mean"))])
    md.append(_table(["Condition", "n", "FCCA", "chance", "chance 95%", "excess", "p<.05", "local FCCA", "local chance"],
                     rows))

    # issue 14: realism
    md.append(_realism_md(result))
    from .detectability_figures import detectability_section  # classifier two-sample test

    md.append(detectability_section(result.rows, systems))

    # paper Table 1
    md.append(_feature_table_md(result))

    # paper Fig 2 + GENEA jerk
    md.append("\n## Amplitude and smoothness (paper Fig 2; GENEA jerk / acceleration)\n")
    rows = []
    for s in systems:
        r = [s]
        for ax in ("rx", "ry", "rz"):
            r.append(_ms(np.degrees(_vals(result, s, f"sd_{ax}")), 2))
        for ax in ("rx", "ry", "rz"):
            r.append(_ms(np.degrees(_vals(result, s, f"sdvel_{ax}")), 1))
        r.append(_ms(_vals(result, s, "accel"), 2))
        r.append(_ms(_vals(result, s, "jerk"), 1))
        rows.append(r)
    md.append(_table(["System", "SD rx (°)", "SD ry (°)", "SD rz (°)", "SD Δrx (°/s)", "SD Δry (°/s)", "SD Δrz (°/s)",
                      "accel (rad/s²)", "jerk (rad/s³)"], rows))

    # paper chance score
    pc = _vals(result, GROUND_TRUTH, "paper_chance")
    md.append("\n## Chance scores\n")
    if len(pc):
        rows = [[sp, _ms(_vals(result, GROUND_TRUTH, "paper_chance", recs), 2),
                 _m(_vals(result, GROUND_TRUTH, "cca_local_null_mean", recs), 2)] for sp, recs in spk.items()]
        md.append("Paper §4.3.2: local CCA between the ground truth and another speaker's randomised motion; "
                  "next to it the circular-shift chance level of local CCA with the speaker's own motion.\n\n")
        md.append(_table(["Speaker", "paper chance score", "shift chance (own motion)"], rows))
    else:
        md.append("The paper's chance score needs a second speaker; this corpus has one. "
                  "The circular-shift chance levels in the tables above replace it.\n")

    # thesis Fig 4.8
    wl = [m for m in result.metrics() if m.startswith("winlocal[")]
    if wl:
        md.append("\n## Local vs global CCA of speech features and head motion against window size (thesis Fig 4.8)\n")
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
        md.append(_table(hdr, rows))

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
        from .figures import evaluation_figures

        figs = evaluation_figures(result, out / "figures")
        figs += realism_figures_for(result, out / "figures")
        from .detectability_figures import figures_for as detectability_figures

        figs += detectability_figures(result, out / "figures")
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

    from ..io.native import save_npz
    from ..types import Motion

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


__all__ = ["write_metrics_csv", "read_metrics_csv", "render_report", "feature_table_section", "write_report", "write_motions",
           "realism_summary", "realism_targets", "ruler_anchor", "coupling_line", "realism_figures_for"]
