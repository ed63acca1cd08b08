"""Chance levels of CCA-type scores (paper §4.3.2 "chance score"; thesis §4.3.1 on spurious CCA).

A bare CCA figure misleads: CCA over few frames finds correlation in unrelated streams (thesis
§4.3.1, Lambert & Durand 1975), and on short clips local CCA over 3 s windows of *shifted* motion
is about 0.65.  Every CCA-type score is therefore reported with its null distribution: the same
score with the motion circularly shifted by ``n_shifts`` (≥ 200) random offsets, seeded.  A
circular shift keeps the motion's own spectrum, amplitude and distribution and only breaks its
synchrony with the other stream, which is exactly the hypothesis being tested.

The default null (``null="bridge"``, docs/decisions/coupling-test.md) differs from a plain
circular shift in two ways, each of which made uncoupled motion come out "tied to speech" too
often (per recording p < 0.05 in 11–12 % of uncoupled anchors on the talking-video corpus):

* it shifts the motion's *bridge* (:func:`bridge`: the motion minus the straight line from its
  first to its last frame), which closes on itself, so a shift puts no jump at the wrap point that
  the unshifted motion does not have; for a random walk the bridge's increments are exchangeable
  and all its cyclic shifts have one distribution (Vervaat 1979);
* it draws offsets from every offset 1 … T − 1 (the whole cyclic group), not from the middle of the
  circle only: a head's correlation time is not small against a 4 s clip, and an unshifted score
  compared only with far-away shifts is more extreme than they are.

The test statistic is then the bridge's score (``statistic``); the reported ``score`` stays the
plain score.  ``null="circular"`` is the former test (plain shifts, offsets from
``[min_shift, T − min_shift]``).

* :func:`shift_null` — generic: any ``score_fn(shifted_x) -> float``.
* :func:`global_cca_null`, :func:`local_cca_null`, :func:`fcca_null` — fast paths for the three
  CCA-type scores (covariances / projections computed once, only the shifted part recomputed).
* :class:`NullResult` — ``score, null_mean, null_p95, p_value, excess (= statistic − null_mean)``;
  ``p_value = (1 + #{null ≥ statistic}) / (n_shifts + 1)``; ``statistic`` is the score of the
  bridged motion (``null="bridge"``) or the score itself (``null="circular"``).
* :func:`paper_chance_score` — the paper's single chance score: local CCA between the ground truth
  and randomised motion of another speaker (a random circular offset into that speaker's
  concatenated motion, averaged over draws).

Libraries considered: no maintained library computes circular-shift nulls of CCA; the shifts are a
few lines on top of :mod:`headmotion.evaluation.measures.metrics`.
"""

from __future__ import annotations

from typing import Callable, NamedTuple, Sequence

import numpy as np

from ...errors import ParameterError
from . import metrics as M

DEFAULT_SHIFTS = 200
#: the nulls: shifts of the motion's bridge (default) or plain circular shifts
NULLS = ("bridge", "circular")


class NullResult(NamedTuple):
    """A score and its circular-shift null distribution."""

    score: float
    null_mean: float
    null_p95: float
    p_value: float
    excess: float
    n_shifts: int
    #: the score the null is compared with (the bridged motion's; the score itself for "circular")
    statistic: float = float("nan")

    def as_dict(self, prefix: str = "") -> dict[str, float]:
        return {f"{prefix}null_mean": self.null_mean, f"{prefix}null_p95": self.null_p95,
                f"{prefix}p": self.p_value, f"{prefix}excess": self.excess}


