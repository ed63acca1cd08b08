"""G-means: choose the number of k-means clusters by testing each for Gaussianity
(Hamerly & Elkan 2003; thesis §5.7.2).

Start with one cluster; for every cluster, split it in two with 2-means, project its points onto
the line joining the two child centres, and apply the Anderson–Darling normality test to the
standardised projection.  Clusters whose projection is not Gaussian (at significance ``alpha``)
are replaced by their children; repeat until every cluster passes or ``max_k`` is reached.  The
final centres seed a k-means with random restarts (the thesis's Monte-Carlo initialisation).

Library considered: scikit-learn has k-means but no G-means; scipy.stats.anderson gives the
statistic (critical values for the normal case with estimated parameters, Stephens 1974).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

# Anderson–Darling critical values for the normal distribution (mean and variance estimated),
# A*^2 = A^2 (1 + 4/n - 25/n^2); Hamerly & Elkan used alpha = 0.0001 (critical value 1.8692)
_AD_CRITICAL = {0.15: 0.576, 0.10: 0.656, 0.05: 0.787, 0.025: 0.918, 0.01: 1.092, 0.0001: 1.8692}


def _ad_statistic(x: np.ndarray) -> float:
    from scipy.stats import norm

    n = len(x)
    x = np.sort((x - x.mean()) / max(x.std(ddof=1), 1e-12))
    cdf = np.clip(norm.cdf(x), 1e-12, 1 - 1e-12)
    i = np.arange(1, n + 1)
    a2 = -n - np.mean((2 * i - 1) * (np.log(cdf) + np.log(1 - cdf[::-1])))
    return float(a2 * (1 + 4.0 / n - 25.0 / n ** 2))


def gmeans(X: np.ndarray, *, alpha: float = 0.0001, max_k: int = 20, min_size: int = 8,
           random_state: int = 0, n_init: int = 10) -> tuple[int, np.ndarray, np.ndarray]:
    """Number of clusters by G-means.

    Parameters
    ----------
    X : (n, D) data (standardise it first when dimensions have different units)
    alpha : significance level of the Anderson–Darling test (one of 0.15 … 0.0001)
    max_k : upper limit on the number of clusters
    min_size : clusters smaller than this are not split
    random_state, n_init : of the k-means runs

    Returns
    -------
    k : int
    centres : (k, D)
    labels : (n,)
    """
    from sklearn.cluster import KMeans

    if alpha not in _AD_CRITICAL:
        raise ParameterError(f"alpha must be one of {sorted(_AD_CRITICAL)}; got {alpha!r}")
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or len(X) < 2:
        raise ParameterError(f"G-means needs at least 2 points of shape (n, D); given {X.shape}")
    crit = _AD_CRITICAL[alpha]
    centres = X.mean(axis=0, keepdims=True)
    while len(centres) < max_k:
        km = KMeans(len(centres), init=centres, n_init=1, random_state=random_state).fit(X)
        centres, labels = km.cluster_centers_, km.labels_
        new = []
        changed = False
        for j in range(len(centres)):
            pts = X[labels == j]
            if len(pts) < max(min_size, 2) or len(new) + (len(centres) - j) >= max_k:
                new.append(centres[j])
                continue
            km2 = KMeans(2, n_init=2, random_state=random_state).fit(pts)
            v = km2.cluster_centers_[0] - km2.cluster_centers_[1]
            nv = float(v @ v)
            if nv <= 1e-18:
                new.append(centres[j])
                continue
            proj = pts @ v / nv
            if _ad_statistic(proj) > crit:
                new.extend(km2.cluster_centers_)
                changed = True
            else:
                new.append(centres[j])
        centres = np.asarray(new)[:max_k]
        if not changed:
            break
    k = len(centres)
    km = KMeans(k, n_init=n_init, random_state=random_state).fit(X)
    return k, km.cluster_centers_, km.labels_


__all__ = ["gmeans"]
