"""Evaluation anchors (thesis §4.2.4, §4.3.1, §5.9 Table 5.8): ground truth, desynchronised,
other speaker, head-motion-shaped noise, still head.

Anchors are not trained models: they need the evaluation corpus.  Their interface:

* ``fit(corpus)`` stores the reference motions (and, for shaped noise, the average magnitude
  spectrum of their motion);
* ``predict_for(recording, corpus=None, seed=None) -> Motion`` makes the anchor's motion for one
  recording of that corpus, with exactly the recording's length and frame rate;
* ``predict(audio, seed=None)`` works only where the audio alone suffices (``still``,
  ``shaped-noise``); the others raise :class:`~headmotion.errors.ParameterError` telling to use
  ``predict_for``.

Definitions:

* ``ground-truth`` — the recording's own motion.
* ``desync`` — the motion of *another recording of the same speaker* (cut or looped to length).
* ``other-speaker`` — the motion of a recording of a *different speaker* (cut or looped).
* ``shaped-noise`` — white noise filtered in the frequency domain by the magnitude spectrum of real
  head motion, inverted back to the time domain, then smoothed with a 5-point Gaussian (thesis
  §4.2.4); scaled to the reference motion's per-axis standard deviation about its mean.
* ``still`` — the mean pose held constant.

Library considered: numpy.fft / scipy.ndimage (no library has these evaluation conditions).
"""

from __future__ import annotations

import numpy as np

from ..align import n_frames as _n_frames
from ..errors import ParameterError
from ..types import Audio, Motion
from .base import Synthesizer


def _fit_length(rv: np.ndarray, T: int) -> np.ndarray:
    """Cut or loop (with mirroring, so there is no jump) to T frames."""
    if len(rv) == 0:
        return np.zeros((T, 3))
    out = rv
    while len(out) < T:
        out = np.vstack([out, out[::-1]])
    return out[:T]


class _Anchor(Synthesizer):
    causal = False

    def __init__(self, *, fps: float | None = None):
        self.fps = fps

    def fit(self, corpus, *, progress=None):
        recs = list(corpus)
        if not recs:
            raise ParameterError(f"anchor {self.name!r} needs a corpus with at least one recording")
        self.fps_ = float(self.fps) if self.fps else float(recs[0].motion.fps)
        self.refs_ = []
        for r in recs:
            m = r.motion if abs(r.motion.fps - self.fps_) < 1e-9 else r.motion.resample(self.fps_)
            self.refs_.append((r.id, r.speaker, np.asarray(m.rotvec)))
        allr = np.vstack([x for _, _, x in self.refs_])
        self.mean_ = allr.mean(axis=0)
        self.sd_ = allr.std(axis=0)
        self.sample_rate_ = int(recs[0].audio.sample_rate)
        self.fitted_ = True
        self._after_fit()
        return self

    def _after_fit(self):
        pass

    def _n(self, audio: Audio) -> int:
        return _n_frames(len(audio.samples), audio.sample_rate, self.fps_)

    def predict(self, audio: Audio, *, seed: int | None = None) -> Motion:
        raise ParameterError(f"anchor {self.name!r} needs the evaluation corpus: use predict_for(recording, corpus)")

    def predict_for(self, recording, corpus=None, *, seed: int | None = None) -> Motion:
        self._check_fitted()
        return Motion(self._rotvec_for(recording, seed), recording.motion.fps, meta={"system": self.name})

    def _pick(self, recording, *, same_speaker: bool, seed):
        cands = [(i, rv) for i, (rid, spk, rv) in enumerate(self.refs_)
                 if rid != recording.id and ((spk == recording.speaker) == same_speaker)]
        if not cands:
            who = "same speaker" if same_speaker else "another speaker"
            raise ParameterError(
                f"anchor {self.name!r}: no other recording of {who} than {recording.id!r} in the corpus")
        rng = np.random.default_rng(seed)
        return cands[int(rng.integers(len(cands)))][1]

    def _rotvec_for(self, recording, seed):
        raise NotImplementedError

    def _get_state(self):
        return {"fps": self.fps_}, {"mean": self.mean_, "sd": self.sd_}

    def _set_state(self, config, arrays):
        self.fps = self.fps_ = float(config["fps"])
        self.mean_, self.sd_ = arrays["mean"], arrays["sd"]
        self.refs_ = []


