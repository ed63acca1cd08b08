"""YIN fundamental-period estimation (de Cheveigné & Kawahara 2002) on fixed windows, row by row,
for the incremental F0 features of :mod:`headmotion.features.streaming`: every operation is per
row, so one frame at a time and a whole file at once give identical values."""

from __future__ import annotations

import numpy as np


def yin_frames(X: np.ndarray, win: int, tau_min: int, tau_max: int, threshold: float):
    """YIN on each row of ``X (n, win + tau_max)``.

    Every operation is per row (a ``np.correlate`` per row, cumulative sums and elementwise
    arithmetic along rows), so a row's result does not depend on the other rows: one frame at a
    time and a whole file at once give identical values.

    Returns ``period (n,)`` in samples (0 for a silent window) and the aperiodicity ``d'(τ*) (n,)``
    (1 for a silent window).
    """
    X = np.asarray(X, dtype=np.float64)
    n = X.shape[0]
    if n == 0:
        return np.zeros(0), np.ones(0)
    if n == 1:                                                                          # Σ_j x_j x_{j+τ}
        r = np.correlate(X[0], X[0, :win], mode="valid")[None, : tau_max + 1]
    else:
        r = np.stack([np.correlate(x, x[:win], mode="valid")[: tau_max + 1] for x in X])
    c = np.zeros((n, X.shape[1] + 1))
    np.cumsum(X * X, axis=1, out=c[:, 1:])
    e = c[:, win:win + tau_max + 1] - c[:, :tau_max + 1]                              # Σ_j x²_{j+τ}
    d = np.maximum(e[:, :1] + e - 2.0 * r, 0.0)
    d[:, 0] = 0.0
    cs = np.cumsum(d[:, 1:], axis=1)
    silent = cs[:, -1] <= 0.0
    dn = np.ones((n, tau_max + 1))
    dn[:, 1:] = d[:, 1:] * np.arange(1, tau_max + 1) / np.maximum(cs, 1e-30)
    seg = dn[:, tau_min:tau_max + 1]
    L = seg.shape[1]
    below = seg < threshold
    has = below.any(axis=1)
    i = np.where(has, np.argmax(below, axis=1), np.argmin(seg, axis=1))
    rows = np.arange(n)
    # walk down to the bottom of the first dip: the first j >= i where seg stops falling
    stop = (seg[:, 1:] >= seg[:, :-1]) & (np.arange(L - 1)[None, :] >= i[:, None])
    bottom = np.where(stop.any(axis=1), np.argmax(stop, axis=1), L - 1)
    i = np.where(has, bottom, i)
    tau = i + tau_min
    ap = dn[rows, tau]
    inner = (tau > tau_min) & (tau < tau_max)
    tc = np.minimum(np.maximum(tau, 1), tau_max - 1)
    a, b, cc = dn[rows, tc - 1], dn[rows, tc], dn[rows, tc + 1]
    den = a - 2.0 * b + cc
    pos = den > 0
    shift = np.where(pos, 0.5 * (a - cc) / np.where(pos, den, 1.0), 0.0)
    period = tau + np.where(inner, np.minimum(np.maximum(shift, -1.0), 1.0), 0.0)
    return np.where(silent, 0.0, period), np.where(silent, 1.0, ap)


def yin_frame(x: np.ndarray, win: int, tau_min: int, tau_max: int, threshold: float):
    """:func:`yin_frames` of one window: ``(period in samples, aperiodicity)``."""
    p, a = yin_frames(np.asarray(x, dtype=np.float64)[None, :], win, tau_min, tau_max, threshold)
    return float(p[0]), float(a[0])


def yin_row(x: np.ndarray, win: int, tau_min: int, tau_max: int, threshold: float,
            lags: np.ndarray | None = None) -> tuple[float, float]:
    """:func:`yin_frames` of one window ``x (win + tau_max,)`` with the same operations in the same
    order (so the same bits), for the stream's one-frame pushes: ~15 numpy calls on 1-D arrays and
    the dip search in Python instead of ~35 calls on 2-D ones.  ``lags`` is ``arange(1, tau_max +
    1)`` as floats (precomputed by the caller).  Returns ``(period in samples, aperiodicity)``."""
    x = np.asarray(x, dtype=np.float64)
    r = np.correlate(x, x[:win], mode="valid")[: tau_max + 1]
    c = np.zeros(len(x) + 1)
    np.cumsum(x * x, out=c[1:])
    e = c[win:win + tau_max + 1] - c[:tau_max + 1]
    d = np.maximum(e[0] + e - 2.0 * r, 0.0)
    cs = np.cumsum(d[1:])
    if cs[-1] <= 0.0:
        return 0.0, 1.0
    dn = np.empty(tau_max + 1)
    dn[0] = 1.0
    if lags is None:
        lags = np.arange(1, tau_max + 1, dtype=np.float64)
    np.divide(d[1:] * lags, np.maximum(cs, 1e-30), out=dn[1:])
    seg = dn[tau_min:]
    L = len(seg)
    below = seg < threshold
    i = int(np.argmax(below))
    if below[i]:
        # down to the bottom of the first dip: the first j >= i where seg stops falling
        rest = seg[i + 1:] >= seg[i:L - 1]
        j = int(np.argmax(rest)) if rest.size else 0
        i = i + j if rest.size and rest[j] else L - 1
    else:
        i = int(np.argmin(seg))
    tau = i + tau_min
    ap = float(dn[tau])
    if not tau_min < tau < tau_max:
        return float(tau), ap
    a, b, cc = float(dn[tau - 1]), float(dn[tau]), float(dn[tau + 1])
    den = a - 2.0 * b + cc
    shift = 0.5 * (a - cc) / den if den > 0 else 0.0
    return tau + min(max(shift, -1.0), 1.0), ap


__all__ = ["yin_frames", "yin_frame", "yin_row"]
