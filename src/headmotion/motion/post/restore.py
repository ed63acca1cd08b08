"""Variance and band restoration and posture drift: the stages of the post-processing chain that
give a system's output the recorded heads' variance and modulation spectrum (not in the paper,
which stops at its post-filter, §3.3, nor in the thesis; ``docs/decisions/post-chain.md``).

* **Variance restoration** (global-variance scaling, Toda & Tokuda 2007, in its simplest post-hoc
  form): the ratio per axis of the training motion's SD to the system output's SD on the training
  recordings, both about each recording's own mean (:func:`gv_ratio`, at most :data:`GV_CAP`),
  multiplies the output's deviations from its centre.
* **Band restoration** (the modulation-spectrum post-filter of Takamichi et al. 2016 in a causal,
  band-wise form): :class:`BandSplit` splits the deviations into the bands of
  :data:`headmotion.motion.bands.BAND_EDGES_HZ` and :func:`band_gains` gives each band of each axis
  its own training ratio, so the slow posture band is restored more than the syllable-rate band.
* **Posture drift**: a seeded Ornstein–Uhlenbeck process (time constant ``tau_s``) carrying a share
  ``share`` of the training motion's within-recording variance; the restored deviations are scaled
  by ``sqrt(1 - share)`` so the total variance stays the training motion's.  Uncorrelated with the
  speech by construction.

:class:`CausalPost` applies them about the **running mean** of its input (``c_t = mean(y_0 … y_t)``):
causal, converging to the utterance mean, and chunking-invariant, so offline synthesis and a stream
give the same frames.  :func:`restore_variance` and :func:`add_drift` (utterance-mean centre) serve
analysis and tests.

Library considered: scipy's ``butter`` / ``lfilter`` (the band filters and the OU recursion, with
state); no library does per-utterance GV scaling or a seeded OU process.
"""

from __future__ import annotations

import numpy as np
from ..iir import butter_lowpass, lfilter  # scipy.signal's, bit for bit, without importing it

from ..bands import BAND_EDGES_HZ

#: largest variance-restoring factor
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
    return lfilter([1.0], [1.0, -a], e)


