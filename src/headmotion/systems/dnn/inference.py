"""Every inference-time forward pass of the DNN systems' networks (paper §3.1–3.3): the
autoencoder's encoder, the ±context regressor and the denoising post-filter, offline and on a
stream.  The one place the trained weights are run; everything else in
:mod:`headmotion.systems.dnn` calls these functions.

The networks run in numpy from the arrays a model file stores
(:mod:`headmotion.models.numpy_nets`), so loading a model and synthesising never import PyTorch;
PyTorch is what training uses.  Inference needs no seeding (no dropout at inference), only the
model's thread count (:func:`threads`).
"""

from __future__ import annotations

import numpy as np

from ...models import numpy_nets


def threads(n: int | None):
    """A context manager: ``n`` BLAS threads for the block (None: the library's setting)."""
    return numpy_nets.inference_threads(n)


def encode(autoencoder, x: np.ndarray) -> np.ndarray:
    """The autoencoder's code of normalised feature frames ``x`` ``(T, D)`` (float32)."""
    return numpy_nets.encode(autoencoder, x)


def regress(regressor, r: np.ndarray) -> np.ndarray:
    """The regressor on every frame of one sequence ``r`` ``(T, D)``, the context beyond its ends
    padded as :data:`headmotion.models.numpy_nets.SYNTHESIS_PAD` says: ``(T, 3)`` float32."""
    return numpy_nets.predict_regressor(regressor, r)


def regress_windows(regressor, z: np.ndarray, n: int) -> np.ndarray:
    """The regressor on the ``n`` frames whose windows ``z[v : v + 2·context + 1]`` (``v < n``)
    are already padded (a stream's block): ``(n, 3)`` float32."""
    return numpy_nets.regress_padded(regressor, z, n)


def postfilter(filt, y: np.ndarray, *, segment: int) -> np.ndarray:
    """The post-filter over ``segment``-frame blocks joined by overlap-add: ``(T, 3)`` float32."""
    return numpy_nets.apply_postfilter(filt, y, segment=int(segment))


def network_output(regressor, filt, r: np.ndarray, *, segment: int) -> np.ndarray:
    """Regressor, then post-filter when there is one, on normalised regressor inputs ``r``."""
    y = regress(regressor, r)
    if filt is not None:
        y = postfilter(filt, y, segment=segment)
    return y


__all__ = ["threads", "encode", "regress", "regress_windows", "postfilter", "network_output"]
