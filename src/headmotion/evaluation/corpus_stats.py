"""Corpus statistics (thesis §3.5: Tables 3.2–3.6, Figs 3.2–3.6).

* Lengths per speaker × task (Table 3.2).
* Speaking rate per recording from syllable nuclei (de Jong & Wempe 2009), mean/SD per speaker and
  task (Table 3.3): :func:`syllable_nuclei`.
* Distribution statistics of rotation, Δ, ΔΔ (Table 3.4, Fig 3.2): :func:`headmotion.evaluation.
  metrics.distribution_stats`.
* Cross-entropy distance between recordings (eq 3.1): :func:`cross_entropy_distances` — rotation +
  Δ + ΔΔ, 50-bin histograms on edges common to all recordings (range of all samples), one count
  added to every bin, dimensions independent.  Because the same bins are used for both recordings,
  ``(1/T_A) Σ_t log p_A(a_t)/p_B(a_t) = Σ_bins q_A (log p_A − log p_B)`` with ``q_A`` the
  unsmoothed histogram, so the whole matrix is two matrix products.
* MDS to 2-D (Fig 3.3): classical scaling (eq 3.3–3.5, with the usual −½ of Torgerson's double
  centring), then iterative SMACOF from that start (scikit-learn ``MDS``); Kruskal stress-1
  ``sqrt(Σ(d − d̂)² / Σ d²)`` (eq 3.2 is the same without the square root; both are reported).
* Speaker / task dependency (Table 3.5), per-speaker heat maps overall and per task (Figs
  3.4–3.6), and the Pearson correlation of speaking-rate difference with motion distance
  (Table 3.6).
* Feature ↔ motion correlation for every registered feature set (paper Table 1, thesis §5.7.1):
  local CCA of each feature set with the recorded motion and its circular-shift chance level, by
  :func:`headmotion.evaluation.protocol.feature_table.feature_table` (the same computation as ``headmotion
  evaluate``) and written by :func:`headmotion.evaluation.reporting.report.feature_table_section` (the same
  table layout).

Libraries considered: Praat's own ``syllable nuclei`` script (de Jong & Wempe) needs Praat
scripting; here the same steps run on parselmouth's intensity and pitch objects (intensity peaks
above a threshold of the 0.99 quantile − 25 dB, a ≥ 2 dB dip to the next peak, voiced at the
peak).  scikit-learn's ``MDS`` (SMACOF) for the iterative MDS; scipy for statistics.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ..corpus import Corpus
from ..errors import ParameterError
from ..types import Audio
from .measures import metrics as M

N_BINS = 50


# -- speaking rate ------------------------------------------------------------------------------
def syllable_nuclei(audio: Audio, *, silence_db: float = -25.0, min_dip_db: float = 2.0,
                    min_pause_s: float = 0.3) -> dict[str, float]:
    """Syllable nuclei after de Jong & Wempe (2009).

    Steps: intensity contour (minimum pitch 50 Hz); threshold = max(0.99 quantile + ``silence_db``,
    minimum); candidate nuclei are intensity peaks above the threshold; a peak is kept when the
    intensity dips by at least ``min_dip_db`` before the next peak; and the pitch (autocorrelation,
    30–450 Hz, the script's settings) is voiced at the peak.  Phonation time is the total length
    of intervals above the threshold longer than ``min_pause_s`` apart.

    Returns
    -------
    ``{"syllables", "duration_s", "phonation_s", "speech_rate" (syll/s over the whole recording),
    "articulation_rate" (syll/s of phonation)}``
    """
    import parselmouth
    from scipy.signal import find_peaks

    x = np.asarray(audio.samples, dtype=np.float64)
    dur = len(x) / audio.sample_rate
    out = {"syllables": 0.0, "duration_s": dur, "phonation_s": 0.0, "speech_rate": 0.0, "articulation_rate": 0.0}
    if dur < 0.2 or not np.any(x):
        return out
    snd = parselmouth.Sound(x, sampling_frequency=audio.sample_rate)
    inten = snd.to_intensity(minimum_pitch=50.0)
    iv = inten.values[0]
    it = inten.xs()
    if len(iv) < 3:
        return out
    finite = np.isfinite(iv)
    iv = np.where(finite, iv, np.nanmin(iv[finite]) if finite.any() else 0.0)
    q99 = float(np.quantile(iv, 0.99))
    threshold = max(q99 + silence_db, float(iv.min()))
    peaks, _ = find_peaks(iv)
    peaks = peaks[iv[peaks] > threshold]
    keep = []
    for k, p in enumerate(peaks):
        nxt = peaks[k + 1] if k + 1 < len(peaks) else None
        if nxt is None:
            keep.append(p)  # the last peak: no following dip to test (as in the script)
            continue
        dip = float(iv[p:nxt + 1].min())
        if abs(iv[p] - dip) > min_dip_db:
            keep.append(p)
    pitch = snd.to_pitch_ac(time_step=0.02, pitch_floor=30.0, max_number_of_candidates=4, very_accurate=False,
                            silence_threshold=0.03, voicing_threshold=0.25, octave_cost=0.01,
                            octave_jump_cost=0.35, voiced_unvoiced_cost=0.25, pitch_ceiling=450.0)
    f0 = pitch.selected_array["frequency"]
    pt = pitch.xs()
    n_syll = 0
    for p in keep:
        j = int(np.argmin(np.abs(pt - it[p]))) if len(pt) else -1
        if j >= 0 and f0[j] > 0:
            n_syll += 1
    # phonation time: above-threshold stretches, bridging pauses shorter than min_pause_s
    dt = float(it[1] - it[0]) if len(it) > 1 else 0.01
    above = iv > threshold
    gap = int(round(min_pause_s / dt))
    idx = np.flatnonzero(above)
    phon = 0.0
    if len(idx):
        starts = [idx[0]]
        ends = []
        for a, b in zip(idx[:-1], idx[1:]):
            if b - a > gap:
                ends.append(a)
                starts.append(b)
        ends.append(idx[-1])
        phon = float(sum((e - s + 1) * dt for s, e in zip(starts, ends)))
    out.update(syllables=float(n_syll), phonation_s=phon, speech_rate=n_syll / dur,
               articulation_rate=n_syll / phon if phon > 0 else 0.0)
    return out


# -- cross-entropy distance ------------------------------------------------------------------------
def motion_observations(rotvec: np.ndarray) -> np.ndarray:
    """``(T, 9)``: rotation, Δ and ΔΔ (per frame) — the observation vector of thesis §3.5.1."""
    a = np.asarray(rotvec, dtype=float)
    return np.hstack([a, M.deltas(a, order=1), M.deltas(a, order=2)])


@M.single_threaded
def cross_entropy_distances(observations: Sequence[np.ndarray], *, n_bins: int = N_BINS) -> np.ndarray:
    """Symmetric cross-entropy distance matrix (thesis eq 3.1) between recordings.

    Parameters
    ----------
    observations : sequence of arrays ``(T_i, D)`` (e.g. :func:`motion_observations`)
    n_bins : int — histogram bins per dimension on edges common to all recordings (50)

    Returns
    -------
    np.ndarray [shape=(N, N)] — zero diagonal, symmetric, non-negative.
    """
    obs = [np.asarray(o, dtype=float) for o in observations]
    if len(obs) < 2:
        raise ParameterError(f"cross-entropy distances need at least 2 recordings; got {len(obs)}")
    D = obs[0].shape[1]
    if any(o.ndim != 2 or o.shape[1] != D or len(o) == 0 for o in obs):
        raise ParameterError("every recording needs a non-empty (T, D) array with the same D")
    lo = np.min([o.min(axis=0) for o in obs], axis=0)
    hi = np.max([o.max(axis=0) for o in obs], axis=0)
    hi = np.where(hi > lo, hi, lo + 1e-12)
    N = len(obs)
    Q = np.zeros((N, D * n_bins))
    L = np.zeros((N, D * n_bins))
    for i, o in enumerate(obs):
        b = np.clip(((o - lo) / (hi - lo) * n_bins).astype(int), 0, n_bins - 1)
        counts = np.zeros((D, n_bins))
        for d in range(D):
            counts[d] = np.bincount(b[:, d], minlength=n_bins)
        Q[i] = (counts / len(o)).ravel()
        smoothed = counts + 1.0
        L[i] = np.log(smoothed / smoothed.sum(axis=1, keepdims=True)).ravel()
    QL = Q @ L.T  # QL[i, j] = (1/T_i) Σ_t log p_j(a_t) summed over dims
    d = np.diag(QL)
    E = (d[:, None] - QL) + (d[None, :] - QL.T)
    np.fill_diagonal(E, 0.0)
    return np.maximum(E, 0.0)


# -- MDS ---------------------------------------------------------------------------------------------
def classical_mds(dist: np.ndarray, n_components: int = 2) -> np.ndarray:
    """Classical (Torgerson) scaling, thesis eq 3.3–3.5: ``B = −½ C D² C``, eigenvectors scaled by
    the square roots of the positive eigenvalues, zero-padded to ``n_components`` columns."""
    D = np.asarray(dist, dtype=float)
    n = len(D)
    C = np.eye(n) - np.ones((n, n)) / n
    B = -0.5 * C @ (D ** 2) @ C
    w, v = np.linalg.eigh(B)
    order = np.argsort(w)[::-1]
    w, v = w[order], v[:, order]
    pos = w > 1e-12 * max(1.0, abs(w[0]))
    X = v[:, pos] * np.sqrt(w[pos])
    if X.shape[1] < n_components:
        X = np.hstack([X, np.zeros((n, n_components - X.shape[1]))])
    return X[:, :n_components]


def stress(dist: np.ndarray, X: np.ndarray) -> tuple[float, float]:
    """``(Kruskal stress-1, thesis eq 3.2 value)`` of the embedding ``X`` for distances ``dist``."""
    from scipy.spatial.distance import pdist, squareform

    d = squareform(np.asarray(dist, dtype=float), checks=False)
    dh = pdist(X)
    s2 = float(np.sum((d - dh) ** 2) / max(np.sum(d ** 2), 1e-300))
    return float(np.sqrt(s2)), s2


@M.single_threaded
def mds(dist: np.ndarray, *, n_components: int = 2, seed: int = 0, max_iter: int = 300) -> tuple[np.ndarray, float, float]:
    """Classical MDS, then metric SMACOF from it; returns ``(X (N, n_components), stress-1, eq-3.2 stress)``."""
    import warnings

    from sklearn.manifold import MDS

    D = np.asarray(dist, dtype=float)
    X0 = classical_mds(D, n_components)
    if len(D) < 3:
        s1, s2 = stress(D, X0)
        return X0, s1, s2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:  # scikit-learn ≥ 1.8
            est = MDS(n_components=n_components, metric_mds=True, metric="precomputed", n_init=1, init="random",
                      max_iter=max_iter, random_state=seed)
        except TypeError:
            est = MDS(n_components=n_components, metric=True, dissimilarity="precomputed", n_init=1,
                      max_iter=max_iter, random_state=seed)
        X = est.fit_transform(D, init=X0)
    s1, s2 = stress(D, X)
    s1_0, _ = stress(D, X0)
    if s1_0 < s1:  # never worse than the start
        X = X0
        s1, s2 = stress(D, X0)
    return X, s1, s2


# -- dependency statistics ---------------------------------------------------------------------------
def pair_statistics(dist: np.ndarray, speakers: Sequence[str], tasks: Sequence[str]) -> list[dict]:
    """Thesis Table 3.5: mean and variance of distances for pairs within each task (all speakers),
    between tasks (same speaker only), within speaker and between speakers."""
    D = np.asarray(dist)
    spk = np.asarray(speakers)
    tsk = np.asarray(tasks)
    iu = np.triu_indices(len(D), 1)
    d = D[iu]
    same_s = spk[iu[0]] == spk[iu[1]]
    same_t = tsk[iu[0]] == tsk[iu[1]]
    rows = []

    def add(name, mask):
        v = d[mask]
        rows.append({"condition": name, "pairs": int(mask.sum()),
                     "mean": float(np.mean(v)) if len(v) else float("nan"),
                     "variance": float(np.var(v, ddof=1)) if len(v) > 1 else float("nan")})

    for t in sorted(set(tasks)):
        add(t, same_t & (tsk[iu[0]] == t))
    add("Between tasks", same_s & ~same_t)
    add("Within speaker", same_s)
    add("Between speakers", ~same_s)
    return rows


def speaker_means(dist: np.ndarray, speakers: Sequence[str], mask: np.ndarray | None = None) -> tuple[list[str], np.ndarray]:
    """Mean distance between the recordings of each pair of speakers (heat maps, Figs 3.4–3.6);
    the diagonal excludes a recording's distance to itself.  ``mask`` selects recordings."""
    spk = np.asarray(speakers)
    sel = np.ones(len(spk), bool) if mask is None else np.asarray(mask, bool)
    names = sorted(set(spk[sel]))
    H = np.full((len(names), len(names)), np.nan)
    for a, sa in enumerate(names):
        ia = np.flatnonzero(sel & (spk == sa))
        for b, sb in enumerate(names):
            ib = np.flatnonzero(sel & (spk == sb))
            block = dist[np.ix_(ia, ib)]
            if a == b:
                if len(ia) > 1:
                    H[a, b] = block[~np.eye(len(ia), dtype=bool)].mean()
            else:
                H[a, b] = block.mean()
    return names, H


def rate_distance_correlation(dist: np.ndarray, rates: Sequence[float], tasks: Sequence[str]) -> list[dict]:
    """Thesis Table 3.6: Pearson correlation of |rate_i − rate_j| with the motion distance over
    pairs, for all pairs and for pairs within each task."""
    from scipy.stats import pearsonr

    r = np.asarray(rates, dtype=float)
    tsk = np.asarray(tasks)
    iu = np.triu_indices(len(r), 1)
    dr = np.abs(r[iu[0]] - r[iu[1]])
    dd = np.asarray(dist)[iu]
    out = []
    for name, mask in [("All", np.ones(len(dd), bool))] + [
            (t, (tsk[iu[0]] == t) & (tsk[iu[1]] == t)) for t in sorted(set(tasks))]:
        ok = mask & np.isfinite(dr) & np.isfinite(dd)
        if ok.sum() >= 3 and np.std(dr[ok]) > 0 and np.std(dd[ok]) > 0:
            c, p = pearsonr(dr[ok], dd[ok])
        else:
            c, p = float("nan"), float("nan")
        out.append({"task": name, "pairs": int(ok.sum()), "correlation": float(c), "p": float(p)})
    return out


# -- the whole analysis --------------------------------------------------------------------------------
@dataclass
class CorpusStats:
    """Everything :func:`corpus_stats` computes."""

    recordings: list[dict]                  # id, speaker, task, seconds, frames, fps, syllables, speech_rate, ...
    distances: np.ndarray                   # (N, N) cross-entropy distances
    mds: np.ndarray                         # (N, 2)
    stress1: float
    stress_eq32: float
    distribution: dict                      # Table 3.4
    pairs: list[dict]                       # Table 3.5
    rate_correlation: list[dict]            # Table 3.6
    histograms: dict = field(default_factory=dict)  # Fig 3.2: column -> (edges, counts)
    timings: dict = field(default_factory=dict)
    #: paper Table 1: {recording: {"featcca_local[fs]" (+ _null_mean, _excess, _p): value}}
    feature_table: dict = field(default_factory=dict)
    #: its settings: feature_sets, window_s, n_shifts, seed, splits {recording: train|valid|test}
    feature_config: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)


