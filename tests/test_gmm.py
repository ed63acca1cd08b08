"""GMM regression (thesis §2.2.1 eq 2.4–2.9), HMM wrappers and G-means."""

import numpy as np
import pytest

from headmotion.errors import NotFittedError, ParameterError
from headmotion.models.gmeans import gmeans
from headmotion.models.gmm import GMMRegression, bic_curve
from headmotion.models.hmm import ErgodicLM, HMMBank, LeftToRightHMM

W = np.array([[1.0, 2.0], [0.0, 1.0], [-1.0, 0.5]])


def _linear(rng, n=3000):
    X = rng.normal(size=(n, 3))
    return X, X @ W + 0.05 * rng.normal(size=(n, 2))


def test_single_gaussian_recovers_a_linear_map(rng):
    X, Y = _linear(rng)
    g = GMMRegression(1).fit(X, Y)
    Xt = rng.normal(size=(50, 3))
    np.testing.assert_allclose(g.predict(Xt, method="mmse"), Xt @ W, atol=0.02)
    np.testing.assert_allclose(g.predict(Xt, method="ml"), g.predict(Xt, method="mmse"))


def test_mixture_modes_and_samples(rng):
    X, Y = _linear(rng)
    g = GMMRegression(3, random_state=0).fit(X, Y)
    for method in ("mmse", "ml"):
        assert np.sqrt(np.mean((g.predict(X, method=method) - Y) ** 2)) < 0.1
    s = g.predict(X, method="sample", rng=np.random.default_rng(0))
    assert 0.03 < np.sqrt(np.mean((s - Y) ** 2)) < 0.2  # samples scatter with the conditional noise
    p = g.posteriors(X[:10])
    np.testing.assert_allclose(p.sum(axis=1), 1.0)


def test_bimodal_conditional_ml_picks_a_mode(rng):
    # y = +-1 regardless of x: MMSE gives ~0, ML gives one of the modes
    X = rng.normal(size=(4000, 1))
    Y = np.where(rng.random(4000) < 0.5, -1.0, 1.0)[:, None] + 0.05 * rng.normal(size=(4000, 1))
    g = GMMRegression(2, random_state=0, n_init=3).fit(X, Y)
    assert abs(g.predict(X[:5], method="mmse")).max() < 0.3
    np.testing.assert_allclose(np.abs(g.predict(X[:5], method="ml")), 1.0, atol=0.1)


def test_log_likelihood_x_matches_scipy(rng):
    from scipy.stats import multivariate_normal

    X, Y = _linear(rng, 500)
    g = GMMRegression(1).fit(X, Y)
    ref = multivariate_normal(g.means_[0, :3], g.covariances_[0, :3, :3]).logpdf(X[:4])
    np.testing.assert_allclose(g.log_likelihood_x(X[:4]), ref)


def test_round_trip_arrays_and_errors(rng):
    X, Y = _linear(rng, 300)
    g = GMMRegression(2, random_state=0).fit(X, Y)
    h = GMMRegression.from_arrays(g.to_arrays("p_"), "p_")
    np.testing.assert_allclose(h.predict(X[:5]), g.predict(X[:5]))
    with pytest.raises(NotFittedError):
        GMMRegression().predict(X)
    with pytest.raises(ParameterError, match="same number of rows"):
        GMMRegression().fit(X, Y[:10])
    with pytest.raises(ParameterError, match="n_components"):
        GMMRegression(0).fit(X, Y)
    with pytest.raises(ParameterError, match="NaN"):
        GMMRegression().fit(np.full((5, 3), np.nan), Y[:5])
    bic = bic_curve(np.hstack([X, Y]), components=(1, 2))
    assert set(bic) == {"full", "diag"} and all(np.isfinite(v) for v in bic["full"])


def test_left_to_right_hmm_recognises_direction(rng):
    def seqs(sign):
        return [np.stack([sign * np.linspace(-1, 1, n) + 0.1 * rng.normal(size=n), np.ones(n)], 1)
                for n in rng.integers(8, 30, 60)]

    up, down = seqs(1), seqs(-1)
    hu = LeftToRightHMM(5).fit(np.vstack(up), [len(s) for s in up])
    hd = LeftToRightHMM(5).fit(np.vstack(down), [len(s) for s in down])
    assert np.all(np.triu(hu.transmat_) == hu.transmat_)  # left-to-right kept
    np.testing.assert_allclose(hu.transmat_.sum(axis=1), 1.0)
    bank = HMMBank([hu, hd], 1)
    for s in up[:5]:
        assert np.argmax(bank.segment_loglik(bank.frame_loglik(s[:, :1]), s[0, 1:])) == 0
    for s in down[:5]:
        assert np.argmax(bank.segment_loglik(bank.frame_loglik(s[:, :1]), s[0, 1:])) == 1


def test_baum_welch_matches_hmmlearn(rng):
    from hmmlearn.hmm import GaussianHMM

    seqs = [np.stack([np.linspace(0, 1, n) + 0.1 * rng.normal(size=n)], 1) for n in rng.integers(8, 30, 40)]
    X, L = np.vstack(seqs), [len(s) for s in seqs]
    ours = LeftToRightHMM(4, n_iter=5).fit(X, L)
    init = LeftToRightHMM(4, n_iter=0).fit(X, L)
    ref = GaussianHMM(4, "diag", init_params="", params="tmc", n_iter=5, tol=0, min_covar=1e-3)
    ref.startprob_, ref.transmat_, ref.means_, ref.covars_ = init.startprob_, init.transmat_, init.means_, init.vars_
    ref.fit(X, L)
    np.testing.assert_allclose(ours.means_, ref.means_, atol=1e-3)  # hmmlearn adds min_covar, we floor
    np.testing.assert_allclose(ours.transmat_, ref.transmat_, atol=1e-3)


def test_ergodic_lm_learns_a_cycle():
    lm = ErgodicLM(5, 3).fit(np.tile([0, 1, 2], 60), [180])
    a = lm.update(lm.initial_state(), 0, first=True)
    assert np.argmax(lm.prior(a)) == 1
    a = lm.update(a, 1)
    assert np.argmax(lm.prior(a)) == 2


def test_gmeans_finds_four_blobs(rng):
    X = np.vstack([rng.normal(c, 0.3, size=(200, 3)) for c in (0, 3, 6, -3)])
    k, centres, labels = gmeans(X)
    assert k == 4 and centres.shape == (4, 3) and labels.shape == (800,)
    k1, _, _ = gmeans(rng.normal(size=(500, 2)))
    assert k1 == 1


def test_state_dp_viterbi_equals_frame_loop(rng):
    hs = []
    for k in range(3):
        seqs = [rng.normal(k * 0.3, 1, (int(n), 3)) for n in rng.integers(6, 40, 20)]
        hs.append(LeftToRightHMM(5).fit(np.vstack(seqs), [len(q) for q in seqs]))
    bank = HMMBank(hs, 2)
    for L in (1, 2, 7, 45):
        x = rng.normal(size=(L, 3))
        fl = bank.frame_loglik(x[:, :2])
        np.testing.assert_allclose(bank.segment_loglik(fl, x[0, 2:]), bank.segment_loglik_loop(fl, x[0, 2:]),
                                   rtol=1e-10, atol=1e-9)
