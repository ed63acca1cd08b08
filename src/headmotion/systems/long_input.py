"""Synthesis of long recordings in bounded memory.

The seeds are silent on hour-long inputs.  A system's stream gives the same frames as its offline
``predict`` (exactly for the causal systems, within 1e-6 rad for the DNN systems that stream with
lookahead; the contract in :mod:`headmotion.systems.base`, tested per system), so a
long file is read block by block (:func:`headmotion.io.audio_blocks.iter_audio_blocks`) and
pushed through ``model.stream``: features and synthesis then hold a few blocks of audio at a time
and time grows linearly with the length.  Only the motion itself (3 floats per frame: 26 MB for
3 h at 100 fps) is kept whole, for the writers.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..types import Motion

#: Inputs longer than this (seconds) are synthesised block by block by ``headmotion synth`` (when
#: the model streams).  Two minutes: a whole-file synthesis of the default holds ~20 MB per minute
#: of speech (the samples, their pre-emphasised copy, the features), so the peak RSS of any input
#: stays within ~40 MB of a 10-second one, and the block path's time per minute is the whole
#: file's; shorter inputs keep the offline computation exactly (the stream agrees with it to
#: 1e-6 rad, not bit for bit: the network sees other batch sizes).
LONG_INPUT_SECONDS = 120.0


def predict_file_in_blocks(model, path, *, seed: int, block_seconds: float = 30.0, progress=None) -> Motion:
    """``model.predict(load_audio(path), seed=seed)`` for a ``model`` that streams, without loading
    the whole file (``seed`` resolved by the caller: :func:`headmotion.seeds.resolve_seed`).

    ``progress(done_seconds)`` is called after each block."""
    from ..io.audio_blocks import iter_audio_blocks

    if not model.can_stream:
        raise ParameterError(f"system {model.name!r} does not stream: it cannot synthesise a file block by block")
    st = model.stream_seeded(seed)
    parts, seconds = [], 0.0
    for block in iter_audio_blocks(path, sample_rate=model.sample_rate, block_seconds=block_seconds):
        out = st.push(block)
        if len(out):
            parts.append(np.asarray(out.rotvec))
        seconds += len(block) / model.sample_rate
        if progress is not None:
            progress(seconds)
    tail = st.flush()
    if len(tail):
        parts.append(np.asarray(tail.rotvec))
    rv = np.vstack(parts) if parts else np.zeros((0, 3))
    return Motion(rv, model.frame_rate, meta={"system": model.name, "seed": seed})


__all__ = ["predict_file_in_blocks", "LONG_INPUT_SECONDS"]
