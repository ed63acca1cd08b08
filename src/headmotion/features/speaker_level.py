"""Pitch and level read relative to the voice heard so far (speaker normalisation, causal).

The f0e-live columns hold absolute values: log F0 (a woman's voice sits about 10 semitones above a
man's) and energy in dB re full scale (the recording's gain).  A library searched with them matches
a new voice to the recordings whose voices sound *like* it, not to the ones whose speech *moves*
like it.  :class:`SpeakerLevel` wraps an incremental f0e-live extractor (:mod:`.streaming`,
:mod:`.praat_stream`) and shifts its ``logf0`` and ``energy`` columns, row by row, by the voice's
own running level: the mean over the voiced frames so far, each frame's weight halving every
``half_life_s`` seconds of voiced speech, with a prior level (``PRIOR_LOGF0``, ``PRIOR_ENERGY_DB``)
worth ``prior_s`` seconds of voiced speech before the voice has said enough.  A row's level uses the
frames up to and including it, so the shift adds no latency, and a whole file through it
(:func:`~.streaming.whole_file`) is the stream's rows exactly.  The deltas, which a constant shift
does not change, are left as they are.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError

#: the prior voice: log F0 of 160 Hz (natural log, the extractors' unit) …
PRIOR_LOGF0 = math.log(160.0)
#: … at this energy (dB re full scale of a 25 ms window)
PRIOR_ENERGY_DB = -30.0


class SpeakerLevel:
    """An f0e-live extractor (``inner``) whose ``logf0`` and ``energy`` are read relative to the voice
    so far (module docstring); ``names``, ``latency_ms``, ``push`` and ``flush`` as ``inner``'s."""

    def __init__(self, inner, *, half_life_s: float, prior_s: float = 1.0):
        names = list(inner.names)
        if not {"logf0", "energy", "voiced"} <= set(names):
            raise ParameterError(f"speaker normalisation needs the logf0, energy and voiced columns; got {names}")
        if not (half_life_s > 0 and prior_s >= 0):
            raise ParameterError(f"speaker normalisation needs half_life_s > 0 and prior_s >= 0; "
                                 f"got {half_life_s}, {prior_s}")
        self.inner = inner
        self.names = names
        self._cols = [names.index("logf0"), names.index("energy")]
        self._voiced = names.index("voiced")
        self._decay = 0.5 ** (1.0 / (float(half_life_s) * float(inner.fps)))
        self._prior_w = float(prior_s) * float(inner.fps)
        self._prior = np.array([PRIOR_LOGF0, PRIOR_ENERGY_DB])
        self._sum = np.zeros(2)  # decayed sums of the voiced frames' logf0 and energy
        self._w = 0.0  # their decayed count

    @property
    def latency_ms(self) -> float:
        return self.inner.latency_ms

    @property
    def fps(self) -> float:
        return self.inner.fps

    def _shift(self, rows: np.ndarray) -> np.ndarray:
        rows = np.array(rows, dtype=np.float64, copy=True)
        for r in rows:
            if r[self._voiced] > 0.5:
                self._sum = self._decay * self._sum + r[self._cols]
                self._w = self._decay * self._w + 1.0
            level = (self._sum + self._prior_w * self._prior) / (self._w + self._prior_w)
            r[self._cols] += self._prior - level
        return rows

    def push(self, samples) -> np.ndarray:
        return self._shift(self.inner.push(samples))

    def flush(self) -> np.ndarray:
        return self._shift(self.inner.flush())


__all__ = ["SpeakerLevel", "PRIOR_LOGF0", "PRIOR_ENERGY_DB"]
