"""Back-channel cues in the other party's pitch: Ward & Tsukahara (2000)'s rule, run causally.

Ward, N. and Tsukahara, W. (2000), "Prosodic features which cue back-channel responses in English
and Japanese", *Journal of Pragmatics* 32(8), 1177–1207.  Their rule for English: back-channel
feedback is appropriate upon

* **P1** a region of pitch below the 26th-percentile pitch level of the speaker,
* **P2** lasting at least 110 ms,
* **P3** after at least 700 ms of speech,
* **P4** when no back-channel was output within the preceding 800 ms,
* **P5** output 700 ms after the start of the region.

Here, on a pitch track of 10 ms frames (:class:`CueDetector`): the percentile is of **the voice
being heard now** — the voiced frames heard so far, each weighing less by half every
``level_half_life_s`` of voiced speech after it, and the frames before a pause of ``turn_pause_s``
or more (a turn change: perhaps another voice) weighing ``turn_keep`` as much again — so the level
follows a new speaker or a pitch range that moves.  Before ``min_voiced_s`` of voiced speech the
level leans on a **prior**: ``prior_semitones`` below the median pitch heard (the typical distance
from a voice's median to its 26th percentile), blended with the percentile by their weights (the
rule is causal); a region is a run of voiced frames below that level (an unvoiced frame ends it);
"speech" is the current run of the speaker's talk, broken by ``pause_s`` without a voiced frame;
P4 is checked when the region qualifies (its 110th ms), against the cues already given, whose
output times are the back-channels' times.  A cue is ``(start_s, output_s)``: the region's start
and the time the back-channel is due (start + ``delay_s``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError


@dataclass(frozen=True)
class CueRule:
    """The rule's parameters (Ward & Tsukahara 2000 for English; seconds)."""

    low_percentile: float = 26.0   # P1: pitch below this percentile of the speaker's pitch
    min_region_s: float = 0.110    # P2: for at least this long
    min_speech_s: float = 0.700    # P3: after at least this much speech
    refractory_s: float = 0.800    # P4: no back-channel output within this much before
    delay_s: float = 0.700         # P5: output this long after the region's start
    pause_s: float = 0.300         # a run of speech ends after this long without a voiced frame
    min_voiced_s: float = 1.0      # voiced speech (weighted) at which the percentile and the prior weigh alike
    level_half_life_s: float = 5.0  # voiced speech over which a frame's weight in the level halves (0: never)
    turn_pause_s: float = 1.0      # a pause this long in the heard voice is a turn change ...
    turn_keep: float = 0.2         # ... after which the frames before it weigh this much
    prior_semitones: float = 1.6   # the prior level: this far below the median pitch heard
    prior_min_voiced_s: float = 0.3  # voiced speech before any level at all

    def __post_init__(self):
        if not 0.0 < self.low_percentile < 100.0:
            raise ParameterError(f"low_percentile must be between 0 and 100; got {self.low_percentile!r}")
        if not 0.0 <= self.turn_keep <= 1.0:
            raise ParameterError(f"turn_keep must be between 0 and 1; got {self.turn_keep!r}")
        if not 0.0 <= self.prior_semitones <= 24.0:
            raise ParameterError(f"prior_semitones must be from 0 to 24; got {self.prior_semitones!r}")
        for name in ("min_region_s", "min_speech_s", "refractory_s", "delay_s", "pause_s", "min_voiced_s",
                     "level_half_life_s", "turn_pause_s", "prior_min_voiced_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0.0 <= v <= 60.0):
                raise ParameterError(f"{name} must be seconds from 0 to 60; got {v!r}")


#: log F0 histogram for the running percentile: 1/20 semitone bins from 40 to 1000 Hz
_LO, _HI, _BIN = np.log(40.0), np.log(1000.0), np.log(2.0) / 240.0
_NBINS = int(np.ceil((_HI - _LO) / _BIN)) + 1
_SEMITONE = np.log(2.0) / 12.0


class CueDetector:
    """:class:`CueRule` over a pitch track pushed frame by frame (or in blocks) at ``fps``.

    ``push(logf0, voiced)`` takes each frame's natural log of F0 (Hz; any value where unvoiced)
    and its voicing flag, and returns the cues that qualified in those frames, as ``(start_s,
    output_s)`` pairs, frame ``i`` being at ``i / fps`` seconds.
    """

    def __init__(self, rule: CueRule | None = None, *, fps: float = 100.0):
        self.rule = rule or CueRule()
        self.fps = float(fps)
        r = self.rule
        self._min_region = max(1, int(round(r.min_region_s * self.fps)))
        self._min_speech = int(round(r.min_speech_s * self.fps))
        self._pause = max(1, int(round(r.pause_s * self.fps)))
        self._min_voiced = r.min_voiced_s * self.fps
        self._prior_min = r.prior_min_voiced_s * self.fps
        self._turn_pause = max(1, int(round(r.turn_pause_s * self.fps)))
        # a frame's weight grows by this factor per voiced frame (the older frames' shrink, relatively)
        self._grow = 2.0 ** (1.0 / (r.level_half_life_s * self.fps)) if r.level_half_life_s > 0 else 1.0
        self._inc = 1.0             # the weight the next voiced frame adds
        self._hist = np.zeros(_NBINS, np.float64)
        self._voiced = 0
        self._t = 0                 # frames pushed
        self._run_start = None      # first frame of the current run of speech
        self._last_voiced = -10 ** 9
        self._region_start = None   # first frame of the current low-pitch region
        self._fired = False         # the current region has given its cue
        self._threshold = None      # log F0 of the percentile (recomputed as frames come)
        self.outputs: list[float] = []  # output times (s) of the cues given

    def level(self) -> float | None:
        """The current low-pitch level (Hz), or None before enough voiced speech."""
        return None if self._threshold is None else float(np.exp(self._threshold))

    def _update_threshold(self) -> None:
        c = np.cumsum(self._hist)
        weight = c[-1] / self._inc  # voiced frames' worth, in the newest frame's weight
        if weight < self._prior_min:
            self._threshold = None
            return
        pct = _LO + (int(np.searchsorted(c, self.rule.low_percentile / 100.0 * c[-1])) + 0.5) * _BIN
        prior = _LO + (int(np.searchsorted(c, 0.5 * c[-1])) + 0.5) * _BIN - self.rule.prior_semitones * _SEMITONE
        self._threshold = (weight * pct + self._min_voiced * prior) / (weight + self._min_voiced)

    def push(self, logf0, voiced) -> list[tuple[float, float]]:
        lf = np.asarray(logf0, dtype=np.float64).reshape(-1)
        vo = np.asarray(voiced).reshape(-1).astype(bool)
        if lf.shape != vo.shape:
            raise ParameterError(f"logf0 and voiced differ in length: {lf.shape} and {vo.shape}")
        cues = []
        for f, v in zip(lf, vo):
            cue = self._one(float(f), bool(v) and np.isfinite(f))
            if cue is not None:
                cues.append(cue)
        return cues

    def _one(self, lf: float, voiced: bool):
        t = self._t
        self._t += 1
        if voiced:
            if self._run_start is None or t - self._last_voiced > self._pause:
                self._run_start = t
            if self._voiced and t - self._last_voiced > self._turn_pause:  # a turn change
                self._hist *= self.rule.turn_keep
            self._last_voiced = t
            k = int(np.clip((lf - _LO) / _BIN, 0, _NBINS - 1))
            self._hist[k] += self._inc
            self._inc *= self._grow
            if self._inc > 1e200:  # (the weights are relative)
                self._hist /= self._inc
                self._inc = 1.0
            self._voiced += 1
            if self._voiced % 10 == 0 or self._threshold is None:  # the level moves slowly
                self._update_threshold()
        elif t - self._last_voiced > self._pause:
            self._run_start = None
        low = voiced and self._threshold is not None and lf < self._threshold
        if not low:
            self._region_start, self._fired = None, False
            return None
        if self._region_start is None:
            self._region_start, self._fired = t, False
        start = self._region_start
        if self._fired or t - start + 1 < self._min_region:
            return None
        self._fired = True  # one cue per region, given or refused
        if self._run_start is None or start - self._run_start < self._min_speech:  # P3
            return None
        now = (t + 1) / self.fps
        if self.outputs and now - self.outputs[-1] < self.rule.refractory_s:  # P4
            return None
        out = start / self.fps + self.rule.delay_s
        self.outputs.append(out)
        return start / self.fps, out


def detect_cues(logf0, voiced, *, fps: float = 100.0, rule: CueRule | None = None) -> list[tuple[float, float]]:
    """Every cue of a whole pitch track (the same as pushing it frame by frame)."""
    return CueDetector(rule, fps=fps).push(logf0, voiced)


__all__ = ["CueRule", "CueDetector", "detect_cues"]
