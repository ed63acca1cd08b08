"""The realism part of the evaluation report: per condition the medians of the realism measures
(:mod:`.realism`), the anchors as the ruler, the realism targets checked per system, and one line
per condition with its pooled speech coupling (mean FCCA excess and the Stouffer-pooled p)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..protocol.conditions import GROUND_TRUTH
from .md_tables import table as _table
from .md_tables import vals as _vals
from ..protocol.results import EvaluationResult


# -- realism -----------------------------------------------------------------------------------------
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
#: per-condition values pooled over the held-out recordings (recording ``ALL``) that
#: :func:`realism_summary` carries; a pooled measure whose value the summary should show goes here
POOLED_SUMMARY_KEYS = ("fcca_excess_pooled", "fcca_p_pooled", "fcca_local_excess_pooled", "fcca_local_p_pooled",
                       "fcca_n_pooled", "speed_hellinger_pooled", "speed_hellinger_pooled_k", "accel_hellinger_pooled",
                       "spectral_l1_pooled", "detect", "detect_ba_stats", "detect_ba_cnn",
                       "xcca_excess_pooled", "xcca_p_pooled", "xcca_n_pooled", "bc_excess_pooled", "bc_p_pooled",
                       "detect_floor", "detect_above_floor", "detect_3hz", "detect_3hz_floor", "detect_3hz_above_floor",
                       "reversals_pitch", "reversals_yaw", "reversals_roll")


def realism_summary(result: EvaluationResult) -> dict[str, dict[str, float]]:
    """``{condition: {metric: median over held-out recordings}}`` of the realism measures, plus
    the pooled coupling (``fcca_excess_pooled``, ``fcca_p_pooled``, …) and ``n``."""
    keys = {k for k, _, _ in REALISM_COLUMNS if k not in POOLED_SUMMARY_KEYS} | {"band_1.5_4_ref", "limit_cycle_ref", "pause_ratio_ref",
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
        for k in POOLED_SUMMARY_KEYS:
            v = _vals(result, s, k, ["ALL"])
            d[k] = float(v[0]) if len(v) else float("nan")
        if not np.isfinite(d["spectral_l1_pooled"]):  # a metrics.csv without the pooled row: the same mean shares
            d["spectral_l1_pooled"] = _pooled_l1_from_rows(result, s, recs)
        out[s] = d
    return out


def _pooled_l1_from_rows(result: EvaluationResult, system: str, recs) -> float:
    """``spectral_l1_pooled`` from the per-recording band shares of metrics.csv (the mean shares of
    the recordings scored, the system's and their ground truths'); nan when they are missing."""
    from ..measures.realism import BAND_NAMES, mean_shares_distance

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
    distribution scores 0.057–0.074), a bar no second real take meets.  Where the fold has no
    other recording of the speaker (held-out speakers of the video corpus) the desync anchor *is*
    the shift, so the two agree there."""
    for name in ("desync", "shifted"):
        if name in summary:
            return name
    return None


def realism_targets(summary: dict[str, dict[str, float]]) -> dict[str, dict[str, bool | None]]:
    """The realism targets per condition (None where the reference is missing):
    ``band`` 1.5–4 Hz share within ±0.05 of the ground truth's; ``l1`` spectral L1 ≤ desync's +
    0.1 (desync = the :func:`ruler_anchor`; between the test set's mean band shares when the
    summary has it, else the per-recording median); ``sd`` every SD ratio in 0.6–1.5; ``speed``
    speed Hellinger ≤ desync's + 0.05 (pooled over the test set, as GENEA computes it, when the
    summary has it — for a stochastic system over its K samples, ``speed_hellinger_pooled_k``, as
    GENEA averages a condition's runs; else the per-recording median); ``lc`` limit-cycle index ≤
    the ground truth's + 0.1; ``sat`` saturation ≤ 2 % (None when the system
    declares no range); ``pause`` pause/speech speed ratio within ±30 % of the ground truth's (for
    a stochastic system over its K samples, ``pause_ratio_k``; else its one motion's)."""
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
    line = (f"- **{name}**: pooled FCCA excess {ex:+.3f}, Stouffer p {_fmt_p(p)} over {n:.0f} recordings — {verdict}"
            f" (local FCCA excess {lx:+.3f}, p {_fmt_p(lp)})")
    xe, xp = d.get("xcca_excess_pooled", np.nan), d.get("xcca_p_pooled", np.nan)
    if np.isfinite(xe):
        line += f"; cross-speaker coupling excess {xe:+.3f}, p {_fmt_p(xp)}"
    be, bp = d.get("bc_excess_pooled", np.nan), d.get("bc_p_pooled", np.nan)
    if np.isfinite(be):
        line += f"; beat alignment (BC) excess {be:+.3f}, p {_fmt_p(bp)}"
    return line


def realism_md(result: EvaluationResult) -> str:
    summ = realism_summary(result)
    if not any(np.isfinite(d.get("spectral_l1", np.nan)) for d in summ.values()):
        return ""
    md = ["\n## Realism\n",
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
    md.append(f"\n\n**Realism targets**: 1.5–4 Hz share within ±0.05 of the ground truth's; L1 (pooled) ≤ {dname}'s + 0.1; "
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
              "level averaged over held-out recordings; their p-values combined by Stouffer's method; *cross-speaker "
              "coupling*: CCA of speech (f0e, ±6 frames at 25 fps) and motion (angles, absolute angular speeds) "
              "fitted on the other speakers' recorded heads of the fold and applied to the held-out motion, the "
              "ground truth's figure being what recorded heads reach; *beat alignment*: BC against the same shift "
              "null — each with the same bridge shift test):\n\n")
    md.append("".join(coupling_line(s, summ[s]) + "\n" for s in order))
    return "\n".join(md)


def realism_figures_for(result: EvaluationResult, out_dir) -> list[Path]:
    """Per-axis spectra, speed histograms and the realism-vs-coupling scatters of the realism
    measures (:mod:`.realism_figures`), if the result kept its motions."""
    if not result.motions or GROUND_TRUTH not in result.motions:
        return []
    from ...types import Motion
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


__all__ = ["REALISM_COLUMNS", "RULER", "POOLED_SUMMARY_KEYS", "realism_summary", "realism_targets", "ruler_anchor", "coupling_line",
           "realism_md", "realism_figures_for"]