class GroundTruth(_Anchor):
    """The recording's own motion."""

    name = "ground-truth"

    def _rotvec_for(self, recording, seed):
        return np.asarray(recording.motion.rotvec)


class Desync(_Anchor):
    """Motion of another recording of the same speaker."""

    name = "desync"

    def _rotvec_for(self, recording, seed):
        return _fit_length(self._pick(recording, same_speaker=True, seed=seed), len(recording.motion))


class OtherSpeaker(_Anchor):
    """Motion of a recording of another speaker."""

    name = "other-speaker"

    def _rotvec_for(self, recording, seed):
        return _fit_length(self._pick(recording, same_speaker=False, seed=seed), len(recording.motion))


class Still(_Anchor):
    """The mean pose, held."""

    name = "still"

    def _rotvec_for(self, recording, seed):
        return np.tile(self.mean_, (len(recording.motion), 1))

    def predict(self, audio: Audio, *, seed: int | None = None) -> Motion:
        self._check_fitted()
        return Motion(np.tile(self.mean_, (self._n(audio), 1)), self.fps_, meta={"system": self.name})


def shaped_noise(n_frames: int, magnitude: np.ndarray, *, rng: np.random.Generator, fps: float,
                 sd: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """White noise filtered by ``magnitude`` (F, 3) (rfft bins of some length), inverse FFT,
    5-point Gaussian smoothing (at 100 Hz; scaled with fps), scaled to ``sd`` about ``mean``."""
    from scipy.ndimage import gaussian_filter1d

    T = int(n_frames)
    if T == 0:
        return np.zeros((0, 3))
    white = rng.standard_normal((T, 3))
    W = np.fft.rfft(white, axis=0)
    F = W.shape[0]
    src = np.linspace(0, 1, magnitude.shape[0])
    dst = np.linspace(0, 1, F)
    mag = np.stack([np.interp(dst, src, magnitude[:, j]) for j in range(3)], axis=1)
    x = np.fft.irfft(W * mag, n=T, axis=0)
    x = gaussian_filter1d(x, 1.0 * fps / 100.0, axis=0, truncate=2.0, mode="nearest")
    x = x - x.mean(axis=0)
    s = x.std(axis=0)
    return mean + x * (sd / np.where(s > 0, s, 1.0))


class ShapedNoise(_Anchor):
    """Head-motion-shaped noise (thesis §4.2.4)."""

    name = "shaped-noise"
    N_FFT = 1024

    def _after_fit(self):
        mags = []
        for _, _, rv in self.refs_:
            x = rv - rv.mean(axis=0)
            if len(x) < 16:
                continue
            # average magnitude spectrum over N_FFT-frame chunks
            n = self.N_FFT
            if len(x) < n:
                x = np.vstack([x, np.zeros((n - len(x), 3))])
            chunks = [x[i:i + n] for i in range(0, len(x) - n + 1, n // 2)]
            mags.append(np.mean([np.abs(np.fft.rfft(c * np.hanning(n)[:, None], axis=0)) for c in chunks], axis=0))
        self.magnitude_ = np.mean(mags, axis=0) if mags else np.ones((self.N_FFT // 2 + 1, 3))

    def _rotvec_for(self, recording, seed):
        return shaped_noise(len(recording.motion), self.magnitude_, rng=np.random.default_rng(seed),
                            fps=self.fps_, sd=self.sd_, mean=self.mean_)

    def predict(self, audio: Audio, *, seed: int | None = None) -> Motion:
        self._check_fitted()
        rv = shaped_noise(self._n(audio), self.magnitude_, rng=np.random.default_rng(seed), fps=self.fps_,
                          sd=self.sd_, mean=self.mean_)
        return Motion(rv, self.fps_, meta={"system": self.name})

    def _get_state(self):
        cfg, arr = super()._get_state()
        arr["magnitude"] = self.magnitude_
        return cfg, arr

    def _set_state(self, config, arrays):
        super()._set_state(config, arrays)
        self.magnitude_ = arrays["magnitude"]


__all__ = ["GroundTruth", "Desync", "OtherSpeaker", "ShapedNoise", "Still", "shaped_noise"]
