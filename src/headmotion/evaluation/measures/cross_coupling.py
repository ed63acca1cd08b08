"""Cross-speaker coupling: is a motion tied to its speech the way *other* speakers' heads are?

The seed's Forced CCA (:func:`.metrics.fcca`) fits its projections on the recorded head of the
*same* recording it scores, so the recorded head's own excess includes the fit and is no level a
model can be asked to reach.  Here the projections are fitted once, on the training folds'
recorded heads and speech, and applied unchanged to a held-out recording's recorded or generated
motion:

* speech: the recording's speech features (``f0e``) at 25 fps with ±``context`` frames of context
  (the columns of frames t − 6 … t + 6 side by side, edges repeated);
* motion: the head angles (degrees) and their absolute angular speeds (°/s, central differences);
* both centred per recording (a speaker's pitch level or resting pose is no coupling), then CCA
  with a ridge (:class:`CrossSpeakerCCA`);
* the statistic of one recording: the correlation, over that recording, of the first canonical
  variates (motion projection against speech projection; signed — a motion moving against the
  training speakers' direction scores below zero);
* its null: the same statistic with the motion's bridge circularly shifted by offsets from every
  offset 1 … T − 1 (:func:`.chance.shift_null`, ``null="bridge"``, the test calibrated for FCCA);
* pooled over recordings: the mean excess and Stouffer's combination of the per-recording mid-p
  values (:func:`pooled`, as the evaluation pools FCCA).

    >>> model = CrossSpeakerCCA().fit(train_motions, train_features, fps=25.0)
    >>> r = model.test(held_out_motion, held_out_features, fps=25.0, n_shifts=100, seed=0)
    >>> r.score, r.excess, r.p_value

Calibration on uncoupled anchors: docs/decisions/cross-speaker-coupling.md
(``scripts/coupling_calibration.py``).

Libraries considered: scikit-learn's ``CCA`` (iterative PLS-style, no ridge, no fixed-projection
scoring of another stream; the closed form is a few lines over an eigendecomposition).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ...errors import NotFittedError, ParameterError
from ...types import FeatureTrack, Motion
from . import chance as C

#: analysis rate (Hz), speech context (frames each side), relative ridge of the covariances
FPS = 25.0
CONTEXT = 6
RIDGE = 1e-2


def _values(x, fps: float | None, what: str) -> tuple[np.ndarray, float]:
    if isinstance(x, Motion):
        return np.asarray(x.rotvec, dtype=float), float(x.fps)
    if isinstance(x, FeatureTrack):
        return np.asarray(x.values, dtype=float), float(x.fps)
    if fps is None:
        raise ParameterError(f"{what} given as an array needs fps")
    a = np.asarray(x, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ParameterError(f"{what} must be (T, D); got shape {a.shape}")
    return a, float(fps)


def resample(x: np.ndarray, fps: float, target: float = FPS) -> np.ndarray:
    """``x (T, D)`` at ``fps`` linearly resampled to ``target`` Hz (unchanged when equal)."""
    x = np.asarray(x, dtype=float)
    if abs(fps - target) < 1e-9 or len(x) < 2:
        return x
    t_src = np.arange(len(x)) / fps
    t_dst = np.arange(int(np.floor(t_src[-1] * target + 1e-9)) + 1) / target
    return np.stack([np.interp(t_dst, t_src, x[:, j]) for j in range(x.shape[1])], axis=1)


def speech_context(features: np.ndarray, context: int = CONTEXT) -> np.ndarray:
    """Features with ±``context`` frames of context: ``(T, D) -> (T, (2·context + 1)·D)``, the block
    of offset k (−context … context) holding frame ``t + k`` (edges repeated)."""
    f = np.asarray(features, dtype=float)
    T = len(f)
    idx = np.clip(np.arange(T)[:, None] + np.arange(-context, context + 1)[None, :], 0, max(T - 1, 0))
    return f[idx].reshape(T, -1)


def motion_descriptors(rotvec: np.ndarray, fps: float) -> np.ndarray:
    """``(T, 3)`` rotation vectors (radians) → ``(T, 6)``: angles (degrees) and absolute angular
    speeds per axis (°/s, central differences)."""
    a = np.degrees(np.asarray(rotvec, dtype=float))
    if len(a) < 2:
        return np.hstack([a, np.zeros_like(a)])
    return np.hstack([a, np.abs(np.gradient(a, axis=0)) * fps])


def _inv_sqrt(c: np.ndarray, ridge: float) -> np.ndarray:
    d = c.shape[0]
    c = c + ridge * max(np.trace(c) / d, 1e-12) * np.eye(d)
    w, v = np.linalg.eigh(c)
    return (v / np.sqrt(np.maximum(w, 1e-300))) @ v.T


def _corr(u: np.ndarray, v: np.ndarray) -> float:
    u = u - u.mean()
    v = v - v.mean()
    den = np.sqrt(np.sum(u * u) * np.sum(v * v))
    return float(np.sum(u * v) / den) if den > 1e-300 else 0.0


class CrossSpeakerCCA:
    """Speech ↔ motion CCA fitted on some recordings, scored on others (module docstring).

    Parameters
    ----------
    context : int — speech frames of context on each side at 25 fps (6: ±240 ms)
    ridge : float — added to each covariance's diagonal, relative to its mean variance
    fps : float — the analysis rate; motion and features are resampled to it

    Attributes
    ----------
    speech_weights_ : np.ndarray [shape=((2·context + 1)·D,)] — first canonical direction of speech
    motion_weights_ : np.ndarray [shape=(6,)] — first canonical direction of the motion descriptors
    correlation_ : float — the first canonical correlation on the training recordings
    n_frames_ : int — training frames (at ``fps``)

    Examples
    --------
    >>> model = CrossSpeakerCCA().fit([m1, m2], [f1, f2], fps=25.0)   # Motion / FeatureTrack or arrays
    >>> model.score(m3, f3, fps=25.0)                                  # one recording's statistic
    >>> model.test(m3, f3, fps=25.0, n_shifts=100, seed=0)             # NullResult (excess, p_value)
    """

    def __init__(self, *, context: int = CONTEXT, ridge: float = RIDGE, fps: float = FPS):
        self.context = context
        self.ridge = ridge
        self.fps = fps

    # -- inputs -----------------------------------------------------------------------------------
    def _check(self) -> None:
        if int(self.context) != self.context or self.context < 0:
            raise ParameterError(f"The 'context' parameter of CrossSpeakerCCA must be an int ≥ 0. Got {self.context!r}")
        if not self.ridge > 0:
            raise ParameterError(f"The 'ridge' parameter of CrossSpeakerCCA must be > 0. Got {self.ridge!r}")
        if not self.fps > 0:
            raise ParameterError(f"The 'fps' parameter of CrossSpeakerCCA must be > 0. Got {self.fps!r}")

    def _pair(self, motion, features, fps) -> tuple[np.ndarray, np.ndarray]:
        """Motion rotation vectors and speech features at the analysis rate, trimmed to one length."""
        m, fm = _values(motion, fps, "motion")
        f, ff = _values(features, fps, "features")
        if m.shape[1] != 3:
            raise ParameterError(f"motion must be (T, 3) rotation vectors; got shape {m.shape}")
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(f))):
            raise ParameterError("motion or features contain NaN or infinite values")
        m, f = resample(m, fm, self.fps), resample(f, ff, self.fps)
        n = min(len(m), len(f))
        return m[:n], f[:n]

    def _speech(self, f: np.ndarray) -> np.ndarray:
        return speech_context(f - f.mean(axis=0), int(self.context))

    # -- fit ----------------------------------------------------------------------------------------
    def fit(self, motions: Sequence, features: Sequence, *, fps: float | Sequence[float] | None = None) -> "CrossSpeakerCCA":
        """Fit the projections on recordings' motion and speech features.

        Parameters
        ----------
        motions : sequence of Motion | np.ndarray [shape=(T_i, 3)] — recorded heads (radians)
        features : sequence of FeatureTrack | np.ndarray [shape=(T_i, D)] — their speech features
        fps : float | sequence of float — the rate of arrays (per recording or one for all)

        Returns
        -------
        self
        """
        self._check()
        if len(motions) != len(features):
            raise ParameterError(f"fit needs one feature track per motion; got {len(motions)} motions and "
                                 f"{len(features)} feature tracks")
        rates = list(fps) if isinstance(fps, (list, tuple, np.ndarray)) else [fps] * len(motions)
        X, Y = [], []
        for m, f, r in zip(motions, features, rates):
            m, f = self._pair(m, f, r)
            if len(m) < 3:
                continue
            d = motion_descriptors(m, self.fps)
            X.append(d - d.mean(axis=0))
            Y.append(self._speech(f))
        if not X or sum(len(x) for x in X) < 10:
            raise ParameterError(f"CrossSpeakerCCA needs at least 10 frames of motion and speech; got "
                                 f"{sum(len(x) for x in X)} from {len(motions)} recordings")
        dims = {y.shape[1] for y in Y}
        if len(dims) > 1:
            raise ParameterError(f"every recording's features must have the same columns; got widths {sorted(dims)}")
        X, Y = np.vstack(X), np.vstack(Y)
        n = len(X)
        mx, my = X.mean(axis=0), Y.mean(axis=0)
        Xc, Yc = X - mx, Y - my
        wx = _inv_sqrt(Xc.T @ Xc / (n - 1), self.ridge)
        wy = _inv_sqrt(Yc.T @ Yc / (n - 1), self.ridge)
        k = wx @ (Xc.T @ Yc / (n - 1)) @ wy
        u, s, vt = np.linalg.svd(k, full_matrices=False)
        self.motion_weights_ = wx @ u[:, 0]
        self.speech_weights_ = wy @ vt[0]
        self.correlation_ = float(s[0])
        self.n_frames_ = int(n)
        return self

    def _fitted(self) -> None:
        if not hasattr(self, "motion_weights_"):
            raise NotFittedError("CrossSpeakerCCA is not fitted: call fit(motions, features) first")

    # -- score --------------------------------------------------------------------------------------
    def _statistic(self, speech_proj: np.ndarray):
        w = self.motion_weights_

        def score(rotvec: np.ndarray) -> float:
            return _corr(motion_descriptors(rotvec, self.fps) @ w, speech_proj)

        return score

    def score(self, motion, features, *, fps: float | None = None) -> float:
        """Correlation of the first canonical variates over one recording (−1 … 1).

        Parameters
        ----------
        motion : Motion | np.ndarray [shape=(T, 3)] — recorded or generated head (radians)
        features : FeatureTrack | np.ndarray [shape=(T, D)] — the recording's speech features
        fps : float — the rate of arrays
        """
        self._fitted()
        m, f = self._pair(motion, features, fps)
        if len(m) < 3:
            raise ParameterError(f"cross-speaker coupling needs at least 3 frames at {self.fps:g} fps; got {len(m)}")
        return self._statistic(self._speech(f) @ self.speech_weights_)(m)

    def test(self, motion, features, *, fps: float | None = None, n_shifts: int = C.DEFAULT_SHIFTS, seed=0,
             null: str = "bridge") -> C.NullResult:
        """:meth:`score` and its circular-shift null (:func:`~.chance.shift_null`: the motion's bridge
        shifted by every offset 1 … T − 1 at 25 fps; the speech stays in place).

        Returns
        -------
        NullResult — ``score`` (the motion's), ``statistic`` (its bridge's), ``null_mean``,
        ``excess`` (= statistic − null mean), ``p_value`` ((1 + #{null ≥ statistic}) / (n_shifts + 1))
        """
        self._fitted()
        m, f = self._pair(motion, features, fps)
        if len(m) < 3:
            raise ParameterError(f"cross-speaker coupling needs at least 3 frames at {self.fps:g} fps; got {len(m)}")
        return C.shift_null(self._statistic(self._speech(f) @ self.speech_weights_), m, n_shifts=n_shifts, seed=seed,
                            null=null)


def pooled(results: Sequence[C.NullResult], *, n_shifts: int | None = None) -> dict[str, float]:
    """Mean excess and Stouffer's combined p (mid-p of the shift p-values with ``n_shifts``,
    :func:`~.realism.stouffer`) over recordings' :class:`~.chance.NullResult`.

    Returns
    -------
    ``{"excess": mean excess, "p": pooled p, "n": recordings}``
    """
    from .realism import stouffer

    ex = [r.excess for r in results if np.isfinite(r.excess)]
    return {"excess": float(np.mean(ex)) if ex else float("nan"),
            "p": stouffer([r.p_value for r in results], n_shifts=n_shifts), "n": float(len(ex))}


def cross_speaker_coupling(train_motions: Sequence, train_features: Sequence, test_motions: Sequence,
                           test_features: Sequence, *, fps=None, test_fps=None, n_shifts: int = C.DEFAULT_SHIFTS,
                           seed: int = 0, context: int = CONTEXT, ridge: float = RIDGE) -> dict:
    """Fit on the training recordings, test each held-out motion, pool (one call for a choice script).

    Parameters
    ----------
    train_motions, train_features : recorded heads and speech features of the training recordings
    test_motions : held-out motions (recorded or generated), one per held-out recording
    test_features : the held-out recordings' speech features
    fps, test_fps : rates of arrays (one value or one per recording)
    n_shifts, seed : the null's shifts; recording i draws its offsets from ``seed + i``

    Returns
    -------
    ``{"excess", "p", "n"}`` pooled (:func:`pooled`) and ``"per_recording"``: the NullResults

    Examples
    --------
    >>> from headmotion.evaluation.measures.cross_coupling import cross_speaker_coupling
    >>> cross_speaker_coupling(train_heads, train_feats, generated, test_feats, fps=25.0, n_shifts=100)
    """
    model = CrossSpeakerCCA(context=context, ridge=ridge).fit(train_motions, train_features, fps=fps)
    if len(test_motions) != len(test_features):
        raise ParameterError(f"one feature track per held-out motion; got {len(test_motions)} and {len(test_features)}")
    rates = list(test_fps) if isinstance(test_fps, (list, tuple, np.ndarray)) else [test_fps] * len(test_motions)
    res = [model.test(m, f, fps=r, n_shifts=n_shifts, seed=seed + i)
           for i, (m, f, r) in enumerate(zip(test_motions, test_features, rates))]
    return {**pooled(res, n_shifts=n_shifts), "per_recording": res}


__all__ = ["CrossSpeakerCCA", "cross_speaker_coupling", "pooled", "speech_context", "motion_descriptors", "resample",
           "FPS", "CONTEXT", "RIDGE"]
