"""Gaussian mixture regression on a joint GMM (thesis §2.2.1 eq 2.4–2.9; §5.5, §5.7.3).

A GMM is fitted to joint vectors ``z = [x, y]`` (inputs then outputs).  Conditioning each component
on ``x`` gives (eq 2.5–2.8)::

    P(m | x)       = w_m N(x; mu_x, S_xx) / sum_n w_n N(x; mu_xn, S_xxn)
    mu_{y|x,m}     = mu_y + S_yx S_xx^-1 (x - mu_x)
    S_{yy|x,m}     = S_yy - S_yx S_xx^-1 S_xy

and the output is estimated by

* ``"mmse"`` — eq 2.9, ``sum_m P(m|x) mu_{y|x,m}`` (Toda et al. 2007);
* ``"ml"``   — the mode of the conditional mixture ``p(y|x)`` (maximum likelihood), found by the
  fixed-point (mean-shift) iteration for Gaussian mixtures started from every component's
  conditional mean; with one component this is the conditional mean;
* ``"sample"`` — draw a component from ``P(m|x)``, then ``y`` from its conditional Gaussian.

:meth:`GMMRegression.log_likelihood_x` is the "observation probability" of the inputs used to pick a
speed class (§5.5, step 3) or cluster.

Fitting uses scikit-learn's :class:`~sklearn.mixture.GaussianMixture` (EM, random restarts via
``n_init``).  A single full-covariance Gaussian (tws-hier, §5.7.3) has a closed-form maximum
likelihood fit, so the thesis's "100 random initialisations" all converge to the same estimate:
:meth:`fit` computes it directly (``n_init`` is recorded, not looped over).  Only the conditioning
is hand-written, after nnmnkwii's ``baseline/gmm.py`` (the XX/XY/YX/YY block split).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import NotFittedError, ParameterError

_LOG2PI = np.log(2.0 * np.pi)


def _check_2d(name, a, dim=None):
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2:
        raise ParameterError(f"{name} must have shape (n, d); given shape {a.shape}")
    if dim is not None and a.shape[1] != dim:
        raise ParameterError(f"{name} must have {dim} columns; given {a.shape[1]}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{name} contains NaN or inf")
    return a


def _gauss_logpdf(x: np.ndarray, mean: np.ndarray, prec_chol: np.ndarray, log_det_prec_chol: float) -> np.ndarray:
    """log N(x; mean, cov) with cov^-1 = L L^T given as ``prec_chol`` (upper form as sklearn: y = (x-mu) @ P)."""
    y = (x - mean) @ prec_chol
    return -0.5 * (x.shape[1] * _LOG2PI + np.sum(y * y, axis=1)) + log_det_prec_chol


def _prec_chol(cov: np.ndarray) -> tuple[np.ndarray, float]:
    """``P`` with ``P P^T = cov^-1`` and ``log|P|`` (= -0.5 log|cov|)."""
    L = np.linalg.cholesky(cov)
    P = np.linalg.inv(L).T
    return P, float(-np.sum(np.log(np.diag(L))))


@dataclass(frozen=True)
class Conditional:
    """``p(y | x)`` for n inputs: a mixture of M Gaussians per input.

    Attributes
    ----------
    log_joint : (n, M), ``log w_m + log N(x; mu_x,m, S_xx,m)`` (= ``log p(x, m)``)
    means : (n, M, Dy), ``mu_{y|x,m}`` (eq 2.7)
    covariances : (M, Dy, Dy), ``S_{yy|x,m}`` (eq 2.8; independent of x)
    chol : (M, Dy, Dy), their lower Cholesky factors
    """

    log_joint: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    chol: np.ndarray

    @property
    def posteriors(self) -> np.ndarray:
        """P(m | x), (n, M) (eq 2.5)."""
        lp = self.log_joint - self.log_joint.max(axis=1, keepdims=True)
        p = np.exp(lp)
        return p / p.sum(axis=1, keepdims=True)

    @property
    def precisions(self) -> np.ndarray:
        return np.linalg.inv(self.covariances)

    @property
    def log_det(self) -> np.ndarray:
        """``log |S_{yy|x,m}|``, (M,)."""
        return 2.0 * np.log(np.diagonal(self.chol, axis1=1, axis2=2)).sum(axis=1)

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """One draw of y per input, (n, Dy): a component from P(m|x), then its Gaussian (one
        component: no draw is spent on the choice)."""
        n, M, Dy = self.means.shape
        if M == 1:
            m = np.zeros(n, dtype=np.int64)
        else:
            cum = np.cumsum(self.posteriors, axis=1)
            m = np.minimum((rng.random((n, 1)) > cum).sum(axis=1), M - 1)
        eps = rng.standard_normal((n, Dy))
        return self.means[np.arange(n), m] + np.einsum("nij,nj->ni", self.chol[m], eps)


class GMMRegression:
    """Joint GMM over ``[x, y]`` with conditional prediction of ``y`` from ``x``.

    Parameters
    ----------
    n_components : int, default 1
    covariance_type : "full" or "diag" (for the joint fit; conditioning needs the full blocks)
    n_init : int, number of EM restarts (random initialisations)
    reg_covar : float, added to the diagonal (relative to each dimension's variance)
    max_iter : int, EM iterations per restart
    random_state : int or None

    Attributes
    ----------
    weights_ : (M,)
    means_ : (M, Dx + Dy)
    covariances_ : (M, Dx + Dy, Dx + Dy)
    dim_x_, dim_y_ : int
    """

    def __init__(self, n_components: int = 1, *, covariance_type: str = "full", n_init: int = 1,
                 reg_covar: float = 1e-4, max_iter: int = 100, random_state: int | None = None):
        self.n_components = n_components
        self.covariance_type = covariance_type
        self.n_init = n_init
        self.reg_covar = reg_covar
        self.max_iter = max_iter
        self.random_state = random_state

    # -- fitting ----------------------------------------------------------------------------
    def fit(self, X, Y) -> "GMMRegression":
        """Fit the joint GMM to ``X`` (n, Dx) and ``Y`` (n, Dy)."""
        if not isinstance(self.n_components, (int, np.integer)) or self.n_components < 1:
            raise ParameterError(f"n_components must be an int >= 1; got {self.n_components!r}")
        if self.covariance_type not in ("full", "diag"):
            raise ParameterError(f"covariance_type must be 'full' or 'diag'; got {self.covariance_type!r}")
        X = _check_2d("X", X)
        Y = _check_2d("Y", Y)
        if len(X) != len(Y):
            raise ParameterError(f"X and Y must have the same number of rows; got {len(X)} and {len(Y)}")
        Z = np.hstack([X, Y])
        n, D = Z.shape
        self.dim_x_, self.dim_y_ = X.shape[1], Y.shape[1]
        var = Z.var(axis=0) if n > 1 else np.ones(D)
        reg = self.reg_covar * np.maximum(var, 1e-12) + 1e-12
        M = int(self.n_components)
        if n < 2:
            raise ParameterError(f"GMM regression needs at least 2 training vectors; got {n}")
        if M == 1 or n < 2 * M * 2:
            # closed-form maximum likelihood of a single Gaussian (every random start converges here)
            mean = Z.mean(axis=0)
            cov = np.cov(Z, rowvar=False, bias=True).reshape(D, D)
            if self.covariance_type == "diag":
                cov = np.diag(np.diag(cov))
            cov = cov + np.diag(reg)
            self.weights_ = np.ones(1)
            self.means_ = mean[None]
            self.covariances_ = cov[None]
        else:
            from sklearn.mixture import GaussianMixture

            # scale-invariant regularisation: fit on standardised data, map back
            mu, sd = Z.mean(axis=0), np.sqrt(np.maximum(var, 1e-12))
            gm = GaussianMixture(M, covariance_type="full" if self.covariance_type == "full" else "diag",
                                 n_init=self.n_init, reg_covar=self.reg_covar, max_iter=self.max_iter,
                                 random_state=self.random_state)
            gm.fit((Z - mu) / sd)
            covs = gm.covariances_ if self.covariance_type == "full" else np.stack([np.diag(c) for c in gm.covariances_])
            self.weights_ = gm.weights_.copy()
            self.means_ = gm.means_ * sd + mu
            self.covariances_ = covs * np.outer(sd, sd)[None]
        self._prepare()
        self.n_train_ = n
        return self

    @classmethod
    def from_params(cls, weights, means, covariances, dim_x: int) -> "GMMRegression":
        obj = cls(n_components=len(weights))
        obj.weights_ = np.asarray(weights, dtype=np.float64)
        obj.means_ = np.asarray(means, dtype=np.float64)
        obj.covariances_ = np.asarray(covariances, dtype=np.float64)
        obj.dim_x_ = int(dim_x)
        obj.dim_y_ = obj.means_.shape[1] - obj.dim_x_
        obj._prepare()
        return obj

    def _prepare(self) -> None:
        dx = self.dim_x_
        M = len(self.weights_)
        self._log_w = np.log(np.maximum(self.weights_, 1e-300))
        self._mx = self.means_[:, :dx]
        self._my = self.means_[:, dx:]
        self._A = np.empty((M, self.dim_y_, dx))
        self._cov_c = np.empty((M, self.dim_y_, self.dim_y_))
        self._Px = np.empty((M, dx, dx))
        self._ldx = np.empty(M)
        self._chol_c = np.empty((M, self.dim_y_, self.dim_y_))
        self._Pz = np.empty_like(self.covariances_)
        self._ldz = np.empty(M)
        for m in range(M):
            S = self.covariances_[m]
            Sxx, Sxy, Syy = S[:dx, :dx], S[:dx, dx:], S[dx:, dx:]
            if dx:
                A = np.linalg.solve(Sxx, Sxy).T
                self._Px[m], self._ldx[m] = _prec_chol(Sxx)
            else:
                A = np.zeros((self.dim_y_, 0))
                self._ldx[m] = 0.0
            self._A[m] = A
            C = Syy - A @ Sxy
            C = 0.5 * (C + C.T) + 1e-12 * np.eye(len(C))
            self._cov_c[m] = C
            self._chol_c[m] = np.linalg.cholesky(C)
            self._Pz[m], self._ldz[m] = _prec_chol(S)

    def _check(self):
        if not hasattr(self, "weights_"):
            raise NotFittedError("GMMRegression is not fitted")

    # -- likelihoods -----------------------------------------------------------------------
    def _component_logpx(self, X: np.ndarray) -> np.ndarray:
        M = len(self.weights_)
        if self.dim_x_ == 0:
            return np.tile(self._log_w, (len(X), 1))
        out = np.empty((len(X), M))
        for m in range(M):
            out[:, m] = self._log_w[m] + _gauss_logpdf(X, self._mx[m], self._Px[m], self._ldx[m])
        return out

    def log_likelihood_x(self, X) -> np.ndarray:
        """log p(x) under the input marginal, (n,) — the class "observation probability"."""
        self._check()
        X = _check_2d("X", X, self.dim_x_)
        lp = self._component_logpx(X)
        mx = lp.max(axis=1, keepdims=True)
        return (mx + np.log(np.exp(lp - mx).sum(axis=1, keepdims=True)))[:, 0]

    def log_likelihood(self, X, Y) -> np.ndarray:
        """log p(x, y) under the joint GMM, (n,)."""
        self._check()
        Z = np.hstack([_check_2d("X", X, self.dim_x_), _check_2d("Y", Y, self.dim_y_)])
        lp = np.stack([self._log_w[m] + _gauss_logpdf(Z, self.means_[m], self._Pz[m], self._ldz[m])
                       for m in range(len(self.weights_))], axis=1)
        mx = lp.max(axis=1, keepdims=True)
        return (mx + np.log(np.exp(lp - mx).sum(axis=1, keepdims=True)))[:, 0]

    def posteriors(self, X) -> np.ndarray:
        """P(m | x), eq 2.5, (n, M)."""
        self._check()
        X = _check_2d("X", X, self.dim_x_)
        lp = self._component_logpx(X)
        lp -= lp.max(axis=1, keepdims=True)
        p = np.exp(lp)
        return p / p.sum(axis=1, keepdims=True)

    def conditional_means(self, X) -> np.ndarray:
        """mu_{y|x,m}, eq 2.7, (n, M, Dy)."""
        self._check()
        X = _check_2d("X", X, self.dim_x_)
        return self._my[None] + np.einsum("myx,nmx->nmy", self._A, X[:, None, :] - self._mx[None])

    def condition(self, X) -> "Conditional":
        """The conditional mixture ``p(y | x)`` for every row of ``X`` (eq 2.5–2.8): the public
        conditioning every caller uses (tws-basic / tws-hier through :meth:`predict`, tws-hier's
        single Gaussians and le2012's per-frame objective directly)."""
        self._check()
        X = _check_2d("X", X, self.dim_x_)
        return Conditional(log_joint=self._component_logpx(X), means=self.conditional_means(X),
                           covariances=self._cov_c.copy(), chol=self._chol_c.copy())

    def bic(self, X, Y) -> float:
        """Bayesian information criterion, eq 2.1 (lower is better)."""
        n = len(np.atleast_2d(X))
        D = self.dim_x_ + self.dim_y_
        M = len(self.weights_)
        k = (M - 1) + M * D + M * D * (D + 1) / 2
        return float(-2 * np.sum(self.log_likelihood(X, Y)) + k * np.log(n))

    # -- prediction ------------------------------------------------------------------------
    def predict(self, X, *, method: str = "mmse", rng: np.random.Generator | None = None,
                n_iter: int = 20) -> np.ndarray:
        """Estimate y for every row of ``X``: (n, Dy).

        Parameters
        ----------
        X : (n, Dx)
        method : "mmse" (eq 2.9), "ml" (mode of p(y|x)) or "sample"
        rng : numpy Generator, required for "sample"
        """
        self._check()
        X = _check_2d("X", X, self.dim_x_)
        post = self.posteriors(X)
        mu = self.conditional_means(X)
        if method == "mmse":
            return np.einsum("nm,nmy->ny", post, mu)
        if method == "sample":
            if rng is None:
                raise ParameterError("method='sample' needs rng")
            cum = np.cumsum(post, axis=1)
            u = rng.random((len(X), 1))
            m = np.minimum((u > cum).sum(axis=1), post.shape[1] - 1)
            eps = rng.standard_normal((len(X), self.dim_y_))
            return mu[np.arange(len(X)), m] + np.einsum("nij,nj->ni", self._chol_c[m], eps)
        if method == "ml":
            if len(self.weights_) == 1:
                return mu[:, 0]
            return self._modes(post, mu, n_iter)
        raise ParameterError(f"method must be 'mmse', 'ml' or 'sample'; got {method!r}")

    def _modes(self, post: np.ndarray, mu: np.ndarray, n_iter: int) -> np.ndarray:
        """Mode of each conditional mixture by mean-shift from every component mean."""
        n, M, Dy = mu.shape
        prec = np.linalg.inv(self._cov_c)  # (M, Dy, Dy)
        logdet = np.array([2 * np.sum(np.log(np.diag(c))) for c in self._chol_c])
        logw = np.log(np.maximum(post, 1e-300)) - 0.5 * logdet[None]  # (n, M)

        def logpdf(y):  # y (n, S, Dy) -> (n, S, M)
            diff = y[:, :, None, :] - mu[:, None, :, :]
            q = np.einsum("nsmi,mij,nsmj->nsm", diff, prec, diff)
            return logw[:, None, :] - 0.5 * q

        y = mu.copy()  # start at every component's conditional mean: (n, S=M, Dy)
        for _ in range(n_iter):
            lp = logpdf(y)
            lp -= lp.max(axis=2, keepdims=True)
            g = np.exp(lp)  # (n, S, M)
            Pm = np.einsum("nsm,mij->nsij", g, prec)
            b = np.einsum("nsm,mij,nmj->nsi", g, prec, mu)
            y = np.linalg.solve(Pm, b[..., None])[..., 0]
        lp = logpdf(y)
        tot = lp.max(axis=2) + np.log(np.exp(lp - lp.max(axis=2, keepdims=True)).sum(axis=2))
        best = np.argmax(tot, axis=1)
        return y[np.arange(n), best]

    # -- persistence ------------------------------------------------------------------------
    def to_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        self._check()
        return {f"{prefix}weights": self.weights_, f"{prefix}means": self.means_,
                f"{prefix}covariances": self.covariances_, f"{prefix}dim_x": np.array(self.dim_x_)}

    @classmethod
    def from_arrays(cls, arrays: dict, prefix: str) -> "GMMRegression":
        return cls.from_params(arrays[f"{prefix}weights"], arrays[f"{prefix}means"],
                               arrays[f"{prefix}covariances"], int(arrays[f"{prefix}dim_x"]))


def bic_curve(Z: np.ndarray, *, components=(1, 2, 3, 4, 5, 6), covariance_types=("full", "diag"),
              random_state: int = 0, n_init: int = 1, max_iter: int = 100) -> dict[str, list[float]]:
    """BIC of GMMs with different structures on the same data (thesis Fig 5.12).

    Returns ``{covariance_type: [bic for each number of components]}`` (NaN where a fit failed)."""
    from sklearn.mixture import GaussianMixture

    Z = _check_2d("Z", Z)
    Zs = (Z - Z.mean(0)) / np.maximum(Z.std(0), 1e-12)
    out: dict[str, list[float]] = {}
    for ct in covariance_types:
        vals = []
        for k in components:
            if len(Z) < 2 * k:
                vals.append(float("nan"))
                continue
            try:
                gm = GaussianMixture(k, covariance_type=ct, random_state=random_state, n_init=n_init,
                                     max_iter=max_iter, reg_covar=1e-4).fit(Zs)
                vals.append(float(gm.bic(Zs)))
            except ValueError:
                vals.append(float("nan"))
        out[ct] = vals
    return out


__all__ = ["GMMRegression", "Conditional", "bic_curve"]
