"""Detectability: can a classifier tell generated head motion from recorded head motion?

A classifier two-sample test (Lopez-Paz & Oquab 2017, "Revisiting classifier two-sample tests";
the discriminator measures of the GENEA challenges): both samples are cut into 4 s windows after
the *same* preprocessing — a zero-phase 6 Hz low-pass and resampling to 25 fps, so a tracker's
jitter or a frame rate decides nothing — and a classifier learns to tell the windows apart with
folds that never put windows of one recording on both sides of a split (scikit-learn's
``StratifiedGroupKFold``, groups = recordings; a generated motion belongs to the recording whose
speech made it).  Its out-of-fold balanced accuracy is the measure: 0.5 — the classifier cannot
tell them apart — to 1 — every window is told.  Two classifiers:

* ``stats`` — scikit-learn's ``HistGradientBoostingClassifier`` on interpretable, pose-free window
  statistics (:func:`window_statistics`: per-axis SD and range, speed and acceleration quantiles,
  share of frames below 2 °/s, direction reversals per frame, velocity autocorrelation at lags 1
  and 5, band shares, kurtosis, axis coupling);
* ``cnn`` — a small 1-D convolutional network on the raw windows (:mod:`.detectability_cnn`).

The condition's detectability is the larger of the two balanced accuracies.  A bootstrap over
recordings gives each figure a 95 % interval; :func:`statistic_aucs` says which statistics separate
most (the AUC of each statistic alone).  Ruler anchors (:func:`ruler_motions`): a recording against
its own time reversal (≈ 0.5), against phase-randomised copies (same per-axis spectrum and SD), and
against the still head (≈ 1).

:func:`detectability_rows` is what ``headmotion evaluate`` adds to ``metrics.csv``.

Libraries: scipy.signal (Butterworth low-pass), scikit-learn (classifier, folds, metrics), torch
(the CNN).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ...errors import ParameterError
from ...types import Motion

#: common frame rate (Hz), low-pass cut-off (Hz), window and hop (s)
FPS = 25.0
CUTOFF_HZ = 6.0
#: the low-pass of the test where a tracker's jitter decides nothing (:func:`low_pass_rows`)
LOW_CUTOFF_HZ = 3.0
WINDOW_S = 4.0
HOP_S = 2.0
STILL_DEG_S = 2.0
BANDS_HZ = ((0.0, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, 4.0), (4.0, 6.0))
AXES = ("pitch", "yaw", "roll")
CLASSIFIERS = ("stats", "cnn")
#: the CNN is trained only with at least this many windows on each side (fewer: it underfits, and
#: the statistics classifier decides)
MIN_CNN_WINDOWS = 40


# -- preprocessing -------------------------------------------------------------------------------
def _as_deg(motion, fps: float | None) -> tuple[np.ndarray, float]:
    if isinstance(motion, Motion):
        return np.degrees(np.asarray(motion.rotvec, dtype=float)), float(motion.fps)
    if fps is None:
        raise ParameterError("a motion given as an array needs fps")
    a = np.asarray(motion, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ParameterError(f"motion must be (T, 3) rotation vectors; got shape {a.shape}")
    return np.degrees(a), float(fps)


def prepare(motion, fps: float | None = None, *, cutoff_hz: float = CUTOFF_HZ) -> np.ndarray:
    """Degrees at :data:`FPS` after a zero-phase 4th-order Butterworth low-pass at ``cutoff_hz``
    (:data:`CUTOFF_HZ`, 6 Hz, unless told).

    Parameters
    ----------
    motion : Motion | np.ndarray [shape=(T, 3)] — rotation vectors in radians
    fps : float — frame rate of an array
    cutoff_hz : float — the low-pass cut-off (3 Hz: the test where a tracker's jitter decides nothing)

    Returns
    -------
    np.ndarray [shape=(T', 3)] — degrees at 25 fps
    """
    from scipy.signal import butter, sosfiltfilt

    x, f = _as_deg(motion, fps)
    if not np.all(np.isfinite(x)):
        raise ParameterError("motion contains NaN or infinite values")
    if len(x) < 2:
        return x[:0]
    if not cutoff_hz > 0:
        raise ParameterError(f"cutoff_hz must be > 0; got {cutoff_hz!r}")
    if f > 2 * cutoff_hz * 1.05 and len(x) > 12:
        sos = butter(4, cutoff_hz, fs=f, output="sos")
        x = sosfiltfilt(sos, x, axis=0, padlen=min(len(x) - 1, 3 * 9))
    if abs(f - FPS) > 1e-9:
        t_src = np.arange(len(x)) / f
        t_dst = np.arange(int(np.floor(t_src[-1] * FPS)) + 1) / FPS
        x = np.stack([np.interp(t_dst, t_src, x[:, j]) for j in range(3)], axis=1)
    return x


def cut_windows(x: np.ndarray, *, window_s: float = WINDOW_S, hop_s: float = HOP_S) -> np.ndarray:
    """Windows ``(n, round(window_s·25), 3)`` of a prepared motion (none when it is shorter)."""
    w, h = int(round(window_s * FPS)), max(1, int(round(hop_s * FPS)))
    if len(x) < w:
        return np.zeros((0, w, 3))
    starts = range(0, len(x) - w + 1, h)
    return np.stack([x[s:s + w] for s in starts])


def reversal_rate(motion, *, fps: float | None = None, cutoff_hz: float = CUTOFF_HZ) -> np.ndarray:
    """Direction reversals per frame and axis: the share of frames at 25 fps where the angular
    velocity changes sign, after a zero-phase low-pass at ``cutoff_hz`` (6 Hz) — :func:`prepare`.

    A tracked head's jitter shows here: video-tracked heads reverse on about a quarter of the
    frames, motion-captured ones on 12–15 %.  A frame without motion keeps the direction before
    it (the window statistic ``reversals`` of :func:`window_statistics` counts only strict sign
    changes).

    Parameters
    ----------
    motion : Motion | np.ndarray [shape=(T, 3)] — rotation vectors in radians
    fps : float — frame rate of an array

    Returns
    -------
    np.ndarray [shape=(3,)] — pitch, yaw, roll reversals per frame (0 … 1; nan under 3 frames)

    Examples
    --------
    >>> from headmotion.evaluation.detection.detectability import reversal_rate
    >>> reversal_rate(recording.motion)              # a Motion carries its rate
    >>> reversal_rate(rotvec, fps=30.0)
    """
    x = prepare(motion, fps, cutoff_hz=cutoff_hz)
    n, rev = _reversals(x)
    return rev / n if n else np.full(3, np.nan)


def _reversals(x: np.ndarray) -> tuple[int, np.ndarray]:
    """(velocity frames, sign changes per axis) of a prepared motion."""
    if len(x) < 3:
        return 0, np.zeros(3)
    sgn = np.sign(np.diff(x, axis=0))
    # a frame without motion keeps the direction before it (a sampled peak can fall on two equal
    # frames: the turn is counted once, not lost)
    idx = np.where(sgn != 0, np.arange(len(sgn))[:, None], 0)
    np.maximum.accumulate(idx, axis=0, out=idx)
    sgn = np.take_along_axis(sgn, idx, axis=0)
    return len(sgn), np.sum((sgn[1:] * sgn[:-1]) < 0, axis=0).astype(float)


# -- window statistics ---------------------------------------------------------------------------
def statistic_names() -> list[str]:
    """Names of the columns of :func:`window_statistics`."""
    per = ["sd", "range", "speed_q10", "speed_q50", "speed_q90", "speed_q99", "accel_q50", "accel_q90",
           "still_share", "reversals", "vel_ac1", "vel_ac5", "vel_kurtosis"]
    per += [f"band_{lo:g}_{hi:g}" for lo, hi in BANDS_HZ]
    names = [f"{ax}_{p}" for ax in AXES for p in per]
    names += ["speed3_q10", "speed3_q50", "speed3_q90", "still3_share"]
    names += [f"coupling_{AXES[i]}_{AXES[j]}" for i, j in ((0, 1), (0, 2), (1, 2))]
    return names


def _autocorr(v: np.ndarray, lag: int) -> np.ndarray:
    """Autocorrelation of ``v`` (n, T, 3) at ``lag`` per window and axis."""
    a = v - v.mean(axis=1, keepdims=True)
    den = np.sum(a * a, axis=1)
    num = np.sum(a[:, lag:] * a[:, :-lag], axis=1)
    return np.where(den > 1e-12, num / np.where(den > 1e-12, den, 1.0), 0.0)


def window_statistics(W: np.ndarray) -> np.ndarray:
    """Pose-free statistics of windows of prepared motion (degrees at 25 fps).

    Parameters
    ----------
    W : np.ndarray [shape=(n, T, 3)]

    Returns
    -------
    np.ndarray [shape=(n, len(statistic_names()))] — see :func:`statistic_names`
    """
    from scipy.stats import kurtosis

    W = np.asarray(W, dtype=float)
    n, T, _ = W.shape
    v = np.diff(W, axis=1) * FPS  # °/s
    acc = np.abs(np.diff(v, axis=1)) * FPS  # °/s²
    sp = np.abs(v)
    cols = []
    sd = W.std(axis=1)
    rng = W.max(axis=1) - W.min(axis=1)
    qs = np.percentile(sp, [10, 50, 90, 99], axis=1)  # (4, n, 3)
    qa = np.percentile(acc, [50, 90], axis=1)
    still = np.mean(sp < STILL_DEG_S, axis=1)
    sgn = np.sign(v)
    rev = np.sum((sgn[:, 1:] * sgn[:, :-1]) < 0, axis=1) / v.shape[1]
    ac1, ac5 = _autocorr(v, 1), _autocorr(v, 5)
    flat = v.std(axis=1) < 1e-9
    kurt = np.where(flat, 0.0, np.nan_to_num(kurtosis(v, axis=1), nan=0.0))
    x = W - W.mean(axis=1, keepdims=True)
    t = np.arange(T) - (T - 1) / 2
    x = x - t[None, :, None] * (np.sum(x * t[None, :, None], axis=1, keepdims=True) / np.sum(t * t))
    P = np.abs(np.fft.rfft(x * np.hanning(T)[None, :, None], axis=1)) ** 2
    freqs = np.fft.rfftfreq(T, 1.0 / FPS)
    tot = P[:, (freqs > 0) & (freqs <= BANDS_HZ[-1][1]), :].sum(axis=1)
    bands = []
    for lo, hi in BANDS_HZ:
        sel = (freqs > lo) & (freqs <= hi)
        bands.append(np.where(tot > 1e-18, P[:, sel, :].sum(axis=1) / np.where(tot > 1e-18, tot, 1.0), 0.0))
    for j in range(3):
        cols += [sd[:, j], rng[:, j], qs[0, :, j], qs[1, :, j], qs[2, :, j], qs[3, :, j], qa[0, :, j], qa[1, :, j],
                 still[:, j], rev[:, j], ac1[:, j], ac5[:, j], kurt[:, j]] + [b[:, j] for b in bands]
    sp3 = np.linalg.norm(v, axis=2)
    cols += list(np.percentile(sp3, [10, 50, 90], axis=1)) + [np.mean(sp3 < STILL_DEG_S, axis=1)]
    vc = v - v.mean(axis=1, keepdims=True)
    vs = np.sqrt(np.sum(vc * vc, axis=1))
    for i, j in ((0, 1), (0, 2), (1, 2)):
        den = vs[:, i] * vs[:, j]
        cols.append(np.where(den > 1e-12, np.abs(np.sum(vc[:, :, i] * vc[:, :, j], axis=1)) /
                             np.where(den > 1e-12, den, 1.0), 0.0))
    out = np.stack(cols, axis=1) if n else np.zeros((0, len(statistic_names())))
    return out


# -- the two samples -----------------------------------------------------------------------------
@dataclass
class Samples:
    """Windows of both samples: ``X`` (n, T, 3), ``y`` (0 recorded, 1 generated), ``groups``."""

    X: np.ndarray
    y: np.ndarray
    groups: np.ndarray


def _rows_of(m) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(m.rotvec if isinstance(m, Motion) else m, dtype=np.float32))


def copied_recordings(real: Mapping, generated: Mapping, *, share: float = 0.2) -> dict[str, set[str]]:
    """Generated recording → the *other* recorded recordings whose frames its motion copies (at least
    ``share`` of its frames found verbatim among theirs: the ``desync`` and ``other-speaker`` anchors
    are recorded motion of another recording, cut or looped)."""
    frames = {q: {row.tobytes() for row in _rows_of(m)} for q, m in real.items()}
    out: dict[str, set[str]] = {}
    for r, g in generated.items():
        for one in (g if isinstance(g, (list, tuple)) else [g]):
            rows = [row.tobytes() for row in _rows_of(one)]
            for q, fq in frames.items():
                if rows and q != r and sum(b in fq for b in rows) >= share * len(rows):
                    out.setdefault(r, set()).add(q)
    return out


def copy_groups(real: Mapping, generated: Mapping, *, share: float = 0.2) -> dict[str, str]:
    """Recording → group, a recording merged with every recording its generated motion copies
    (:func:`copied_recordings`)."""
    parent = {r: r for r in set(real) | set(generated)}

    def root(r):
        while parent[r] != r:
            parent[r] = parent[parent[r]]
            r = parent[r]
        return r

    for r, qs in copied_recordings(real, generated, share=share).items():
        for q in qs:
            parent[root(r)] = root(q)
    return {r: root(r) for r in parent}


def _self_copies(real: Mapping, generated: Mapping, *, share: float = 0.2) -> set[str]:
    """Recordings whose generated motion copies their own frames (rearranged: time reversal, a
    circular shift) — cut into chunks, a chunk's copy would sit in another chunk's group."""
    out = set()
    for r, g in generated.items():
        if r not in real:
            continue
        own = {row.tobytes() for row in _rows_of(real[r])}
        for one in (g if isinstance(g, (list, tuple)) else [g]):
            rows = [row.tobytes() for row in _rows_of(one)]
            if rows and sum(b in own for b in rows) >= share * len(rows):
                out.add(r)
    return out


def _windows_of(motions: Mapping, fps, chunk_s: float | None, groups: Mapping[str, str] | None = None,
                whole: set[str] = frozenset(), cutoff_hz: float = CUTOFF_HZ) -> tuple[list[np.ndarray], list[str]]:
    Ws, gs = [], []
    merged = set(whole)
    if groups:
        roots = list(groups.values())
        merged |= {r for r, g in groups.items() if roots.count(g) > 1}
    for rid, m in motions.items():
        ms = m if isinstance(m, (list, tuple)) else [m]
        grp = groups.get(rid, rid) if groups else rid
        for one in ms:
            x = prepare(one, None if isinstance(one, Motion) else (fps[rid] if isinstance(fps, Mapping) else fps),
                        cutoff_hz=cutoff_hz)
            chunked = chunk_s and rid not in merged  # a merged recording stays whole
            step = len(x) if not chunked else max(int(round(chunk_s * FPS)), int(round(WINDOW_S * FPS)))
            starts = list(range(0, max(len(x), 1), max(step, 1)))
            if len(starts) > 1 and len(x) - starts[-1] < step:  # a short tail joins the chunk before it
                starts = starts[:-1]
            for c, s in enumerate(starts):
                e = starts[c + 1] if c + 1 < len(starts) else len(x)
                W = cut_windows(x[s:e])
                if len(W):
                    Ws.append(W)
                    gs += [f"{grp}#{c}"] * len(W)
    return Ws, gs


def make_samples(real: Mapping, generated: Mapping, *, fps=None, chunk_s: float | None = None,
                 cutoff_hz: float = CUTOFF_HZ) -> Samples:
    """Windows of the recorded motions (``{recording: Motion or array}``) and the generated ones
    (``{recording: Motion, array or list of them}``); a generated motion's group is its recording,
    so it never sits on the other side of a split from the recording it was made for.  A generated
    motion that copies other recordings' frames (:func:`copied_recordings`) would meet the same
    motion as "recorded" in training and as "generated" in testing: the copied recordings leave the
    recorded sample, or — when fewer than two recordings would remain — share one group with their
    copies (:func:`copy_groups`).  ``chunk_s`` cuts every recording into groups of that many seconds
    (a single long take), except a recording whose generated motion rearranges its own frames (time
    reversal, a circular shift), which stays one group."""
    copied = set().union(*copied_recordings(real, generated).values()) if generated else set()
    groups = None
    if copied and len(set(real) - copied) >= 2:
        real = {q: m for q, m in real.items() if q not in copied}
    elif copied:
        groups = copy_groups(real, generated)
    whole = _self_copies(real, generated) if chunk_s else set()
    Wr, gr = _windows_of(real, fps, chunk_s, groups, whole, cutoff_hz)
    Wg, gg = _windows_of(generated, fps, chunk_s, groups, whole, cutoff_hz)
    if not Wr or not Wg:
        raise ParameterError(f"detectability needs motions of at least {WINDOW_S:g} s on both sides; "
                             f"got {sum(len(w) for w in Wr)} recorded and {sum(len(w) for w in Wg)} generated windows")
    X = np.concatenate(Wr + Wg)
    y = np.r_[np.zeros(len(gr), int), np.ones(len(gg), int)]
    return Samples(X, y, np.asarray(gr + gg))


# -- classifiers and scores ----------------------------------------------------------------------
@dataclass
class ClassifierScore:
    """Out-of-fold balanced accuracy and AUC of one classifier, with 95 % bootstrap intervals."""

    balanced_accuracy: float
    auc: float
    ba_ci: tuple[float, float]
    auc_ci: tuple[float, float]
    proba: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))


@dataclass
class DetectabilityResult:
    """Both classifiers' scores, the detectability (the larger balanced accuracy), the per-statistic
    AUCs and the sizes of the samples."""

    scores: dict[str, ClassifierScore]
    statistic_auc: dict[str, float]
    n_real: int
    n_generated: int
    n_groups: int

    @property
    def detectability(self) -> float:
        return float(max(s.balanced_accuracy for s in self.scores.values()))

    def top_statistics(self, k: int = 5) -> list[tuple[str, float]]:
        """The ``k`` statistics whose AUC is farthest from 0.5."""
        return sorted(self.statistic_auc.items(), key=lambda kv: -abs(kv[1] - 0.5))[:k]


def _folds(y: np.ndarray, groups: np.ndarray, n_splits: int, seed: int):
    from sklearn.model_selection import StratifiedGroupKFold

    n_groups = len(np.unique(groups))
    k = min(n_splits, n_groups)
    if k < 2:
        raise ParameterError(f"detectability needs at least 2 groups of recordings; got {n_groups}")
    return list(StratifiedGroupKFold(n_splits=k, shuffle=True, random_state=seed).split(np.zeros(len(y)), y, groups))


def _fit_stats(Ftr, ytr, Fte, seed: int) -> np.ndarray:
    from sklearn.ensemble import HistGradientBoostingClassifier

    clf = HistGradientBoostingClassifier(max_iter=150, learning_rate=0.05, max_leaf_nodes=15, min_samples_leaf=10,
                                         l2_regularization=1.0, class_weight="balanced", early_stopping=False,
                                         random_state=seed)
    clf.fit(Ftr, ytr)
    return clf.predict_proba(Fte)[:, 1]


def _ba(y: np.ndarray, proba: np.ndarray) -> float:
    """Balanced accuracy at threshold 0.5 (mean of the two classes' recalls)."""
    hit = (proba >= 0.5) == (y == 1)
    return float(0.5 * (hit[y == 1].mean() + hit[y == 0].mean()))


def _auc(y: np.ndarray, score: np.ndarray) -> float:
    """ROC AUC by the Mann–Whitney rank sum (ties count half), as sklearn's roc_auc_score."""
    from scipy.stats import rankdata

    r = rankdata(score)
    n1 = int(np.sum(y == 1))
    n0 = len(y) - n1
    return float((r[y == 1].sum() - n1 * (n1 + 1) / 2) / (n1 * n0))


def _score(y: np.ndarray, proba: np.ndarray, groups: np.ndarray, *, n_boot: int, seed: int) -> ClassifierScore:
    ba, auc = _ba(y, proba), _auc(y, proba)
    rng = np.random.default_rng(seed)
    ug = np.unique(groups)
    idx_of = {g: np.flatnonzero(groups == g) for g in ug}
    bas, aucs = [], []
    for _ in range(n_boot):
        idx = np.concatenate([idx_of[g] for g in rng.choice(ug, size=len(ug), replace=True)])
        if len(np.unique(y[idx])) < 2:
            continue
        bas.append(_ba(y[idx], proba[idx]))
        aucs.append(_auc(y[idx], proba[idx]))

    def ci(v):
        return (float(np.percentile(v, 2.5)), float(np.percentile(v, 97.5))) if v else (np.nan, np.nan)

    return ClassifierScore(ba, auc, ci(bas), ci(aucs), proba)


def statistic_aucs(F: np.ndarray, y: np.ndarray) -> dict[str, float]:
    """AUC of each window statistic alone (generated = positive; 0.5 = no separation)."""
    return {n: _auc(y, F[:, j]) for j, n in enumerate(statistic_names())}


def _samples_within(real: Mapping, generated: Mapping, within: Mapping | None, *, fps, chunk_s,
                    cutoff_hz: float = CUTOFF_HZ):
    """:func:`make_samples` of each evaluation fold (``within``: recording → fold; copies are looked
    for inside a fold), concatenated, and the window indices of each fold."""
    if not within:
        s = make_samples(real, generated, fps=fps, chunk_s=chunk_s, cutoff_hz=cutoff_hz)
        return s, [np.arange(len(s.y))]
    parts, blocks, n = [], [], 0
    for f in dict.fromkeys(within[r] for r in real if r in within):
        rk = {r: m for r, m in real.items() if within.get(r) == f}
        s = make_samples(rk, {r: m for r, m in generated.items() if r in rk}, fps=fps, chunk_s=chunk_s,
                         cutoff_hz=cutoff_hz)
        parts.append(s)
        blocks.append(np.arange(n, n + len(s.y)))
        n += len(s.y)
    return Samples(np.concatenate([p.X for p in parts]), np.concatenate([p.y for p in parts]),
                   np.concatenate([p.groups for p in parts])), blocks


_NO_TORCH_WARNED: list[bool] = []


def _available(classifiers: Sequence[str]) -> tuple[str, ...]:
    """``classifiers`` without the network when PyTorch is not installed (with a warning; the
    statistics classifier decides), or the missing-dependency error when the network is all there is."""
    from ...devices import has_torch, missing_torch

    classifiers = tuple(classifiers)
    if "cnn" not in classifiers or has_torch():
        return classifiers
    rest = tuple(c for c in classifiers if c != "cnn")
    if not rest:
        raise missing_torch("the detectability test's network classifier")
    if not _NO_TORCH_WARNED:  # once a process: an evaluation asks for every condition
        _NO_TORCH_WARNED.append(True)
        warnings.warn("PyTorch is not installed: the detectability test's statistics classifier decides "
                      "alone (pip install 'headmotion[nets]' adds its network classifier)", stacklevel=3)
    return rest


def detectability(real: Mapping, generated: Mapping, *, fps=None, seed: int = 0, n_splits: int = 5,
                  n_boot: int = 1000, classifiers: Sequence[str] = CLASSIFIERS,
                  chunk_s: float | None = None, within: Mapping | None = None,
                  cutoff_hz: float = CUTOFF_HZ) -> DetectabilityResult:
    """Classifier two-sample test of recorded against generated motion (see the module docstring).

    Parameters
    ----------
    real : mapping recording → Motion | np.ndarray [shape=(T, 3)] (radians)
    generated : mapping recording → Motion | array | list of them (a recording's generated motion
        shares its group)
    fps : float | mapping recording → float — the rate of motions given as arrays
    seed : int — folds, classifiers and bootstrap derive from it (same seed, same result)
    n_splits : int — grouped folds (at most the number of groups)
    n_boot : int — bootstrap resamples of the recordings for the intervals
    classifiers : subset of ``("stats", "cnn")``
    chunk_s : float, optional — cut every recording into groups of this many seconds
    within : mapping recording → evaluation fold, optional — classifiers are trained and tested
        only among one fold's windows (out-of-fold probabilities pooled over the folds): a
        condition that replays other recordings' motion (retrieval, ``other-speaker``) made its
        motion from the *other* folds' recordings, which a pooled classifier would also see
        labelled "recorded"
    cutoff_hz : float — both sides' low-pass (:func:`prepare`; 3 Hz: where a tracker's jitter
        decides nothing)

    Returns
    -------
    DetectabilityResult
    """
    bad = [c for c in classifiers if c not in CLASSIFIERS]
    if bad or not classifiers:
        raise ParameterError(f"classifiers must be a non-empty subset of {CLASSIFIERS}; got {list(classifiers)}")
    classifiers = _available(classifiers)
    s, blocks = _samples_within(real, generated, within, fps=fps, chunk_s=chunk_s, cutoff_hz=cutoff_hz)
    F = window_statistics(s.X)
    folds = [(b[tr], b[te]) for b in blocks for tr, te in _folds(s.y[b], s.groups[b], n_splits, seed)]
    scores = {}
    few = min(min(np.sum(s.y[b] == 0), np.sum(s.y[b] == 1)) for b in blocks) < MIN_CNN_WINDOWS
    for name in classifiers:
        if name == "cnn" and few and len(classifiers) > 1:
            continue  # too few windows to train a network: the statistics classifier decides
        proba = np.zeros(len(s.y))
        for k, (tr, te) in enumerate(folds):
            if name == "stats":
                proba[te] = _fit_stats(F[tr], s.y[tr], F[te], seed + k)
            else:
                from .detectability_cnn import fit_predict

                proba[te] = fit_predict(s.X[tr], s.y[tr], s.X[te], seed=seed + k)
        scores[name] = _score(s.y, proba, s.groups, n_boot=n_boot, seed=seed)
    return DetectabilityResult(scores, statistic_aucs(F, s.y), int(np.sum(s.y == 0)), int(np.sum(s.y == 1)),
                               len(np.unique(s.groups)))


# -- ruler -----------------------------------------------------------------------------------------
def phase_randomised(x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A copy of ``x`` (T, D) with its per-column magnitude spectrum and mean, random phases."""
    x = np.asarray(x, dtype=float)
    mu = x.mean(axis=0)
    X = np.fft.rfft(x - mu, axis=0)
    ph = np.exp(2j * np.pi * rng.random(X.shape))
    ph[0] = 1.0
    if len(x) % 2 == 0:
        ph[-1] = np.sign(np.cos(2 * np.pi * rng.random(X.shape[1])))
    return mu + np.fft.irfft(np.abs(X) * ph, n=len(x), axis=0)


def ruler_motions(real: Mapping, *, seed: int = 0) -> dict[str, dict[str, np.ndarray]]:
    """The ruler's anchors for ``real`` ({recording: (T, 3) array}): ``reversed`` (time reversal),
    ``phase-randomised`` and ``still`` (the recording's mean pose held)."""
    rng = np.random.default_rng(seed)
    out: dict[str, dict[str, np.ndarray]] = {"reversed": {}, "phase-randomised": {}, "still": {}}
    for rid, m in real.items():
        a = np.asarray(m.rotvec if isinstance(m, Motion) else m, dtype=float)
        out["reversed"][rid] = a[::-1].copy()
        out["phase-randomised"][rid] = phase_randomised(a, rng)
        out["still"][rid] = np.tile(a.mean(axis=0), (len(a), 1))
    return out


# -- rows for headmotion evaluate ----------------------------------------------------------------
def result_rows(system: str, res: DetectabilityResult, *, prefix: str = "detect") -> list[dict]:
    """``{system, recording: "ALL", metric, value}`` rows of one result."""
    vals = {prefix: res.detectability, f"{prefix}_n_windows_real": res.n_real,
            f"{prefix}_n_windows_generated": res.n_generated, f"{prefix}_n_groups": res.n_groups}
    for name, sc in res.scores.items():
        vals.update({f"{prefix}_ba_{name}": sc.balanced_accuracy, f"{prefix}_ba_{name}_lo": sc.ba_ci[0],
                     f"{prefix}_ba_{name}_hi": sc.ba_ci[1], f"{prefix}_auc_{name}": sc.auc,
                     f"{prefix}_auc_{name}_lo": sc.auc_ci[0], f"{prefix}_auc_{name}_hi": sc.auc_ci[1]})
    for n, v in res.statistic_auc.items():
        vals[f"{prefix}_stat_auc[{n}]"] = v
    return [{"system": system, "recording": "ALL", "metric": k, "value": float(v)} for k, v in vals.items()]


def _condition_rows(cond: str, real: Mapping, gen: Mapping, kw: dict) -> list[dict]:
    """One condition's rows: the test within folds (``detect*``, ``detect_within_folds`` = 1) and
    over all folds (``detect_pooled*``, statistics classifier); when a fold has too little motion
    for the test within folds, the test over all folds is ``detect*`` (``detect_within_folds`` = 0)."""
    rows: list[dict] = []
    if kw["within"]:
        try:
            rows = result_rows(cond, detectability(real, gen, **kw))
        except ParameterError:
            rows = []  # a fold with too little motion of 4 s windows: the test over all folds decides
    within_ok = bool(rows)
    try:
        pooled = detectability(real, gen, **{**kw, "within": None,
                                             "classifiers": ("stats",) if within_ok else kw["classifiers"]})
    except ParameterError:
        return rows
    if within_ok:
        rows += [r for r in result_rows(cond, pooled, prefix="detect_pooled") if "_stat_auc[" not in r["metric"]]
    else:
        rows = result_rows(cond, pooled)
    if kw["within"]:
        rows.append({"system": cond, "recording": "ALL", "metric": "detect_within_folds", "value": float(within_ok)})
    return rows


def detectability_rows(real_by_rec: Mapping, generated_by_condition: Mapping[str, Mapping], fps=None, *,
                       seed: int = 0, ruler: str | None = "ground-truth", n_boot: int = 1000,
                       classifiers: Sequence[str] = CLASSIFIERS, chunk_s: float | None = None,
                       within: Mapping | None = None) -> list[dict]:
    """Detectability rows for every condition, for ``metrics.csv``.

    Parameters
    ----------
    real_by_rec : mapping recording → Motion | array — the held-out recorded motions
    generated_by_condition : mapping condition → (recording → motion) — only recordings in
        ``real_by_rec`` are used; a condition with fewer than two such recordings is skipped
    fps : float | mapping recording → float — the rate of arrays
    ruler : system name under which the ruler's anchors (:func:`ruler_motions`) are reported as
        ``detect_reversed``, ``detect_phase_randomised``, ``detect_still`` (None: no ruler)
    within : mapping recording → evaluation fold, optional — the classifiers are trained and
        tested within each fold (:func:`detectability`); the test over all folds at once, with the
        statistics classifier, is reported beside it as ``detect_pooled*``

    Returns
    -------
    list of ``{system, recording: "ALL", metric, value}``: ``detect`` (the larger balanced
    accuracy), ``detect_ba_stats`` / ``detect_auc_stats`` / ``detect_ba_cnn`` / ``detect_auc_cnn``
    (each with ``_lo`` / ``_hi`` 95 % bootstrap bounds), ``detect_stat_auc[<statistic>]``, sizes.
    """
    rows: list[dict] = []
    real = dict(real_by_rec)
    within = within if within and len(set(within.values())) > 1 else None
    kw = {"fps": fps, "seed": seed, "n_boot": n_boot, "classifiers": classifiers, "chunk_s": chunk_s, "within": within}
    for cond, gen in generated_by_condition.items():
        g = {r: m for r, m in gen.items() if r in real}
        if len(g) < 2:
            continue
        rows += _condition_rows(cond, {r: real[r] for r in g}, g, kw)
    if ruler:
        arrays = {r: (m.rotvec if isinstance(m, Motion) else m) for r, m in real.items()}
        rates = {r: (m.fps if isinstance(m, Motion) else (fps[r] if isinstance(fps, Mapping) else fps))
                 for r, m in real.items()}
        for name, gen in ruler_motions(arrays, seed=seed).items():
            try:
                res = detectability(arrays, gen, **{**kw, "fps": rates})
            except ParameterError:
                try:  # a fold with too little motion: over all folds (the ruler's motions copy nothing)
                    res = detectability(arrays, gen, **{**kw, "fps": rates, "within": None})
                except ParameterError:
                    continue
            rows += [r for r in result_rows(ruler, res, prefix=f"detect_{name.replace('-', '_')}")
                     if "_stat_auc[" not in r["metric"]]
    return rows


def low_pass_rows(real_by_rec: Mapping, generated_by_condition: Mapping[str, Mapping], fps=None, *, seed: int = 0,
                  cutoff_hz: float = LOW_CUTOFF_HZ, n_boot: int = 1000, classifiers: Sequence[str] = CLASSIFIERS,
                  chunk_s: float | None = None, within: Mapping | None = None) -> list[dict]:
    """The same test as :func:`detectability_rows` with both sides low-passed at ``cutoff_hz``
    (3 Hz: a tracker's jitter, which lives above it, decides nothing), within folds where the folds
    allow, else over all folds; rows ``detect_3hz``, ``detect_3hz_ba_stats``, … (prefix
    ``detect_<cutoff>hz``; no per-statistic AUCs, no ruler)."""
    prefix = f"detect_{cutoff_hz:g}hz".replace(".", "_")
    real = dict(real_by_rec)
    within = within if within and len(set(within.values())) > 1 else None
    rows: list[dict] = []
    for cond, gen in generated_by_condition.items():
        g = {r: m for r, m in gen.items() if r in real}
        if len(g) < 2:
            continue
        kw = {"fps": fps, "seed": seed, "n_boot": n_boot, "classifiers": classifiers, "chunk_s": chunk_s,
              "cutoff_hz": cutoff_hz}
        res = None
        for w in ((within, None) if within else (None,)):
            try:
                res = detectability({r: real[r] for r in g}, g, **kw, within=w)
                break
            except ParameterError:
                continue
        if res is not None:
            rows += [r for r in result_rows(cond, res, prefix=prefix) if "_stat_auc[" not in r["metric"]]
    return rows


def floor_rows(rows: Sequence[Mapping], *, floor: str = "floor",
               prefixes: Sequence[str] = ("detect", "detect_3hz")) -> list[dict]:
    """Every condition's detectability beside the floor's (the ``floor`` condition: other speakers'
    recorded heads against the held-out ones, :class:`~.anchors.Floor`): rows ``<prefix>_floor``
    (the floor's value) and ``<prefix>_above_floor`` (the condition's minus the floor's) for each
    prefix the floor has a value of; none without a floor."""
    val = {(r["system"], r["metric"]): float(r["value"]) for r in rows if r["recording"] == "ALL"}
    out = []
    for prefix in prefixes:
        f = val.get((floor, prefix))
        if f is None or not np.isfinite(f):
            continue
        for (cond, metric), v in val.items():
            if metric == prefix:
                out += [{"system": cond, "recording": "ALL", "metric": f"{prefix}_floor", "value": f},
                        {"system": cond, "recording": "ALL", "metric": f"{prefix}_above_floor", "value": v - f}]
    return out


def reversal_rows(motions_by_condition: Mapping[str, Mapping], fps) -> list[dict]:
    """Direction reversals per frame and axis of every condition, pooled over its recordings
    (reversals over frames, :func:`reversal_rate`): rows ``reversals_pitch|yaw|roll``, recording ``ALL``."""
    out = []
    for cond, d in motions_by_condition.items():
        n, rev = 0, np.zeros(3)
        for rid, m in d.items():
            x = prepare(m, None if isinstance(m, Motion) else (fps[rid] if isinstance(fps, Mapping) else fps))
            k, r = _reversals(x)
            n, rev = n + k, rev + r
        if n:
            out += [{"system": cond, "recording": "ALL", "metric": f"reversals_{ax}", "value": float(v / n)}
                    for ax, v in zip(AXES, rev)]
    return out


__all__ = ["FPS", "CUTOFF_HZ", "LOW_CUTOFF_HZ", "low_pass_rows", "floor_rows", "reversal_rows", "WINDOW_S", "prepare", "reversal_rate", "cut_windows", "statistic_names", "window_statistics",
           "copy_groups", "make_samples", "Samples", "ClassifierScore", "DetectabilityResult", "detectability", "statistic_aucs",
           "phase_randomised", "ruler_motions", "result_rows", "detectability_rows"]
