"""Template discovery analysis (thesis §5.3, Figs 5.4–5.6; after Smyth 1997).

1. Segment every axis (§5.2) and normalise each segment to 1 rad amplitude and 1 s duration by
   linear warping (resampled to ``n_points`` samples; the segment's start is subtracted and its
   sign kept, so rising and falling shapes stay distinct).
2. Train a left-to-right HMM (3–5 states) on each segment of a random subset — the
   "initialisers" — and compute the symmetric cross-entropy distance between every pair
   (eq 3.1 with HMM likelihoods: ``E(A,B) = [log p_A(A) − log p_B(A)]/T_A + [log p_B(B) − log p_A(B)]/T_B``).
3. Cluster the initialisers by furthest-neighbour (complete-linkage) agglomerative clustering
   (scipy), recording the maximum intra- and inter-cluster distance for every k (Fig 5.5).
4. Stability (Fig 5.4): for several random initialiser sets of each size, cluster into
   ``k_stability`` clusters, train one HMM per cluster on all its members, compute the mean
   cross-entropy distance between the clusters of two sets, match them with the stable-marriage
   (Gale–Shapley) algorithm and report the total distance between matched clusters.
5. Assign every segment to the cluster HMM with the highest likelihood and draw 2D histograms
   (150 × 150 bins) of the normalised segments per cluster (Fig 5.6).

On real data the literal procedure broke: on 70 s of one video-derived speaker it gave
917 segments in clusters of 906 and 11, distances of 5×10⁵ and an empty Fig 5.6.  Causes and the
choices made (the thesis is silent on each):

* the motion is resampled to 100 Hz (the thesis's rate, at which its smoothing and minimum
  segment are defined) before segmenting, and segmented with a minimum swing (default 1°,
  :func:`headmotion.motion.segmentation.segment_axis` ``min_swing``) so tracking jitter does not
  make hundreds of sub-degree segments;
* segments whose start-to-end change is below the minimum swing are dropped (dividing a jitter
  wiggle by its tiny end-to-end change made values of ±50 that dominated every distance), and
  the normalised values are clipped to ±1.5;
* per-segment HMMs use a variance floor of 0.01 (a 20-point segment gives 4–5 points per state);
* Fig 5.5 is drawn on a log scale; Fig 5.6 resamples every segment to 150 points so the 150 × 150
  histogram has a value in every column, with a power-law grey scale (darker where more segments
  pass) and one panel per cluster;
* the first k whose smallest inter-cluster distance exceeds the largest intra-cluster distance is
  chosen; if none, the k after which the largest intra-cluster distance drops least (the elbow).

:func:`warping_bic` (Fig 5.12, BIC of GMM structures on the warping parameters) lives here too.

Library considered: scipy.cluster.hierarchy (complete linkage), hmmlearn-style HMMs from
:mod:`headmotion.models.hmm` (batched Baum–Welch); the stable matching is hand-written (a dozen
lines, no maintained library).  Everything is scaled down by default (a few hundred segments) so
the analysis runs in minutes; the thesis's sizes are parameters.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..models.hmm import HMMBank, LeftToRightHMM
from .segmentation import segment_axis, smooth

#: thesis §5.2 rate: segmentation parameters are defined at 100 Hz
DISCOVERY_FPS = 100.0
#: default minimum swing (degrees) between extrema for real, jittery data
DEFAULT_MIN_SWING_DEG = 1.0
HMM_MIN_COVAR = 1e-2
CLIP = 1.5


def segment_table(motions, *, fps: float | None = DISCOVERY_FPS, min_swing_deg: float | None = DEFAULT_MIN_SWING_DEG):
    """Per axis and segment: ``(motion index, axis, start, stop, smoothed values (L,))`` after
    resampling to ``fps`` (None keeps each motion's rate) and segmenting with the minimum swing."""
    swing = np.radians(min_swing_deg) if min_swing_deg else 0.0
    out = []
    for i, m in enumerate(motions):
        mm = m if fps is None else m.resample(fps)
        xs = smooth(np.asarray(mm.rotvec), fps=mm.fps)
        for j in range(3):
            b = segment_axis(xs[:, j], fps=mm.fps, smoothed=True, min_swing=swing)
            for k in range(len(b) - 1):
                out.append((i, j, int(b[k]), int(b[k + 1]), xs[int(b[k]):int(b[k + 1]) + 1, j]))
    return out


def normalise(y: np.ndarray, n_points: int) -> np.ndarray:
    """A segment's values → start at 0, end at ±1 (sign kept), ``n_points`` samples, clipped to
    ±1.5."""
    y = np.asarray(y, dtype=np.float64) - y[0]
    amp = abs(y[-1]) if abs(y[-1]) > 1e-12 else np.max(np.abs(y)) + 1e-12
    t = np.linspace(0, len(y) - 1, n_points)
    return np.clip(np.interp(t, np.arange(len(y)), y) / amp, -CLIP, CLIP)


def normalised_segments(motions, *, n_points: int = 20, max_segments: int | None = None,
                        rng: np.random.Generator | None = None, fps: float | None = DISCOVERY_FPS,
                        min_swing_deg: float | None = DEFAULT_MIN_SWING_DEG) -> np.ndarray:
    """All segments of all axes, normalised to amplitude 1 and duration 1: (N, n_points).

    Segments whose start-to-end change is below ``min_swing_deg`` are left out."""
    swing = np.radians(min_swing_deg) if min_swing_deg else 0.0
    out = [normalise(y, n_points) for (_, _, a, b, y) in segment_table(motions, fps=fps, min_swing_deg=min_swing_deg)
           if b - a >= 2 and abs(y[-1] - y[0]) >= max(swing, 1e-9)]
    X = np.asarray(out).reshape(-1, n_points)
    if max_segments is not None and len(X) > max_segments:
        rng = rng or np.random.default_rng(0)
        X = X[rng.choice(len(X), max_segments, replace=False)]
    return X


def _seq(x: np.ndarray) -> np.ndarray:
    """Observation sequence of a normalised segment: value and its slope, (L, 2)."""
    return np.stack([x, np.gradient(x)], axis=1)


def _fit_hmms(groups: list[np.ndarray], n_states: int) -> list[LeftToRightHMM]:
    hmms = []
    for g in groups:
        seqs = [_seq(x) for x in g]
        hmms.append(LeftToRightHMM(n_states, n_iter=5, min_covar=HMM_MIN_COVAR).fit(np.vstack(seqs), [len(s) for s in seqs]))
    return hmms


def _loglik_matrix(hmms: list[LeftToRightHMM], X: np.ndarray) -> np.ndarray:
    """(N, K) mean per-frame Viterbi log-likelihood of each segment under each HMM."""
    bank = HMMBank(hmms, 2)
    out = np.empty((len(X), len(hmms)))
    for i, x in enumerate(X):
        s = _seq(x)
        out[i] = bank.segment_loglik(bank.frame_loglik(s), np.zeros(0)) / len(s)
    return out


def cross_entropy_distances(X: np.ndarray, *, n_states: int = 4) -> np.ndarray:
    """Symmetric cross-entropy distance (eq 3.1) between per-segment HMMs: (N, N)."""
    hmms = _fit_hmms([x[None] for x in X], n_states)
    L = _loglik_matrix(hmms, X)  # L[i, j] = log p_j(x_i) / T
    own = np.diag(L)
    D = (own[:, None] - L) + (own[None, :] - L.T)
    np.fill_diagonal(D, 0.0)
    return np.maximum(D, 0.0)


def complete_linkage(D: np.ndarray, k: int) -> np.ndarray:
    """Furthest-neighbour agglomerative clustering into k clusters: labels (N,)."""
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import squareform

    Z = linkage(squareform(D, checks=False), method="complete")
    return fcluster(Z, k, criterion="maxclust") - 1


def intra_inter(D: np.ndarray, ks=range(1, 11), *, min_size: int = 1) -> dict[str, list[float]]:
    """Max intra-cluster and min/max inter-cluster distance for each k (Fig 5.5), over the
    members of clusters with at least ``min_size`` members (smaller ones are outliers)."""
    res = {"k": [], "max_intra": [], "min_inter": [], "max_inter": []}
    for k in ks:
        lab = complete_linkage(D, k)
        sizes = np.bincount(lab)
        ok = sizes[lab] >= min_size
        if ok.sum() < 2:
            ok[:] = True
        lab = np.where(ok, lab, -1)
        same = (lab[:, None] == lab[None, :]) & ok[:, None] & ok[None, :]
        diff = (lab[:, None] != lab[None, :]) & ok[:, None] & ok[None, :]
        res["k"].append(int(k))
        res["max_intra"].append(float(D[same].max()))
        res["min_inter"].append(float(D[diff].min()) if diff.any() else float("nan"))
        res["max_inter"].append(float(D[diff].max()) if diff.any() else float("nan"))
    return res


def stable_matching(C: np.ndarray) -> np.ndarray:
    """Gale–Shapley on a cost matrix (K, K): rows propose in order of increasing cost; returns
    ``match[row] = column``."""
    K = C.shape[0]
    prefs = np.argsort(C, axis=1)
    nxt = np.zeros(K, dtype=int)
    col_of = -np.ones(K, dtype=int)
    row_of = -np.ones(K, dtype=int)
    free = list(range(K))
    while free:
        r = free.pop(0)
        c = prefs[r, nxt[r]]
        nxt[r] += 1
        if row_of[c] < 0:
            row_of[c], col_of[r] = r, c
        elif C[r, c] < C[row_of[c], c]:
            free.append(row_of[c])
            col_of[row_of[c]] = -1
            row_of[c], col_of[r] = r, c
        else:
            free.append(r)
    return col_of


def _cluster_set(X, idx, k, n_states):
    D = cross_entropy_distances(X[idx], n_states=n_states)
    lab = complete_linkage(D, k)
    groups = [X[idx][lab == c] for c in range(k) if np.any(lab == c)]
    return _fit_hmms(groups, n_states)


def cluster_set_distance(X, hmms_a, hmms_b) -> float:
    """Total distance between matched clusters of two clusterings (Fig 5.4)."""
    La, Lb = _loglik_matrix(hmms_a, X), _loglik_matrix(hmms_b, X)
    ka, kb = La.shape[1], Lb.shape[1]
    k = min(ka, kb)
    # assign samples to the clusters of each clustering, then mean cross-entropy between clusters
    aa, ab = La.argmax(1), Lb.argmax(1)
    C = np.zeros((k, k))
    for i in range(k):
        for j in range(k):
            A = X[aa == i] if np.any(aa == i) else X[:1]
            B = X[ab == j] if np.any(ab == j) else X[:1]
            la_a, lb_a = _loglik_matrix([hmms_a[i], hmms_b[j]], A).mean(0)
            la_b, lb_b = _loglik_matrix([hmms_a[i], hmms_b[j]], B).mean(0)
            C[i, j] = (la_a - lb_a) + (lb_b - la_b)
    match = stable_matching(C)
    return float(sum(C[i, match[i]] for i in range(k)))


def choose_k(ii: dict) -> int:
    """First k whose smallest inter-cluster distance exceeds the largest intra-cluster distance;
    otherwise the elbow of the largest intra-cluster distance (the k after which it drops least,
    relative to its drop so far); at least 2."""
    for k, a, b in zip(ii["k"], ii["max_intra"], ii["min_inter"]):
        if k >= 2 and np.isfinite(b) and b > a:
            return int(k)
    v = np.log(np.maximum(np.asarray(ii["max_intra"], float), 1e-12))
    if len(v) < 3:
        return 2
    drops = -np.diff(v)  # drop from k to k+1
    # elbow: the k where the next drop is smallest compared with the previous one
    ratio = drops[1:] / np.maximum(drops[:-1], 1e-12)
    return int(max(2, ii["k"][int(np.argmin(ratio)) + 1]))


def assign(hmms, X: np.ndarray) -> np.ndarray:
    """Cluster of each segment: the HMM with the highest likelihood."""
    return _loglik_matrix(hmms, X).argmax(1)


def discover(motions, *, n_init: int = 120, n_states: int = 4, max_k: int = 10, seed: int = 0,
             max_segments: int = 3000, fps: float | None = DISCOVERY_FPS,
             min_swing_deg: float | None = DEFAULT_MIN_SWING_DEG, k: int | None = None,
             min_cluster_share: float = 0.05) -> dict:
    """Template discovery without figures (clusters of the initialisers smaller than
    ``min_cluster_share`` of them, at least 2, are outliers: no template is made of them): ``{"X", "idx", "D", "intra_inter", "k", "hmms",
    "assign", "sizes"}`` (segments, initialiser indices, their distances, Fig 5.5 numbers, chosen
    k, cluster HMMs, every segment's cluster, cluster sizes)."""
    rng = np.random.default_rng(seed)
    X = normalised_segments(motions, max_segments=max_segments, rng=rng, fps=fps, min_swing_deg=min_swing_deg)
    if len(X) < 10:
        raise ParameterError(f"template discovery needs at least 10 segments; the corpus has {len(X)}")
    idx = rng.choice(len(X), min(n_init, len(X)), replace=False)
    D = cross_entropy_distances(X[idx], n_states=n_states)
    min_size = max(2, int(np.ceil(min_cluster_share * len(idx))))
    ii = intra_inter(D, range(1, min(max_k, len(idx)) + 1), min_size=min_size)
    min_size = max(2, int(np.ceil(min_cluster_share * len(idx))))
    k_sel = choose_k(ii) if k is None else int(k)
    lab = complete_linkage(D, k_sel)
    sizes = np.bincount(lab, minlength=k_sel)
    keep = [c for c in range(k_sel) if sizes[c] >= min_size]
    if not keep:
        keep = [int(np.argmax(sizes))]
    hmms = _fit_hmms([X[idx][lab == c] for c in keep], n_states)
    a = assign(hmms, X)
    return {"X": X, "idx": idx, "D": D, "intra_inter": ii, "k": len(hmms), "k_cut": k_sel, "hmms": hmms,
            "assign": a, "sizes": np.bincount(a, minlength=len(hmms)).tolist(),
            "outlier_initialisers": int(sum(sizes[c] for c in range(k_sel) if c not in keep))}


def stability(X: np.ndarray, n_initialisers, *, n_sets: int = 3, k: int = 2, n_states: int = 4, seed: int = 0) -> dict:
    """Fig 5.4: mean and SD of the total distance between matched clusters of random initialiser
    sets of each size."""
    rng = np.random.default_rng(seed)
    out = {}
    for n in n_initialisers:
        n = min(int(n), len(X))
        sets = [_cluster_set(X, rng.choice(len(X), n, replace=False), k, n_states) for _ in range(n_sets)]
        d = [cluster_set_distance(X, sets[a], sets[b]) for a in range(n_sets) for b in range(a + 1, n_sets)]
        out[n] = (float(np.mean(d)), float(np.std(d)))
    return out


def warping_vectors(motions, *, fps: float | None = DISCOVERY_FPS, min_swing_deg: float | None = DEFAULT_MIN_SWING_DEG):
    """Warping parameters of every segment after the first of each axis, with the previous
    segment's: rows ``(d, a, d_prev, a_prev, c)`` (s, rad, s, rad, rad), as the template-warping
    systems learn them (thesis §5.4–5.5)."""
    rows = []
    segs = segment_table(motions, fps=fps, min_swing_deg=min_swing_deg)
    f = {i: (fps or m.fps) for i, m in enumerate(motions)}
    for p, q in zip(segs[:-1], segs[1:]):
        if p[0] != q[0] or p[1] != q[1]:
            continue
        fr = f[q[0]]
        rows.append(((q[3] - q[2]) / fr, abs(q[4][-1] - q[4][0]), (p[3] - p[2]) / fr, abs(p[4][-1] - p[4][0]), q[4][0]))
    return np.asarray(rows, dtype=np.float64).reshape(-1, 5)


def warping_bic(motions, *, components=(1, 2, 3, 4, 5, 6), fps: float | None = DISCOVERY_FPS,
                min_swing_deg: float | None = DEFAULT_MIN_SWING_DEG) -> dict:
    """Fig 5.12: BIC of GMM structures (full / diagonal covariance, 1–6 components) on the
    warping parameters (:func:`warping_vectors`)."""
    from ..models.gmm import bic_curve

    Z = warping_vectors(motions, fps=fps, min_swing_deg=min_swing_deg)
    if len(Z) < 20:
        raise ParameterError(f"Fig 5.12 needs at least 20 segments with a predecessor; got {len(Z)}")
    return {"components": list(components), "n": int(len(Z)), **bic_curve(Z, components=components)}


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    from ..io.atomic import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
    _plt().close(fig)


def figure_stability(stabs: dict, path) -> None:
    """Fig 5.4: ``stabs = {k: {n_initialisers: (mean, sd)}}``, one curve per number of clusters."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    for k, stab in sorted(stabs.items()):
        ns = sorted(stab)
        ax.errorbar(ns, [stab[n][0] for n in ns], yerr=[stab[n][1] for n in ns], marker="o", capsize=3,
                    label=f"{k} clusters")
    ax.set_xlabel("number of initialisers")
    ax.set_ylabel("total cross-entropy distance\nbetween matched clusters")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    ax.set_title("Fig 5.4: clustering stability (0 = identical partitions)")
    _save(fig, Path(path))


def figure_intra_inter(ii: dict, path, *, k_selected: int) -> None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.semilogy(ii["k"], np.maximum(ii["max_intra"], 1e-6), "o-", label="max intra-cluster")
    ax.semilogy(ii["k"], np.maximum(ii["min_inter"], 1e-6), "s-", label="min inter-cluster")
    ax.axvline(k_selected, color="0.6", ls="--", lw=1, label=f"chosen k = {k_selected}")
    ax.set_xlabel("number of clusters k")
    ax.set_ylabel("cross-entropy distance (log)")
    ax.set_title("Fig 5.5: intra- vs inter-cluster distance")
    ax.legend(fontsize=8)
    _save(fig, Path(path))


def figure_histograms(X: np.ndarray, labels: np.ndarray, k: int, path, *, bins: int = 150) -> None:
    """Fig 5.6: per cluster a 2-D histogram (``bins`` × ``bins``) of its normalised segments,
    each resampled to ``bins`` points; darker where more segments pass."""
    from matplotlib.colors import PowerNorm

    plt = _plt()
    fig, axes = plt.subplots(1, k, figsize=(3.4 * k, 3.4), squeeze=False)
    tt = np.linspace(0, 1, bins)
    src = np.linspace(0, 1, X.shape[1])
    for c, ax in enumerate(axes[0]):
        sel = X[labels == c]
        if len(sel):
            dense = np.stack([np.interp(tt, src, x) for x in sel])
            H, xe, ye = np.histogram2d(np.tile(tt, len(sel)), dense.ravel(), bins=bins,
                                       range=[[0, 1], [-CLIP, CLIP]])
            ax.imshow(H.T, origin="lower", extent=[0, 1, -CLIP, CLIP], aspect="auto", cmap="Greys",
                      norm=PowerNorm(0.5, vmin=0, vmax=max(H.max(), 1)), interpolation="nearest")
            ax.plot(tt, np.median(dense, axis=0), color="tab:red", lw=1, alpha=0.8)
        ax.set_title(f"cluster {c + 1} ({len(sel)} segments)", fontsize=9)
        ax.set_xlabel("time (normalised)")
    axes[0][0].set_ylabel("amplitude (normalised)")
    fig.suptitle("Fig 5.6: segments per cluster (red: median)")
    _save(fig, Path(path))


def figure_bic(bic: dict, path) -> None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    for ct in ("full", "diag"):
        if ct in bic:
            ax.plot(bic["components"], bic[ct], "o-", label=f"{ct} covariance")
    ax.set_xlabel("mixture components")
    ax.set_ylabel("BIC (lower is better)")
    ax.set_title(f"Fig 5.12: BIC of GMM structures ({bic['n']} segments)")
    ax.legend()
    _save(fig, Path(path))


def analyse(motions, out_dir, *, n_initialisers=(20, 40, 80), n_sets: int = 3, k_stability: int | None = None,
            n_init_main: int = 120, n_states: int = 4, max_k: int = 10, seed: int = 0,
            max_segments: int = 3000, fps: float | None = DISCOVERY_FPS,
            min_swing_deg: float | None = DEFAULT_MIN_SWING_DEG, bic: bool = True) -> dict:
    """Run the §5.3 analysis and write ``fig5_4_stability.png``, ``fig5_5_intra_inter.png``,
    ``fig5_6_histograms.png``, ``fig5_12_bic.png`` (``bic``) and ``discovery.json`` to
    ``out_dir``.  Fig 5.4 is drawn for ``k_stability`` clusters, by default for the chosen k and
    k + 2.  Returns the numbers."""
    import json

    from ..io.atomic import atomic_write_text

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    d = discover(motions, n_init=n_init_main, n_states=n_states, max_k=max_k, seed=seed, max_segments=max_segments,
                 fps=fps, min_swing_deg=min_swing_deg)
    X = d["X"]
    res: dict = {"segments": int(len(X)), "fps": fps, "min_swing_deg": min_swing_deg,
                 "intra_inter": d["intra_inter"], "k_selected": int(d["k"]), "k_cut": int(d["k_cut"]),
                 "cluster_sizes": d["sizes"], "outlier_initialisers": d["outlier_initialisers"]}
    kss = [int(k_stability)] if k_stability else sorted({int(d["k"]), int(d["k"]) + 2})
    stabs = {k: stability(X, n_initialisers, n_sets=n_sets, k=k, n_states=n_states, seed=seed + 1) for k in kss}
    res["stability"] = {str(k): {str(n): v for n, v in st.items()} for k, st in stabs.items()}
    figure_stability(stabs, out / "fig5_4_stability.png")
    figure_intra_inter(d["intra_inter"], out / "fig5_5_intra_inter.png", k_selected=d["k"])
    figure_histograms(X, d["assign"], d["k"], out / "fig5_6_histograms.png")
    if bic:
        try:
            b = warping_bic(motions, fps=fps, min_swing_deg=min_swing_deg)
            res["bic"] = b
            figure_bic(b, out / "fig5_12_bic.png")
        except ParameterError as e:
            res["bic_error"] = str(e)
    atomic_write_text(out / "discovery.json", json.dumps(res, indent=2))
    return res


__all__ = ["normalised_segments", "segment_table", "normalise", "cross_entropy_distances", "complete_linkage",
           "intra_inter", "stable_matching", "cluster_set_distance", "choose_k", "assign", "discover", "stability",
           "warping_vectors", "warping_bic", "analyse", "DISCOVERY_FPS", "DEFAULT_MIN_SWING_DEG"]
