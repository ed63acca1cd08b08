"""HMM wrappers for hierarchical template warping (thesis §2.2.2, §5.6.2, §5.7.4).

* :class:`LeftToRightHMM` — a left-to-right Gaussian HMM with diagonal covariance (5 states in the
  thesis), one per warping-parameter cluster: the "middle layer" cluster recogniser.  Trained by
  our own Baum–Welch (``_baum_welch_batched``: scaled forward–backward over all sequences of a
  cluster at once, vectorised in numpy, which hmmlearn's per-sequence loop is not), start state
  fixed to the first and the transition matrix initialised upper-bidiagonal (EM keeps structural
  zeros).  Scoring at synthesis time is a vectorised Viterbi over a bank of HMMs (thesis §5.8:
  "Viterbi decoding with the observation probabilities dictated by the lower level HMMs").
* :class:`ErgodicLM` — an ergodic categorical HMM over cluster sequences of one axis, the
  "language model" (top layer) that biases the cluster selection; trained with hmmlearn's
  ``CategoricalHMM``; used causally by a forward filter (:meth:`ErgodicLM.prior`,
  :meth:`ErgodicLM.update`).

Library considered: hmmlearn (trains the language model; the Gaussian HMMs' training and scoring
are ours, for speed); HTS/HTK as in the thesis is not a Python library.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import ParameterError

_LOG2PI = np.log(2 * np.pi)
#: floor of log self-transition probabilities in :class:`HMMBank` (exp(-1e4) is 0 in float64)
_LOG_FLOOR = -1e4


def _quiet_hmmlearn():
    import logging

    logging.getLogger("hmmlearn").setLevel(logging.ERROR)


class LeftToRightHMM:
    """Left-to-right Gaussian HMM, diagonal covariance.

    Parameters
    ----------
    n_states : int, default 5
    n_iter : int, Baum–Welch iterations (capped for speed)
    min_covar : float, variance floor (features are normalised to unit variance)
    random_state : int

    Attributes
    ----------
    startprob_ : (S,), transmat_ : (S, S), means_ : (S, D), vars_ : (S, D)
    """

    def __init__(self, n_states: int = 5, *, n_iter: int = 8, min_covar: float = 1e-3,
                 random_state: int = 0):
        self.n_states = n_states
        self.n_iter = n_iter
        self.min_covar = min_covar
        self.random_state = random_state

    def fit(self, X: np.ndarray, lengths) -> "LeftToRightHMM":
        """Fit on sequences concatenated in ``X`` (n, D) with ``lengths`` summing to n.

        Baum–Welch (scaled forward–backward) vectorised over all sequences at once (padded to the
        longest), from a flat start that splits each sequence into ``n_states`` equal parts.
        hmmlearn's ``GaussianHMM.fit`` gives the same estimates but loops over sequences in
        Python, which is ~50× slower for the thousands of short segments a corpus holds."""
        X = np.asarray(X, dtype=np.float64)
        lengths = np.asarray(lengths, dtype=np.int64)
        if lengths.sum() != len(X):
            raise ParameterError(f"lengths sum to {lengths.sum()} but X has {len(X)} rows")
        S = int(self.n_states)
        pos = np.concatenate([np.linspace(0, S, n, endpoint=False) for n in lengths]).astype(int) if len(X) else np.zeros(0, int)
        pos = np.minimum(pos, S - 1)
        gvar = (X.var(axis=0) if len(X) > 1 else np.ones(X.shape[1])) + self.min_covar
        gmean = X.mean(axis=0) if len(X) else np.zeros(X.shape[1])
        means = np.stack([X[pos == s].mean(axis=0) if np.any(pos == s) else gmean for s in range(S)])
        var = np.tile(gvar, (S, 1))
        trans = np.zeros((S, S))
        for s in range(S):
            if s + 1 < S:
                trans[s, s], trans[s, s + 1] = 0.5, 0.5
            else:
                trans[s, s] = 1.0
        start = np.zeros(S)
        start[0] = 1.0
        if len(lengths) and len(X) >= S:
            means, var, trans = _baum_welch_batched(X, lengths, means, var, trans, start,
                                                    n_iter=self.n_iter, min_covar=self.min_covar)
        self.startprob_, self.transmat_, self.means_, self.vars_ = start, trans, means, var
        return self

    def to_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        return {f"{prefix}start": self.startprob_, f"{prefix}trans": self.transmat_,
                f"{prefix}means": self.means_, f"{prefix}vars": self.vars_}

    @classmethod
    def from_arrays(cls, arrays, prefix: str) -> "LeftToRightHMM":
        obj = cls(n_states=len(arrays[f"{prefix}start"]))
        obj.startprob_ = np.asarray(arrays[f"{prefix}start"], dtype=np.float64)
        obj.transmat_ = np.asarray(arrays[f"{prefix}trans"], dtype=np.float64)
        obj.means_ = np.asarray(arrays[f"{prefix}means"], dtype=np.float64)
        obj.vars_ = np.asarray(arrays[f"{prefix}vars"], dtype=np.float64)
        return obj


def _diag_loglik(X: np.ndarray, means: np.ndarray, var: np.ndarray) -> np.ndarray:
    """log N(x; mean_s, diag var_s) for X (..., D): (..., S)."""
    P = 1.0 / var
    const = -0.5 * (np.sum(np.log(var), axis=1) + var.shape[1] * _LOG2PI)
    q = (X * X) @ P.T - 2 * X @ (P * means).T + np.sum(P * means * means, axis=1)
    return const - 0.5 * q


def _baum_welch_batched(X, lengths, means, var, trans, start, *, n_iter: int, min_covar: float):
    """EM for a Gaussian HMM on many sequences at once (scaled forward–backward)."""
    N, L, D = len(lengths), int(lengths.max()), X.shape[1]
    Xp = np.zeros((N, L, D))
    mask = np.arange(L)[None, :] < lengths[:, None]  # (N, L)
    Xp[mask] = X
    maskf = mask.astype(np.float64)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        return _bw_loop(Xp, mask, maskf, means, var, trans, start, n_iter, min_covar)


def _bw_loop(Xp, mask, maskf, means, var, trans, start, n_iter, min_covar):
    N, L, D = Xp.shape
    S = len(start)
    for _ in range(max(0, int(n_iter))):
        logB = _diag_loglik(Xp, means, var)  # (N, L, S)
        mx = logB.max(axis=2, keepdims=True)
        B = np.exp(np.maximum(logB - mx, -300.0))
        alpha = np.empty((N, L, S))
        c = np.ones((N, L))
        a = start[None] * B[:, 0]
        c[:, 0] = a.sum(axis=1)
        alpha[:, 0] = a / c[:, 0:1]
        for t in range(1, L):
            a = (alpha[:, t - 1] @ trans) * B[:, t]
            ct = a.sum(axis=1)
            valid = mask[:, t]
            ct = np.where(valid, np.maximum(ct, 1e-250), 1.0)
            alpha[:, t] = np.where(valid[:, None], a / ct[:, None], alpha[:, t - 1])
            c[:, t] = ct
        beta = np.ones((N, L, S))
        xi = np.zeros((S, S))
        for t in range(L - 2, -1, -1):
            valid = mask[:, t + 1]
            bb = B[:, t + 1] * beta[:, t + 1] / c[:, t + 1:t + 2]  # (N, S)
            beta[:, t] = np.where(valid[:, None], bb @ trans.T, 1.0)
            xi += trans * ((alpha[:, t] * valid[:, None]).T @ bb)
        gamma = alpha * beta
        gamma /= np.maximum(gamma.sum(axis=2, keepdims=True), 1e-300)
        gamma = np.nan_to_num(gamma, nan=0.0, posinf=0.0)
        xi = np.nan_to_num(xi, nan=0.0, posinf=0.0)
        gamma *= maskf[:, :, None]
        g = gamma.reshape(-1, S)
        Xf = Xp.reshape(-1, D)
        occ = g.sum(axis=0)
        ok = occ > 1e-6
        new_means = (g.T @ Xf) / np.maximum(occ, 1e-300)[:, None]
        new_var = (g.T @ (Xf * Xf)) / np.maximum(occ, 1e-300)[:, None] - new_means ** 2
        means = np.where(ok[:, None], new_means, means)
        var = np.where(ok[:, None], np.maximum(new_var, min_covar), var)
        rows = xi.sum(axis=1, keepdims=True)
        trans = np.where(rows > 0, xi / np.maximum(rows, 1e-300), trans)
        if not (np.all(np.isfinite(means)) and np.all(np.isfinite(var)) and np.all(np.isfinite(trans))):
            raise ParameterError("HMM training diverged (non-finite parameters)")
    return means, var, trans


class HMMBank:
    """Several :class:`LeftToRightHMM` with equal state counts, scored together.

    Observations split into a per-frame part (speech features + Δ + ΔΔ) and a per-segment
    constant part (the other axes' current warping parameters), so emission log-likelihoods of the
    per-frame part can be precomputed once per utterance and a segment is scored with a
    vectorised Viterbi over all models at once."""

    def __init__(self, hmms: list[LeftToRightHMM], n_frame_dims: int):
        self.hmms = hmms
        self.n_frame_dims = int(n_frame_dims)
        self.means = np.stack([h.means_ for h in hmms])  # (K, S, D)
        self.vars = np.stack([h.vars_ for h in hmms])
        with np.errstate(divide="ignore"):
            self.logA = np.log(np.stack([h.transmat_ for h in hmms]))  # (K, S, S)
            self.logpi = np.log(np.stack([h.startprob_ for h in hmms]))  # (K, S)
        # a state that never stays (self-transition 0, seen with a few very short training
        # segments) gets a finite floor: -inf in the cumulative sums below turns into -inf - -inf = NaN
        self.logA_self = np.maximum(np.einsum("kss->ks", self.logA), _LOG_FLOOR)
        S = self.means.shape[1]
        self.logA_next = np.full_like(self.logA_self, -np.inf)
        for s in range(S - 1):
            self.logA_next[:, s + 1] = self.logA[:, s, s + 1]
        self._prec = 1.0 / self.vars
        self._const = -0.5 * (np.sum(np.log(self.vars), axis=2) + self.vars.shape[2] * _LOG2PI)  # (K, S)

    def frame_loglik(self, F: np.ndarray) -> np.ndarray:
        """Per-frame part of the emission log-likelihood: (T, K, S), without the constant."""
        d = self.n_frame_dims
        mu = self.means[:, :, :d]
        P = self._prec[:, :, :d]
        # sum_j P (f - mu)^2 = f^2·P - 2 f·(P mu) + mu^2·P
        F = np.asarray(F, dtype=np.float64)
        a = np.einsum("tj,ksj->tks", F * F, P)
        b = np.einsum("tj,ksj->tks", F, P * mu)
        c = np.sum(P * mu * mu, axis=2)
        return -0.5 * (a - 2 * b + c[None])

    def segment_loglik(self, frame_ll: np.ndarray, const_obs: np.ndarray) -> np.ndarray:
        """Viterbi log-likelihood of one segment under each model: (K,).

        frame_ll : (L, K, S) from :meth:`frame_loglik` for the segment's frames
        const_obs : (Dc,) the per-segment constant part of the observation
        """
        d = self.n_frame_dims
        diff = np.asarray(const_obs, dtype=np.float64)[None, None, :] - self.means[:, :, d:]
        cpart = -0.5 * np.sum(self._prec[:, :, d:] * diff * diff, axis=2) + self._const  # (K, S)
        L = len(frame_ll)
        if L == 0:
            return np.zeros(len(self.hmms))
        # Viterbi for the no-skip left-to-right topology as a dynamic programme over *states*
        # (S steps of cumulative sums / running maxima over time) instead of over frames.
        a = self.logA_self  # (K, S)
        G = np.cumsum(frame_ll + (cpart + a)[None], axis=0)  # (L, K, S)
        Gp = np.concatenate([np.zeros((1,) + G.shape[1:]), G[:-1]], axis=0)  # G(t-1)
        V = self.logpi[None, :, 0] + G[:, :, 0] - a[None, :, 0]  # (L, K)
        best = V[-1]
        for s in range(1, G.shape[2]):
            inner = np.empty_like(V)
            inner[0] = self.logpi[:, s]
            inner[1:] = V[:-1] + self.logA_next[None, :, s] - Gp[1:, :, s]
            V = G[:, :, s] - a[None, :, s] + np.maximum.accumulate(inner, axis=0)
            best = np.maximum(best, V[-1])
        return best

    def segment_loglik_loop(self, frame_ll: np.ndarray, const_obs: np.ndarray) -> np.ndarray:
        """Reference frame-by-frame Viterbi (same result as :meth:`segment_loglik`)."""
        d = self.n_frame_dims
        diff = np.asarray(const_obs, dtype=np.float64)[None, None, :] - self.means[:, :, d:]
        cpart = -0.5 * np.sum(self._prec[:, :, d:] * diff * diff, axis=2) + self._const
        L = len(frame_ll)
        if L == 0:
            return np.zeros(len(self.hmms))
        delta = self.logpi + frame_ll[0] + cpart
        shifted = np.empty_like(delta)
        for t in range(1, L):
            shifted[:, 0] = -np.inf
            shifted[:, 1:] = delta[:, :-1]
            delta = np.maximum(delta + self.logA_self, shifted + self.logA_next) + frame_ll[t] + cpart
        return delta.max(axis=1)


class ErgodicLM:
    """Ergodic categorical HMM over cluster symbols: the "language model" of one axis.

    Parameters
    ----------
    n_states : int, default 5 (thesis: same number of states as the middle layer)
    n_symbols : int, number of distinct cluster symbols
    n_iter : int
    """

    def __init__(self, n_states: int = 5, n_symbols: int = 4, *, n_iter: int = 20, random_state: int = 0):
        self.n_states = n_states
        self.n_symbols = n_symbols
        self.n_iter = n_iter
        self.random_state = random_state

    def fit(self, symbols: np.ndarray, lengths) -> "ErgodicLM":
        from hmmlearn.hmm import CategoricalHMM

        _quiet_hmmlearn()
        sym = np.asarray(symbols, dtype=np.int64).reshape(-1, 1)
        S, V = int(self.n_states), int(self.n_symbols)
        rng = np.random.default_rng(self.random_state)
        m = CategoricalHMM(S, n_features=V, n_iter=self.n_iter, init_params="", params="ste",
                           random_state=self.random_state, tol=1e-3)
        m.startprob_ = np.full(S, 1.0 / S)
        t = rng.uniform(0.5, 1.5, (S, S))
        m.transmat_ = t / t.sum(1, keepdims=True)
        counts = np.bincount(sym[:, 0], minlength=V) + 1.0
        e = counts[None] * rng.uniform(0.5, 1.5, (S, V))
        m.emissionprob_ = e / e.sum(1, keepdims=True)
        self.trained_ = False
        failure = None
        if len(sym) >= 2:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    m.fit(sym, lengths)
                    self.trained_ = True
                except ValueError as exc:  # e.g. lengths that do not sum to the symbols
                    failure = exc
        if failure is not None:
            warnings.warn(f"language model: Baum–Welch failed ({failure}); it keeps its random initialisation "
                          f"(floored so every symbol stays possible)", UserWarning, stacklevel=2)
        # floor so no symbol becomes impossible
        self.startprob_ = _norm(np.asarray(m.startprob_) + 1e-3)
        self.transmat_ = _norm(np.asarray(m.transmat_) + 1e-3)
        self.emission_ = _norm(np.asarray(m.emissionprob_) + 1e-3)
        return self

    def initial_state(self) -> np.ndarray:
        """Forward probabilities before any symbol: the start distribution (S,)."""
        return self.startprob_.copy()

    def prior(self, alpha: np.ndarray, *, first: bool = False) -> np.ndarray:
        """Log probability of the next symbol given the filtered state ``alpha``: (V,)."""
        pred = alpha if first else alpha @ self.transmat_
        return np.log(pred @ self.emission_)

    def update(self, alpha: np.ndarray, symbol: int, *, first: bool = False) -> np.ndarray:
        """Forward-filter step after observing ``symbol``."""
        pred = alpha if first else alpha @ self.transmat_
        a = pred * self.emission_[:, int(symbol)]
        return a / a.sum()

    def to_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        return {f"{prefix}start": self.startprob_, f"{prefix}trans": self.transmat_, f"{prefix}emis": self.emission_}

    @classmethod
    def from_arrays(cls, arrays, prefix: str) -> "ErgodicLM":
        e = np.asarray(arrays[f"{prefix}emis"], dtype=np.float64)
        obj = cls(n_states=e.shape[0], n_symbols=e.shape[1])
        obj.startprob_ = np.asarray(arrays[f"{prefix}start"], dtype=np.float64)
        obj.transmat_ = np.asarray(arrays[f"{prefix}trans"], dtype=np.float64)
        obj.emission_ = e
        return obj


def _norm(a: np.ndarray) -> np.ndarray:
    return a / a.sum(axis=-1, keepdims=True)


__all__ = ["LeftToRightHMM", "HMMBank", "ErgodicLM"]
