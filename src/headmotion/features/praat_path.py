"""Praat's pitch read as the audio arrives: Praat's candidates frame by frame, its path searched
forward — the ``f0e-live`` columns with F0 and voicing from Praat's autocorrelation method
(Boersma 1993, through parselmouth) at a fixed cost per frame.

Praat's reading has two parts.  Each analysis frame's **candidates** (periods with their
autocorrelation strengths, and an unvoiced candidate) depend on that frame's window of audio
alone (3 periods of the pitch floor: 40 ms at 75 Hz).  Its **path search** then chooses one
candidate per frame by Viterbi over the whole read, with the costs Boersma (1993) states and
Praat's manual gives (voicing, silence and octave costs, an octave-jump cost per octave and a
voiced/unvoiced cost per change, both scaled by ``0.01 s / step``; candidates at or above the
ceiling count as unvoiced).

:class:`.praat_stream.StreamingPraatF0e` reads the last 0.3 s for every frame: 15 analysis frames
analysed again per frame, and a path that forgets everything before them.  Here each analysis
frame is read **once** (one Praat call on exactly its window), and the path search runs
**forward** over everything heard so far: a frame's value is the end of the best path to it
(its forward score's best candidate), final as soon as its window is in — 40 ms after the frame's
start at 25 fps, a 20 ms step and a 75 Hz floor.  The forward search is
:func:`path_scores`; over a whole read with its backtrace it gives Praat's own path
(tests/test_praat_path.py).

Praat's silence cost compares a frame's local peak with the read's global peak.  A stream has no
global peak, so the peak is the **running peak**: the loudest frame so far, halving every
``peak_half_life_s``.  A frame's local peak is Praat's own (its intensity on a read of exactly the
window, times that window's peak about its mean), so every frame's reading depends only on the
audio up to its window's end, whatever the chunking.  Why this reader: docs/decisions/read-any-voice.md.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from .prosody import PITCH_CEILING, PITCH_FLOOR
from .streaming import StreamingF0e

#: Praat's defaults for speech: voicing and silence thresholds, octave cost, octave-jump cost and
#: voiced/unvoiced cost (the last two per 10 ms, scaled by 0.01 s / step)
PRAAT_VOICING = 0.45
PRAAT_SILENCE = 0.03
OCTAVE_COST = 0.01
OCTAVE_JUMP_COST = 0.35
VOICED_UNVOICED_COST = 0.14
#: Praat's most candidates per frame
MAX_CANDIDATES = 15
#: seconds over which the running peak halves
PEAK_HALF_LIFE_S = 10.0


def local_strengths(freq: np.ndarray, strength: np.ndarray, peak_ratio: float, *, ceiling: float,
                    voicing_threshold: float = PRAAT_VOICING, silence_threshold: float = PRAAT_SILENCE,
                    octave_cost: float = OCTAVE_COST) -> tuple[np.ndarray, np.ndarray]:
    """One frame's candidate strengths as the path search weighs them (Boersma 1993, eq. 24 and
    the unvoiced candidate's strength): voiced candidates ``r − octave_cost · log2(ceiling / F)``,
    unvoiced ones (F = 0 or F ≥ ceiling) ``voicing_threshold + max(0, 2 − peak_ratio ·
    (1 + voicing_threshold) / silence_threshold)``.  Returns ``(strengths, voiced mask)``."""
    voiced = (freq > 0) & (freq < ceiling)
    unvoiced = voicing_threshold + max(0.0, 2.0 - peak_ratio * (1.0 + voicing_threshold) / silence_threshold)
    return np.where(voiced, strength - octave_cost * np.log2(ceiling / np.where(voiced, freq, 1.0)), unvoiced), voiced


def transition_costs(log2_prev: np.ndarray, voiced_prev: np.ndarray, log2_next: np.ndarray, voiced_next: np.ndarray,
                     *, step: float, octave_jump_cost: float = OCTAVE_JUMP_COST,
                     voiced_unvoiced_cost: float = VOICED_UNVOICED_COST) -> np.ndarray:
    """Praat's cost of going from each candidate of a frame to each of the next, ``(k_prev, k_next)``:
    octaves jumped times the octave-jump cost between voiced ones, the voiced/unvoiced cost between
    a voiced and an unvoiced one, nothing between unvoiced ones; both scaled by ``0.01 s / step``."""
    scale = 0.01 / step
    a, b = voiced_prev[:, None], voiced_next[None, :]
    jump = octave_jump_cost * scale * np.abs(log2_prev[:, None] - log2_next[None, :])
    return np.where(a & b, jump, np.where(a ^ b, voiced_unvoiced_cost * scale, 0.0))


def path_scores(prev: np.ndarray | None, costs: np.ndarray | None, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One forward step of the path search: each candidate's best score (the best predecessor's
    score less the transition cost, plus its own strength) and that predecessor.  ``prev`` None:
    the first frame (the scores are its strengths)."""
    if prev is None:
        return local.copy(), np.zeros(len(local), np.int64)
    total = prev[:, None] - costs
    back = np.argmax(total, axis=0)
    return total[back, np.arange(total.shape[1])] + local, back


