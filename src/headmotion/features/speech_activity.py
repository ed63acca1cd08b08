"""Speech / non-speech per frame decided causally (frame ``t`` from frames ``<= t``), from a
system's own feature frames or from frame energies in dBFS, so that pauses are the same in the
stream and offline; every synthesis system's pause settling reads it.  The seeds are silent on
pauses.

The detector is the causal counterpart of :func:`headmotion.features.vad.speaking_mask`'s energy
rule (cheaper: the percentiles are updated every ``update_frames`` (10) frames from every
``stride`` (5)-th frame of the window, at absolute frame indices so chunking does not matter): the
feature set's frame energy (column ``energy``; dB for ``f0e``, natural log for
``mfcc`` / ``fbank``, converted to dB) is compared with an adaptive threshold
``floor + max(min_snr_db, 0.25 (level - floor))`` where ``floor`` and ``level`` are the 10th and
95th percentiles of the energy over the past ``window_s`` (3 s) of the utterance; where that window
has less than ``min_snr_db`` of dynamic range it is speech iff the frame is above ``silence_db``
(-50 dBFS).  Adaptive, because an absolute threshold learned on the training audio does not carry
over to other recordings (a linear classifier on the normalised features trained on the training
audio's VAD labels reaches 0.97 balanced accuracy on ZEGGS but leaves the head moving in the pauses
of other speech files).  At training the agreement with ``speaking_mask`` on the
training audio is recorded (``accuracy``, balanced).  Feature sets without an energy column get no
detector (no pause settling).

Library considered: webrtcvad / silero-vad (see :mod:`headmotion.features.vad`); reading the
energy the system already computes costs almost nothing at synthesis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .vad import ENERGY_PERCENTILES, LEVEL_SHARE, MIN_SNR_DB, SILENCE_DB


@dataclass
class SpeechDetector:
    """Adaptive causal energy detector (module docstring) on normalised feature frames."""

    col: int            # the energy column
    mu: float           # normaliser mean and SD of that column (normalised -> raw)
    sd: float
    db_per_unit: float  # raw energy units -> dB
    accuracy: float = float("nan")
    fps: float = 100.0
    window_s: float = 3.0
    min_snr_db: float = MIN_SNR_DB
    silence_db: float = SILENCE_DB

    @classmethod
    def for_features(cls, names, normalizer, fps: float) -> "SpeechDetector | None":
        names = list(names)
        if "energy" not in names:
            return None
        col = names.index("energy")
        db = 1.0 if any(n == "logf0" for n in names) else 10.0 / math.log(10.0)
        return cls(col=col, mu=float(normalizer.mean_[col]), sd=float(normalizer.std_[col]), db_per_unit=db,
                   fps=float(fps))

    def energy_db(self, F: np.ndarray) -> np.ndarray:
        F = np.asarray(F, dtype=np.float64)
        return (F[:, self.col] * self.sd + self.mu) * self.db_per_unit

    def start(self) -> "SpeechTracker":
        return SpeechTracker(self)

    def flags(self, F: np.ndarray) -> np.ndarray:
        """Flags of a whole utterance (a fresh tracker)."""
        return self.start().push(F)

    def score(self, feats: list[np.ndarray], masks: list[np.ndarray]) -> "SpeechDetector":
        """Record the balanced agreement with reference masks (the training audio's VAD)."""
        pred = np.concatenate([self.flags(F) for F in feats])
        y = np.concatenate([np.asarray(m, dtype=bool) for m in masks])
        if y.all() or (~y).all():
            self.accuracy = float(np.mean(pred == y))
        else:
            self.accuracy = float(0.5 * (np.mean(pred[y]) + np.mean(~pred[~y])))
        return self

    def to_arrays(self) -> dict:
        return {"vad_energy": np.array([self.col, self.mu, self.sd, self.db_per_unit, self.accuracy, self.fps,
                                        self.window_s, self.min_snr_db, self.silence_db], dtype=np.float64)}

    @classmethod
    def from_arrays(cls, arrays) -> "SpeechDetector | None":
        if "vad_energy" not in arrays:
            return None
        v = np.asarray(arrays["vad_energy"], dtype=np.float64)
        return cls(col=int(v[0]), mu=float(v[1]), sd=float(v[2]), db_per_unit=float(v[3]), accuracy=float(v[4]),
                   fps=float(v[5]), window_s=float(v[6]), min_snr_db=float(v[7]), silence_db=float(v[8]))


class SpeechTracker:
    """The detector's state over one utterance: push feature frames in order, get their flags."""

    update_frames = 10
    stride = 5

    def __init__(self, det: SpeechDetector):
        self.det = det
        self.W = max(2, int(round(det.window_s * det.fps)))
        self._ebuf = np.zeros(2 * self.W + 64)   # storage of ``e``, shifted down when full
        self._elen = 0
        self.e_off = 0             # the absolute frame index of e[0]
        self.n = 0                 # frames pushed so far
        self.stats = (np.nan, np.nan)  # (floor, level) of the latest update
        self._lags = np.arange(0, self.W, self.stride)   # a full window: frames u - lags

    @property
    def e(self) -> np.ndarray:
        """The energies (dB) held: frames ``e_off …`` (at least the last W)."""
        return self._ebuf[:self._elen]

    def _append(self, e: np.ndarray) -> None:
        k = len(e)
        if self._elen + k > len(self._ebuf):
            # forget what no later window can reach (memory and time per push stay bounded)
            drop = max(self._elen - self.W, 0)
            keep = self._ebuf[drop:self._elen].copy()
            if len(keep) + k > len(self._ebuf):
                self._ebuf = np.zeros(2 * (len(keep) + k))
            self._ebuf[:len(keep)] = keep
            self._elen = len(keep)
            self.e_off += drop
        self._ebuf[self._elen:self._elen + k] = e
        self._elen += k

    def _window(self, u: int) -> np.ndarray:
        return self.e[max(0, u - self.W + 1) - self.e_off: u + 1 - self.e_off][::-1][:: self.stride]

    def push(self, F: np.ndarray) -> np.ndarray:
        """Flags of the next feature frames (normalised rows of the system's features)."""
        if len(F) == 0:
            return np.zeros(0, dtype=bool)
        if len(F) == 1 and self.n >= self.update_frames - 1:
            d = self.det
            return np.array([self.push_one_db((float(F[0, d.col]) * d.sd + d.mu) * d.db_per_unit)])
        return self.push_db(self.det.energy_db(F))

    def push_one_db(self, e: float) -> bool:
        """The flag of the next frame given its energy in dB, once the first ``update_frames - 1``
        frames are in: :meth:`push_db` of one frame with the same operations on scalars (the
        percentiles, every ``update_frames`` frames, by the same numpy calls)."""
        u = self.n
        if u < self.update_frames - 1:
            return bool(self.push_db(np.array([e]))[0])
        if self._elen == len(self._ebuf):
            self._append(np.array([e]))
        else:
            self._ebuf[self._elen] = e
            self._elen += 1
        self.n += 1
        if (u + 1) % self.update_frames == 0:
            if u >= self.W - 1:
                st = np.percentile(self.e[(u - self._lags)[None, :] - self.e_off], ENERGY_PERCENTILES, axis=1)[:, 0]
            else:
                st = np.percentile(self._window(u), ENERGY_PERCENTILES)
            self.stats = (float(st[0]), float(st[1]))
        floor, level = self.stats
        d = self.det
        rng = level - floor
        if rng < d.min_snr_db:
            return e > d.silence_db
        return e > floor + max(d.min_snr_db, LEVEL_SHARE * rng)

    def push_db(self, e: np.ndarray) -> np.ndarray:
        """Flags of the next frames given their energies in dB (for systems whose features have no
        ``energy`` column, e.g. le2012's loudness converted to dB)."""
        e = np.asarray(e, dtype=np.float64).ravel()
        if len(e) == 0:
            return np.zeros(0, dtype=bool)
        t0 = self.n
        self._append(e)
        self.n += len(e)
        n = len(e)
        K = self.update_frames
        floor = np.empty(n)
        level = np.empty(n)
        # the first K-1 frames of the utterance: their own (short) windows
        for i in range(0, max(0, min(n, K - 1 - t0))):
            floor[i], level[i] = np.percentile(self._window(t0 + i), ENERGY_PERCENTILES)
        # update points u ((u+1) % K == 0) inside the chunk; frames use the latest update <= t
        lo = max(t0, K - 1)
        ups = np.arange(lo + (-(lo + 1)) % K, t0 + n, K)
        if len(ups):
            full = ups[ups >= self.W - 1]
            part = ups[ups < self.W - 1]
            st = np.empty((len(ups), 2))
            for k, u in enumerate(part):
                st[k] = np.percentile(self._window(int(u)), ENERGY_PERCENTILES)
            if len(full):
                idx = full[:, None] - np.arange(0, self.W, self.stride)[None, :]
                st[len(part):] = np.percentile(self.e[idx - self.e_off], ENERGY_PERCENTILES, axis=1).T
        i0 = max(0, K - 1 - t0)
        if i0 < n:
            tt = np.arange(t0 + i0, t0 + n)
            j = np.searchsorted(ups, tt, side="right") - 1
            prev = np.asarray(self.stats)
            got = st[np.maximum(j, 0)] if len(ups) else np.tile(prev, (len(tt), 1))
            got = np.where((j >= 0)[:, None], got, prev[None, :])
            floor[i0:], level[i0:] = got[:, 0], got[:, 1]
        if len(ups):
            self.stats = (float(st[-1, 0]), float(st[-1, 1]))
        rng = level - floor
        thr = floor + np.maximum(self.det.min_snr_db, LEVEL_SHARE * rng)
        return np.where(rng < self.det.min_snr_db, e > self.det.silence_db, e > thr)


__all__ = ["SpeechDetector", "SpeechTracker"]
