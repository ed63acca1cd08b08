"""Plain-numpy per-frame gradient ascent of the Le et al. (2012) baseline (thesis eq 2.21, eq 5.15).

The reference the compiled kernels (:mod:`._le2012_kernel`) are tested against, and what
``Le2012(compiled=False)`` runs; :mod:`.le2012` documents the algorithm.
"""

from __future__ import annotations

import numpy as np


def mix_grad(z, logw, cm, P):
    """d/dz log sum_m exp(logw_m) N(z; cm_m, P_m^-1) for z (Dz,)."""
    d = z[None, :] - cm  # (M, Dz)
    pd = np.einsum("mij,mj->mi", P, d)
    lp = logw - 0.5 * np.sum(d * pd, axis=1)
    r = np.exp(lp - lp.max())
    return -(r[:, None] * pd).sum(axis=0) / r.sum()


def ascent_reference(out, cond, mu, sd, lo, hi, *, joint: bool, n_steps: int, step: float, pull=0.0, pose=None,
                     jitter=None) -> None:
    """Fill ``out[2:]`` frame by frame given ``out[0:2]``: ``n_steps`` gradient steps of at most
    ``step`` standard deviations on the conditional mixtures ``cond`` (joint, or the five
    univariate ones), each frame started from the constant-velocity guess, pulled towards
    ``pose`` by ``pull`` and moved by ``jitter[t]``, clipped to ``[lo, hi]``."""
    T = len(out)
    if not joint:
        # stack the five univariate conditional mixtures: (T, 5, M), (5, M)
        keys = ["angle0", "angle1", "angle2", "vel", "acc"]
        LW = np.stack([cond[k][0] for k in keys], axis=1)
        CM = np.stack([cond[k][1][..., 0] for k in keys], axis=1)
        PR = np.stack([cond[k][2][:, 0, 0] for k in keys], axis=0)
    for t in range(2, T):
        p1, p2 = out[t - 1], out[t - 2]
        theta = p1 + (p1 - p2)
        if pull:
            theta = theta - pull * (p1 - pose)
        if jitter is not None:
            theta = theta + jitter[t]
        for _ in range(n_steps):
            du, dd = theta - p1, theta - 2 * p1 + p2
            v, a = np.sqrt(du @ du), np.sqrt(dd @ dd)
            gv = du / v if v > 1e-12 else np.zeros(3)
            ga = dd / a if a > 1e-12 else np.zeros(3)
            z = np.r_[(theta - mu[:3]) / sd[:3], (v - mu[3]) / sd[3], (a - mu[4]) / sd[4]]
            if joint:
                g = mix_grad(z, cond["joint"][0][t], cond["joint"][1][t], cond["joint"][2])
            else:
                d = z[:, None] - CM[t]  # (5, M)
                lp = LW[t] - 0.5 * d * d * PR
                r = np.exp(lp - lp.max(axis=1, keepdims=True))
                g = -(r * d * PR).sum(axis=1) / r.sum(axis=1)
            grad = g[:3] / sd[:3] + g[3] / sd[3] * gv + g[4] / sd[4] * ga
            # gradient ascent in standardised units, at most `step` SDs per coordinate and step
            dz = np.clip(step * grad * sd[:3], -step, step)
            theta = np.minimum(np.maximum(theta + dz * sd[:3], lo), hi)
        out[t] = theta


__all__ = ["ascent_reference", "mix_grad"]
