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
from .segmentation import segment


def normalised_segments(motions, *, n_points: int = 20, max_segments: int | None = None,
                        rng: np.random.Generator | None = None) -> np.ndarray:
    """All segments of all axes, normalised to amplitude 1 and duration 1: (N, n_points)."""
    out = []
    for m in motions:
        for j in range(3):
            seg = segment(m.rotvec[:, j], fps=m.fps)
            x = np.asarray(m.rotvec[:, j])
            from .segmentation import smooth

            xs = smooth(x, fps=m.fps)
            for k in range(seg.n_segments):
                a, b = int(seg.bounds[k]), int(seg.bounds[k + 1])
                y = xs[a:b + 1] - xs[a]
                amp = abs(y[-1]) if abs(y[-1]) > 1e-9 else np.max(np.abs(y)) + 1e-12
                t = np.linspace(0, len(y) - 1, n_points)
                out.append(np.interp(t, np.arange(len(y)), y) / amp)
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
        hmms.append(LeftToRightHMM(n_states, n_iter=5, min_covar=1e-3).fit(np.vstack(seqs), [len(s) for s in seqs]))
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


def intra_inter(D: np.ndarray, ks=range(1, 11)) -> dict[str, list[float]]:
    """Max intra-cluster and min/max inter-cluster distance for each k (Fig 5.5)."""
    res = {"k": [], "max_intra": [], "min_inter": [], "max_inter": []}
    for k in ks:
        lab = complete_linkage(D, k)
        same = lab[:, None] == lab[None, :]
        res["k"].append(int(k))
        res["max_intra"].append(float(D[same].max()))
        res["min_inter"].append(float(D[~same].min()) if (~same).any() else float("nan"))
        res["max_inter"].append(float(D[~same].max()) if (~same).any() else float("nan"))
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


def analyse(motions, out_dir, *, n_initialisers=(20, 40, 80), n_sets: int = 3, k_stability: int = 5,
            n_init_main: int = 120, n_states: int = 4, max_k: int = 10, seed: int = 0,
            max_segments: int = 3000) -> dict:
    """Run the §5.3 analysis and write ``fig5_4_stability.png``, ``fig5_5_intra_inter.png``,
    ``fig5_6_histograms.png`` and ``discovery.json`` to ``out_dir``.  Returns the numbers."""
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    X = normalised_segments(motions, max_segments=max_segments, rng=rng)
    if len(X) < 10:
        raise ParameterError(f"template discovery needs at least 10 segments; the corpus has {len(X)}")
    res: dict = {"segments": int(len(X))}
    # Fig 5.4: stability vs number of initialisers
    stab = {}
    for n in n_initialisers:
        n = min(int(n), len(X))
        sets = [_cluster_set(X, rng.choice(len(X), n, replace=False), k_stability, n_states) for _ in range(n_sets)]
        dists = [cluster_set_distance(X, sets[a], sets[b]) for a in range(n_sets) for b in range(a + 1, n_sets)]
        stab[n] = (float(np.mean(dists)), float(np.std(dists)))
    res["stability"] = {str(k): v for k, v in stab.items()}
    fig, ax = plt.subplots(figsize=(6, 4))
    ks = sorted(stab)
    ax.errorbar(ks, [stab[k][0] for k in ks], yerr=[stab[k][1] for k in ks], marker="o")
    ax.set_xlabel("number of initialisers")
    ax.set_ylabel("total distance between matched clusters")
    ax.set_title("Fig 5.4: clustering stability")
    fig.tight_layout()
    fig.savefig(out / "fig5_4_stability.png", dpi=100)
    plt.close(fig)
    # Fig 5.5: intra vs inter distances
    idx = rng.choice(len(X), min(n_init_main, len(X)), replace=False)
    D = cross_entropy_distances(X[idx], n_states=n_states)
    ii = intra_inter(D, range(1, min(max_k, len(idx)) + 1))
    res["intra_inter"] = ii
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(ii["k"], ii["max_intra"], "o-", label="max intra-cluster")
    ax.plot(ii["k"], ii["min_inter"], "s-", label="min inter-cluster")
    ax.set_xlabel("number of clusters k")
    ax.set_ylabel("cross-entropy distance")
    ax.set_title("Fig 5.5: intra- vs inter-cluster distance")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "fig5_5_intra_inter.png", dpi=100)
    plt.close(fig)
    # Fig 5.6: histograms of all segments assigned to cluster HMMs (k chosen where inter > intra)
    k_sel = next((k for k, a, b in zip(ii["k"], ii["max_intra"], ii["min_inter"]) if b > a), 3)
    k_sel = max(2, min(k_sel, 6))
    lab = complete_linkage(D, k_sel)
    hmms = _fit_hmms([X[idx][lab == c] for c in range(k_sel) if np.any(lab == c)], n_states)
    assign = _loglik_matrix(hmms, X).argmax(1)
    res["k_selected"] = int(len(hmms))
    res["cluster_sizes"] = np.bincount(assign, minlength=len(hmms)).tolist()
    fig, axes = plt.subplots(1, len(hmms), figsize=(3.2 * len(hmms), 3.2), squeeze=False)
    tt = np.tile(np.linspace(0, 1, X.shape[1]), 1)
    for c, ax in enumerate(axes[0]):
        sel = X[assign == c]
        if len(sel):
            ax.hist2d(np.tile(tt, len(sel)), sel.ravel(), bins=150, range=[[0, 1], [-1.5, 1.5]], cmap="Greys")
        ax.set_title(f"cluster {c + 1} ({len(sel)} segments)")
        ax.set_xlabel("time (normalised)")
    axes[0][0].set_ylabel("amplitude (normalised)")
    fig.suptitle("Fig 5.6: segments per cluster")
    fig.tight_layout()
    fig.savefig(out / "fig5_6_histograms.png", dpi=100)
    plt.close(fig)
    (out / "discovery.json").write_text(json.dumps(res, indent=2))
    return res


__all__ = ["normalised_segments", "cross_entropy_distances", "complete_linkage", "intra_inter",
           "stable_matching", "cluster_set_distance", "analyse"]
