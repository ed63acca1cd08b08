"""Resampling of audio that arrives in chunks (a live input, a stream's pushes).

Library: ``soxr.ResampleStream`` does the work; this class only keeps the identity case free.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

#: a stream's resampling, by name → soxr quality: ``exact`` resamples as a whole file is resampled
#: (:func:`headmotion.io.audio.resample`; soxr's stream gives those samples, so a stream's frames
#: are the offline answer's; ~20 ms of delay), ``fast`` with ~10 ms less delay and samples that
#: differ slightly (frames then differ by up to a few degrees)
QUALITY = {"exact": "HQ", "fast": "LQ"}


class Resampler:
    """Mono float32 stream resampling (``soxr.ResampleStream``); identity when the rates match."""

    def __init__(self, in_rate: int, out_rate: int, *, quality: str = "LQ"):
        if int(in_rate) <= 0 or int(out_rate) <= 0:
            raise ParameterError(f"sample rates must be positive; got {in_rate} → {out_rate}")
        self.in_rate, self.out_rate = int(in_rate), int(out_rate)
        self._rs = None
        if self.in_rate != self.out_rate:
            import soxr

            self._rs = soxr.ResampleStream(self.in_rate, self.out_rate, 1, dtype="float32", quality=quality)

    def __call__(self, x: np.ndarray, last: bool = False) -> np.ndarray:
        x = np.ascontiguousarray(np.asarray(x, dtype=np.float32).reshape(-1))
        if self._rs is None:
            return x
        return self._rs.resample_chunk(x, last=last)


def check_resample(name) -> str:
    """The soxr quality of a resampling name (:data:`QUALITY`), or a ParameterError naming them."""
    if not isinstance(name, str) or name not in QUALITY:
        raise ParameterError(f"resample must be one of {sorted(QUALITY)}; got {name!r:.40}")
    return QUALITY[name]


__all__ = ["Resampler", "QUALITY", "check_resample"]
