"""Synthesis-time post-processing of the DNN systems' output (issue 14 §2, diagnosis §3.6):
global-variance restoration and a seeded slow posture component.

The paper (§3.3) stops at its denoising post-filter; it is silent on both steps below, which are
ours and can be switched off (``variance_restore=False, drift_share=0`` reproduces the paper's
output bit for bit).  Why they are needed, measured on real data (docs/natural_motion_diagnosis.md):
an MMSE regressor averages over the many head movements that fit the same speech, so its output has
0.14–0.44 of the recorded heads' SD and lacks their slow posture shifts (share of power below
0.5 Hz 0.35–0.53 against 0.73–0.76).

* **Variance restoration** (global-variance scaling, as used for the over-smoothing of statistical
  parametric speech synthesis — Toda & Tokuda 2007 — here in its simplest post-hoc form): at
  training, after the post-filter, the ratio per axis of the training motion's SD to the network
  output's SD on the same training recordings, both measured about each recording's own mean
  (:func:`gv_ratio`, capped at :data:`GV_CAP`); at synthesis, every utterance's deviations from its
  own mean are multiplied by it (:func:`restore_variance`).  The training-set ratio, not a
  per-utterance one, so that a quiet utterance stays quieter than a lively one.
* **Posture drift**: a seeded Ornstein–Uhlenbeck process (time constant ``tau_s``, 2 s — real
  heads hold a posture for seconds) carrying a share ``share`` of the training motion's
  within-recording variance; the network's deviations are scaled by ``sqrt(1 - share)`` so that the
  total variance stays that of the training motion (:func:`add_drift`).  The OU starts from its
  stationary distribution, so each seed also gives a different posture.  It is uncorrelated with
  the speech by construction: a larger share makes the motion more realistic and less coupled.

All arrays here are in the model's normalised motion space (rotation-vector components, which for
head rotations of a few degrees are pitch, yaw and roll to within a fraction of a percent).

Library considered: none does per-utterance GV scaling or an OU process in a few lines; scipy's
``lfilter`` would run the OU recursion, a loop-free numpy version is used instead.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

#: largest variance-restoring factor (the diagnosis's prototype cap)
GV_CAP = 6.0


def within_sd(arrays) -> np.ndarray:
    """SD per axis of a list of ``(T, D)`` arrays, each about its own mean (pooled over all frames)."""
    arrs = [np.asarray(a, dtype=np.float64) for a in arrays if len(a)]
    if not arrs:
        raise ValueError("within_sd needs at least one non-empty array")
    ss = sum(((a - a.mean(axis=0)) ** 2).sum(axis=0) for a in arrs)
    n = sum(len(a) for a in arrs)
    return np.sqrt(ss / n)


def gv_ratio(predicted, target, *, cap: float = GV_CAP) -> np.ndarray:
    """Per-axis ``within_sd(target) / within_sd(predicted)``, at most ``cap`` (1 where the
    prediction does not move)."""
    sp, st = within_sd(predicted), within_sd(target)
    g = np.where(sp > 1e-12, st / np.maximum(sp, 1e-12), 1.0)
    return np.minimum(g, cap)


def restore_variance(y: np.ndarray, gv) -> np.ndarray:
    """``mean(y) + gv * (y - mean(y))`` per axis (``y`` one utterance, ``(T, D)``)."""
    y = np.asarray(y, dtype=np.float64)
    if len(y) == 0:
        return y.copy()
    c = y.mean(axis=0)
    return c + np.asarray(gv, dtype=np.float64) * (y - c)


def ou_process(n: int, dims: int, *, fps: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """A stationary unit-variance Ornstein–Uhlenbeck process sampled at ``fps`` (``(n, dims)``):
    ``x_t = a x_{t-1} + sqrt(1 - a²) e_t`` with ``a = exp(-1 / (tau_s · fps))``, ``x_0 ~ N(0, 1)``."""
    if n == 0:
        return np.zeros((0, dims))
    a = float(np.exp(-1.0 / (float(tau_s) * float(fps))))
    e = rng.standard_normal((n, dims))
    e[1:] *= np.sqrt(1.0 - a * a)
    # x_t = a x_{t-1} + e_t with x_0 = e_0: a first-order IIR filter over time
    return lfilter([1.0], [1.0, -a], e, axis=0)


def add_drift(y: np.ndarray, *, share: float, sd, fps: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """``mean(y) + sqrt(1 - share) (y - mean(y)) + sqrt(share) · sd · OU`` (``sd`` per axis: the
    training motion's within-recording SD)."""
    y = np.asarray(y, dtype=np.float64)
    if share <= 0 or len(y) == 0:
        return y.copy()
    c = y.mean(axis=0)
    slow = ou_process(len(y), y.shape[1], fps=fps, tau_s=tau_s, rng=rng)
    return c + np.sqrt(1.0 - share) * (y - c) + np.sqrt(share) * np.asarray(sd, dtype=np.float64) * slow


__all__ = ["GV_CAP", "within_sd", "gv_ratio", "restore_variance", "ou_process", "add_drift"]
