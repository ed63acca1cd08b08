"""Analysis of listening-test results (thesis §4.2.3.2, §4.2.4.2, §5.5.1, §5.9; paper §4.4).

``headmotion listen analyze RESULTS -o REPORT_DIR`` writes a Markdown report and PNG figures:

* exclusion of participants who rate everything the same (thesis §4.2.3.2: "the results of one
  were excluded because they rated all videos the same"); for A/B: who always pick the same side;
* rescaling of scores to [0, 1] per participant and per speaker (thesis §4.2.3.2), and per
  participant only (Table 5.9 "rescaled for each subject");
* windowed score differences between two conditions over presentation order, mean and standard
  deviation over participants, one line per group (e.g. rendering style) (Figs 4.5–4.6), with key
  statistics (Table 4.1) and score histograms (Fig 4.7);
* MOS tables per participant group (Tables 4.4, 5.9) and Student's t-tests between groups on the
  normalised scores (Table 4.3);
* pairwise tests between systems: paired Student's t-tests and Wilcoxon signed-rank tests on
  per-participant mean normalised scores (ratings) or two-sided binomial tests (A/B), with Holm's
  step-down correction for multiple comparisons;
* MUSHRA box plots of the raw 0–100 scores (paper Fig 3; line = median) and the standard
  post-screening (hidden reference ≥ threshold in a fraction of items; reported, not enforced);
* the A/B preference matrix (Table 5.4: % of times the row system was preferred to the column
  system) with side balance and side bias.

Libraries considered: pandas (not a dependency of the package; the tables here are small),
statsmodels (``multipletests`` offers Holm, but it is a heavy dependency for five lines), pingouin
(not installed).  Tests come from :mod:`scipy.stats`; Holm is implemented in :func:`holm`.
"""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FormatError, ParameterError
from ..io._limits import check_file

RATING_KINDS = ("mos", "mushra")


