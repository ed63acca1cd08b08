"""Inference of the DNN systems' networks with numpy — synthesis never imports PyTorch.

The three networks of paper §3 (Fig. 1 A–C; :mod:`headmotion.models.nets` builds and trains them
with PyTorch) are, at inference, a few dense layers: the autoencoder's encoder (CCCAE / AE
embedding), the context regressor (dropout is the identity in eval mode) and the denoising
post-filter applied in 50-frame segments joined by Hann overlap-add.  Model files already store
the torch state dicts as arrays (:func:`headmotion.models.nets.state_to_arrays`), so this module
reads those arrays and runs the same layers in float32 with numpy: ``x @ W.T + b`` for
``torch.nn.Linear``, ``max(x, 0)`` / ``tanh`` / logistic for the activations.  The motion matches
the PyTorch forward pass to float32 rounding (``tests/test_numpy_nets.py`` checks ≤ 1e-6 rad on
the shipped model and on freshly trained models of every DNN system).

Why numpy and not ONNX Runtime: importing PyTorch takes ~1.3 s and ~200 MB on the 2-core
reference machine, numpy is already loaded, and the networks are small matrix products (the
default's regressor is 51·D → 256 → 256 → 3), so numpy is as fast as either at this size without
another dependency.

Every inference path goes through this module, also for a model trained in this process (its
torch modules are read into arrays by :func:`as_numpy`): a model gives the same motion before
and after it is saved.
"""

from __future__ import annotations

import contextlib
from typing import Callable

import numpy as np

#: how sequences are padded beyond their ends: the edge frame repeated, or mirrored about it
PAD_MODES = ("edge", "reflect")
#: how :func:`predict_regressor` pads a sequence's ends at synthesis
#: (:mod:`headmotion.models.nets` explains the choice; read when called)
SYNTHESIS_PAD = "reflect"


def pad_indices(idx, n: int, mode: str = "edge") -> np.ndarray:
    """Frame numbers ``idx`` (any integers) of a sequence of ``n`` frames mapped into ``[0, n)``:
    ``"edge"`` clips to the end frames; ``"reflect"`` mirrors about them (``-1 → 1``,
    ``n → n − 2``, as ``numpy.pad(mode="reflect")``; periodic for indices beyond one length)."""
    idx = np.asarray(idx, dtype=np.int64)
    if n <= 1 or mode == "edge":
        return np.clip(idx, 0, max(n - 1, 0))
    if mode != "reflect":
        raise ValueError(f"padding mode must be one of {PAD_MODES}; got {mode!r}")
    period = 2 * (n - 1)
    i = np.mod(idx, period)
    return np.where(i > n - 1, period - i, i)


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, np.float32(0.0), out=x)


def _tanh(x: np.ndarray) -> np.ndarray:
    return np.tanh(x, out=x)


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return (1.0 / (1.0 + np.exp(-x))).astype(np.float32)


ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {"relu": _relu, "tanh": _tanh, "sigmoid": _sigmoid}