def _shifts(T: int, n_shifts: int, seed, min_shift: int | None, null: str = "circular") -> np.ndarray:
    """``n_shifts`` offsets: every offset 1 … T − 1 for the bridge null (the whole cyclic group, so the
    unshifted motion is exchangeable with its shifts), ``[min_shift, T − min_shift]`` otherwise."""
    if null == "bridge" and min_shift is None:
        min_shift = 1
    if n_shifts < 1:
        raise ParameterError(f"n_shifts must be at least 1; got {n_shifts}")
    if T < 3:
        raise ParameterError(f"chance levels need at least 3 frames; got {T}")
    m = max(1, T // 10) if min_shift is None else int(min_shift)
    m = min(max(m, 1), max(1, T // 2))
    rng = np.random.default_rng(seed)
    lo, hi = m, T - m  # inclusive range of offsets, symmetric around T/2
    if hi < lo:
        lo, hi = 1, T - 1
    return rng.integers(lo, hi + 1, size=n_shifts)


def bridge(a: np.ndarray) -> np.ndarray:
    """``a`` minus the straight line from its first to its last frame (per column): a motion that
    closes on itself, so a circular shift of it has no jump at the wrap point.

    Parameters
    ----------
    a : np.ndarray [shape=(T, D)]

    Returns
    -------
    np.ndarray [shape=(T, D)] — ``out[0] == out[-1] == a[0]``
    """
    a = np.asarray(a, dtype=float)
    if len(a) < 2:
        return a.copy()
    t = np.linspace(0.0, 1.0, len(a))[:, None]
    return a - t * (a[-1] - a[0])[None, :]


def _surrogate_base(a: np.ndarray, null: str) -> np.ndarray:
    """The array whose circular shifts form the null (and whose score is the statistic)."""
    if null == "bridge":
        return bridge(a)
    if null == "circular":
        return np.asarray(a, dtype=float)
    raise ParameterError(f"null must be one of {NULLS}; got {null!r}")


def _result(score: float, null: np.ndarray, statistic: float | None = None) -> NullResult:
    null = np.asarray(null, dtype=float)
    stat = float(score if statistic is None else statistic)
    p = (1.0 + np.sum(null >= stat - 1e-12)) / (len(null) + 1.0)
    mean = float(np.mean(null))
    return NullResult(float(score), mean, float(np.percentile(null, 95)), float(p), float(stat - mean), len(null),
                      stat)


@M.single_threaded
def shift_null(score_fn: Callable[[np.ndarray], float], x, *, n_shifts: int = DEFAULT_SHIFTS, seed=0,
               min_shift: int | None = None, null: str = "bridge") -> NullResult:
    """Null distribution of ``score_fn`` under circular shifts of ``x``.

    Parameters
    ----------
    score_fn : callable ``(T, D) array -> float``
    x : array (T, D) | Motion | FeatureTrack — the stream that is shifted
    n_shifts : int (default 200)
    seed : int | np.random.SeedSequence — the offsets are drawn from it
    min_shift : int, optional — smallest offset in frames (offsets lie in ``[min_shift, T − min_shift]``;
        default 1 for the bridge null — every offset, the whole cyclic group — and T // 10 for
        ``null="circular"``)
    null : "bridge" (default) | "circular" — shift the motion's bridge (:func:`bridge`) or the
        motion itself
    """
    a, _ = M.as_array(x)
    score = float(score_fn(a))
    b = _surrogate_base(a, null)
    stat = score if null == "circular" else float(score_fn(b))
    draws = [score_fn(np.roll(b, int(s), axis=0)) for s in _shifts(len(a), n_shifts, seed, min_shift, null)]
    return _result(score, np.array(draws), stat)


@M.single_threaded
def global_cca_null(x, y, *, n_shifts: int = DEFAULT_SHIFTS, seed=0, min_shift: int | None = None,
                    ridge: float = M.RIDGE, null: str = "bridge") -> NullResult:
    """Global CCA of ``x`` and ``y`` and its null with ``x`` (its bridge by default) circularly shifted."""
    a, b, _ = M._pair(x, y)
    score = M.cca(a, b, ridge=ridge)
    a = _surrogate_base(a, null)
    stat = score if null == "circular" else M.cca(a, b, ridge=ridge)
    shifts = _shifts(len(a), n_shifts, seed, min_shift, null)
    # whiten once: covariances are invariant under a circular shift, only Cxy changes
    ac = a - a.mean(0)
    bc = b - b.mean(0)
    n = len(a)
    wx = M._inv_sqrt(ac.T @ ac / (n - 1), np.max(np.abs(a)) ** 2, ridge)
    wy = M._inv_sqrt(bc.T @ bc / (n - 1), np.max(np.abs(b)) ** 2, ridge)
    aw, bw = ac @ wx, bc @ wy
    draws = np.empty(len(shifts))
    for i, s in enumerate(shifts):
        k = np.roll(aw, int(s), axis=0).T @ bw / (n - 1)
        draws[i] = min(1.0, np.linalg.svd(k, compute_uv=False)[0]) if k.size else 0.0
    return _result(score, draws, stat)


@M.single_threaded
def local_cca_null(x, y, *, window: int = M.DEFAULT_WINDOW, window_s: float | None = None, hop: int | None = None,
                   fps: float | None = None, n_shifts: int = DEFAULT_SHIFTS, seed=0, min_shift: int | None = None,
                   ridge: float = M.RIDGE, chunk: int = 16, null: str = "bridge") -> NullResult:
    """Local CCA of ``x`` and ``y`` (see :func:`~headmotion.evaluation.measures.metrics.local_cca`) and its
    null with ``x`` (its bridge by default) circularly shifted (windows batched, ``chunk`` shifts at
    a time)."""
    a, b, f = M._pair(x, y)
    w = M._window_frames(window, fps if fps is not None else f, window_s)
    h = w if hop is None else int(hop)
    score = M.local_cca(a, b, window=w, hop=h, ridge=ridge)
    a = _surrogate_base(a, null)
    stat = score if null == "circular" else M.local_cca(a, b, window=w, hop=h, ridge=ridge)
    shifts = _shifts(len(a), n_shifts, seed, min_shift if min_shift is not None or null == "bridge" else min(w, len(a) // 4),
                     null)
    bw = M.windows(b, w, h)
    yw = M._whiten(bw, ridge=ridge)  # the unshifted stream is whitened once for all shifts
    draws = []
    for i in range(0, len(shifts), chunk):
        xa = np.stack([M.windows(np.roll(a, int(s), axis=0), w, h) for s in shifts[i:i + chunk]])
        draws.extend(M._cca_batch(xa, bw, ridge=ridge, Yw=yw)[..., 0].mean(axis=1))
    return _result(score, np.array(draws), stat)


@M.single_threaded
def fcca_null(motion_orig, features, motion_synth, *, window: int | None = None, window_s: float | None = None,
              fps: float | None = None, n_shifts: int = DEFAULT_SHIFTS, seed=0, min_shift: int | None = None,
              ridge: float = M.RIDGE, null: str = "bridge") -> NullResult:
    """Forced CCA (thesis eq 4.5) and its null with the synthesised motion (its bridge by default,
    :func:`bridge`) circularly shifted.

    The CCA weights are fitted once on (original motion, features); only the projection of the
    shifted synthesised motion changes."""
    X, Y, f = M._pair(motion_orig, features, ("motion_orig", "features"))
    Xs, _, _ = M._pair(motion_synth, X, ("motion_synth", "motion_orig"))
    n = min(len(X), len(Xs))
    X, Y, Xs = X[:n], Y[:n], Xs[:n]
    score = M.fcca(X, Y, Xs, window=window, window_s=window_s, fps=fps, ridge=ridge)
    if window is None and window_s is None:
        w = n
    else:
        w = M._window_frames(window if window is not None else M.DEFAULT_WINDOW, fps if fps is not None else f,
                             window_s)
    wX, wY = M.windows(X, w, w), M.windows(Y, w, w)
    _, A, B, _, _ = M._cca_batch(wX, wY, ridge=ridge, weights=True)
    v = (wY @ B[..., :, :1])[..., 0]  # (nw, w)

    def forced(xs_full: np.ndarray) -> float:
        u = (M.windows(xs_full, w, w) @ A[..., :, :1])[..., 0]
        return float(np.mean(M._abs_corr(u, v)))

    Xs = _surrogate_base(Xs, null)
    stat = score if null == "circular" else forced(Xs)
    shifts = _shifts(n, n_shifts, seed, min_shift if min_shift is not None or null == "bridge" else min(w, n // 4), null)
    draws = np.array([forced(np.roll(Xs, int(s), axis=0)) for s in shifts])
    return _result(score, draws, stat)


@M.single_threaded
def paper_chance_score(ground_truth, other_motions: Sequence, *, window: int = M.DEFAULT_WINDOW,
                       n_draws: int = 20, seed=0) -> float:
    """The paper's chance score (§4.3.2): local CCA between the ground truth and randomised motion
    of another speaker.

    ``other_motions`` (arrays (T, 3) or Motion, from a speaker other than the ground truth's) are
    concatenated; each draw takes a random circular offset into that sequence, tiles it to the
    ground truth's length and scores local CCA with ``window`` frames; the mean over ``n_draws``
    draws is returned (the paper reports one number per subject, ≈ 0.28–0.29).
    """
    gt, _ = M.as_array(ground_truth, name="ground_truth")
    if not other_motions:
        raise ParameterError("paper_chance_score needs motion from at least one other speaker")
    other = np.vstack([M.as_array(m, name="other motion")[0] for m in other_motions])
    T = len(gt)
    rng = np.random.default_rng(seed)
    reps = int(np.ceil(T / len(other))) + 1
    tiled = np.tile(other, (reps, 1))
    scores = []
    for _ in range(n_draws):
        off = int(rng.integers(0, len(other)))
        scores.append(M.local_cca(gt, tiled[off:off + T], window=window))
    return float(np.mean(scores))


__all__ = ["NullResult", "NULLS", "bridge", "shift_null", "global_cca_null", "local_cca_null", "fcca_null", "paper_chance_score",
           "DEFAULT_SHIFTS"]