def praat_candidates(window: np.ndarray, sample_rate: int, *, step: float, floor: float, ceiling: float,
                     voicing_threshold: float = PRAAT_VOICING, silence_threshold: float = PRAAT_SILENCE):
    """Praat's candidates of the one analysis frame a read of exactly ``window`` holds: frequencies
    and strengths (in Praat's order) and the frame's local peak (Praat's intensity of it times the
    window's peak about its mean)."""
    import parselmouth

    if not len(window):
        return np.zeros(1), np.zeros(1), 0.0
    mean = float(np.add.reduce(window)) / len(window)
    peak = max(float(window.max()) - mean, mean - float(window.min()))   # max |window − mean|
    if peak == 0.0:
        return np.zeros(1), np.zeros(1), 0.0
    snd = parselmouth.Sound(window, sampling_frequency=float(sample_rate))
    try:
        pitch = snd.to_pitch_ac(time_step=step, pitch_floor=floor, pitch_ceiling=ceiling,
                                max_number_of_candidates=MAX_CANDIDATES, silence_threshold=silence_threshold,
                                voicing_threshold=voicing_threshold)
    except parselmouth.PraatError:  # (cannot happen on a full window; read as unvoiced)
        return np.zeros(1), np.zeros(1), 0.0
    if pitch.n_frames < 1:
        return np.zeros(1), np.zeros(1), 0.0
    i = (pitch.n_frames - 1) // 2
    arr = pitch.to_array()[:, i]
    freq, strength = arr["frequency"], arr["strength"]
    ok = ~np.isnan(freq)
    if not ok.all():
        freq, strength = freq[ok], strength[ok]
    return freq, strength, float(pitch.get_frame(i + 1).intensity) * peak