def linear(x: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """``torch.nn.Linear`` in float32: ``x @ weight.T + bias`` (``weight`` is ``(out, in)``)."""
    y = x @ weight.T
    y += bias
    return y


class _Layers:
    """Dense layers read from a state dict: ``keys[i]`` is the ``(weight, bias)`` key pair of
    layer ``i`` as PyTorch named it (so :meth:`state_arrays` writes the file's arrays back)."""

    def __init__(self, arrays: dict[str, np.ndarray], keys: list[tuple[str, str]]):
        self.keys = keys
        self.params = [(np.ascontiguousarray(arrays[w], dtype=np.float32),
                        np.ascontiguousarray(arrays[b], dtype=np.float32)) for w, b in keys]

    def forward(self, x: np.ndarray, activation: str) -> np.ndarray:
        """The layers in order, ``activation`` between them (none after the last), float32."""
        x = np.asarray(x, dtype=np.float32)
        last = len(self.params) - 1
        for i, (w, b) in enumerate(self.params):
            x = linear(x, w, b)
            if i < last:
                x = ACTIVATIONS[activation](x)
        return x

    def state_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        """``{prefix + key: array}``, the arrays :func:`headmotion.models.nets.state_to_arrays` writes."""
        out = {}
        for (kw, kb), (w, b) in zip(self.keys, self.params):
            out[prefix + kw], out[prefix + kb] = w.copy(), b.copy()
        return out


def _layer_keys(arrays: dict[str, np.ndarray], prefix: str, group: str) -> list[tuple[str, str]]:
    """``[(group.i.weight, group.i.bias), ...]`` in layer order, for the keys under ``prefix``."""
    idx = sorted({int(k[len(prefix) + len(group) + 1:].split(".")[0]) for k in arrays
                  if k.startswith(f"{prefix}{group}.") and k.endswith(".weight")})
    return [(f"{group}.{i}.weight", f"{group}.{i}.bias") for i in idx]


def _strip(arrays: dict[str, np.ndarray], prefix: str) -> dict[str, np.ndarray]:
    return {k[len(prefix):]: v for k, v in arrays.items() if k.startswith(prefix)}


class Autoencoder:
    """:class:`headmotion.models.nets.StackedAutoencoder` at inference: ``encode`` (the embedding)
    and ``__call__`` (encode then decode: the post-filter).  Hidden layers use ``activation``;
    the code and output layers are linear."""

    def __init__(self, arrays: dict[str, np.ndarray], activation: str):
        if activation not in ACTIVATIONS:
            raise ValueError(f"activation must be one of {sorted(ACTIVATIONS)}; got {activation!r}")
        self.activation = activation
        self.encoder = _Layers(arrays, _layer_keys(arrays, "", "encoder"))
        self.decoder = _Layers(arrays, _layer_keys(arrays, "", "decoder"))
        if not self.encoder.params or len(self.encoder.params) != len(self.decoder.params):
            raise ValueError("the autoencoder's arrays do not hold matching encoder and decoder layers")
        self.sizes = tuple([int(self.encoder.params[0][0].shape[1])] + [int(w.shape[0]) for w, _ in self.encoder.params])

    def encode(self, x: np.ndarray) -> np.ndarray:
        """``(B, in_dim) → (B, code_dim)``, float32."""
        return self.encoder.forward(x, self.activation)

    def decode(self, z: np.ndarray) -> np.ndarray:
        return self.decoder.forward(z, self.activation)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return self.decode(self.encode(x))

    def state_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        return {**self.encoder.state_arrays(prefix), **self.decoder.state_arrays(prefix)}


class Regressor:
    """:class:`headmotion.models.nets.ContextRegressor` at inference: ``(B, (2·context + 1)·in_dim)
    → (B, out_dim)``, ReLU between the layers (dropout is the identity in eval mode)."""

    def __init__(self, arrays: dict[str, np.ndarray], context: int):
        self.layers = _Layers(arrays, _layer_keys(arrays, "", "net"))
        if not self.layers.params:
            raise ValueError("the regressor's arrays hold no layers")
        self.context = int(context)
        width = int(self.layers.params[0][0].shape[1])
        if width % (2 * self.context + 1):
            raise ValueError(f"the regressor's input width {width} is not a multiple of "
                             f"2·context + 1 = {2 * self.context + 1}")
        self.in_dim = width // (2 * self.context + 1)
        self.out_dim = int(self.layers.params[-1][0].shape[0])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return self.layers.forward(x, "relu")

    def state_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        return self.layers.state_arrays(prefix)


# -- building -------------------------------------------------------------------------------------
def _check_shape(arrays: dict[str, np.ndarray], key: str, shape: tuple[int, ...]) -> None:
    if key not in arrays:
        raise KeyError(key)
    a = arrays[key]
    if tuple(a.shape) != tuple(shape):
        raise ValueError(f"array {key} has shape {tuple(a.shape)}, expected {tuple(shape)}")


def _check_dense(arrays, prefix: str, group: str, sizes: list[int], indices: list[int]) -> None:
    for i, (a, b) in zip(indices, zip(sizes[:-1], sizes[1:])):
        _check_shape(arrays, f"{prefix}{group}.{i}.weight", (b, a))
        _check_shape(arrays, f"{prefix}{group}.{i}.bias", (b,))


def autoencoder_from_arrays(arrays: dict[str, np.ndarray], prefix: str, *, sizes, activation: str) -> Autoencoder:
    """The autoencoder of ``sizes`` (``in_dim, hidden…, code_dim``) stored under ``prefix``
    (strict, as :func:`headmotion.models.nets.arrays_to_state`: every layer present, shapes as expected)."""
    sizes = [int(s) for s in sizes]
    n = len(sizes) - 1
    _check_dense(arrays, prefix, "encoder", sizes, list(range(n)))
    _check_dense(arrays, prefix, "decoder", sizes[::-1], list(range(n)))
    return Autoencoder(_strip(arrays, prefix), activation)


def regressor_from_arrays(arrays: dict[str, np.ndarray], prefix: str, *, in_dim: int, context: int,
                          hidden, dropout: float, out_dim: int = 3) -> Regressor:
    """The context regressor stored under ``prefix`` (layer numbering as ``nn.Sequential`` gives
    it: Linear, ReLU[, Dropout] per hidden layer)."""
    sizes = [(2 * int(context) + 1) * int(in_dim), *[int(h) for h in hidden], int(out_dim)]
    step = 3 if float(dropout) > 0 else 2
    _check_dense(arrays, prefix, "net", sizes, [step * i for i in range(len(sizes) - 1)])
    return Regressor(_strip(arrays, prefix), context)


def load_system_nets(system, arrays: dict[str, np.ndarray]):
    """``(autoencoder or None, regressor, post-filter or None)`` of a DNN system from its model
    file's arrays, as its parameters describe them (the system's ``_set_state``)."""
    autoencoder = None
    in_dim = int(system.input_dim_)
    if system.uses_embedding:
        autoencoder = autoencoder_from_arrays(
            arrays, "autoencoder/", sizes=[in_dim, *system.ae_hidden, int(system.embedding_dim)],
            activation=str(system.ae_activation))
        in_dim = int(system.embedding_dim)
    regressor = regressor_from_arrays(arrays, "regressor/", in_dim=in_dim, context=int(system.context),
                                      hidden=system.regressor_hidden, dropout=float(system.dropout))
    postfilter = None
    if system.postfilter:
        postfilter = autoencoder_from_arrays(
            arrays, "postfilter/", sizes=[int(system.segment) * 3, *system.postfilter_hidden,
                                          int(system.postfilter_code)], activation="tanh")
    return autoencoder, regressor, postfilter


def as_numpy(net):
    """``net`` as a numpy network: a numpy network itself; a torch ``StackedAutoencoder`` or
    ``ContextRegressor`` read into arrays (its weights now; nothing is cached); any other
    callable module (a test's identity network) wrapped to take and return numpy arrays."""
    if isinstance(net, (Autoencoder, Regressor)):
        return net
    kind = type(net).__name__
    if kind in ("StackedAutoencoder", "ContextRegressor"):
        arrays = {k: v.detach().cpu().numpy() for k, v in net.state_dict().items()}
        if kind == "StackedAutoencoder":
            return Autoencoder(arrays, str(net.activation))
        return Regressor(arrays, int(net.context))
    return _TorchCallable(net)


class _TorchCallable:
    """A torch module other than the known networks, called on numpy arrays."""

    def __init__(self, module):
        self.module = module

    def __call__(self, x: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            return self.module(torch.from_numpy(np.ascontiguousarray(x, dtype=np.float32))).numpy()


def state_arrays(net, prefix: str) -> dict[str, np.ndarray]:
    """The arrays a model file stores for ``net`` (numpy or torch), keyed ``prefix + name``."""
    if isinstance(net, (Autoencoder, Regressor)):
        return net.state_arrays(prefix)
    return {f"{prefix}{k}": v.detach().cpu().numpy().copy() for k, v in net.state_dict().items()}


# -- inference ------------------------------------------------------------------------------------
@contextlib.contextmanager
def inference_threads(n: int | None):
    """BLAS threads limited to the model's ``n_threads`` for the block (None: the library's
    setting).  threadpoolctl is asked only when the count differs from what it already is."""
    if not n:
        yield
        return
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl comes with scikit-learn
        yield
        return
    with threadpool_limits(limits=int(n), user_api="blas"):
        yield


def encode(autoencoder, x: np.ndarray) -> np.ndarray:
    """The embedding ``(T, code_dim)`` of z-scored frames ``x`` (float32)."""
    return as_numpy(autoencoder).encode(np.ascontiguousarray(x, dtype=np.float32))


def windows(data: np.ndarray, starts: np.ndarray, width: int) -> np.ndarray:
    """``(B, width·D)`` rows ``data[s : s + width]`` flattened, for each start ``s``
    (:func:`headmotion.models.nets.gather_windows` in numpy)."""
    idx = np.asarray(starts, dtype=np.int64)[:, None] + np.arange(width)[None, :]
    return data[idx].reshape(len(idx), -1)


def regress_padded(regressor, padded: np.ndarray, n: int, *, chunk: int = 4096) -> np.ndarray:
    """Regressor outputs ``(n, out_dim)`` of the frames whose windows start at rows ``0 … n − 1``
    of ``padded`` (frames with their ``context`` frames on both sides)."""
    net = as_numpy(regressor)
    data = np.ascontiguousarray(padded, dtype=np.float32)
    width = 2 * net.context + 1
    if n <= 0:
        return np.zeros((0, net.out_dim), dtype=np.float32)
    out = [net(windows(data, np.arange(s, min(s + chunk, n)), width)) for s in range(0, n, chunk)]
    return np.concatenate(out, 0) if len(out) > 1 else out[0]


def predict_regressor(regressor, features: np.ndarray, *, chunk: int = 4096, pad: str | None = None) -> np.ndarray:
    """The regressor on every frame of one sequence: ``(T, D) → (T, out_dim)``, the context
    beyond the ends padded as ``pad`` says (:func:`pad_indices`; None: :data:`SYNTHESIS_PAD`)."""
    net = as_numpy(regressor)
    feats = np.asarray(features, dtype=np.float32)
    T = len(feats)
    if T == 0:
        return np.zeros((0, net.out_dim), dtype=np.float32)
    c = net.context
    padded = feats[pad_indices(np.arange(-c, T + c), T, SYNTHESIS_PAD if pad is None else pad)]
    return regress_padded(net, padded, T, chunk=chunk)


def hann_segment_window(segment: int) -> np.ndarray:
    """The post-filter's overlap-add window: Hann sampled half a frame off its zeros, positive
    everywhere, two copies half a segment apart sum to exactly 1 (sin² + cos²)."""
    return (np.sin(np.pi * (np.arange(segment) + 0.5) / segment) ** 2).astype(np.float32)


def apply_postfilter(postfilter, motion: np.ndarray, *, segment: int = 50, hop: int | None = None) -> np.ndarray:
    """Filter a ``(T, dims)`` trajectory in ``segment``-frame blocks joined by overlap-add.

    The trajectory is edge-padded by ``hop`` frames in front (and enough at the end), cut into
    blocks every ``hop`` frames (default ``segment // 2``), each block's mean is removed, the
    block goes through the autoencoder, the mean is added back, and the blocks are summed with
    :func:`hann_segment_window` normalised by the summed window (exactly 1 for 50 % overlap).

    Returns
    -------
    np.ndarray [shape=(T, dims), dtype=float32]
    """
    net = as_numpy(postfilter)
    y = np.asarray(motion, dtype=np.float32)
    T, dims = y.shape
    if T == 0:
        return y.copy()
    hop = segment // 2 if hop is None else int(hop)
    if not 1 <= hop <= segment:
        raise ValueError(f"hop must be in [1, {segment}]; got {hop}")
    back = hop + (-(T + hop - segment) % hop) if T + hop >= segment else segment - T
    yp = np.pad(y, ((hop, back), (0, 0)), mode="edge")
    starts = np.arange(0, len(yp) - segment + 1, hop)
    blocks = np.stack([yp[s:s + segment] for s in starts])            # (n, seg, dims)
    means = blocks.mean(axis=1, keepdims=True)
    flat = np.ascontiguousarray((blocks - means).reshape(len(blocks), -1))
    out = np.asarray(net(flat), dtype=np.float32).reshape(blocks.shape) + means
    w = hann_segment_window(segment)
    acc = np.zeros_like(yp)
    wsum = np.zeros(len(yp), dtype=np.float32)
    for s, b in zip(starts, out):
        acc[s:s + segment] += w[:, None] * b
        wsum[s:s + segment] += w
    res = acc[hop:hop + T] / np.maximum(wsum[hop:hop + T], 1e-6)[:, None]
    return res.astype(np.float32)


__all__ = [
    "Autoencoder", "Regressor", "autoencoder_from_arrays", "regressor_from_arrays", "load_system_nets",
    "as_numpy", "state_arrays", "inference_threads", "encode", "windows", "regress_padded",
    "predict_regressor", "apply_postfilter", "hann_segment_window", "pad_indices", "PAD_MODES",
    "SYNTHESIS_PAD", "linear", "ACTIVATIONS",
]
