"""Chance levels by circular shifts (headmotion.evaluation.measures.chance)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.evaluation.measures import chance as C
from headmotion.evaluation.measures import metrics as M


def _smooth(rng, T, D, width=15):
    k = np.hanning(width)
    k /= k.sum()
    x = rng.normal(size=(T + width, D))
    return np.stack([np.convolve(x[:, d], k, mode="valid")[:T] for d in range(D)], 1)


@pytest.fixture
def streams():
    rng = np.random.default_rng(11)
    T = 1500
    f = _smooth(rng, T, 6)
    x = f[:, :3] @ rng.normal(size=(3, 3)) + 0.5 * _smooth(rng, T, 3)
    return x, f


def test_fast_paths_equal_generic(streams):
    x, f = streams
    g = C.global_cca_null(x, f, n_shifts=30, seed=4, min_shift=100)
    g2 = C.shift_null(lambda s: M.cca(s, f), x, n_shifts=30, seed=4, min_shift=100)
    assert g.score == pytest.approx(g2.score)
    assert g.null_mean == pytest.approx(g2.null_mean, abs=1e-7)
    assert g.null_p95 == pytest.approx(g2.null_p95, abs=1e-7)
    loc = C.local_cca_null(x, f, window=300, n_shifts=30, seed=4, min_shift=100)
    loc2 = C.shift_null(lambda s: M.local_cca(s, f, window=300), x, n_shifts=30, seed=4, min_shift=100)
    assert loc.null_mean == pytest.approx(loc2.null_mean, abs=1e-7)
    synth = x + 0.3 * np.random.default_rng(0).normal(size=x.shape)
    fc = C.fcca_null(x, f, synth, n_shifts=30, seed=4, min_shift=100)
    fc2 = C.shift_null(lambda s: M.fcca(x, f, s), synth, n_shifts=30, seed=4, min_shift=100)
    assert fc.score == pytest.approx(fc2.score)
    assert fc.null_mean == pytest.approx(fc2.null_mean, abs=1e-7)
    fcl = C.fcca_null(x, f, synth, window=300, n_shifts=10, seed=1, min_shift=100)
    fcl2 = C.shift_null(lambda s: M.fcca(x, f, s, window=300), synth, n_shifts=10, seed=1, min_shift=100)
    assert fcl.null_mean == pytest.approx(fcl2.null_mean, abs=1e-7)


def test_synchronised_streams_beat_chance(streams):
    x, f = streams
    r = C.local_cca_null(x, f, window=300, n_shifts=200, seed=0)
    assert r.n_shifts == 200
    assert r.p_value == pytest.approx(1 / 201)
    assert r.excess == pytest.approx(r.statistic - r.null_mean)
    assert r.statistic == pytest.approx(M.local_cca(C.bridge(x), f, window=300))
    assert r.score > r.null_p95 > r.null_mean
    # short windows of smooth unrelated motion: a high chance level (why chance levels are measured)
    assert r.null_mean > 0.3


def test_independent_streams_are_at_chance():
    rng = np.random.default_rng(5)
    ps = []
    for i in range(30):
        x, y = _smooth(rng, 800, 3), _smooth(rng, 800, 3)
        ps.append(C.global_cca_null(x, y, n_shifts=200, seed=i).p_value)
    ps = np.array(ps)
    # roughly uniform p-values: not all significant, median in the middle
    assert np.mean(ps < 0.05) < 0.25
    assert 0.25 < np.median(ps) < 0.75


def test_seeded_and_reproducible(streams):
    x, f = streams
    a = C.local_cca_null(x, f, n_shifts=50, seed=123)
    b = C.local_cca_null(x, f, n_shifts=50, seed=123)
    c = C.local_cca_null(x, f, n_shifts=50, seed=124)
    assert a == b
    assert a.null_mean != c.null_mean
    with pytest.raises(ParameterError, match="n_shifts"):
        C.shift_null(lambda _s: 0.0, x, n_shifts=0)


def test_paper_chance_score():
    rng = np.random.default_rng(2)
    gt = _smooth(rng, 3000, 3)
    others = [_smooth(rng, 1000, 3), _smooth(rng, 700, 3)]
    s = C.paper_chance_score(gt, others, n_draws=10, seed=0)
    assert s == C.paper_chance_score(gt, others, n_draws=10, seed=0)
    # unrelated smooth motion over 300-frame windows: well above 0, well below 1
    assert 0.15 < s < 0.7
    assert C.paper_chance_score(gt, [gt], n_draws=5, seed=0) <= 1.0
    with pytest.raises(ParameterError, match="other speaker"):
        C.paper_chance_score(gt, [])


def test_bridge_closes_the_motion():
    a = np.cumsum(np.random.default_rng(0).normal(size=(50, 3)), axis=0)
    b = C.bridge(a)
    np.testing.assert_allclose(b[0], a[0])
    np.testing.assert_allclose(b[-1], a[0])
    np.testing.assert_allclose(np.diff(b, axis=0), np.diff(a, axis=0) - (a[-1] - a[0]) / 49)
    with pytest.raises(ParameterError, match="null"):
        C.fcca_null(a, a, a, null="mirror")


def _pooled_share(null: str, min_shift, n_draws: int = 300, T: int = 100) -> float:
    """Share of p < 0.05 of Forced CCA between a random walk (the "synthesised" motion, uncoupled)
    and features with an unrelated recorded motion, over ``n_draws`` independent draws."""
    rng = np.random.default_rng(7)
    ps = []
    for i in range(n_draws):
        feats = _smooth(rng, T, 2, width=9)
        orig = feats @ rng.normal(size=(2, 3)) + 0.5 * _smooth(rng, T, 3, width=9)
        walk = np.cumsum(rng.normal(size=(T, 3)), axis=0)  # a slowly drifting head, unrelated to the speech
        ps.append(C.fcca_null(orig, feats, walk, n_shifts=60, seed=i, null=null, min_shift=min_shift).p_value)
    return float(np.mean(np.array(ps) < 0.05))


def test_uncoupled_drift_is_uniform_under_the_bridge_null():
    from scipy.stats import binom

    n = 300
    hi = binom.ppf(0.999, n, 0.05) / n  # one-sided 99.9 % bound of the share under a calibrated test
    lo = binom.ppf(0.001, n, 0.05) / n
    share = _pooled_share("bridge", None, n)
    assert lo <= share <= hi
    # the plain circular shift over the middle half of the circle calls such drift coupled far too often
    assert _pooled_share("circular", 25, n) > hi


def test_motion_made_from_the_speech_is_coupled():
    rng = np.random.default_rng(3)
    T = 200
    feats = _smooth(rng, T, 3, width=9)
    orig = feats @ rng.normal(size=(3, 3)) + 0.3 * _smooth(rng, T, 3, width=9)
    synth = feats @ rng.normal(size=(3, 3)) + 0.3 * _smooth(rng, T, 3, width=9)  # another motion from the same speech
    r = C.fcca_null(orig, feats, synth, n_shifts=100, seed=0)
    assert r.p_value < 0.02
    assert r.excess > 0.3