class PraatPathF0e(StreamingF0e):
    """:class:`.streaming.StreamingF0e` with F0 and voicing from Praat's candidates, read frame by
    frame, and its path searched forward.

    Parameters
    ----------
    praat_step : float or None, Praat's analysis step in seconds (None: ``min(0.02, 1 / fps)``)
    voicing_threshold, silence_threshold, octave_cost, octave_jump_cost, voiced_unvoiced_cost :
        Praat's settings (its defaults for speech)
    peak_half_life_s : float, seconds over which the running peak halves (> 0)
    **kw : the other parameters of :class:`.streaming.StreamingF0e` (energy, smoothing, deltas)
    """

    step_samples: float | None = None   # analysis step in samples (set by the constructor)

    def __init__(self, *, praat_step: float | None = None, voicing_threshold: float = PRAAT_VOICING,
                 silence_threshold: float = PRAAT_SILENCE, octave_cost: float = OCTAVE_COST,
                 octave_jump_cost: float = OCTAVE_JUMP_COST, voiced_unvoiced_cost: float = VOICED_UNVOICED_COST,
                 peak_half_life_s: float = PEAK_HALF_LIFE_S, max_jump_semitones: float = 0.0, **kw):
        super().__init__(voicing_threshold=voicing_threshold, max_jump_semitones=max_jump_semitones, **kw)
        step = min(0.02, 1.0 / self.fps) if praat_step is None else float(praat_step)
        if not (math.isfinite(step) and step > 0):
            raise ParameterError(f"praat_step must be positive seconds; got {praat_step!r}")
        if not (math.isfinite(peak_half_life_s) and peak_half_life_s > 0):
            raise ParameterError(f"peak_half_life_s must be positive seconds; got {peak_half_life_s!r}")
        for name, v in (("silence_threshold", silence_threshold), ("octave_cost", octave_cost),
                        ("octave_jump_cost", octave_jump_cost), ("voiced_unvoiced_cost", voiced_unvoiced_cost)):
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"{name} must be a finite number >= 0; got {v!r}")
        if silence_threshold <= 0:
            raise ParameterError(f"silence_threshold must be > 0; got {silence_threshold!r}")
        self.step = step
        self.floor = float(kw.get("pitch_floor", PITCH_FLOOR))
        self.ceiling = float(kw.get("pitch_ceiling", PITCH_CEILING))
        self.costs = {"voicing_threshold": float(voicing_threshold), "silence_threshold": float(silence_threshold),
                      "octave_cost": float(octave_cost)}
        self.jump_costs = {"octave_jump_cost": float(octave_jump_cost), "voiced_unvoiced_cost": float(voiced_unvoiced_cost)}
        # Praat's window: 3 periods of the floor, one analysis frame centred in it
        self.praat_win = int(math.ceil(3.0 / self.floor * self.sample_rate))
        self.step_samples = step * self.sample_rate
        self._decay = 0.5 ** (step / peak_half_life_s)
        # state: the analysis frames read so far, the running peak and the forward search
        self._n_grid = 0
        self._peak = 0.0
        self._scores: np.ndarray | None = None
        self._log2: np.ndarray | None = None
        self._cand_voiced: np.ndarray | None = None
        self._best_f = 0.0   # the last analysis frame's chosen frequency (0: unvoiced)
        self._need_next = self._needed(0)

    # -- geometry --------------------------------------------------------------------------------
    def _grid_start(self, j: int) -> int:
        """First sample of analysis frame ``j``'s window (frame 0 centred on frame 0's centre)."""
        return int(math.floor(self._centre(0) + j * self.step_samples - self.praat_win / 2 + 0.5))

    def _grid_of(self, t: int) -> int:
        """The analysis frame frame ``t`` takes its value from: the last one centred at or before
        its centre."""
        return int(math.floor((self._centre(t) - self._centre(0)) / self.step_samples + 1e-9))

    def _needed(self, t: int) -> int:
        if self.step_samples is None:  # (StreamingF0e's constructor asks before the grid is set)
            return super()._needed(t)
        return max(self._grid_start(self._grid_of(t)) + self.praat_win, self._start(t, self.win) + self.win)

    def _first_needed(self) -> int:
        return min(self._grid_start(self._n_grid), self._start(self._n_static, self.win), self._n_in)

    # -- analysis --------------------------------------------------------------------------------
    def _window(self, s0: int) -> np.ndarray:
        """Samples ``[s0, s0 + praat_win)``; zeros outside the pushed samples."""
        n = self.praat_win
        a = s0 - self._buf0
        if s0 >= self._buf0 and s0 + n <= self._n_in:
            return self._abuf[a:a + n]
        seg = np.zeros(n)
        lo, hi = max(s0, self._buf0, 0), min(s0 + n, self._n_in)
        if hi > lo:
            seg[lo - s0:hi - s0] = self._buf[lo - self._buf0:hi - self._buf0]
        return seg

    def _advance_path(self, j: int) -> None:
        """Read analysis frame ``j`` and take the forward search one frame on."""
        freq, strength, local_peak = praat_candidates(self._window(self._grid_start(j)), self.sample_rate,
                                                      step=self.step, floor=self.floor, ceiling=self.ceiling,
                                                      voicing_threshold=self.costs["voicing_threshold"],
                                                      silence_threshold=self.costs["silence_threshold"])
        self._peak = max(self._peak * self._decay, local_peak)
        ratio = local_peak / self._peak if self._peak > 0 else 0.0
        local, voiced = local_strengths(freq, strength, ratio, ceiling=self.ceiling, **self.costs)
        log2 = np.log2(np.where(voiced, freq, 1.0))
        costs = None
        if self._scores is not None:
            costs = transition_costs(self._log2, self._cand_voiced, log2, voiced, step=self.step, **self.jump_costs)
        scores, _ = path_scores(self._scores, costs, local)
        scores -= scores.max()   # (kept near 0 over a long stream; the choice does not change)
        self._scores, self._log2, self._cand_voiced = scores, log2, voiced
        best = int(np.argmax(scores))
        self._best_f = float(freq[best]) if voiced[best] else 0.0
        self._n_grid = j + 1

    def _static_frames(self, t0: int, t1: int) -> None:
        energy = self._energy_db(t0, t1)
        logf0, voiced = np.zeros(t1 - t0), np.zeros(t1 - t0, bool)
        for k, t in enumerate(range(t0, t1)):
            for j in range(self._n_grid, self._grid_of(t) + 1):
                self._advance_path(j)
            f = self._best_f
            v = self._hold(t, f > 0 and bool(energy[k] > self.silence_db), math.log(f) if f > 0 else 0.0)
            logf0[k], voiced[k] = self._last_logf0, v
        self._static.extend(np.stack([logf0, energy], axis=1))
        self._voiced.extend(voiced.astype(np.float64))

    def _static_one(self, t: int) -> None:
        self._static_frames(t, t + 1)


__all__ = ["PraatPathF0e", "local_strengths", "transition_costs", "path_scores", "praat_candidates",
           "PRAAT_VOICING", "PRAAT_SILENCE", "OCTAVE_COST", "OCTAVE_JUMP_COST", "VOICED_UNVOICED_COST",
           "PEAK_HALF_LIFE_S"]
