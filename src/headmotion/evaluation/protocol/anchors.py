"""Evaluation anchors (thesis §4.2.4, §4.3.1, §5.9 Table 5.8): ground truth, desynchronised,
other speaker, head-motion-shaped noise, still head.

Anchors are evaluation conditions (:class:`~headmotion.evaluation.protocol.conditions.Condition`) that make
their motion from the corpus's recorded motion, not from speech: ``fit(corpus)`` stores the
reference motions (and, for shaped noise, the average magnitude spectrum of their motion);
``motion_for(recording, *, seed=None)`` makes the anchor's motion for one recording, with exactly
the recording's length and frame rate; ``needs_other_speakers``: fit it on the *other* speakers'
recordings.  :data:`ANCHORS` maps the names ``headmotion evaluate --systems`` accepts to the
classes; :func:`create_anchor` makes one.

Definitions:

* ``ground-truth`` — the recording's own motion.
* ``desync`` — the motion of *another recording of the same speaker* (cut or looped to length);
  when the fold has none (held-out speakers, or a speaker with one recording) the recording's own
  motion circularly shifted by half its length (chosen here: the same spectrum and amplitude as
  the ground truth, uncoupled from the speech).
* ``shifted`` — the recording's own motion circularly shifted by half its length (chosen here: the
  ruler of the realism targets — exactly the recording's amplitude and nearly its spectrum and
  speed distribution, uncoupled from its speech).
* ``other-speaker`` — the motion of a recording of a *different speaker* (cut or looped).
* ``shaped-noise`` — white noise filtered in the frequency domain by the magnitude spectrum of real
  head motion, inverted back to the time domain, then smoothed with a 5-point Gaussian (thesis
  §4.2.4); scaled to the reference motion's per-axis standard deviation about its mean.
* ``still`` — the mean pose held constant.
* ``floor`` — recorded heads of *other* speakers (the training folds' under ``--protocol
  speakers``), a different stretch for every held-out recording: the held-out recordings take
  turns at the training recordings in a seeded order, each a contiguous stretch of its length
  never given to another held-out recording (only when no training recording has that many frames
  left is a stretch reused, and a shorter one looped with mirroring).  Its detectability is what
  the data allows — the level at which recorded heads of other people are told from these
  people's — and ``evaluate`` adds it beside every condition's (docs/decisions/detectability.md).
  Unlike ``other-speaker``, which copies the start of one drawn recording, possibly the same one
  for several held-out recordings, no frame of the training heads appears twice, so a classifier
  cannot win by recognising a copied stretch across its folds.

Library considered: numpy.fft / scipy.ndimage (no library has these evaluation conditions).
"""

from __future__ import annotations

import numpy as np

from abc import abstractmethod
from typing import ClassVar

from ...errors import NotFittedError, ParameterError
from ...types import Motion
from .conditions import GROUND_TRUTH, Condition


def loop_to_length(rv: np.ndarray, T: int) -> np.ndarray:
    """Cut or loop (with mirroring, so there is no jump) to T frames."""
    if len(rv) == 0:
        return np.zeros((T, 3))
    out = rv
    while len(out) < T:
        out = np.vstack([out, out[::-1]])
    return out[:T]


class Anchor(Condition):
    """An evaluation condition made from recorded motion: fitted on a corpus, gives the motion for
    one recording."""

    name: ClassVar[str] = ""
    #: fit on the other speakers' recordings (the evaluation arranges it)
    needs_other_speakers: ClassVar[bool] = False
    #: the motion comes from the training recordings (else from the recording alone: fit reads none)
    uses_training: ClassVar[bool] = True

    def fit(self, corpus) -> "Anchor":
        if not self.uses_training:
            self.fitted_ = True
            return self
        recs = list(corpus)
        if not recs:
            raise ParameterError(f"anchor {self.name!r} needs a corpus with at least one recording")
        self.fps_ = float(recs[0].motion.fps)
        self.refs_ = []
        for r in recs:
            m = r.motion.resample(self.fps_)
            self.refs_.append((r.id, r.speaker, np.asarray(m.rotvec)))
        allr = np.vstack([x for _, _, x in self.refs_])
        self.mean_ = allr.mean(axis=0)
        self.sd_ = allr.std(axis=0)
        self._after_fit()
        self.fitted_ = True
        return self

    def _after_fit(self) -> None:  # noqa: B027  (an optional hook, empty by default)
        """Hook for what an anchor learns beyond the reference motions."""

    def motion_for(self, recording, *, seed: int | None = None) -> Motion:
        """The anchor's motion for ``recording`` (its length and frame rate)."""
        if not getattr(self, "fitted_", False):
            raise NotFittedError(f"anchor {self.name!r} is not fitted: call fit(corpus)")
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

    @abstractmethod
    def _rotvec_for(self, recording, seed) -> np.ndarray:
        """``(T, 3)`` rotation vectors for the recording."""


class GroundTruth(Anchor):
    """The recording's own motion."""

    name = GROUND_TRUTH
    reference = True
    uses_training = False

    def _rotvec_for(self, recording, seed):  # noqa: ARG002  (deterministic)
        return np.asarray(recording.motion.rotvec)