@M.single_threaded
def _one_recording(corpus: Corpus, i: int, speaking_rate: bool) -> dict:
    rec = corpus[i]
    row = {"recording": rec.id, "speaker": rec.speaker, "task": rec.task, "seconds": rec.duration,
           "frames": len(rec.motion), "fps": float(rec.motion.fps)}
    if speaking_rate:
        row.update(syllable_nuclei(rec.audio))
    return {"row": row, "obs": motion_observations(rec.motion.rotvec).astype(np.float32),
            "rotvec": np.asarray(rec.motion.rotvec, dtype=np.float32)}


def corpus_stats(corpus: Corpus, *, n_bins: int = N_BINS, speaking_rate: bool = True, n_jobs: int = 1,
                 seed: int = 0, feature_sets: Sequence | None = None, window_s: float = 3.0, n_shifts: int = 200,
                 progress: Callable | None = None) -> CorpusStats:
    """Thesis §3.5 statistics of ``corpus`` (see the module docstring).

    Parameters
    ----------
    corpus : Corpus (≥ 2 recordings)
    n_bins : int — histogram bins for the cross-entropy distance (50)
    speaking_rate : bool — compute syllable-nuclei speaking rates (needs parselmouth)
    n_jobs : int — recordings are loaded and analysed in parallel with joblib
    seed : int — seed of the iterative MDS and of the chance levels' circular shifts
    feature_sets : feature sets for the paper Table 1 (default: every registered set, as
        ``headmotion evaluate``; ``[]`` = none): names or ``callable(audio, fps=, n_frames=)``
    window_s : float — local CCA window in seconds for the feature table (3 s)
    n_shifts : int — circular shifts per chance level (200)
    progress : callable ``(done, total, description)``
    """
    if len(corpus) < 2:
        raise ParameterError(f"corpus statistics need at least 2 recordings; got {len(corpus)}")
    t0 = time.perf_counter()
    n = len(corpus)
    if progress:
        progress(0, n + 1, "recordings")
    if n_jobs == 1:
        items = []
        for i in range(n):
            items.append(_one_recording(corpus, i, speaking_rate))
            if progress:
                progress(i + 1, n + 1, f"recording {items[-1]['row']['recording']}")
    else:
        from joblib import Parallel, delayed

        items = []
        for i, it in enumerate(Parallel(n_jobs=n_jobs, return_as="generator")(
                delayed(_one_recording)(corpus, i, speaking_rate) for i in range(n))):
            items.append(it)
            if progress:
                progress(i + 1, n + 1, f"recording {it['row']['recording']}")
    t1 = time.perf_counter()
    rows = [it["row"] for it in items]
    obs = [it["obs"] for it in items]
    dist = cross_entropy_distances(obs, n_bins=n_bins)
    X, s1, s2 = mds(dist, seed=seed)
    spk = [r["speaker"] for r in rows]
    tsk = [r["task"] for r in rows]
    dstats = M.distribution_stats([it["rotvec"] for it in items])
    pooled = np.vstack(obs)
    names = list(dstats)
    hists = {}
    for j, nm in enumerate(names):
        c, e = np.histogram(pooled[:, j], bins=N_BINS)
        hists[nm] = (e, c)
    rates = [r.get("speech_rate", float("nan")) for r in rows]
    rc = rate_distance_correlation(dist, rates, tsk) if speaking_rate else []
    if progress:
        progress(n + 1, n + 1, "distances and MDS")
    t2 = time.perf_counter()
    timings = {"recordings": t1 - t0, "distances+mds": t2 - t1}
    table, fconfig, warns = _feature_table(corpus, feature_sets, window_s=window_s, n_shifts=n_shifts, seed=seed,
                                           n_jobs=n_jobs, progress=progress)
    if fconfig:
        timings["feature table"] = time.perf_counter() - t2
    return CorpusStats(recordings=rows, distances=dist, mds=X, stress1=s1, stress_eq32=s2, distribution=dstats,
                       pairs=pair_statistics(dist, spk, tsk), rate_correlation=rc, histograms=hists,
                       timings=timings, feature_table=table, feature_config=fconfig, warnings=warns)


