"""Compiled per-frame gradient ascent of the Le et al. (2012) baseline (thesis eq 2.21, eq 5.15).

The causal optimiser visits every frame and takes ``n_steps`` gradient steps on a few 3–5 dim
quantities; in numpy each step costs ~10 small-array calls, so the Python overhead dominated
synthesis (17× real time, the slowest row of the benchmarks).  These numba kernels do the same
arithmetic in compiled loops.  numba is already a dependency of librosa; kernels are cached on disk
after the first compilation.  :mod:`headmotion.systems.le2012` documents the algorithm; the tests
check these kernels against the plain-numpy reference (:mod:`._le2012_reference`).

Every frame's ascent starts from ``2 p1 - p2 - pull (p1 - pose) + jitter[t]`` (``p1``, ``p2`` the
two previous frames): ``pull = 0`` and ``jitter = 0`` is Le et al.'s constant-velocity start; the
leaky pull towards the training mean pose and the seeded jitter are ours (see le2012.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _clip(x, lo, hi):
    return min(max(x, lo), hi)


@njit(cache=True)
def _motion_terms(theta, p1, p2, mu, sd, z, gv, ga):
    v2 = 0.0
    a2 = 0.0
    for k in range(3):
        du = theta[k] - p1[k]
        dd = theta[k] - 2.0 * p1[k] + p2[k]
        gv[k] = du
        ga[k] = dd
        v2 += du * du
        a2 += dd * dd
    v = np.sqrt(v2)
    a = np.sqrt(a2)
    for k in range(3):
        gv[k] = gv[k] / v if v > 1e-12 else 0.0
        ga[k] = ga[k] / a if a > 1e-12 else 0.0
        z[k] = (theta[k] - mu[k]) / sd[k]
    z[3] = (v - mu[3]) / sd[3]
    z[4] = (a - mu[4]) / sd[4]


@njit(cache=True)
def _ascent_update(theta, g, gv, ga, sd, lo, hi, step):
    """One clipped gradient step on the angles from the gradient ``g`` over (angles, v, a)."""
    for k in range(3):
        grad = g[k] / sd[k] + g[3] / sd[3] * gv[k] + g[4] / sd[4] * ga[k]
        dz = _clip(step * grad * sd[k], -step, step)
        theta[k] = _clip(theta[k] + dz * sd[k], lo[k], hi[k])


@njit(cache=True)
def _ascend(out, LW, CM, PR, joint, mu, sd, lo, hi, step, n_steps, pull, pose, jitter):
    """Fill ``out[2:]`` frame by frame: from the frame's start (module docstring), ``n_steps``
    clipped steps along the gradient of the frame's conditional mixtures — five univariate ones
    (eq 2.21; ``PR`` their precisions (5, M), ``joint`` None) or one joint one (eq 5.15; ``PR``
    None, ``joint`` its precision matrices (M, 5, 5) and work arrays).  numba prunes the branch of
    the argument that is None before typing, so each kernel compiles only its own gradient."""
    z = np.empty(5)
    gv = np.empty(3)
    ga = np.empty(3)
    g = np.empty(5)
    theta = np.empty(3)
    if joint is not None:
        P, d, pd, lp = joint
    for t in range(2, out.shape[0]):
        for k in range(3):
            theta[k] = 2.0 * out[t - 1, k] - out[t - 2, k] - pull * (out[t - 1, k] - pose[k]) + jitter[t, k]
        for _ in range(n_steps):
            _motion_terms(theta, out[t - 1], out[t - 2], mu, sd, z, gv, ga)
            if PR is not None:
                M = LW.shape[2]
                for i in range(5):
                    best = -1e300
                    for m in range(M):
                        dz = z[i] - CM[t, i, m]
                        lpm = LW[t, i, m] - 0.5 * dz * dz * PR[i, m]
                        if lpm > best:
                            best = lpm
                    num = 0.0
                    den = 0.0
                    for m in range(M):
                        dz = z[i] - CM[t, i, m]
                        r = np.exp(LW[t, i, m] - 0.5 * dz * dz * PR[i, m] - best)
                        num += r * dz * PR[i, m]
                        den += r
                    g[i] = -num / den
            if joint is not None:
                M = LW.shape[1]
                best = -1e300
                for m in range(M):
                    for i in range(5):
                        d[i] = z[i] - CM[t, m, i]
                    q = 0.0
                    for i in range(5):
                        s = 0.0
                        for j in range(5):
                            s += P[m, i, j] * d[j]
                        pd[m, i] = s
                        q += d[i] * s
                    lp[m] = LW[t, m] - 0.5 * q
                    if lp[m] > best:
                        best = lp[m]
                den = 0.0
                for i in range(5):
                    g[i] = 0.0
                for m in range(M):
                    r = np.exp(lp[m] - best)
                    den += r
                    for i in range(5):
                        g[i] -= r * pd[m, i]
                for i in range(5):
                    g[i] /= den
            _ascent_update(theta, g, gv, ga, sd, lo, hi, step)
        for k in range(3):
            out[t, k] = theta[k]


@njit(cache=True)
def ascent_independent(out, LW, CM, PR, mu, sd, lo, hi, step, n_steps, pull, pose, jitter):
    """Five univariate conditional mixtures (eq 2.21). ``out`` (T, 3) holds frames 0 and 1."""
    _ascend(out, LW, CM, PR, None, mu, sd, lo, hi, step, n_steps, pull, pose, jitter)


@njit(cache=True)
def ascent_joint(out, LW, CM, P, mu, sd, lo, hi, step, n_steps, pull, pose, jitter):
    """One joint conditional mixture over (angles, v, a) (eq 5.15)."""
    M = LW.shape[1]
    work = (P, np.empty(5), np.empty((M, 5)), np.empty(M))
    _ascend(out, LW, CM, None, work, mu, sd, lo, hi, step, n_steps, pull, pose, jitter)


@njit(cache=True)
def conditionals(X, c0, mx, Px, A, my, const, LW, CM, row0):
    """Condition G stacked GMMs on the feature rows ``X (T, dx)`` (eq 2.5–2.8; what
    :meth:`headmotion.systems.le2012.Le2012._conditionals` computes with einsum, with the same
    products summed in the same order): for frame t, GMM g, component m, ``d = x_t − mx[g, m]``,
    ``LW[row0 + t, g, m] = c0[g, m] − 0.5 (const + |d Px[g, m]|²)`` and ``CM[row0 + t, g, m] =
    my[g, m] + A[g, m] d``.  ``Px`` is the Cholesky factor of the component's feature precision,
    ``A`` its regression matrix (both computed once per model)."""
    T, dx = X.shape
    G, M = c0.shape
    dz = my.shape[2]
    d = np.empty(dx)
    for t in range(T):
        for g in range(G):
            for m in range(M):
                for i in range(dx):
                    d[i] = X[t, i] - mx[g, m, i]
                q = 0.0
                for j in range(dx):
                    y = 0.0
                    for i in range(dx):
                        y += d[i] * Px[g, m, i, j]
                    q += y * y
                LW[row0 + t, g, m] = c0[g, m] - 0.5 * (const + q)
                for k in range(dz):
                    s = 0.0
                    for i in range(dx):
                        s += A[g, m, k, i] * d[i]
                    CM[row0 + t, g, m, k] = my[g, m, k] + s
