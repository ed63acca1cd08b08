"""Resampling of audio that arrives in chunks (a live input, a stream's pushes).

Library: ``soxr.ResampleStream`` does the work; this class only keeps the identity case free.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError


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


__all__ = ["Resampler"]