def add_drift(y: np.ndarray, *, share: float, sd, fps: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """``mean(y) + sqrt(1 - share) (y - mean(y)) + sqrt(share) · sd · OU`` (``sd`` per axis: the
    training motion's within-recording SD)."""
    y = np.asarray(y, dtype=np.float64)
    if share <= 0 or len(y) == 0:
        return y.copy()
    c = y.mean(axis=0)
    slow = ou_process(len(y), y.shape[1], fps=fps, tau_s=tau_s, rng=rng)
    return c + np.sqrt(1.0 - share) * (y - c) + np.sqrt(share) * np.asarray(sd, dtype=np.float64) * slow


#: largest per-band gain
BAND_CAP = 8.0


class BandSplit:
    """Causal complementary split of a ``(T, D)`` signal into ``len(BAND_EDGES_HZ) + 1`` bands:
    band 0 = low-pass(x) at the first edge, band k = low-pass(rest) at edge k where rest is what
    the lower bands left, the last band the final rest.  Each low-pass is a 2nd-order Butterworth
    (``scipy.signal.butter``) run with state (``lfilter`` with ``zi``), so the bands sum to the
    input exactly and chunked pushes give what one push gives.  The bands are soft: a causal
    low-pass lags, and its lag leaks into the rest (a 0.7 Hz sinusoid puts ~60 % of its power in
    band 1, ~30 % in band 2); the gains are measured and applied with the same split, so this
    only blurs the edges of what each gain controls."""

    def __init__(self, *, fps: float, dims: int, edges=BAND_EDGES_HZ):
        nyq = 0.5 * float(fps)
        self.filters = [butter_lowpass(2, min(float(e), 0.95 * nyq), float(fps)) for e in edges]
        self.state = [np.zeros((2, int(dims))) for _ in edges]

    @property
    def n_bands(self) -> int:
        return len(self.filters) + 1

    def push(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        out = np.empty((len(x), self.n_bands, x.shape[1]))
        rest = x
        for k, (b, a) in enumerate(self.filters):
            lo, self.state[k] = lfilter(b, a, rest, zi=self.state[k])
            out[:, k] = lo
            rest = rest - lo
        out[:, -1] = rest
        return out


def _starts(arrays, starts) -> list[int]:
    return [0] * len(arrays) if starts is None else [int(s) for s in starts]


def band_variance(arrays, *, fps: float, starts=None) -> np.ndarray:
    """Variance per band and axis ``(B, D)`` of a list of ``(T, D)`` arrays, each split about its
    own mean by a fresh :class:`BandSplit`, pooled over the frames from ``starts[i]`` on (default:
    all frames; the split runs over the whole array either way)."""
    pairs = [(np.asarray(a, dtype=np.float64), s) for a, s in zip(arrays, _starts(arrays, starts))]
    pairs = [(a, s) for a, s in pairs if len(a) > s]
    if not pairs:
        raise ValueError("band_variance needs at least one array with frames to count")
    D = pairs[0][0].shape[1]
    ss, n = 0.0, 0
    for a, s in pairs:
        bands = BandSplit(fps=fps, dims=D).push(a - a.mean(axis=0))[s:]
        ss = ss + (bands ** 2).sum(axis=0)
        n += len(bands)
    return ss / n


def band_gains(predicted, target, *, fps: float, share: float = 0.0, cap: float = BAND_CAP,
               starts=None) -> np.ndarray:
    """Per-band, per-axis gains ``(B, D)`` that give the network output (``predicted``) the
    modulation spectrum of the motion (``target``): ``sqrt(var_target / var_predicted)`` per band
    (:func:`band_variance`, over the frames from ``starts`` on), at most ``cap``.  With posture
    drift of ``share`` (an OU process whose power lies almost entirely in the lowest band), the
    lowest band's target is reduced by the drift's variance (to no less than a tenth of itself)."""
    vp, vt = band_variance(predicted, fps=fps, starts=starts), band_variance(target, fps=fps, starts=starts)
    if share > 0:
        total = within_sd(target) ** 2
        vt = vt.copy()
        vt[0] = np.maximum(vt[0] - share * total, 0.1 * vt[0])
    g = np.where(vp > 1e-18, np.sqrt(vt / np.maximum(vp, 1e-18)), 1.0)
    return np.minimum(g, cap)


class CausalPost:
    """Variance restoration and posture drift about the running mean, with state (see the module
    docstring): ``push(y)`` takes the next frames ``(n, D)`` of normalised network output and
    returns ``c + k (y − c) + sqrt(share) · sd · OU`` with ``c`` the running mean,
    ``k = gv · sqrt(1 − share)`` (``gv`` = 1 without restoration).  The OU process is drawn from
    ``rng`` in frame order (``x_0 ~ N(0, 1)``, as :func:`ou_process`), so chunking does not change
    the draws.  Feeding an utterance in chunks gives bit for bit the output of one push."""

    def __init__(self, *, gv=None, share: float = 0.0, sd=None, fps: float = 100.0, tau_s: float = 4.0,
                 rng: np.random.Generator | None = None, band_gains=None):
        self.gv = None if gv is None else np.asarray(gv, dtype=np.float64)
        #: per-band gains ``(B, D)`` (modulation-spectrum restoration); replaces ``gv`` when given
        self.band_gains = None if band_gains is None else np.asarray(band_gains, dtype=np.float64)
        self.split = None if band_gains is None else BandSplit(fps=fps, dims=self.band_gains.shape[1])
        self.share = float(share)
        self.sd = None if sd is None else np.asarray(sd, dtype=np.float64)
        if self.share > 0 and (rng is None or self.sd is None):
            raise ValueError("CausalPost with drift needs rng and sd")
        self.a = float(np.exp(-1.0 / (float(tau_s) * float(fps))))
        self.rng = rng
        self.total = None   # running sum of y (float64)
        self.n = 0          # frames seen
        self.x = None       # last OU value

    @property
    def identity(self) -> bool:
        return self.gv is None and self.band_gains is None and self.share <= 0

    def push(self, y: np.ndarray) -> np.ndarray:
        y = np.asarray(y, dtype=np.float64)
        if self.identity:
            return y
        n, D = y.shape
        if n == 0:
            return y.copy()
        if self.total is None:
            self.total = np.zeros(D)
        cs = np.cumsum(np.vstack([self.total[None], y]), axis=0)[1:]   # sequential: chunking-invariant
        c = cs / np.arange(self.n + 1, self.n + n + 1, dtype=np.float64)[:, None]
        self.total, self.n = cs[-1], self.n + n
        if self.band_gains is not None:
            bands = self.split.push(y - c)                       # (n, B, D)
            out = c + np.einsum("nbd,bd->nd", bands, self.band_gains)
        else:
            k = np.sqrt(1.0 - self.share) * (np.ones(D) if self.gv is None else self.gv)
            out = c + k * (y - c)
        if self.share > 0:
            e = self.rng.standard_normal((n, D))
            first = self.x is None
            if first:
                e[1:] *= np.sqrt(1.0 - self.a * self.a)
                zi = np.zeros((1, D))
            else:
                e *= np.sqrt(1.0 - self.a * self.a)
                zi = (self.a * self.x)[None]
            slow, _ = lfilter([1.0], [1.0, -self.a], e, zi=zi)
            self.x = slow[-1].copy()
            out = out + np.sqrt(self.share) * self.sd * slow
        return out


__all__ = ["CausalPost", "BandSplit", "band_variance", "band_gains", "BAND_EDGES_HZ", "BAND_CAP", "GV_CAP", "within_sd", "gv_ratio", "restore_variance", "ou_process", "add_drift"]
