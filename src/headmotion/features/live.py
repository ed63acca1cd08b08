"""Live feature sets on a stream: the sets computed frame by frame (:mod:`.streaming`), their
incremental extractor, and :class:`LiveFeatures`, which takes samples at any rate and gives the
frames :func:`headmotion.features.extract` gives for the same 16 kHz audio (the streaming template
systems read it: tws, le2012)."""

from __future__ import annotations

import numpy as np


#: feature sets computed incrementally by :mod:`headmotion.features.streaming` (frame by frame)
LIVE_SETS = ("f0e-live", "prosody-live")


def live_extractor(config):
    """The incremental extractor of a live feature set (16 kHz input, the set's parameters)."""
    from . import ANALYSIS_RATE
    from .readers import f0e_stream
    from .streaming import StreamingProsody

    cls = f0e_stream if config.name == "f0e-live" else StreamingProsody
    return cls(sample_rate=ANALYSIS_RATE, fps=float(config.fps), **dict(config.params))


class LiveFeatures:
    """A live feature set on a stream: samples at ``sample_rate`` in (resampled on the stream to
    16 kHz by soxr when needed), final feature frames out, cast to float32 as
    :func:`headmotion.features.extract` does, so they equal the offline features of the same
    16 kHz audio bit for bit."""

    def __init__(self, config, sample_rate: int):
        from . import ANALYSIS_RATE

        self.ex = live_extractor(config)
        self.rs = None
        if int(sample_rate) != ANALYSIS_RATE:
            import soxr

            self.rs = soxr.ResampleStream(int(sample_rate), ANALYSIS_RATE, 1, dtype="float64")

    @property
    def latency_ms(self) -> float:
        return self.ex.latency_ms

    def push(self, x: np.ndarray) -> np.ndarray:
        if self.rs is not None:
            x = self.rs.resample_chunk(np.asarray(x, dtype=np.float64))
        return self.ex.push(x).astype(np.float32).astype(np.float64)

    def flush(self) -> np.ndarray:
        parts = []
        if self.rs is not None:
            parts.append(self.ex.push(self.rs.resample_chunk(np.zeros(0), last=True)))
        parts.append(self.ex.flush())
        return np.vstack(parts).astype(np.float32).astype(np.float64)


__all__ = ["LIVE_SETS", "live_extractor", "LiveFeatures"]
