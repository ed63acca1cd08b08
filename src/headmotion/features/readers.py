"""How the ``f0e-live`` prosody reads pitch (docs/decisions/read-any-voice.md): per-frame YIN
(:class:`.streaming.StreamingF0e`), Praat in blocks (:class:`.praat_stream.StreamingPraatF0e`) or
Praat's candidates frame by frame with its path searched forward (:class:`.praat_path.PraatPathF0e`), all
incremental with the same columns, so a stream and a whole file give the same values."""

from __future__ import annotations

from ..errors import ParameterError
from ..types import Audio
from .praat_path import PraatPathF0e
from .praat_stream import StreamingPraatF0e
from .streaming import StreamingF0e, whole_file

#: the pitch readers of the f0e-live set
READERS = ("yin", "praat", "praat-path")


def f0e_stream(*, reader: str = "yin", speaker_half_life_s: float = 0.0, **params):
    """The incremental f0e-live extractor that reads pitch with ``reader`` (:data:`READERS`);
    ``params`` are the extractor's.  ``speaker_half_life_s`` > 0: pitch and level relative to the
    voice so far (:class:`~.speaker_level.SpeakerLevel`, its half-life in seconds of voiced speech)."""
    if speaker_half_life_s:
        from .speaker_level import SpeakerLevel

        return SpeakerLevel(f0e_stream(reader=reader, **params), half_life_s=float(speaker_half_life_s))
    if reader == "yin":
        return StreamingF0e(**params)
    if reader == "praat":
        return StreamingPraatF0e(**params)
    if reader == "praat-path":
        return PraatPathF0e(**params)
    raise ParameterError(f"the f0e-live reader must be one of {', '.join(READERS)}; got {reader!r}")


def f0e_live(audio: Audio, *, fps: float, n_frames: int, **params):
    """The ``f0e-live`` feature set: :func:`f0e_stream`'s extractor run over the whole file at once
    (the same code path as streaming, so identical values).  Returns ``(values (T, 6|7), names)``."""
    return whole_file(f0e_stream(sample_rate=audio.sample_rate, fps=fps, **params), audio, n_frames)


__all__ = ["READERS", "f0e_stream", "f0e_live"]
