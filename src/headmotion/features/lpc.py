"""LPC-derived features: line spectral pairs (LSP) and log area ratios (LAR) (thesis §5.7.1, §2.2.4).

Per frame (25 ms Hamming window centred on the frame, pre-emphasis 0.97, signal at 16 kHz by
default) an all-pole model ``A(z) = 1 + a_1 z^-1 + … + a_p z^-p`` is fitted, by default with the
autocorrelation method (a vectorised Levinson–Durbin recursion here: guaranteed stable, ~100×
faster over thousands of frames), or with Burg's method through **librosa.lpc**
(``method="burg"``, what we first used; too slow for the ≥ 200× real-time budget), then converted:

* :func:`lpc_to_lsf` — line spectral frequencies: the angles in (0, π) of the roots of
  ``P(z) = A(z) + z^-(p+1) A(1/z)`` and ``Q(z) = A(z) − z^-(p+1) A(1/z)``; for a stable ``A`` they
  lie on the unit circle and interleave.  Roots are found for all frames at once as eigenvalues of
  stacked companion matrices.
* :func:`lpc_to_reflection` — reflection (PARCOR) coefficients by the step-down (backward
  Levinson) recursion; :func:`reflection_to_lar` — ``LAR_i = log((1 + k_i) / (1 − k_i))``
  ``= 2 artanh(k_i)`` (the sign convention of ``A(z)`` above, where ``k_m`` is the last coefficient
  of the order-``m`` polynomial).

These conversions are written by hand: no maintained Python library offers them (librosa stops at
the LPC polynomial; SPTK's ``lpc2lsp``/``lpc2par`` are C command-line tools; ``spectrum`` and
``audiolazy`` are unmaintained; scipy has none).  The order defaults to 16 at 16 kHz; the thesis
does not state its order.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..types import Audio
from .frames import frame_signal, pre_emphasis


def levinson(r: np.ndarray, order: int):
    """Levinson–Durbin recursion for many frames at once.

    Parameters
    ----------
    r : np.ndarray [shape=(T, ≥ order + 1)], autocorrelation lags 0..order
    order : int

    Returns
    -------
    a : np.ndarray [shape=(T, order + 1)], ``a[:, 0] == 1``
    k : np.ndarray [shape=(T, order)], reflection coefficients (``k_m = a_m^(m)``)
    """
    r = np.asarray(r, dtype=np.float64)
    T = r.shape[0]
    a = np.zeros((T, order + 1))
    a[:, 0] = 1.0
    k = np.zeros((T, order))
    err = r[:, 0].copy()
    for i in range(1, order + 1):
        acc = r[:, i] + np.einsum("tj,tj->t", a[:, 1:i], r[:, i - 1:0:-1])
        ki = np.clip(-acc / err, -1 + 1e-9, 1 - 1e-9)
        a[:, 1:i] = a[:, 1:i] + ki[:, None] * a[:, i - 1:0:-1]
        a[:, i] = ki
        k[:, i - 1] = ki
        err = err * (1.0 - ki ** 2)
    return a, k


def lpc_frames(audio: Audio, *, fps: float, n_frames: int, order: int = 16, window_s: float = 0.025,
               pre_emph: float = 0.97, method: str = "autocorrelation", return_reflection: bool = False):
    """LPC polynomials per frame, ``(T, order + 1)`` with ``a_0 = 1``.

    Parameters
    ----------
    method : {"autocorrelation", "burg"}
        ``"autocorrelation"`` (default): the autocorrelation method with a vectorised
        Levinson–Durbin recursion — always a stable filter (what LSPs need) and ~100× faster than
        ``"burg"``, which calls ``librosa.lpc`` (Burg's method).
    return_reflection : bool
        Also return the reflection coefficients ``(T, order)``.
    """
    if order < 1:
        raise ParameterError(f"LPC order must be at least 1; got {order}")
    if method not in ("autocorrelation", "burg"):
        raise ParameterError(f"LPC method must be 'autocorrelation' or 'burg'; got {method!r}")
    win = max(order + 2, int(round(window_s * audio.sample_rate)))
    x = pre_emphasis(audio.samples, pre_emph).astype(np.float64)
    frames = frame_signal(x, sample_rate=audio.sample_rate, fps=fps, n_frames=n_frames, win_length=win)
    if n_frames == 0:
        a = np.zeros((0, order + 1))
        return (a, np.zeros((0, order))) if return_reflection else a
    frames = frames * np.hamming(win)[None, :]
    if method == "burg":
        from ..numba_cache import first_use, import_librosa

        librosa = import_librosa()  # its compiled functions first used under a machine-wide lock
        # a deterministic -100 dB dither keeps silent (all-zero) frames well conditioned
        frames = frames + 1e-5 * np.random.default_rng(0).standard_normal(frames.shape)
        with first_use("librosa.lpc"):
            a = np.asarray(librosa.lpc(frames, order=order, axis=-1), dtype=np.float64)
        return (a, lpc_to_reflection(a)) if return_reflection else a
    # direct lags 0..order: cheaper than an FFT for order << window
    r = np.stack([np.einsum("tw,tw->t", frames[:, : win - lag], frames[:, lag:])
                  for lag in range(order + 1)], axis=1)
    r[:, 0] = r[:, 0] * (1.0 + 1e-9) + 1e-10  # white-noise floor: silent frames stay defined
    a, k = levinson(r, order)
    return (a, k) if return_reflection else a


def _roots_batched(c: np.ndarray) -> np.ndarray:
    """Roots of polynomials ``c[:, 0] x^n + … + c[:, n]`` (rows), ``(T, n+1) -> (T, n)`` complex."""
    T, n1 = c.shape
    n = n1 - 1
    comp = np.zeros((T, n, n))
    comp[:, 0, :] = -c[:, 1:] / c[:, :1]
    if n > 1:
        comp[:, np.arange(1, n), np.arange(n - 1)] = 1.0
    return np.linalg.eigvals(comp)


def _lsf_eig(P: np.ndarray, Q: np.ndarray, p: int) -> np.ndarray:
    out = []
    for poly, n_up in ((P, (p + 1) // 2), (Q, p // 2)):
        if n_up == 0:
            continue
        r = _roots_batched(poly)
        # the n_up roots in the upper half plane (largest imaginary part; excludes z = ±1)
        idx = np.argsort(-r.imag, axis=1)[:, :n_up]
        out.append(np.abs(np.angle(np.take_along_axis(r, idx, axis=1))))
    return np.sort(np.hstack(out), axis=1)


def _lsf_grid(poly: np.ndarray, n_roots: int, symmetric: bool, grid: int = 512):
    """Zeros in (0, π) of the real zero-phase form of a (anti)symmetric polynomial.

    ``e^{jω(p+1)/2} P(e^{jω}) = Σ_k P_k cos((p+1)/2 − k) ω`` (symmetric) or ``j Σ_k Q_k sin(…)``
    (antisymmetric): sign changes on a grid, linear interpolation, two Newton steps.
    Returns ``(roots (T, n_roots), ok (T,))``; rows with another number of sign changes are not ok.
    """
    T, m = poly.shape
    half = (m - 1) / 2.0
    mult = half - np.arange(m)
    w = np.linspace(0.0, np.pi, grid + 1)[1:-1]
    basis = np.cos(np.outer(mult, w)) if symmetric else np.sin(np.outer(mult, w))
    f = poly @ basis
    s = np.signbit(f)
    change = s[:, :-1] != s[:, 1:]
    ok = change.sum(axis=1) == n_roots
    roots = np.zeros((T, n_roots))
    if not ok.any() or n_roots == 0:
        return roots, ok
    good = np.flatnonzero(ok)
    rows, cols = np.nonzero(change[good])
    rows_full = good[rows]
    f0, f1 = f[rows_full, cols], f[rows_full, cols + 1]
    w0, w1 = w[cols], w[cols + 1]
    est = (w0 - f0 * (w1 - w0) / (f1 - f0)).reshape(-1, n_roots)
    pk = poly[good][:, None, :]
    pkm = pk * mult
    for _ in range(2):
        arg = est[:, :, None] * mult[None, None, :]
        c, s_ = np.cos(arg), np.sin(arg)
        if symmetric:
            val = np.einsum("tnk,tnk->tn", np.broadcast_to(pk, arg.shape), c)
            der = -np.einsum("tnk,tnk->tn", np.broadcast_to(pkm, arg.shape), s_)
        else:
            val = np.einsum("tnk,tnk->tn", np.broadcast_to(pk, arg.shape), s_)
            der = np.einsum("tnk,tnk->tn", np.broadcast_to(pkm, arg.shape), c)
        step = np.where(np.abs(der) > 1e-12, val / np.where(der == 0, 1, der), 0.0)
        est = np.clip(est - np.clip(step, -(w[1] - w[0]), w[1] - w[0]), 0.0, np.pi)
    roots[ok] = est
    return roots, ok


def lpc_to_lsf(a: np.ndarray) -> np.ndarray:
    """Line spectral frequencies of LPC polynomials.

    Parameters
    ----------
    a : np.ndarray [shape=(T, p+1) or (p+1,)], ``a[..., 0] == 1``

    Returns
    -------
    np.ndarray [shape=(T, p) or (p,)], radians in (0, π), ascending; for a stable ``A(z)`` the
    frequencies alternate between roots of ``P`` and roots of ``Q`` (``P`` first).

    Roots are located on a 512-point grid of the zero-phase forms of ``P`` and ``Q`` and polished
    by Newton steps (vectorised over frames); frames where two roots share a grid cell fall back
    to the eigenvalues of companion matrices.
    """
    a = np.asarray(a, dtype=np.float64)
    single = a.ndim == 1
    a = np.atleast_2d(a)
    if a.shape[1] < 2:
        raise ParameterError(f"LPC polynomial needs at least 2 coefficients; got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a[:, 0] == 0):
        raise ParameterError("LPC polynomials must be finite with a nonzero leading coefficient")
    a = a / a[:, :1]
    p = a.shape[1] - 1
    ext = np.hstack([a, np.zeros((len(a), 1))])
    rev = np.hstack([np.zeros((len(a), 1)), a[:, ::-1]])
    P, Q = ext + rev, ext - rev
    rp, okp = _lsf_grid(P, (p + 1) // 2, True)
    rq, okq = _lsf_grid(Q, p // 2, False)
    lsf = np.sort(np.hstack([rp, rq]), axis=1)
    bad = ~(okp & okq)
    if bad.any():
        lsf[bad] = _lsf_eig(P[bad], Q[bad], p)
    return lsf[0] if single else lsf


def lsf_to_lpc(lsf: np.ndarray) -> np.ndarray:
    """Inverse of :func:`lpc_to_lsf` for even order: ``(T, p) -> (T, p+1)``."""
    w = np.atleast_2d(np.asarray(lsf, dtype=np.float64))
    p = w.shape[1]
    if p % 2:
        raise ParameterError(f"lsf_to_lpc supports even orders only; got p={p}")
    out = np.empty((len(w), p + 1))
    for i, row in enumerate(w):
        pw, qw = row[0::2], row[1::2]
        P = np.array([1.0, 1.0])  # (1 + z^-1)
        Q = np.array([1.0, -1.0])  # (1 - z^-1)
        for f in pw:
            P = np.convolve(P, [1.0, -2.0 * np.cos(f), 1.0])
        for f in qw:
            Q = np.convolve(Q, [1.0, -2.0 * np.cos(f), 1.0])
        out[i] = (0.5 * (P + Q))[: p + 1]
    return out[0] if np.asarray(lsf).ndim == 1 else out


def lpc_to_reflection(a: np.ndarray) -> np.ndarray:
    """Reflection coefficients by the step-down recursion, ``(T, p+1) -> (T, p)``.

    ``k_m = a_m^(m)``; ``a_i^(m-1) = (a_i^(m) − k_m a_{m−i}^(m)) / (1 − k_m²)``.  |k| < 1 for a
    stable filter; values are clipped to ±(1 − 1e-9) so that a marginal frame stays finite.
    """
    a = np.asarray(a, dtype=np.float64)
    single = a.ndim == 1
    cur = np.atleast_2d(a / np.atleast_2d(a)[:, :1]).copy()
    p = cur.shape[1] - 1
    k = np.zeros((len(cur), p))
    for m in range(p, 0, -1):
        km = np.clip(cur[:, m], -1 + 1e-9, 1 - 1e-9)
        k[:, m - 1] = km
        if m > 1:
            inner = cur[:, 1:m]
            flipped = cur[:, m - 1:0:-1]
            cur[:, 1:m] = (inner - km[:, None] * flipped) / (1.0 - km[:, None] ** 2)
    return k[0] if single else k


def reflection_to_lar(k: np.ndarray) -> np.ndarray:
    """Log area ratios ``log((1 + k) / (1 − k))``, same shape as ``k``."""
    k = np.clip(np.asarray(k, dtype=np.float64), -1 + 1e-9, 1 - 1e-9)
    return np.log((1.0 + k) / (1.0 - k))


def lsp(audio: Audio, *, fps: float, n_frames: int, order: int = 16, window_s: float = 0.025,
        pre_emph: float = 0.97, method: str = "autocorrelation"):
    """Line spectral frequencies, ``(T, order)`` in radians; names ``lsp01..``."""
    a = lpc_frames(audio, fps=fps, n_frames=n_frames, order=order, window_s=window_s,
                   pre_emph=pre_emph, method=method)
    vals = lpc_to_lsf(a) if len(a) else np.zeros((0, order))
    return vals, [f"lsp{i:02d}" for i in range(1, order + 1)]


def lar(audio: Audio, *, fps: float, n_frames: int, order: int = 16, window_s: float = 0.025,
        pre_emph: float = 0.97, method: str = "autocorrelation"):
    """Log area ratios, ``(T, order)``; names ``lar01..``."""
    _, k = lpc_frames(audio, fps=fps, n_frames=n_frames, order=order, window_s=window_s,
                      pre_emph=pre_emph, method=method, return_reflection=True)
    return reflection_to_lar(k), [f"lar{i:02d}" for i in range(1, order + 1)]


__all__ = ["levinson", "lpc_frames", "lpc_to_lsf", "lsf_to_lpc", "lpc_to_reflection", "reflection_to_lar",
           "lsp", "lar"]
