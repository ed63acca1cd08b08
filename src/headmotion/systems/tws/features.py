"""Speech features of the template-warping systems, whole-utterance or block by block (thesis
§5.7.2; blocks are our choice so that streamed and offline synthesis see identical features).

Library considered: the feature extractors of :mod:`headmotion.features`; the blocking is ours.
"""

from __future__ import annotations

import numpy as np

from ...features import feature_config as make_feature_config  # noqa: F401  (the tws modules' name)

from ...types import Audio


def extract_blocked(audio: Audio, config, n_frames: int, *, block: int, context: int,
                    start_block: int = 0, stop_frame: int | None = None, sample_offset: int = 0) -> np.ndarray:
    """Features ``(T, D)`` computed block by block (``block`` frames, ``context`` frames of audio on
    each side), so streamed and offline synthesis see identical features.

    Frames ``[start_block*block, stop_frame)`` are returned; ``n_frames`` is the total length.
    ``audio`` may start at sample ``sample_offset`` of the utterance (a stream that dropped the
    audio it has consumed); frame and sample positions stay those of the whole utterance."""
    fps = float(config.fps)
    sr = audio.sample_rate
    stop = n_frames if stop_frame is None else stop_frame
    out = []
    b = start_block
    while b * block < stop:
        f0 = b * block
        f1 = min(f0 + block, n_frames)
        a0 = max(0, f0 - context)
        a1 = min(n_frames, f1 + context)
        s0 = int(round(a0 * sr / fps)) - sample_offset
        s1 = min(len(audio.samples), int(round(a1 * sr / fps)) - sample_offset)
        if s0 < 0:
            raise ValueError(f"extract_blocked: sample {s0 + sample_offset} was dropped (audio starts at {sample_offset})")
        seg = Audio(audio.samples[s0:s1], sr)
        tr = config.extract(seg, n_frames=a1 - a0)
        out.append(np.asarray(tr.values, dtype=np.float64)[f0 - a0:f1 - a0])
        b += 1
    if not out:
        return np.zeros((0, 0))
    return np.vstack(out)[: stop - start_block * block]


__all__ = ["make_feature_config", "extract_blocked"]
