"""Every inference-time forward pass of the DNN systems' networks (paper §3.1–3.3): the
autoencoder's encoder, the ±context regressor and the denoising post-filter, offline and on a
stream.  The one place a different backend for the trained weights plugs in; everything else in
:mod:`headmotion.systems.dnn` calls these functions.

The networks are PyTorch modules of :mod:`headmotion.models.nets` in eval mode; inference needs no
seeding (no dropout in eval mode), only the model's intra-op thread count (:func:`threads`).
"""

from __future__ import annotations

import contextlib

import numpy as np


@contextlib.contextmanager
def threads(n: int | None):
    """torch's intra-op threads set to ``n`` for the block (None: torch's setting)."""
    import torch

    prev = torch.get_num_threads()
    if n:
        torch.set_num_threads(int(n))
    try:
        yield
    finally:
        if n:
            torch.set_num_threads(prev)


def encode(autoencoder, x: np.ndarray) -> np.ndarray:
    """The autoencoder's code of normalised feature frames ``x`` ``(T, D)`` (float32)."""
    import torch

    with torch.no_grad():
        return autoencoder.encode(torch.from_numpy(np.ascontiguousarray(x))).numpy()


def regress(regressor, r: np.ndarray) -> np.ndarray:
    """The regressor on every frame of one sequence ``r`` ``(T, D)``, the context beyond its ends
    padded as :data:`headmotion.models.nets.SYNTHESIS_PAD` says: ``(T, 3)`` float32."""
    from ...models import nets

    return nets.predict_regressor(regressor, r)


def regress_windows(regressor, z: np.ndarray, n: int) -> np.ndarray:
    """The regressor on the ``n`` frames whose windows ``z[v : v + 2·context + 1]`` (``v < n``)
    are already padded (a stream's block): ``(n, 3)`` float32."""
    import torch

    from ...models import nets

    with torch.no_grad():
        return regressor(nets.gather_windows(torch.from_numpy(np.ascontiguousarray(z)), torch.arange(n),
                                             2 * int(regressor.context) + 1)).numpy()


def postfilter(filt, y: np.ndarray, *, segment: int) -> np.ndarray:
    """The post-filter over ``segment``-frame blocks joined by overlap-add
    (:func:`headmotion.models.nets.apply_postfilter`): ``(T, 3)`` float32."""
    from ...models import nets

    return nets.apply_postfilter(filt, y, segment=int(segment))


def network_output(regressor, filt, r: np.ndarray, *, segment: int) -> np.ndarray:
    """Regressor, then post-filter when there is one, on normalised regressor inputs ``r``."""
    y = regress(regressor, r)
    if filt is not None:
        y = postfilter(filt, y, segment=segment)
    return y


__all__ = ["threads", "encode", "regress", "regress_windows", "postfilter", "network_output"]
