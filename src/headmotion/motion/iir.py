"""Recursive (IIR) filters with state — what the post stages need of ``scipy.signal`` without
importing it (``import scipy.signal`` pulls in scipy.stats, scipy.optimize and scipy.interpolate:
~0.4 s and ~40 MB, more than the rest of ``headmotion synth``).

* :func:`lfilter` — ``scipy.signal.lfilter(b, a, x, axis=0, zi=zi)`` for the short filters used
  here (first- and second-order), with the same arithmetic in the same order (transposed direct
  form II, as scipy's C loop: ``y = z₀ + b₀x``, ``zₖ = zₖ₊₁ + x·bₖ₊₁ − y·aₖ₊₁``), so the result is
  bit for bit scipy's (``tests/test_iir.py``) and chunked calls with the returned state give what
  one call gives.  The recursion runs per channel in plain Python floats (IEEE doubles, the same
  rounding): ~0.1–0.2 µs per sample and channel, a few ms for a minute of motion at 100 fps.
* :func:`butter_lowpass` — ``scipy.signal.butter(order, cutoff, fs=fs)``: Butterworth analogue
  prototype, frequency pre-warping, bilinear transform, the same steps as scipy.
"""

from __future__ import annotations

import math

import numpy as np


def _run(x: list[float], b: list[float], a: list[float], z: list[float]) -> tuple[list[float], list[float]]:
    """One channel of transposed direct form II (``a[0] == 1``; ``len(b) == len(a)``)."""
    n = len(a) - 1
    b0 = b[0]
    out = [0.0] * len(x)
    if n == 1:
        b1, a1 = b[1], a[1]
        z0 = z[0]
        for i, xn in enumerate(x):
            y = z0 + b0 * xn
            z0 = xn * b1 - y * a1
            out[i] = y
        return out, [z0]
    if n == 2:
        b1, b2, a1, a2 = b[1], b[2], a[1], a[2]
        z0, z1 = z
        for i, xn in enumerate(x):
            y = z0 + b0 * xn
            z0 = z1 + xn * b1 - y * a1
            z1 = xn * b2 - y * a2
            out[i] = y
        return out, [z0, z1]
    z = list(z)
    for i, xn in enumerate(x):
        y = z[0] + b0 * xn
        for k in range(n - 1):
            z[k] = z[k + 1] + xn * b[k + 1] - y * a[k + 1]
        z[n - 1] = xn * b[n] - y * a[n]
        out[i] = y
    return out, z


def lfilter(b, a, x, *, zi=None):
    """Filter ``x`` (``(T,)`` or ``(T, D)``, along axis 0) by ``b / a``.

    Parameters
    ----------
    b, a : sequences of float — numerator and denominator (``a[0] != 0``; normalised by it)
    x : array_like [shape=(T,) or (T, D)]
    zi : array_like [shape=(max(len(a), len(b)) - 1, D)], optional — initial state (scipy's
        convention); None starts from rest and returns only the output.

    Returns
    -------
    y : np.ndarray [shape of x, float64]; with ``zi`` given, also the final state ``zf``
    (``zi``'s shape).
    """
    a = [float(v) for v in np.atleast_1d(a)]
    b = [float(v) for v in np.atleast_1d(b)]
    if not a or a[0] == 0.0:
        raise ValueError("a[0] must be non-zero")
    m = max(len(a), len(b))
    a, b = a + [0.0] * (m - len(a)), b + [0.0] * (m - len(b))
    if a[0] != 1.0:
        a0 = a[0]
        a, b = [v / a0 for v in a], [v / a0 for v in b]
    xa = np.asarray(x, dtype=np.float64)
    one = xa.ndim == 1
    x2 = xa[:, None] if one else xa
    T, D = x2.shape
    n = m - 1
    z = np.zeros((n, D)) if zi is None else np.asarray(zi, dtype=np.float64).reshape(n, D)
    if n == 0:
        y = x2 * b[0]
        return (y[:, 0] if one else y) if zi is None else ((y[:, 0] if one else y), z.copy())
    y = np.empty((T, D))
    zf = np.empty((n, D))
    for d in range(D):
        col, zf[:, d] = _run(x2[:, d].tolist(), b, a, z[:, d].tolist())
        y[:, d] = col
    y = y[:, 0] if one else y
    if zi is None:
        return y
    return y, zf.reshape(np.shape(zi))


def butter_lowpass(order: int, cutoff: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """``(b, a)`` of a digital Butterworth low-pass of ``order`` at ``cutoff`` Hz for sampling
    rate ``fs`` (``scipy.signal.butter(order, cutoff, fs=fs)``)."""
    order, fs = int(order), float(fs)
    wn = 2.0 * float(cutoff) / fs
    if not 0.0 < wn < 1.0:
        raise ValueError(f"cutoff must be between 0 and fs/2 = {fs / 2:g} Hz; got {cutoff}")
    m = np.arange(-order + 1, order, 2)
    p = -np.exp(1j * math.pi * m / (2 * order))                       # analogue prototype poles
    warped = 2 * 2.0 * math.tan(math.pi * wn / 2.0)                    # pre-warped, digital fs = 2
    p = warped * p
    k = 1.0 * warped ** order
    fs2 = 2.0 * 2.0
    pz = (fs2 + p) / (fs2 - p)                                         # bilinear transform
    zz = -np.ones(order)
    kz = k * np.real(np.prod(fs2 - np.array([], dtype=complex)) / np.prod(fs2 - p))
    b = kz * np.poly(zz)
    a = np.poly(pz)
    return np.real(b).astype(np.float64), np.real(a).astype(np.float64)


__all__ = ["lfilter", "butter_lowpass"]
