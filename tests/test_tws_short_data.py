"""tws-hier on very little data: fewer clusters with a warning, or a clear ParameterError
(thesis §5.7.2 clusters; the real corpus has 21-second leave-one-out folds)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.corpus import Corpus, Recording
from headmotion.errors import ParameterError
from headmotion.synthetic import planted_corpus
from headmotion.systems.tws.hier import TwsHier
from headmotion.types import Audio, Motion

#: regression Gaussian over [prev (3), others (4), frame + context mean (2 × 6 f0e), (d, a)] = 21
#: dimensions: a full-rank covariance needs 22 vectors
MIN_SIZE = 22


def _check_clusters(m: TwsHier):
    for key, counts in m.fit_info_["counts"].items():
        assert len(counts) == m.fit_info_["k"][key]
        assert len(counts) == 1 or min(counts) >= MIN_SIZE, (key, counts)


class SplitOffOutliers:
    """Stands in for sklearn's KMeans: leaves k - 1 singleton clusters, as k-means did on the real
    21 s fold (clusters of 1 and 55 change points)."""

    def __init__(self, n_clusters, **kw):
        self.k = n_clusters

    def fit(self, Z):
        lab = np.zeros(len(Z), dtype=np.int64)
        lab[: self.k - 1] = np.arange(1, self.k)
        self.labels_ = lab
        self.cluster_centers_ = np.stack([Z[lab == c].mean(axis=0) for c in range(self.k)])
        return self


def test_singleton_cluster_reduces_k_with_a_warning(monkeypatch):
    import sklearn.cluster

    corpus = planted_corpus(minutes=0.8, n_recordings=1, seed=1)  # ~50-70 change points: k capped at 2
    monkeypatch.setattr(sklearn.cluster, "KMeans", SplitOffOutliers)
    with pytest.warns(UserWarning, match=r"too little training data for 4 clusters \(48\.0 s of motion"):
        m = TwsHier(hmm_iter=2).fit(corpus)
    assert set(m.fit_info_["k"].values()) == {1}
    _check_clusters(m)
    assert len(m.fit_warnings_) == 1 and "clusters used rx+ 1" in m.fit_warnings_[0]
    out = m.predict(corpus[0].audio.slice_seconds(0, 3))
    assert out.rotvec.shape == (300, 3) and np.all(np.isfinite(out.rotvec))


def test_short_corpora_train_with_big_enough_clusters():
    for minutes in (0.35, 1.0):  # 21 s (one cluster each) and 60 s (k-means finds 3 on one axis)
        corpus = planted_corpus(minutes=minutes, n_recordings=1, seed=1)
        with pytest.warns(UserWarning, match="too little training data"):
            m = TwsHier(hmm_iter=2, min_swing_deg=0.0).fit(corpus)  # thesis segmentation: more segments
        _check_clusters(m)
        assert np.all(np.isfinite(m.predict(corpus[0].audio.slice_seconds(0, 2)).rotvec))
    assert max(m.fit_info_["k"].values()) > 1


def test_too_few_change_points_raise():
    # four V-shaped recordings: every axis has one change point each, all of the rising template
    sr, fps, T = 8000, 100.0, 200
    rng = np.random.default_rng(0)
    tt = np.linspace(-1, 1, T)
    recs = [Recording(f"v{i}", "s", "read", Audio((0.1 * rng.normal(size=T * 80)).astype(np.float32), sr),
                      Motion(np.column_stack([0.05 * tt ** 2, 0.03 * tt ** 2, 0.02 * tt ** 2]), fps))
            for i in range(4)]
    with pytest.raises(ParameterError, match=r"axis rx, falling template has 0 change point\(s\) in 8\.0 s of "
                                             r"training motion; it needs at least 2"):
        TwsHier().fit(Corpus(recs, sample_rate=sr))
