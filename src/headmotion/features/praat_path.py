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
frame is read **once** (Praat reads exactly its window; the frames that are ready are read by one
call, their windows laid side by side, :func:`praat_candidates`), and the path search runs
**forward** over everything heard so far: a frame's value is the end of the best path to it
(its forward score's best candidate), final as soon as its window is in — 40 ms after the frame's
start at 25 fps, a 20 ms step and a 75 Hz floor.  The forward search is
:func:`path_scores`; over a whole read with its backtrace it gives Praat's own path
(tests/test_praat_path.py).

Praat's silence cost compares a frame's local peak with the read's global peak.  A stream has no
global peak, so the peak is the **running peak**: the loudest frame so far, halving every
``peak_half_life_s``.  A frame's local peak is Praat's own (:func:`local_peaks`), so every frame's
reading depends only on the audio up to its window's end, whatever the chunking.  Why this reader: docs/decisions/read-any-voice.md.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

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
#: analysis frames read by one Praat call at most (a long push is read in blocks: bounded memory)
BLOCK = 256


def local_strengths(freq: np.ndarray, strength: np.ndarray, peak_ratio, *, ceiling: float,
                    voicing_threshold: float = PRAAT_VOICING, silence_threshold: float = PRAAT_SILENCE,
                    octave_cost: float = OCTAVE_COST) -> tuple[np.ndarray, np.ndarray]:
    """Candidate strengths as the path search weighs them (Boersma 1993, eq. 24 and the unvoiced
    candidate's strength): voiced candidates ``r − octave_cost · log2(ceiling / F)``, unvoiced ones
    (F = 0 or F ≥ ceiling) ``voicing_threshold + max(0, 2 − peak_ratio · (1 + voicing_threshold) /
    silence_threshold)``; ``−inf`` where F is NaN (no candidate: a frame with fewer than others).
    One frame (``freq`` ``(K,)``, ``peak_ratio`` a number) or many (``(n, K)`` and ``(n,)``).
    Returns ``(strengths, voiced mask)``."""
    voiced = (freq > 0) & (freq < ceiling)
    unvoiced = voicing_threshold + np.maximum(0.0, 2.0 - np.asarray(peak_ratio, dtype=np.float64)
                                              * (1.0 + voicing_threshold) / silence_threshold)
    if unvoiced.ndim:
        unvoiced = unvoiced[:, None]
    local = np.where(voiced, strength - octave_cost * np.log2(ceiling / np.where(voiced, freq, 1.0)), unvoiced)
    return np.where(np.isnan(freq), -np.inf, local), voiced


def transition_costs(log2_prev: np.ndarray, voiced_prev: np.ndarray, log2_next: np.ndarray, voiced_next: np.ndarray,
                     *, step: float, octave_jump_cost: float = OCTAVE_JUMP_COST,
                     voiced_unvoiced_cost: float = VOICED_UNVOICED_COST) -> np.ndarray:
    """Praat's cost of going from each candidate of a frame to each of the next, ``(k_prev, k_next)``
    (or ``(n, k_prev, k_next)`` for ``n`` pairs of frames): octaves jumped times the octave-jump cost
    between voiced ones, the voiced/unvoiced cost between a voiced and an unvoiced one, nothing
    between unvoiced ones; both scaled by ``0.01 s / step``."""
    scale = 0.01 / step
    a, b = voiced_prev[..., :, None], voiced_next[..., None, :]
    jump = octave_jump_cost * scale * np.abs(log2_prev[..., :, None] - log2_next[..., None, :])
    return np.where(a & b, jump, np.where(a ^ b, voiced_unvoiced_cost * scale, 0.0))


def path_scores(prev: np.ndarray | None, costs: np.ndarray | None, local: np.ndarray, *,
                back: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """One forward step of the path search: each candidate's best score (the best predecessor's
    score less the transition cost, plus its own strength) and that predecessor (None with
    ``back=False``: a forward search that needs no backtrace).  ``prev`` None: the first frame (the
    scores are its strengths)."""
    if prev is None:
        return local.copy(), (np.zeros(len(local), np.int64) if back else None)
    total = prev[:, None] - costs
    return total.max(axis=0) + local, (np.argmax(total, axis=0) if back else None)


@functools.lru_cache(maxsize=16)
def _peak_geometry(width: int, sample_rate: int, floor: float) -> tuple[slice, int, slice, np.ndarray]:
    """For :func:`local_peaks`: the local mean's samples and count, the local peak's samples and
    the Hanning window's values on them (Praat's ``Sound_to_Pitch`` geometry for a frame centred
    in ``width`` samples)."""
    n_period = int(math.floor(sample_rate / floor))
    half_period = n_period // 2 + 1
    half = int(math.floor(3.0 / floor * sample_rate)) // 2 - 1
    n_window = 2 * half
    left = (width + 1) // 2 - 1   # 0-based samples either side of the centre
    right = left + 1
    j0, j1 = max(1, half + 1 - half_period), min(n_window, half + half_period)
    hann = 0.5 - 0.5 * np.cos(np.arange(j0, j1 + 1) * 2.0 * math.pi / (n_window + 1))
    hann.setflags(write=False)
    return slice(right - n_period, left + n_period + 1), 2 * n_period, slice(right - half + j0 - 1, right - half + j1), hann


def local_peaks(windows: np.ndarray, sample_rate: int, *, floor: float) -> np.ndarray:
    """Praat's local peak of the one analysis frame centred in each row of ``windows`` ``(n, W)``:
    the largest ``|x − local mean| · Hanning`` within half a longest period (``1 / floor``) of the
    centre, the local mean taken over a longest period to each side (Boersma 1993; Praat's
    ``Sound_to_Pitch``), at most the row's own peak about its mean (as Praat's read of the row
    alone caps it: its intensity is at most 1).  Row by row, so a frame's value does not depend
    on the rows read with it."""
    around, count, centre, hann = _peak_geometry(windows.shape[1], int(sample_rate), float(floor))
    mean = np.add.reduce(windows[:, around], axis=1) / count
    local = np.max(np.abs((windows[:, centre] - mean[:, None]) * hann), axis=1)
    whole = np.add.reduce(windows, axis=1) / windows.shape[1]
    own = np.maximum(windows.max(axis=1) - whole, whole - windows.min(axis=1))
    return np.minimum(local, own)


def praat_candidates(windows: np.ndarray, sample_rate: int, *, floor: float, ceiling: float,
                     voicing_threshold: float = PRAAT_VOICING, silence_threshold: float = PRAAT_SILENCE):
    """Praat's candidates of the analysis frame centred in each row of ``windows`` ``(n, W)``, all
    read by **one** Praat call on the rows laid side by side (a time step of one row, so each
    analysis frame reads exactly its own row).  Returns ``(frequencies, strengths, local peaks)``:
    ``(n, K)``, ``(n, K)`` and ``(n,)``, each row's candidates sorted by frequency and strength and
    padded with NaN (frequency 0: the unvoiced candidate; a row without a peak has it alone).

    A frame's candidates depend on its window alone (Praat's ``Sound_into_PitchFrame``); only
    their order depends on the read (Praat's path search moves its choice to the front), so
    sorted they are the same bits whether a row is read alone, among a stream's other frames or
    among other streams' (tests/test_praat_path.py).  The local peak is :func:`local_peaks`."""
    import parselmouth

    windows = np.ascontiguousarray(windows, dtype=np.float64)
    n, W = windows.shape
    freq, strength = np.full((n, 1), np.nan), np.full((n, 1), np.nan)
    if n == 0:
        return freq, strength, np.zeros(0)
    peaks = local_peaks(windows, sample_rate, floor=floor)
    silent = peaks == 0   # a constant row or a flat centre: voicelessness alone (Praat: a local peak of 0)
    if not silent.all():
        # a quarter of a row of zeros at each end: Praat fits n frames, centred, with room to spare
        pad = max(1, W // 4)
        buf = np.zeros(n * W + 2 * pad)
        buf[pad:pad + n * W] = windows.reshape(-1)
        pitch = parselmouth.Sound(buf, sampling_frequency=float(sample_rate)).to_pitch_ac(
            time_step=W / sample_rate, pitch_floor=floor, pitch_ceiling=ceiling,
            max_number_of_candidates=MAX_CANDIDATES, silence_threshold=silence_threshold,
            voicing_threshold=voicing_threshold)
        if pitch.n_frames != n:   # (cannot happen: the padding keeps Praat's frame count off a rounding edge)
            raise AssertionError(f"Praat fitted {pitch.n_frames} frames in {n} windows")
        arr = pitch.to_array().T   # (n, K); NaN past a frame's last candidate
        freq, strength = arr["frequency"].copy(), arr["strength"].copy()
        freq[silent], strength[silent] = np.nan, np.nan
        order = np.argsort(freq, axis=1, kind="stable")   # (NaN last; no two candidates share a frequency)
        freq, strength = np.take_along_axis(freq, order, 1), np.take_along_axis(strength, order, 1)
    freq[silent, 0], strength[silent, 0], peaks[silent] = 0.0, 0.0, 0.0
    return freq, strength, peaks


@dataclass(frozen=True)
class Read:
    """A stream's ask for Praat's candidates of the analysis windows ``windows`` ``(n, W)`` its
    push made ready (:meth:`PraatPathF0e.push_steps`), read with ``settings`` (sample rate, floor,
    ceiling, voicing and silence thresholds).  Reads with the same settings are answered together
    (:mod:`headmotion.systems.decisions`): :meth:`answer_many` reads all their windows by one
    call, and each gets what it gets alone."""

    windows: np.ndarray
    settings: tuple

    @property
    def batch(self) -> tuple:
        return (Read, self.settings)

    @staticmethod
    def answer_many(reads: "list[Read]") -> list:
        """Each read's ``(frequencies, strengths, local peaks)`` (:func:`praat_candidates`), all
        read by one Praat call."""
        rate, floor, ceiling, voicing, silence = reads[0].settings
        windows = reads[0].windows if len(reads) == 1 else np.concatenate([r.windows for r in reads])
        got = praat_candidates(windows, rate, floor=floor, ceiling=ceiling, voicing_threshold=voicing,
                               silence_threshold=silence)
        out, o = [], 0
        for r in reads:
            n = len(r.windows)
            out.append(tuple(x[o:o + n] for x in got))
            o += n
        return out


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
        #: what a :class:`Read` of this reader reads with
        self._settings = (self.sample_rate, self.floor, self.ceiling, float(voicing_threshold), float(silence_threshold))
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
        self._read: tuple | None = None   # (first, end, candidates) sent to push_steps
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

    # -- step by step ---------------------------------------------------------------------------
    def push_steps(self, samples):
        """:meth:`push` step by step: a generator that yields one :class:`Read` of the analysis
        frames the push makes ready (at most :data:`BLOCK` of them; more are read as ``push`` reads
        them) and is sent their candidates; returns the new final frames.  A batched engine reads
        many streams' windows by one Praat call (:mod:`headmotion.live.engine`)."""
        if not self._take(samples):
            return self._empty
        t1 = self._static_ready()
        if t1 > self._n_static:
            a, b = self._n_grid, self._grid_of(t1 - 1) + 1
            if 0 < b - a <= BLOCK:
                read = Read(self._windows_of(a, b), self._settings)
                self._read = (a, b, (yield read))
        return self._advance(t1)

    def _windows_of(self, a: int, b: int) -> np.ndarray:
        return np.stack([self._window(self._grid_start(j)) for j in range(a, b)])

    def _advance_path(self, upto: int) -> list[float]:
        """Read analysis frames ``_n_grid … upto − 1`` (one Praat call per :data:`BLOCK` of them, or
        the candidates :meth:`push_steps` was sent for them) and take the forward search over them;
        the frequency each chose (0: unvoiced)."""
        chosen: list[float] = []
        read, self._read = self._read, None
        for a in range(self._n_grid, upto, BLOCK):
            b = min(a + BLOCK, upto)
            got = read[2] if read is not None and read[:2] == (a, b) else \
                Read.answer_many([Read(self._windows_of(a, b), self._settings)])[0]
            chosen.extend(self._search(*got))
            self._n_grid = b
        return chosen

    def _search(self, freq: np.ndarray, strength: np.ndarray, peaks: np.ndarray) -> list[float]:
        """The forward search over analysis frames read together (:func:`praat_candidates`)."""
        ratios = np.zeros(len(peaks))
        for k, p in enumerate(peaks.tolist()):   # the running peak
            self._peak = max(self._peak * self._decay, p)
            ratios[k] = p / self._peak if self._peak > 0 else 0.0
        local, voiced = local_strengths(freq, strength, ratios, ceiling=self.ceiling, **self.costs)
        log2 = np.log2(np.where(voiced, freq, 1.0))
        jumps = transition_costs(log2[:-1], voiced[:-1], log2[1:], voiced[1:], step=self.step, **self.jump_costs)
        scores, chosen = self._scores, []
        for k in range(len(peaks)):
            costs = jumps[k - 1] if k else None if scores is None else transition_costs(
                self._log2, self._cand_voiced, log2[0], voiced[0], step=self.step, **self.jump_costs)
            scores, _ = path_scores(scores, costs, local[k], back=False)
            scores -= scores.max()   # (kept near 0 over a long stream; the choice does not change)
            best = int(np.argmax(scores))
            chosen.append(float(freq[k, best]) if voiced[k, best] else 0.0)
        self._scores, self._log2, self._cand_voiced = scores, log2[-1], voiced[-1]
        return chosen

    def _static_frames(self, t0: int, t1: int) -> None:
        energy = self._energy_db(t0, t1)
        logf0, voiced = np.zeros(t1 - t0), np.zeros(t1 - t0, bool)
        j0, before = self._n_grid, self._best_f
        chosen = self._advance_path(self._grid_of(t1 - 1) + 1)
        for k, t in enumerate(range(t0, t1)):
            j = self._grid_of(t)
            f = chosen[j - j0] if j >= j0 else before   # (j0 − 1: the analysis frame read last)
            v = self._hold(t, f > 0 and bool(energy[k] > self.silence_db), math.log(f) if f > 0 else 0.0)
            logf0[k], voiced[k] = self._last_logf0, v
        if chosen:
            self._best_f = chosen[-1]
        self._static.extend(np.stack([logf0, energy], axis=1))
        self._voiced.extend(voiced.astype(np.float64))

    def _static_one(self, t: int) -> None:
        self._static_frames(t, t + 1)


__all__ = ["PraatPathF0e", "Read", "local_strengths", "transition_costs", "path_scores", "praat_candidates",
           "local_peaks", "PRAAT_VOICING", "PRAAT_SILENCE", "OCTAVE_COST", "OCTAVE_JUMP_COST", "VOICED_UNVOICED_COST",
           "PEAK_HALF_LIFE_S"]