def _feature_table(corpus: Corpus, feature_sets, *, window_s: float, n_shifts: int, seed: int, n_jobs: int,
                   progress: Callable | None) -> tuple[dict, dict, list[str]]:
    """Paper Table 1 of the whole corpus: ``(table, settings, warnings)``; empty when there are no
    feature sets."""
    from ..corpus import paper_split
    from .protocol.feature_table import feature_set_name, feature_table

    if feature_sets is None:
        from .. import features as F

        feature_sets = tuple(F.available())
    feature_sets = tuple(feature_sets)
    if not feature_sets:
        return {}, {}, []
    if progress:
        progress(0, len(corpus), "feature table")
    table, warns = feature_table(
        corpus, feature_sets, window_s=window_s, n_shifts=n_shifts, seed=int(seed), n_jobs=n_jobs,
        progress=(lambda d, t, desc: progress(d, t, f"feature table {desc}")) if progress else None)
    config = {"feature_sets": [feature_set_name(f) for f in feature_sets], "window_s": float(window_s),
              "n_shifts": int(n_shifts), "seed": int(seed), "splits": paper_split(corpus, seed=seed),
              "speakers": {e.recording: e.speaker for e in corpus.entries}}
    return table, config, warns

__all__ = ["syllable_nuclei", "motion_observations", "cross_entropy_distances", "classical_mds", "mds", "stress",
           "pair_statistics", "speaker_means", "rate_distance_correlation", "CorpusStats", "corpus_stats"]
