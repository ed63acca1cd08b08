"""Objective metrics for head motion — ONE implementation of each (thesis §4.3, Table 3.4; paper §4.3).

Every function accepts time-first numpy arrays ``(T, D)`` (a 1-D array is one column) or the
package's :class:`~headmotion.types.Motion` (its ``rotvec``) and
:class:`~headmotion.types.FeatureTrack` (its ``values``).  Two inputs must cover the same frames:
lengths that differ by at most one frame plus 50 ms (one frame when no rate is known) are trimmed
to the shorter, larger differences raise :class:`~headmotion.errors.LengthMismatchError`.

Metrics
-------
* :func:`nmse` — paper §4.3: mean-squared error normalised by the ground-truth variance, per axis
  and mean.  Predicting the ground truth gives 0, predicting its mean gives exactly 1.
* :func:`cca` / :func:`global_cca` — thesis §4.3.1 eq 4.1–4.4: canonical correlations of two
  streams, in closed form: with covariances ``Cxx, Cyy, Cxy`` the canonical correlations are the
  singular values of the whitened cross-covariance ``Cxx^-1/2 Cxy Cyy^-1/2`` and the canonical
  weights are ``A = Cxx^-1/2 U``, ``B = Cyy^-1/2 V`` (the SVD method Matlab's ``canoncorr`` uses).
  A tiny ridge (``1e-10`` × the mean variance) is added to each covariance before whitening, and
  directions with numerically zero variance (a constant column, a still head) are dropped, so a
  constant stream has correlation 0 instead of an arbitrary number.
* :func:`local_cca` — thesis §4.3.1 ρ_l, paper §4.3: the mean first canonical correlation over
  windows (300 frames = 3 s in the paper).  Windows are non-overlapping by default; a tail shorter
  than the window is dropped; a sequence shorter than one window is scored as one window.
* :func:`fcca` — thesis §4.3.2 eq 4.5–4.6, Forced CCA: fit CCA between the original motion ``X``
  and the speech features ``Y`` of a recording, then ``ρ_f = |cor(a'X*, b'Y)|`` with the first pair
  of weights ``a, b`` reused on the synthesised motion ``X*``.  ``fcca(X, Y, X) == cca(X, Y)``.
* :func:`sd_stats` — paper Fig 2: SD of each rotation axis and of its first derivative (velocity,
  in rad/s when the frame rate is known, else per frame).
* :func:`jerk_accel` — GENEA-challenge style mean magnitude of the acceleration and the jerk of the
  rotation vector (finite differences scaled by the frame rate: rad/s², rad/s³).
* :func:`distribution_stats` — thesis Table 3.4: skew, kurtosis and the Kolmogorov–Smirnov
  statistic of rotation, Δ and ΔΔ per axis.
* :func:`deltas` — the Δ / ΔΔ used by these statistics and by the corpus statistics.

Libraries considered: ``sklearn.cross_decomposition.CCA`` is an iterative NIPALS PLS variant
(slow, approximate, no batched form) and gives slightly different correlations on short windows;
we need exact values for thousands of short windows and shifted copies (chance levels), so CCA is
written here in closed form with batched ``numpy.linalg.eigh``/``svd``.  Skew, kurtosis and KS use
:mod:`scipy.stats`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...errors import LengthMismatchError, ParameterError
from ...types import FeatureTrack, Motion

#: ridge added to covariances before whitening, relative to the mean variance
RIDGE = 1e-10
#: a direction whose variance is below this fraction of the data's squared magnitude is constant
_CONST_TOL = 1e-13

DEFAULT_WINDOW = 300  # frames (paper §4.3: 300 frames = 3 s at 100 fps)


# -- BLAS threads ----------------------------------------------------------------------------------
_CONTROLLER = None


def single_threaded(fn):
    """Run ``fn`` with one BLAS thread.

    The metrics work on many small matrices (3 × 3 to 100 × 100); multi-threaded OpenBLAS gains
    nothing there and, on a busy machine, its spinning threads made batched ``eigh`` 50× slower
    (measured: 4 s instead of 0.08 s).  Uses threadpoolctl (a scikit-learn dependency)."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        global _CONTROLLER
        if _CONTROLLER is None:
            try:
                from threadpoolctl import ThreadpoolController

                _CONTROLLER = ThreadpoolController()
            except ImportError:  # pragma: no cover
                _CONTROLLER = False
        if not _CONTROLLER:
            return fn(*args, **kwargs)
        with _CONTROLLER.limit(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return wrapper


# -- input handling --------------------------------------------------------------------------------
def as_array(x, *, name: str = "input") -> tuple[np.ndarray, float | None]:
    """``(values (T, D) float64, fps or None)`` from an array, Motion or FeatureTrack."""
    fps = None
    if isinstance(x, Motion):
        a, fps = x.rotvec, float(x.fps)
    elif isinstance(x, FeatureTrack):
        a, fps = x.values, float(x.fps)
    else:
        a = x
    try:
        a = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an array (T, D), a Motion or a FeatureTrack; got {type(x).__name__}") from None
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ParameterError(f"{name} must have shape (T, D); given shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{name} contains NaN or inf")
    return a, fps


def _pair(x, y, names=("x", "y")) -> tuple[np.ndarray, np.ndarray, float | None]:
    a, fa = as_array(x, name=names[0])
    b, fb = as_array(y, name=names[1])
    if fa is not None and fb is not None and abs(fa - fb) > 1e-6:
        raise ParameterError(f"{names[0]} is at {fa:g} fps but {names[1]} at {fb:g} fps; resample one first")
    fps = fa if fa is not None else fb
    if len(a) != len(b):
        tol = 1 + (0.05 * fps if fps else 0)
        if abs(len(a) - len(b)) > tol:
            raise LengthMismatchError(
                f"{names[0]} has {len(a)} frames but {names[1]} has {len(b)}; expected equal lengths "
                f"(within {tol:g} frames)")
        n = min(len(a), len(b))
        a, b = a[:n], b[:n]
    return a, b, fps


def deltas(x, *, order: int = 1) -> np.ndarray:
    """Time derivative per frame (``numpy.gradient``: central differences, same length).

    Parameters
    ----------
    x : array (T, D) | Motion | FeatureTrack
    order : int, 1 (Δ) or 2 (ΔΔ)

    Returns
    -------
    np.ndarray [shape=(T, D)] — per-frame units (multiply by fps**order for per-second units).
    """
    a, _ = as_array(x)
    if order not in (1, 2):
        raise ParameterError(f"order must be 1 or 2; got {order!r}")
    if len(a) < 2:
        return np.zeros_like(a)
    d = np.gradient(a, axis=0)
    if order == 2:
        d = np.gradient(d, axis=0)
    return d


# -- NMSE ----------------------------------------------------------------------------------------
class NMSE(NamedTuple):
    """NMSE per axis ``(D,)`` and their mean (NaN for an axis whose ground truth is constant)."""

    per_axis: np.ndarray
    mean: float


def nmse(ref, pred) -> NMSE:
    """Normalised mean-squared error (paper §4.3): ``mean((pred - ref)²) / var(ref)`` per axis.

    Parameters
    ----------
    ref : array (T, D) | Motion — ground truth
    pred : array (T, D) | Motion — prediction

    Returns
    -------
    NMSE(per_axis (D,), mean) — 0 for a perfect prediction, 1 for predicting the mean of ``ref``.
    An axis with zero ground-truth variance gives NaN and is left out of the mean.
    """
    r, p, _ = _pair(ref, pred, ("ref", "pred"))
    if r.shape[1] != p.shape[1]:
        raise ParameterError(f"ref has {r.shape[1]} columns but pred has {p.shape[1]}")
    if len(r) == 0:
        raise ParameterError("nmse needs at least one frame")
    var = r.var(axis=0)
    mse = np.mean((p - r) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        per = np.where(var > 0, mse / np.where(var > 0, var, 1.0), np.nan)
    mean = float(np.nanmean(per)) if np.any(np.isfinite(per)) else float("nan")
    return NMSE(per, mean)


# -- CCA -----------------------------------------------------------------------------------------
def _inv_sqrt(c: np.ndarray, mag2: np.ndarray, ridge: float) -> np.ndarray:
    """Batched symmetric inverse square root with ridge; constant directions map to zero."""
    w, v = np.linalg.eigh(c)
    d = c.shape[-1]
    scale = np.trace(c, axis1=-2, axis2=-1) / d
    thr = np.maximum(_CONST_TOL * mag2, 1e-300)[..., None]
    keep = w > thr
    inv = np.where(keep, 1.0 / np.sqrt(np.maximum(w, 0) + ridge * scale[..., None] + 1e-300), 0.0)
    return (v * inv[..., None, :]) @ np.swapaxes(v, -1, -2)


def _whiten(X: np.ndarray, *, ridge: float = RIDGE):
    """Centred and whitened windows: ``(Xc @ W, W, mean)`` for stacked ``X (..., n, d)``, with
    ``W = Cxx^-1/2`` (ridge, constant directions dropped)."""
    n = X.shape[-2]
    mx = X.mean(axis=-2, keepdims=True)
    Xc = X - mx
    cxx = np.swapaxes(Xc, -1, -2) @ Xc / max(n - 1, 1)
    w = _inv_sqrt(cxx, np.max(np.abs(X), axis=(-2, -1)) ** 2, ridge)
    return Xc @ w, w, mx[..., 0, :]


def _cca_batch(X: np.ndarray, Y: np.ndarray, *, ridge: float = RIDGE, weights: bool = False, Yw=None):
    """CCA of stacked windows ``X (..., n, dx)``, ``Y (..., n, dy)``.

    Returns correlations ``(..., k)`` with ``k = min(dx, dy)``, and with ``weights`` also
    ``A (..., dx, k)``, ``B (..., dy, k)``, ``mean_x (..., dx)``, ``mean_y (..., dy)``.
    ``Yw`` may pass a precomputed :func:`_whiten` of ``Y`` (reused across shifted ``X``)."""
    n = X.shape[-2]
    xw, wx, mx = _whiten(X, ridge=ridge)
    yw, wy, my = _whiten(Y, ridge=ridge) if Yw is None else Yw
    k_mat = np.swapaxes(xw, -1, -2) @ yw / max(n - 1, 1)
    k = min(X.shape[-1], Y.shape[-1])
    if not weights:
        s = np.linalg.svd(k_mat, compute_uv=False)[..., :k]
        return np.clip(s, 0.0, 1.0)
    u, s, vt = np.linalg.svd(k_mat, full_matrices=False)
    a = wx @ u[..., :, :k]
    b = wy @ np.swapaxes(vt, -1, -2)[..., :, :k]
    return np.clip(s[..., :k], 0.0, 1.0), a, b, mx, my


class CCAFit(NamedTuple):
    """A fitted CCA: ``correlations (k,)``, weights ``x_weights (Dx, k)``, ``y_weights (Dy, k)``
    and the means removed before projecting (``U = (X - x_mean) @ x_weights``)."""

    correlations: np.ndarray
    x_weights: np.ndarray
    y_weights: np.ndarray
    x_mean: np.ndarray
    y_mean: np.ndarray

    def transform(self, x=None, y=None):
        """Canonical variables of new data: ``U (T, k)`` and/or ``V (T, k)``."""
        out = []
        if x is not None:
            a, _ = as_array(x)
            out.append((a - self.x_mean) @ self.x_weights)
        if y is not None:
            b, _ = as_array(y)
            out.append((b - self.y_mean) @ self.y_weights)
        return out[0] if len(out) == 1 else tuple(out)


def _check_cca_input(a, b):
    if min(len(a), len(b)) < 3:
        raise ParameterError(f"CCA needs at least 3 frames; got {len(a)} and {len(b)}")


@single_threaded
def cca_fit(x, y, *, ridge: float = RIDGE) -> CCAFit:
    """Fit CCA between ``x (T, Dx)`` and ``y (T, Dy)`` (thesis eq 4.1–4.4); see :class:`CCAFit`."""
    a, b, _ = _pair(x, y)
    _check_cca_input(a, b)
    s, wa, wb, ma, mb = _cca_batch(a, b, ridge=ridge, weights=True)
    return CCAFit(s, wa, wb, ma, mb)


@single_threaded
def cca(x, y, *, all_components: bool = False, ridge: float = RIDGE):
    """Canonical correlation of two streams over their whole length (global CCA, ρ_g).

    Parameters
    ----------
    x : array (T, Dx) | Motion | FeatureTrack
    y : array (T, Dy) | Motion | FeatureTrack
    all_components : bool
        Return all ``min(Dx, Dy)`` canonical correlations (descending) instead of the first.
    ridge : float
        Relative ridge added to the covariances (default 1e-10).

    Returns
    -------
    float in [0, 1], or np.ndarray [shape=(min(Dx, Dy),)] with ``all_components``.

    Notes
    -----
    With T frames and independent streams the first canonical correlation is biased upwards:
    roughly ``sqrt(Dx·Dy / T)`` for small ``Dx·Dy/T`` (e.g. ≈ 0.1 for 3 × 3 dims over 1000 frames).
    """
    a, b, _ = _pair(x, y)
    _check_cca_input(a, b)
    s = _cca_batch(a, b, ridge=ridge)
    return s.copy() if all_components else float(s[0])


global_cca = cca


def _window_frames(window, fps, window_s):
    if window_s is not None:
        if fps is None:
            raise ParameterError("window_s needs a frame rate: pass fps= or a Motion/FeatureTrack")
        w = int(round(float(window_s) * fps))
    else:
        w = int(window)
    if w < 3:
        raise ParameterError(f"window must be at least 3 frames; got {w}")
    return w


def windows(a: np.ndarray, window: int, hop: int) -> np.ndarray:
    """``(n_windows, window, D)`` views of ``a (T, D)``; a short tail is dropped; T < window gives
    the whole sequence as a single window."""
    if len(a) <= window:
        return a[None]
    v = np.lib.stride_tricks.sliding_window_view(a, window, axis=0)[::hop]  # (n, D, window)
    return np.swapaxes(v, -1, -2)


@single_threaded
def local_cca(x, y, *, window: int = DEFAULT_WINDOW, window_s: float | None = None, hop: int | None = None,
              fps: float | None = None, return_windows: bool = False, ridge: float = RIDGE):
    """Local CCA ρ_l: mean first canonical correlation over windows (thesis §4.3.1; paper §4.3).

    Parameters
    ----------
    x, y : array (T, D) | Motion | FeatureTrack
    window : int
        Window length in frames (default 300, the paper's 3 s at 100 fps).
    window_s : float, optional
        Window length in seconds instead (needs ``fps`` or an input that carries its rate).
    hop : int, optional
        Hop in frames; default = the window (non-overlapping windows).
    fps : float, optional
        Frame rate for ``window_s`` when the inputs are bare arrays.
    return_windows : bool
        Return the per-window correlations ``(n_windows,)`` instead of their mean.

    Returns
    -------
    float (mean over windows) or np.ndarray [shape=(n_windows,)].
    """
    a, b, f = _pair(x, y)
    _check_cca_input(a, b)
    w = _window_frames(window, fps if fps is not None else f, window_s)
    h = w if hop is None else int(hop)
    if h < 1:
        raise ParameterError(f"hop must be at least 1 frame; got {hop!r}")
    s = _cca_batch(windows(a, w, h), windows(b, w, h), ridge=ridge)[:, 0]
    return s.copy() if return_windows else float(np.mean(s))


@single_threaded
def fcca(motion_orig, features, motion_synth, *, window: int | None = None, window_s: float | None = None,
         fps: float | None = None, ridge: float = RIDGE) -> float:
    """Forced CCA ρ_f (thesis §4.3.2, eq 4.5–4.6).

    ``a, b = argmax cor(a'X, b'Y)`` is fitted between the original motion ``X`` and the speech
    features ``Y``; the score is ``|cor(a'X*, b'Y)|`` for the synthesised motion ``X*``.

    Parameters
    ----------
    motion_orig : array (T, Dm) | Motion — X, the recorded motion of the recording
    features : array (T, Df) | FeatureTrack — Y, its speech features
    motion_synth : array (T, Dm) | Motion — X*, the motion to score
    window, window_s : optional
        When given, the score is computed per window (CCA fitted per window) and averaged —
        a local FCCA; by default the whole recording is one window, as in the thesis.

    Returns
    -------
    float in [0, 1]; ``fcca(X, Y, X) == cca(X, Y)``; 0 when ``X*`` is constant.
    """
    X, Y, f = _pair(motion_orig, features, ("motion_orig", "features"))
    Xs, _, _ = _pair(motion_synth, X, ("motion_synth", "motion_orig"))
    n = min(len(X), len(Xs))
    X, Y, Xs = X[:n], Y[:n], Xs[:n]
    if Xs.shape[1] != X.shape[1]:
        raise ParameterError(f"motion_synth has {Xs.shape[1]} columns but motion_orig has {X.shape[1]}")
    _check_cca_input(X, Y)
    if window is None and window_s is None:
        wX, wY, wXs = X[None], Y[None], Xs[None]
    else:
        w = _window_frames(window if window is not None else DEFAULT_WINDOW, fps if fps is not None else f, window_s)
        wX, wY, wXs = windows(X, w, w), windows(Y, w, w), windows(Xs, w, w)
    return float(np.mean(_forced_batch(wX, wY, wXs, ridge=ridge)))


def _forced_batch(X, Y, Xs, *, ridge: float = RIDGE) -> np.ndarray:
    """|cor(a'X*, b'Y)| per stacked window ``(B, n, D)`` → ``(B,)``."""
    _, a, b, _, _ = _cca_batch(X, Y, ridge=ridge, weights=True)
    u = (Xs @ a[..., :, :1])[..., 0]
    v = (Y @ b[..., :, :1])[..., 0]
    return _abs_corr(u, v)


def _abs_corr(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    u = u - u.mean(axis=-1, keepdims=True)
    v = v - v.mean(axis=-1, keepdims=True)
    su = np.sqrt(np.sum(u * u, axis=-1))
    sv = np.sqrt(np.sum(v * v, axis=-1))
    num = np.abs(np.sum(u * v, axis=-1))
    den = su * sv
    # a projection with (numerically) no variance carries no correlation
    mag_u = np.max(np.abs(u), axis=-1) * np.sqrt(u.shape[-1])
    ok = (su > 1e-9 * np.maximum(mag_u, 1e-300)) & (sv > 0)
    return np.where(ok, num / np.where(ok, den, 1.0), 0.0).clip(0.0, 1.0)


# -- amplitude and smoothness -----------------------------------------------------------------------
class SDStats(NamedTuple):
    """``sd (D,)`` of each axis and ``sd_velocity (D,)`` of its first difference (× fps when known:
    rad/s), as in paper Fig 2."""

    sd: np.ndarray
    sd_velocity: np.ndarray


def sd_stats(motion, *, fps: float | None = None) -> SDStats:
    """SD of each rotation axis and of its first derivative (paper Fig 2).

    Parameters
    ----------
    motion : array (T, D) | Motion
    fps : float, optional — frame rate (taken from a Motion); the velocity is ``diff × fps``.
    """
    a, f = as_array(motion, name="motion")
    f = fps if fps is not None else f
    sd = a.std(axis=0)
    vel = np.diff(a, axis=0) * (f if f else 1.0)
    return SDStats(sd, vel.std(axis=0) if len(vel) else np.zeros(a.shape[1]))


def jerk_accel(motion, *, fps: float | None = None) -> tuple[float, float]:
    """Mean magnitude of the jerk and of the acceleration (GENEA-challenge style).

    The n-th finite difference of the rotation vector, times ``fps**n``, has its Euclidean norm
    taken over the axes per frame and averaged over frames.

    Parameters
    ----------
    motion : array (T, D) | Motion
    fps : float, required when ``motion`` is a bare array.

    Returns
    -------
    (jerk rad/s³, acceleration rad/s²)
    """
    a, f = as_array(motion, name="motion")
    f = fps if fps is not None else f
    if f is None:
        raise ParameterError("jerk_accel needs the frame rate: pass fps= or a Motion")
    if len(a) < 4:
        raise ParameterError(f"jerk_accel needs at least 4 frames; got {len(a)}")
    acc = np.diff(a, n=2, axis=0) * f ** 2
    jerk = np.diff(a, n=3, axis=0) * f ** 3
    return float(np.mean(np.linalg.norm(jerk, axis=1))), float(np.mean(np.linalg.norm(acc, axis=1)))


# -- distributions (thesis Table 3.4) -----------------------------------------------------------------
@single_threaded
def distribution_stats(motion, *, axis_names=("rx", "ry", "rz")) -> dict[str, dict[str, float]]:
    """Skew, kurtosis and Kolmogorov–Smirnov statistics of rotation, Δ and ΔΔ (thesis Table 3.4).

    Parameters
    ----------
    motion : array (T, 3) | Motion, or a list of them (pooled, Δ taken within each)

    Returns
    -------
    ``{column: {"skew", "kurtosis", "ks", "ks_std_normal"}}`` for the columns
    ``rx ry rz Δrx Δry Δrz ΔΔrx ΔΔry ΔΔrz``.  ``kurtosis`` is Pearson's (3 for a normal, as in
    the thesis' table); ``ks`` is the KS statistic against a normal fitted to the data (mean, SD);
    ``ks_std_normal`` against N(0, 1) — what the thesis' values (≈ 0.4–0.5 for data of a few
    hundredths of a radian) evidently used.
    """
    from scipy import stats

    items = motion if isinstance(motion, (list, tuple)) else [motion]
    cols = []
    for m in items:
        a, _ = as_array(m, name="motion")
        cols.append(np.hstack([a, deltas(a, order=1), deltas(a, order=2)]))
    data = np.vstack(cols)
    d = data.shape[1] // 3
    names = list(axis_names[:d]) if len(axis_names) >= d else [f"x{i}" for i in range(d)]
    names = names + [f"Δ{n}" for n in names] + [f"ΔΔ{n}" for n in names]
    out: dict[str, dict[str, float]] = {}
    for j, n in enumerate(names):
        c = data[:, j]
        sd = c.std()
        if sd > 0:
            ks = stats.kstest(c, "norm", args=(c.mean(), sd)).statistic
            sk = stats.skew(c)
            ku = stats.kurtosis(c, fisher=False)
        else:
            ks, sk, ku = float("nan"), float("nan"), float("nan")
        out[n] = {"skew": float(sk), "kurtosis": float(ku), "ks": float(ks),
                  "ks_std_normal": float(stats.kstest(c, "norm").statistic)}
    return out


__all__ = [
    "NMSE", "CCAFit", "SDStats", "as_array", "deltas", "nmse", "cca", "cca_fit", "global_cca", "local_cca",
    "fcca", "sd_stats", "jerk_accel", "distribution_stats", "windows", "RIDGE", "DEFAULT_WINDOW",
]
