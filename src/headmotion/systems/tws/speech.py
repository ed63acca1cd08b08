"""Speech / non-speech per frame from the template-warping systems' own (normalised) features, so
that pauses are decided causally, frame by frame, in the stream and offline alike (issue 14 §3,
issue 16).  The seeds are silent on pauses.

At training, :func:`headmotion.features.vad.speaking_mask` (energy + voicing with hangover, which
looks at the whole clip) labels the training audio; a linear classifier (logistic regression with
balanced class weights, scikit-learn) learns to tell those labels from one normalised feature frame.
At synthesis a frame is speech when ``F[t] @ coef + bias > 0`` — it depends on frame ``t`` only.
The pause logic on top (:class:`headmotion.motion.pauses.CausalPauseWeight`) bridges the gaps between
words.  Library considered: webrtcvad / silero-vad (see :mod:`headmotion.features.vad`); a linear
read-out of features the system already computes costs nothing at synthesis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SpeechDetector:
    """Linear speech detector on normalised feature frames."""

    coef: np.ndarray   # (D,)
    bias: float
    accuracy: float    # balanced accuracy on the training frames

    @classmethod
    def fit(cls, feats: list[np.ndarray], masks: list[np.ndarray], *, random_state: int = 0) -> "SpeechDetector | None":
        """From normalised features (T, D) and VAD masks (T,); None when the training audio has
        only speech or only silence (nothing to learn: pauses are then not detected)."""
        from sklearn.linear_model import LogisticRegression

        X = np.vstack(feats)
        y = np.concatenate([np.asarray(m, dtype=bool) for m in masks])
        n_sp = int(y.sum())
        if n_sp < 10 or len(y) - n_sp < 10:
            return None
        clf = LogisticRegression(class_weight="balanced", max_iter=500, random_state=random_state).fit(X, y)
        coef, bias = clf.coef_[0].astype(np.float64), float(clf.intercept_[0])
        pred = X @ coef + bias > 0
        acc = 0.5 * (np.mean(pred[y]) + np.mean(~pred[~y]))
        return cls(coef=coef, bias=bias, accuracy=float(acc))

    def flags(self, F: np.ndarray) -> np.ndarray:
        """True where frame ``F[t]`` is speech."""
        F = np.asarray(F, dtype=np.float64)
        if len(F) == 0:
            return np.zeros(0, dtype=bool)
        return F @ self.coef + self.bias > 0

    def to_arrays(self) -> dict:
        return {"vad_coef": self.coef, "vad_bias": np.array([self.bias]), "vad_accuracy": np.array([self.accuracy])}

    @classmethod
    def from_arrays(cls, arrays) -> "SpeechDetector | None":
        if "vad_coef" not in arrays:
            return None
        return cls(coef=np.asarray(arrays["vad_coef"], dtype=np.float64), bias=float(arrays["vad_bias"][0]),
                   accuracy=float(arrays["vad_accuracy"][0]))


__all__ = ["SpeechDetector"]
