"""Praat's pitch read on a stream, block by block: the ``f0e-live`` columns with F0 and voicing from
Praat's autocorrelation method (Boersma 1993, through parselmouth) instead of per-frame YIN.

Praat (the ``f0e`` set's tracker, :mod:`.prosody`) reads a whole file: its voicing decision and its
path search (the candidates' octave and voicing costs, resolved by Viterbi) see every frame.  It
cannot run on a stream as it stands, and a two-hour file held whole costs gigabytes.  Here the
frames are grouped in **blocks** of ``praat_block`` frames; each block is read by one Praat call on
the audio from ``praat_back_s`` before the block to ``praat_ahead_s`` after it (plus the half
analysis window and one Praat frame its last frame needs).  A frame's value depends only on its
block's audio, so a stream and a whole file give the same bits whatever the chunking, and the audio
held is one read's worth:

* **offline** (the ``default`` model): blocks of 30 s read with 1 s on each side at one 40 ms
  analysis step a frame, unvoiced frames' log F0 interpolated between the voiced frames around them where the read holds both (the rule of
  the ``f0e`` set, thesis §2.2.4), held otherwise;
* **live** (the ``stream`` model and the listening head): a block of one frame read on the last
  ``praat_back_s`` of audio and nothing after it, unvoiced frames holding the last voiced value; a
  frame is final once the audio to its centre plus 30 ms (half of Praat's 40 ms window at a 75 Hz
  floor, and half its 20 ms analysis step) is in: 50 ms after the frame's start at 25 fps.

Energy, smoothing, deltas and the voicing column are those of :class:`.streaming.StreamingF0e`;
frames quieter than ``silence_db`` are unvoiced whatever Praat says.  Praat's silence threshold is
relative to the loudest sample of what it reads — over a whole file, the speech's peak; over 0.3 s
of a pause, the pause's own noise, which it would then read for voice.  So each read's threshold is
set relative to the **running peak** instead: the loudest sample read so far, decaying by half every
``peak_half_life_s`` (a causal stand-in for the file's peak; a long read's own peak where that is
higher).  The octave-jump guard is off by default:
Praat's path search is what keeps octaves apart.  Why this reader and these settings:
docs/decisions/read-any-voice.md.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from .prosody import PITCH_CEILING, PITCH_FLOOR
from .streaming import StreamingF0e

#: Praat's voicing threshold (its own default for speech) and silence threshold
PRAAT_VOICING = 0.45
PRAAT_SILENCE = 0.03
#: seconds over which the running peak (the silence threshold's reference) halves
PEAK_HALF_LIFE_S = 10.0


class StreamingPraatF0e(StreamingF0e):
    """:class:`.streaming.StreamingF0e` with F0 and voicing read by Praat in blocks.

    Parameters
    ----------
    praat_block : int, frames per Praat call
    praat_back_s, praat_ahead_s : float, seconds of audio read before and after a block
    praat_step : float or None, Praat's analysis step in seconds (None: ``min(0.02, 1 / fps)``)
    interpolate : bool, unvoiced frames' log F0 interpolated between the voiced frames of the read
        around them (else held from the last voiced frame)
    voicing_threshold : float, Praat's voicing threshold (0.45, Praat's default)
    peak_half_life_s : float, seconds over which the running peak the silence threshold is relative
        to halves (0: each read's own peak, as Praat on that read alone)
    **kw : the other parameters of :class:`.streaming.StreamingF0e` (energy, smoothing, deltas)
    """

    B: int | None = None   # frames per block (set by the constructor)

    def __init__(self, *, praat_block: int = 1, praat_back_s: float = 0.5, praat_ahead_s: float = 0.0,
                 praat_step: float | None = None, interpolate: bool = False,
                 voicing_threshold: float = PRAAT_VOICING, max_jump_semitones: float = 0.0,
                 peak_half_life_s: float = PEAK_HALF_LIFE_S, **kw):
        super().__init__(voicing_threshold=voicing_threshold, max_jump_semitones=max_jump_semitones, **kw)
        if not (isinstance(praat_block, (int, np.integer)) and praat_block >= 1):
            raise ParameterError(f"praat_block must be a whole number of frames >= 1; got {praat_block!r}")
        if not (praat_back_s >= 0 and praat_ahead_s >= 0):
            raise ParameterError(f"praat_back_s and praat_ahead_s must be >= 0 seconds; got {praat_back_s}, "
                                 f"{praat_ahead_s}")
        step = min(0.02, 1.0 / self.fps) if praat_step is None else float(praat_step)
        if not step > 0:
            raise ParameterError(f"praat_step must be positive seconds; got {praat_step!r}")
        self.B = int(praat_block)
        self.step = step
        self.back = int(round(praat_back_s * self.sample_rate))
        self.ahead = int(round(praat_ahead_s * self.sample_rate))
        self.interpolate = bool(interpolate)
        self.floor = float(kw.get("pitch_floor", PITCH_FLOOR))
        self.ceiling = float(kw.get("pitch_ceiling", PITCH_CEILING))
        # Praat's frames are centred in what it reads: with half its window (3 periods of the floor)
        # and half a step past a frame's centre, its last frame lies within half a step of that centre
        self.edge = int(math.ceil((1.5 / self.floor + 0.5 * step) * self.sample_rate))
        self._prev_voiced: int | None = None   # the last voiced frame (interpolation starts there)
        if not peak_half_life_s >= 0:
            raise ParameterError(f"peak_half_life_s must be >= 0 seconds; got {peak_half_life_s!r}")
        # the running peak decays per block by this factor (0: none kept)
        self._decay = 0.5 ** (self.B / self.fps / peak_half_life_s) if peak_half_life_s > 0 else 0.0
        self._peak = 0.0
        self._need_next = self._needed(0)

    # -- geometry ------------------------------------------------------------------------------
    def _read_span(self, b: int) -> tuple[int, int]:
        """Samples ``[s0, s1)`` block ``b`` reads (``s1`` may lie past the input at the end)."""
        s0 = max(0, int(math.floor(b * self.B * self.sample_rate / self.fps)) - self.back)
        s1 = int(math.ceil(self._centre((b + 1) * self.B - 1))) + self.edge + self.ahead
        return s0, s1

    def _needed(self, t: int) -> int:
        if self.B is None:  # (StreamingF0e's constructor asks before the blocks are set)
            return super()._needed(t)
        return max(self._read_span(t // self.B)[1], self._start(t, self.win) + self.win)

    def _static_ready(self) -> int:
        if self._total is not None:
            return self._total
        b = max(self._n_static // self.B, int(self._n_in * self.fps / self.sample_rate) // self.B - 1)
        while b > self._n_static // self.B and self._read_span(b - 1)[1] > self._n_in:
            b -= 1
        while self._read_span(b)[1] <= self._n_in:
            b += 1
        return max(self._n_static, b * self.B)

    def _first_needed(self) -> int:
        return min(self._read_span(self._n_static // self.B)[0], self._start(self._n_static, self.win), self._n_in)

    # -- analysis --------------------------------------------------------------------------------
    def _praat(self, b: int) -> tuple[np.ndarray, np.ndarray, int]:
        """Praat's reading of block ``b``: log F0 and voicing at the centres of the frames from the
        block's first to the last one its read covers, and that first frame."""
        import parselmouth

        s0, s1 = self._read_span(b)
        s1 = min(s1, self._n_in)
        t0 = b * self.B
        t_last = int(math.floor((s1 - self.edge) * self.fps / self.sample_rate - 0.5))  # frames Praat reaches
        t_last = max(t_last, t0 + self.B - 1)
        if self._total is not None:
            t_last = min(t_last, self._total - 1)
        n = max(t_last - t0 + 1, 0)
        logf0, voiced = np.zeros(n), np.zeros(n, bool)
        seg = self._buf[s0 - self._buf0:s1 - self._buf0]
        if n == 0 or len(seg) == 0:
            return logf0, voiced, t0
        own = float(np.max(np.abs(seg)))
        self._peak = max(self._peak * self._decay, own)
        silence = min(PRAAT_SILENCE * self._peak / own, 1.0) if own > 0 else PRAAT_SILENCE
        snd = parselmouth.Sound(seg, sampling_frequency=float(self.sample_rate), start_time=s0 / self.sample_rate)
        try:
            pitch = snd.to_pitch_ac(time_step=self.step, pitch_floor=self.floor, pitch_ceiling=self.ceiling,
                                    max_number_of_candidates=15, silence_threshold=silence,
                                    voicing_threshold=self.voicing_threshold)
        except parselmouth.PraatError:  # shorter than Praat's window: nothing voiced
            return logf0, voiced, t0
        times = np.asarray(pitch.xs(), dtype=np.float64)
        freq = np.asarray(pitch.selected_array["frequency"], dtype=np.float64)
        if times.size == 0:
            return logf0, voiced, t0
        centres = (np.arange(t0, t0 + n) + 0.5) / self.fps
        k = np.clip(np.round((centres - times[0]) / pitch.dt).astype(np.int64), 0, len(times) - 1)
        f = freq[k]
        voiced = (f > 0) & (np.abs(centres - times[k]) <= pitch.dt)
        logf0[voiced] = np.log(f[voiced])
        return logf0, voiced, t0

    def _static_frames(self, t0: int, t1: int) -> None:
        energy = self._energy_db(t0, t1)
        logf0, voiced = np.zeros(t1 - t0), np.zeros(t1 - t0, bool)
        for b in range(t0 // self.B, (t1 - 1) // self.B + 1):
            lf, v, first = self._praat(b)
            a, e = max(t0, first), min(t1, (b + 1) * self.B)
            loud = energy[a - t0:e - t0] > self.silence_db
            vb = v[a - first:e - first] & loud
            logf0[a - t0:e - t0] = self._fill(lf[a - first:e - first], vb, lf[e - first:], v[e - first:], a)
            voiced[a - t0:e - t0] = vb  # (the octave guard, when on, may have unvoiced some)
        self._static.extend(np.stack([logf0, energy], axis=1))
        self._voiced.extend(voiced.astype(np.float64))

    def _fill(self, lf: np.ndarray, v: np.ndarray, lf_after: np.ndarray, v_after: np.ndarray, t0: int) -> np.ndarray:
        """Log F0 of a block's frames ``t0 …``: voiced frames their own (through the octave guard
        when it is on), unvoiced ones held, or interpolated towards the next voiced frame of the read."""
        out = np.empty(len(lf))
        nxt = None
        if self.interpolate:
            later = np.flatnonzero(v_after)
            if later.size:
                nxt = (t0 + len(lf) + int(later[0]), float(lf_after[later[0]]))
        for i in range(len(lf)):
            t = t0 + i
            if v[i] and self._hold(t, True, float(lf[i])):
                self._prev_voiced = t
                out[i] = self._last_logf0
                continue
            v[i] = False
            target = None
            if self.interpolate:
                j = np.flatnonzero(v[i + 1:])
                target = (t + 1 + int(j[0]), float(lf[i + 1 + j[0]])) if j.size else nxt
            prev = self._prev_voiced
            if target is None:
                out[i] = self._last_logf0
            elif prev is None:          # before the first voiced frame: the first voiced value
                out[i] = target[1]
            else:
                w = (t - prev) / (target[0] - prev)
                out[i] = (1.0 - w) * self._last_logf0 + w * target[1]
        return out

    def _static_one(self, t: int) -> None:
        self._static_frames(t, t + 1)


__all__ = ["StreamingPraatF0e", "PRAAT_VOICING", "PRAAT_SILENCE", "PEAK_HALF_LIFE_S"]