class Desync(Anchor):
    """Motion of another recording of the same speaker."""

    name = "desync"

    def _rotvec_for(self, recording, seed):
        if not any(rid != recording.id and spk == recording.speaker for rid, spk, _ in self.refs_):
            # a held-out speaker (protocol "speakers") or a one-recording speaker: the recording's own
            # motion circularly shifted by half its length — same spectrum and amplitude, out of step
            rv = np.asarray(recording.motion.rotvec)
            return np.roll(rv, len(rv) // 2, axis=0)
        return loop_to_length(self._pick(recording, same_speaker=True, seed=seed), len(recording.motion))


class Shifted(Anchor):
    """The recording's own motion circularly shifted by half its length."""

    name = "shifted"
    uses_training = False

    def _rotvec_for(self, recording, seed):  # noqa: ARG002  (deterministic)
        rv = np.asarray(recording.motion.rotvec)
        return np.roll(rv, len(rv) // 2, axis=0)


class OtherSpeaker(Anchor):
    """Motion of a recording of another speaker."""

    name = "other-speaker"
    needs_other_speakers = True

    def _rotvec_for(self, recording, seed):
        return loop_to_length(self._pick(recording, same_speaker=False, seed=seed), len(recording.motion))


class Still(Anchor):
    """The mean pose, held."""

    name = "still"

    def _rotvec_for(self, recording, seed):  # noqa: ARG002  (deterministic)
        return np.tile(self.mean_, (len(recording.motion), 1))


class Floor(Anchor):
    """Stretches of other speakers' recorded heads, none used twice (module docstring)."""

    name = "floor"
    needs_other_speakers = True

    def __init__(self, random_state: int | None = None):
        self.random_state = random_state

    def _after_fit(self):
        order = np.random.default_rng(self.random_state).permutation(len(self.refs_))
        self.order_ = [int(i) for i in order]
        self.used_ = [0] * len(self.refs_)  # frames already given out, per training recording
        self.given_: dict[str, np.ndarray] = {}
        self.turn_ = 0

    def motion_for(self, recording, *, seed: int | None = None) -> Motion:
        if not getattr(self, "fitted_", False):
            raise NotFittedError(f"anchor {self.name!r} is not fitted: call fit(corpus)")
        fps = float(recording.motion.fps)
        rv = self._rotvec_for(recording, seed)
        return Motion(rv, self.fps_, meta={"system": self.name}).resample(fps) if abs(fps - self.fps_) > 1e-9 else \
            Motion(rv, fps, meta={"system": self.name})

    def _rotvec_for(self, recording, seed):  # noqa: ARG002  (the order is drawn at fit)
        if recording.id in self.given_:  # asked again: the same stretch
            return self.given_[recording.id]
        fps = float(recording.motion.fps)
        T = int(np.ceil(len(recording.motion) * self.fps_ / fps)) + (0 if abs(fps - self.fps_) < 1e-9 else 1)
        cands = [i for i in self.order_ if self.refs_[i][1] != recording.speaker]
        if not cands:
            raise ParameterError(f"anchor {self.name!r}: no recording of another speaker than {recording.id!r}'s "
                                 f"({recording.speaker!r}) in the corpus")
        k = len(cands)
        turn = [cands[(self.turn_ + j) % k] for j in range(k)]
        free = [i for i in turn if len(self.refs_[i][2]) - self.used_[i] >= T]
        if free:
            i = free[0]
            out = self.refs_[i][2][self.used_[i]:self.used_[i] + T]
            self.used_[i] += T
        else:  # no training recording has T frames left: the longest one again (looped when shorter)
            i = max(turn, key=lambda j: len(self.refs_[j][2]))
            out = loop_to_length(self.refs_[i][2], T)
        self.turn_ = (cands.index(i) + 1) % k
        self.given_[recording.id] = np.asarray(out)
        return self.given_[recording.id]


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


class ShapedNoise(Anchor):
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
                            fps=float(recording.motion.fps), sd=self.sd_, mean=self.mean_)



#: anchor name → class (the names ``headmotion evaluate --systems`` accepts besides systems)
ANCHORS: dict[str, type[Anchor]] = {c.name: c for c in (GroundTruth, Desync, Shifted, OtherSpeaker, ShapedNoise,
                                                          Still, Floor)}


def create_anchor(name: str, random_state: int | None = None) -> Anchor:
    """A new anchor by name (``random_state``: the seed of an anchor that draws at fit, ``floor``);
    ParameterError naming the anchors for an unknown one."""
    if name not in ANCHORS:
        raise ParameterError(f"unknown anchor {name!r}; expected one of {sorted(ANCHORS)}")
    return ANCHORS[name](random_state) if ANCHORS[name] is Floor else ANCHORS[name]()


__all__ = ["Anchor", "ANCHORS", "create_anchor", "GroundTruth", "Desync", "Shifted", "OtherSpeaker", "ShapedNoise", "Still", "Floor",
           "shaped_noise", "loop_to_length"]