# ---------------------------------------------------------------------------------------------
# loading
# ---------------------------------------------------------------------------------------------
def load_results(path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Read results exported by the app: ``.json`` (admin download), ``.csv`` or the ``.sqlite``.

    Returns
    -------
    test : dict
        Test settings (type, hidden reference, anchor, screening, ...); partial for CSV.
    rows : list of dict
        One per stored answer, long format (participant, trial_index, phase, kind, item, speaker,
        group, slot, condition, value, other, response_ms, demo_*).
    """
    path = check_file(path, expected="a results file (.json, .csv or .sqlite)")
    suffix = path.suffix.lower()
    if suffix == ".json":
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise FormatError(f"not a JSON results file: {exc}", path=path) from None
        if not isinstance(doc, dict) or "answers" not in doc:
            raise FormatError("expected the JSON written by /api/admin/results.json (with an "
                              "'answers' list)", path=path)
        return dict(doc.get("test") or {}), [dict(r) for r in doc["answers"]]
    if suffix == ".csv":
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            need = {"participant", "trial_index", "kind", "condition", "value"}
            if not need <= set(reader.fieldnames or ()):
                raise FormatError(f"CSV results need the columns {sorted(need)}; got "
                                  f"{reader.fieldnames}", path=path, line=1)
            rows = []
            for r in reader:
                r = dict(r)
                r["participant"] = int(r["participant"])
                r["trial_index"] = int(r["trial_index"])
                r["value"] = float(r["value"]) if r["value"] not in ("", None) else math.nan
                r["response_ms"] = float(r["response_ms"]) if r.get("response_ms") else math.nan
                rows.append(r)
        return {}, rows
    if suffix in (".sqlite", ".db", ".sqlite3"):
        from .db import Database

        db = Database(f"sqlite:///{path.resolve()}")
        try:
            test = db.get_meta("config", {}) or {}
            return dict(test), db.answer_rows()
        finally:
            db.close()
    raise FormatError(f"unknown results format {suffix!r}; expected .json, .csv or .sqlite",
                      path=path)


# ---------------------------------------------------------------------------------------------
# statistics
# ---------------------------------------------------------------------------------------------
def holm(pvalues) -> np.ndarray:
    """Holm's step-down adjusted p-values (family-wise error control), same order as given.

    ``p_adj[(i)] = max_{j<=i} min(1, (m - j) * p_(j))`` for the sorted p-values ``p_(0) <= ...``.
    """
    p = np.asarray(pvalues, dtype=float)
    m = p.size
    if m == 0:
        return p
    order = np.argsort(p, kind="stable")
    adj = np.minimum(1.0, (m - np.arange(m)) * p[order])
    adj = np.maximum.accumulate(adj)
    out = np.empty(m)
    out[order] = adj
    return out


def rescale(rows: list[dict], *, by: tuple[str, ...], key: str = "value",
            out: str = "norm") -> None:
    """Rescale ``row[key]`` to [0, 1] within each group of ``by`` (in place, into ``row[out]``).

    Thesis §4.2.3.2: "all the scores are scaled to be on the unit interval for each participant
    individually ... the results from each speaker also have to be scaled separately".  A group
    whose scores are all equal maps to 0.5."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in rows:
        groups[tuple(r.get(b, "") for b in by)].append(r)
    for g in groups.values():
        v = np.array([r[key] for r in g], dtype=float)
        lo, hi = np.nanmin(v), np.nanmax(v)
        for r, x in zip(g, v):
            r[out] = 0.5 if hi - lo <= 0 else float((x - lo) / (hi - lo))


def constant_raters(rows: list[dict]) -> list[Any]:
    """Participants whose (non-attention) ratings are all identical — or, in an A/B test, who
    always chose the same side."""
    by: dict[Any, set] = defaultdict(set)
    count: dict[Any, int] = defaultdict(int)
    for r in rows:
        if r["kind"] == "attention":
            continue
        by[r["participant"]].add(r["slot"] if r["kind"] == "ab" else r["value"])
        count[r["participant"]] += 1
    return sorted(p for p, s in by.items() if len(s) == 1 and count[p] > 1)


def windowed_differences(rows: list[dict], *, reference: str, compare: str, window: int = 10,
                         value: str = "norm") -> dict[str, dict[str, np.ndarray]]:
    """Mean score difference ``reference - compare`` in a sliding window over presentation order.

    For each participant, trials are numbered in the order shown (training included: the point of
    the figure is to see where training ends and boredom starts, thesis §4.2.3.2).  For a window
    start ``s`` the participant's difference is mean(score of ``reference`` in trials
    ``[s, s + window)``) − mean(score of ``compare`` there) when both occur.  Returned per group
    (``row['group']``, '' = all): ``start`` (S,), ``mean`` (S,), ``std`` (S,), ``n`` (S,) over
    participants.
    """
    by_group: dict[str, dict[Any, list[dict]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        if r["kind"] in RATING_KINDS:
            by_group[r.get("group") or ""][r["participant"]].append(r)
    out = {}
    for g, parts in sorted(by_group.items()):
        diffs: list[np.ndarray] = []
        n_pos = 0
        for prs in parts.values():
            order = {t: i for i, t in enumerate(sorted({r["trial_index"] for r in prs}))}
            n_pos = max(n_pos, len(order))
            pos = np.array([order[r["trial_index"]] for r in prs])
            val = np.array([r[value] for r in prs], dtype=float)
            cond = np.array([r["condition"] for r in prs])
            n_starts = max(0, len(order) - window + 1)
            d = np.full(max(n_pos, 1), np.nan)
            for s in range(n_starts):
                w = (pos >= s) & (pos < s + window)
                a, b = val[w & (cond == reference)], val[w & (cond == compare)]
                if a.size and b.size:
                    d[s] = a.mean() - b.mean()
            diffs.append(d)
        n_starts = max(0, n_pos - window + 1)
        if n_starts == 0:
            continue
        m = np.full((len(diffs), n_starts), np.nan)
        for i, d in enumerate(diffs):
            k = min(n_starts, d.size)
            m[i, :k] = d[:k]
        n = np.sum(np.isfinite(m), axis=0)
        with np.errstate(invalid="ignore"), _quiet():
            mean = np.nanmean(m, axis=0)
            std = np.nanstd(m, axis=0)
        out[g] = {"start": np.arange(n_starts), "mean": mean, "std": std, "n": n}
    return out


class _quiet:
    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *a):
        self._w.__exit__(*a)


def preference_matrix(rows: list[dict]) -> tuple[list[str], np.ndarray, np.ndarray]:
    """A/B preferences: ``wins[i, j]`` = times system i was chosen over j; ``n[i, j]`` = times the
    pair was compared.  Systems are ordered by overall win rate (best first)."""
    ab = [r for r in rows if r["kind"] == "ab"]
    systems = sorted({r["condition"] for r in ab} | {r["other"] for r in ab})
    idx = {s: i for i, s in enumerate(systems)}
    wins = np.zeros((len(systems), len(systems)))
    for r in ab:
        wins[idx[r["condition"]], idx[r["other"]]] += 1
    n = wins + wins.T
    rate = wins.sum(1) / np.maximum(n.sum(1), 1)
    order = np.argsort(-rate, kind="stable")
    return [systems[i] for i in order], wins[np.ix_(order, order)], n[np.ix_(order, order)]


def summarize(test: dict[str, Any], rows: list[dict[str, Any]], *, window: int = 10,
              reference: str | None = None, compare: str | None = None,
              include_training: bool = False) -> dict[str, Any]:
    """All the numbers of the report (no files written).

    Returns a dict with (depending on the test type) ``ranking`` (conditions, best first),
    ``excluded``, ``mos_table``, ``group_ttests``, ``pairwise``, ``windowed``, ``mushra_screening``,
    ``ab`` and ``attention``."""

    if window < 1:
        raise ParameterError(f"window must be a positive number of trials; got {window}")
    res: dict[str, Any] = {"test": test, "warnings": []}
    rows = [dict(r) for r in rows]
    for r in rows:
        r.setdefault("group", "")
        r.setdefault("speaker", "")
        r.setdefault("other", "")
        r["value"] = float(r["value"]) if r.get("value") not in (None, "") else math.nan
    attention = [r for r in rows if r["kind"] == "attention"]
    if attention:
        per: dict[Any, list[float]] = defaultdict(list)
        for r in attention:
            per[r["participant"]].append(r["value"])
        res["attention"] = {p: float(np.mean(v)) for p, v in sorted(per.items())}
    all_trials = [r for r in rows if r["kind"] != "attention"]
    res["n_training_answers"] = sum(r.get("phase") == "training" for r in all_trials)
    excluded = constant_raters([r for r in all_trials if r.get("phase") != "training"])
    res["excluded"] = excluded
    kept_all = [r for r in all_trials if r["participant"] not in set(excluded)]
    data = kept_all if include_training else [r for r in kept_all if r.get("phase") != "training"]
    res["participants"] = sorted({r["participant"] for r in all_trials})
    res["n_participants_kept"] = len({r["participant"] for r in data})
    demo_fields = sorted({k for r in rows for k in r if k.startswith("demo_")})
    kinds = {r["kind"] for r in data}
    if not data:
        res["warnings"].append("no answers to analyse")
        res["ranking"] = []
        return res

    if kinds & set(RATING_KINDS):
        rated = [r for r in data if r["kind"] in RATING_KINDS]
        rescale(rated, by=("participant", "speaker"), out="norm")
        rescale(rated, by=("participant",), out="norm_p")
        conds = sorted({r["condition"] for r in rated})
        mean_norm = {c: float(np.mean([r["norm"] for r in rated if r["condition"] == c]))
                     for c in conds}
        ranking = sorted(conds, key=lambda c: -mean_norm[c])
        res["ranking"] = ranking
        res["kind"] = "mushra" if "mushra" in kinds else "mos"

        res["mos_table"] = _mos_table(rated, ranking, demo_fields)
        res["group_ttests"] = _group_ttests(rated, ranking, demo_fields)
        res["pairwise"] = _pairwise_tests(rated, ranking)
        _windowed_summary(res, kept_all, rated, conds, ranking, window=window, reference=reference, compare=compare)
        if "mushra" in kinds:
            _mushra_screening(res, test, rated, conds, ranking)
    if "ab" in kinds:
        _ab_summary(res, data)
    return res


def _mos_table(rated: list[dict], ranking: list[str], demo_fields: list[str]) -> list[tuple]:
    """Mean scores per condition: per demographic group, raw, normalised (Table 4.2-style)."""
    def mean_of(sel, key):
        return {c: _mean([r[key] for r in sel if r["condition"] == c]) for c in ranking}

    table = []
    for f in demo_fields:
        for v in sorted({str(r.get(f)) for r in rated if r.get(f) not in (None, "")}):
            sel = [r for r in rated if str(r.get(f)) == v]
            table.append((f"{f[5:]} = {v}", len({r['participant'] for r in sel}),
                          mean_of(sel, "value")))
    n_all = len({r["participant"] for r in rated})
    table.append(("Mean results", n_all, mean_of(rated, "value")))
    table.append(("Mean normalised results (participant × speaker)", n_all,
                  mean_of(rated, "norm")))
    table.append(("Rescaled per participant", n_all, mean_of(rated, "norm_p")))
    return table



def _group_ttests(rated: list[dict], ranking: list[str], demo_fields: list[str]) -> list[tuple]:
    """Student's t-tests between participant groups on normalised scores (Table 4.3)."""
    from scipy import stats

    # Student's t-tests between participant groups (Table 4.3), normalised scores
    tt = []
    for f in demo_fields:
        values = sorted({str(r.get(f)) for r in rated if r.get(f) not in (None, "")})
        for a, b in combinations(values, 2):
            ps = {}
            for c in ranking:
                xa = [r["norm"] for r in rated if str(r.get(f)) == a and r["condition"] == c]
                xb = [r["norm"] for r in rated if str(r.get(f)) == b and r["condition"] == c]
                if len(xa) >= 2 and len(xb) >= 2:
                    ps[c] = float(stats.ttest_ind(xa, xb, equal_var=True).pvalue)
                else:
                    ps[c] = math.nan
            tt.append((f[5:], a, b, ps))
    return tt



def _pairwise_tests(rated: list[dict], ranking: list[str]) -> list[dict]:
    """Paired t and Wilcoxon tests between conditions on per-participant means, Holm-corrected."""
    from scipy import stats

    # pairwise tests between systems on per-participant means, Holm-corrected
    per_part: dict[Any, dict[str, float]] = defaultdict(dict)
    for p in {r["participant"] for r in rated}:
        for c in ranking:
            v = [r["norm"] for r in rated if r["participant"] == p and r["condition"] == c]
            if v:
                per_part[p][c] = float(np.mean(v))
    pw = []
    for a, b in combinations(ranking, 2):
        pairs = [(d[a], d[b]) for d in per_part.values() if a in d and b in d]
        x = np.array([u for u, _ in pairs])
        y = np.array([v for _, v in pairs])
        t_p = w_p = math.nan
        t_stat = math.nan
        if len(pairs) >= 2 and np.any(x - y != 0):
            tr = stats.ttest_rel(x, y)
            t_stat, t_p = float(tr.statistic), float(tr.pvalue)
            try:
                w_p = float(stats.wilcoxon(x, y).pvalue)
            except ValueError:
                w_p = math.nan
        pw.append({"a": a, "b": b, "n": len(pairs), "mean_diff": float(np.mean(x - y))
                   if pairs else math.nan, "t": t_stat, "p_t": t_p, "p_wilcoxon": w_p})
    _apply_holm(pw, "p_t", "p_t_holm")
    _apply_holm(pw, "p_wilcoxon", "p_wilcoxon_holm")
    return pw



def _windowed_summary(res: dict, kept_all: list[dict], rated: list[dict], conds: list[str], ranking: list[str], *,
                      window: int, reference: str | None, compare: str | None) -> None:
    """Windowed differences between two conditions and key statistics after the first window."""
    # windowed differences (training included; all kept participants)
    win_rows = [r for r in kept_all if r["kind"] in RATING_KINDS]
    rescale(win_rows, by=("participant", "speaker"), out="norm")
    ref = reference or ranking[0]
    cmp_ = compare or (ranking[1] if len(ranking) > 1 else ranking[0])
    for name, c in (("reference", ref), ("compare", cmp_)):
        if c not in conds:
            raise ParameterError(f"--{name} condition {c!r} is not in the results; "
                                 f"conditions are {conds}")
    res["window"] = {"reference": ref, "compare": cmp_, "size": window,
                     "curves": windowed_differences(win_rows, reference=ref, compare=cmp_,
                                                    window=window)}
    # Table 4.1-style key statistics per group after the first window (training)
    # (thesis: "pairs 10 to 40" — the first window of trials counts as training)
    trials_of: dict[Any, list[int]] = defaultdict(list)
    for r in win_rows:
        trials_of[r["participant"]].append(r["trial_index"])
    position = {p: {t: i for i, t in enumerate(sorted(set(ts)))}
                for p, ts in trials_of.items()}
    after = [r for r in win_rows if position[r["participant"]][r["trial_index"]] >= window]
    if not after:
        after = win_rows
        res["warnings"].append(f"fewer than {window} trials per participant: key statistics "
                               "use all trials")
    key = []
    for g in sorted({r["group"] for r in after}):
        parts = defaultdict(lambda: defaultdict(list))
        rts = []
        for r in after:
            if r["group"] == g and r["condition"] in (ref, cmp_):
                parts[r["participant"]][r["condition"]].append(r["norm"])
                if r.get("response_ms") not in (None, "") and math.isfinite(
                        float(r["response_ms"])):
                    rts.append(float(r["response_ms"]) / 1000)
        d = np.array([np.mean(v[ref]) - np.mean(v[cmp_]) for v in parts.values()
                      if v[ref] and v[cmp_]])
        key.append({"group": g or "all", "mean_difference": _mean(d),
                    "variance": float(np.var(d)) if d.size else math.nan,
                    "mean_time_s": _mean(rts),
                    "variance_time": float(np.var(rts)) if rts else math.nan})
    res["window_stats"] = key
    res["rated_rows"] = rated



def _mushra_screening(res: dict, test: dict, rated: list[dict], conds: list[str], ranking: list[str]) -> None:
    """MUSHRA post-screening on the hidden reference."""
    hidden = test.get("hidden_reference") or "reference"
    thr = float(test.get("screening_threshold", 90.0))
    frac = float(test.get("screening_fraction", 0.85))
    scr = []
    for p in sorted({r["participant"] for r in rated}):
        hr = [r["value"] for r in rated if r["participant"] == p and r["condition"] == hidden]
        ok = float(np.mean(np.array(hr) >= thr)) if hr else math.nan
        scr.append({"participant": p, "items": len(hr), "fraction_ok": ok,
                    "passes": bool(hr) and ok >= frac})
    res["mushra_screening"] = {"hidden_reference": hidden, "threshold": thr,
                               "fraction": frac, "participants": scr}
    if hidden not in conds:
        res["warnings"].append(f"hidden reference condition {hidden!r} not found")
    passing = {s["participant"] for s in scr if s["passes"]}
    res["mushra_after_screening"] = {
        c: _mean([r["value"] for r in rated if r["condition"] == c
                  and r["participant"] in passing]) for c in ranking}


def _ab_summary(res: dict, data: list[dict]) -> None:
    """A/B preference counts, binomial tests (Holm-corrected) and side bias."""
    from scipy import stats

    ab = [r for r in data if r["kind"] == "ab"]
    systems, wins, n = preference_matrix(ab)
    tests = []
    for i, j in combinations(range(len(systems)), 2):
        if n[i, j] > 0:
            p = float(stats.binomtest(int(wins[i, j]), int(n[i, j]), 0.5).pvalue)
            tests.append({"a": systems[i], "b": systems[j], "n": int(n[i, j]),
                          "a_preferred": float(wins[i, j] / n[i, j]), "p": p})
    _apply_holm(tests, "p", "p_holm")
    left = sum(r["slot"] == "left" for r in ab)
    sides: dict[tuple, list[int]] = defaultdict(lambda: [0, 0])
    for r in ab:
        left_sys = r["condition"] if r["slot"] == "left" else r["other"]
        key = tuple(sorted((r["condition"], r["other"])))
        sides[key][0 if left_sys == key[0] else 1] += 1
    res["ab"] = {"systems": systems, "wins": wins, "n": n, "tests": tests,
                 "left_fraction": left / max(1, len(ab)),
                 "side_counts": {f"{k[0]} vs {k[1]}": v for k, v in sorted(sides.items())}}
    if "ranking" not in res:
        res["ranking"] = systems


def _apply_holm(rows: list[dict], key: str, out: str) -> None:
    ps = [r[key] for r in rows]
    finite = [i for i, p in enumerate(ps) if isinstance(p, float) and math.isfinite(p)]
    adj = holm([ps[i] for i in finite])
    for r in rows:
        r[out] = math.nan
    for i, a in zip(finite, adj):
        rows[i][out] = float(a)


def _mean(v) -> float:
    v = [x for x in v if x is not None and math.isfinite(float(x))]
    return float(np.mean(v)) if v else math.nan


# ---------------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------------
def analyze(results, output, *, window: int = 10, reference: str | None = None,
            compare: str | None = None, include_training: bool = False) -> Path:
    """Analyse ``results`` and write ``REPORT_DIR/report.md`` plus PNG figures; returns the report
    path.  See the module docstring for what is computed."""
    test, rows = load_results(results)
    res = summarize(test, rows, window=window, reference=reference, compare=compare,
                    include_training=include_training)
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    from .analysis_report import figures, markdown

    figs = figures(res, out)
    md = markdown(res, figs, Path(results).name)
    from ..io.atomic import atomic_write_text

    report = out / "report.md"
    atomic_write_text(report, md)
    atomic_write_text(out / "summary.json", json.dumps(_jsonable(res), indent=1))
    analyze.last_warnings = res["warnings"]
    return report


def _jsonable(res: dict) -> dict:
    skip = {"rated_rows"}

    def conv(x):
        if isinstance(x, dict):
            return {str(k): conv(v) for k, v in x.items() if k not in skip}
        if isinstance(x, (list, tuple)):
            return [conv(v) for v in x]
        if isinstance(x, np.ndarray):
            return conv(x.tolist())
        if isinstance(x, (np.floating, float)):
            return None if not math.isfinite(float(x)) else float(x)
        if isinstance(x, np.integer):
            return int(x)
        return x

    return conv(res)


__all__ = ["load_results", "summarize", "analyze", "rescale", "holm", "constant_raters",
           "windowed_differences", "preference_matrix"]
