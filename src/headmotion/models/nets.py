"""The paper's three networks and their training loops (paper §3.1–3.3, §4.2, Fig. 1 A–C).

* :class:`StackedAutoencoder` — Fig. 1 (A): a symmetric autoencoder trained greedily layer by layer
  (:func:`pretrain_layerwise`, "layer-wise pre-training", §4.2, after Takaki & Yamagishi 2016) and
  then fine-tuned end to end on eq 1 (:func:`train_autoencoder`):
  ``mean_t ‖X_t − p(f(X_t))‖² / D − α · CCA(f(X), Y)``.
  With ``α = 0`` it is the plain autoencoder (Wav_AE), with ``α = 1`` the CCCAE (Wav_CCCAE).
  The paper writes the reconstruction term as a sum over frames; we take the mean over the
  mini-batch and the input dimensions so that ``α = 1`` weighs a reconstruction error of order 1
  (inputs are z-scored) against a sum of canonical correlations in ``[0, 3]`` — with a raw sum
  the CCA term would vanish next to a 100-dim × 1000-frame error and ``α = 1`` would mean nothing.
  The CCA term is :func:`headmotion.models.dcca.cca_objective` on the mini-batch (1000 frames,
  relative ridge 1e-3; the reasons are in that module).
* :class:`ContextRegressor` — Fig. 1 (B): a feed-forward net from ``2C + 1 = 51`` frames
  (``C = 25``, ±25 frames, paper §3.2) of any feature set, flattened, to the 3 rotation-vector
  components.  Windows are gathered on the fly from padded sequences (:func:`gather_windows`),
  so a 30-minute corpus never materialises its ``(N, 51·D)`` design matrix.  Trained with MSE on
  z-scored motion (:func:`train_regressor`).  Training pads each sequence's ends by repeating its
  edge frame; synthesis (:func:`predict_regressor`) mirrors the frames about the edge instead
  (:func:`pad_indices`): the paper is silent, and an edge frame held for
  the 25 frames of context is a sound no speech makes — on real speech cut mid-utterance
  (4 files, 31 cuts; ``docs/decisions/dnn_context_padding.md``) the default's last 0.25 s
  strayed from what the uncut file gives by 2.0° on average (up to 14°, a visible turn as the
  clip ends) with the edge held, 1.3° (up to 9°) mirrored.
* :class:`StackedAutoencoder` again as the post-filter, Fig. 1 (C): a denoising autoencoder on
  50-frame segments of the 3 rotation components (150 inputs), trained to map clean motion plus
  white noise back to the clean motion (:func:`train_postfilter`, after Lu & Shimodaira 2019,
  the paper's ref. [15]), and applied to the regressor's output in 50-frame segments with a hop
  of 25 frames, joined by Hann-window overlap-add (:func:`apply_postfilter`).  Each segment's
  mean is removed before the network and added back after it, so the filter only reshapes the
  trajectory within a segment and cannot move its level or shift it in time.

Layer sizes are ours: the paper's Figure 1, which gives them, is not in the text we have.
Defaults (all exposed as parameters of the systems in :mod:`headmotion.systems.dnn`):

======================  ===========================================  ==========================
network                 layers                                       activation
======================  ===========================================  ==========================
autoencoder (A)         100 → 256 → 128 → **30** → 128 → 256 → 100   ReLU; linear code/output
regressor (B)           51·D → 256 → 256 → 3                          ReLU, dropout 0.1
post-filter (C)         150 → 256 → 64 → 256 → 150                    tanh; linear code/output
======================  ===========================================  ==========================

The embedding width is 30 as chosen in §4.2 (15 and 60 selectable).  The autoencoder's hidden
activation is ReLU in the systems (``ae_activation``; tanh and sigmoid selectable): what correlates
with head motion is an *even* function of the waveform (its envelope), and a linear code over ReLU
units represents ``|w·x|`` exactly (``relu(w·x) + relu(−w·x)``) whereas odd tanh units need many
biased copies; on the planted-envelope corpus of ``tests/test_cccae.py`` (40 epochs, same seed) the
CCCAE's validation CCA reached 0.57 with ReLU against 0.41 with tanh.  Every optimiser is Adam with
learning rate 0.0002 (§4.2); every training loop keeps the parameters of the epoch with the best
validation loss and stops after ``patience`` epochs without improvement (early stopping).

Randomness comes only from the global torch generator — the CPU's, on every device — which the
caller seeds inside ``torch.random.fork_rng`` (see :func:`headmotion.systems.dnn`); all operations
used have deterministic CPU kernels.  The regressor's dropout is :class:`HostDropout`: on a GPU its
masks are drawn on the CPU as the CPU draws them.  A GPU's own generator would give other masks
and leave the CPU generator, which orders the later batches and draws the post-filter's noise,
where the CPU path does not: the models then differ by more than rounding — enough for cccae,
whose outputs on the GPU correlated 0.84 with the CPU model's (``docs/decisions/gpu-training.md``).

Libraries considered: PyTorch (CPU) for the networks, as docs/design.md chooses; skorch / Lightning
would add a dependency for three small loops; scikit-learn's ``MLPRegressor`` has no custom loss
(the CCA term) and no layer-wise pre-training.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import math
from typing import Callable, Sequence

import numpy as np
import torch
from torch import nn

from .dcca import DEFAULT_CCA_BATCH, DEFAULT_REG, cca_objective
from .train_speed import Speed

DEFAULT_AE_HIDDEN = (256, 128)
DEFAULT_EMBEDDING_DIM = 30
DEFAULT_REGRESSOR_HIDDEN = (256, 256)
DEFAULT_CONTEXT = 25
DEFAULT_POSTFILTER_HIDDEN = (256,)
DEFAULT_POSTFILTER_CODE = 64
DEFAULT_SEGMENT = 50
LEARNING_RATE = 2e-4

_ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "sigmoid": nn.Sigmoid}

Progress = Callable[[int, int, float], None] | None  # (epoch, max_epochs, validation loss)


def _activation(name: str) -> nn.Module:
    try:
        return _ACTIVATIONS[name]()
    except KeyError:
        raise ValueError(f"activation must be one of {sorted(_ACTIVATIONS)}; got {name!r}") from None


# -- (A) autoencoder --------------------------------------------------------------------------------
class StackedAutoencoder(nn.Module):
    """Symmetric autoencoder ``in_dim → hidden… → code_dim → …hidden → in_dim``.

    Function ``encode: (B, in_dim) -> (B, code_dim)``, ``forward: (B, in_dim) -> (B, in_dim)``.
    Hidden layers use ``activation``; the code layer and the output layer are linear.
    ``encoder[i]`` and ``decoder[n - 1 - i]`` form the shallow autoencoder of pre-training step ``i``.
    """

    def __init__(self, in_dim: int, *, hidden: Sequence[int] = DEFAULT_AE_HIDDEN,
                 code_dim: int = DEFAULT_EMBEDDING_DIM, activation: str = "tanh"):
        super().__init__()
        sizes = [int(in_dim), *[int(h) for h in hidden], int(code_dim)]
        self.sizes = tuple(sizes)
        self.activation = activation
        self.encoder = nn.ModuleList(nn.Linear(sizes[i], sizes[i + 1]) for i in range(len(sizes) - 1))
        self.decoder = nn.ModuleList(nn.Linear(sizes[i + 1], sizes[i]) for i in reversed(range(len(sizes) - 1)))
        self.act = _activation(activation)

    @property
    def n_layers(self) -> int:
        return len(self.encoder)

    def encode(self, x: torch.Tensor, *, depth: int | None = None) -> torch.Tensor:
        """Output of the first ``depth`` encoder layers (all by default)."""
        depth = self.n_layers if depth is None else depth
        for i in range(depth):
            x = self.encoder[i](x)
            if i < self.n_layers - 1:
                x = self.act(x)
        return x

    def decode(self, z: torch.Tensor) -> torch.Tensor:
        for j, layer in enumerate(self.decoder):
            z = layer(z)
            if j < self.n_layers - 1:
                z = self.act(z)
        return z

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.decode(self.encode(x))

    def _shallow(self, i: int, h: torch.Tensor) -> torch.Tensor:
        """Pre-training step ``i``: ``h`` (output of layer ``i - 1``) → code ``i`` → back to ``h``."""
        z = self.encoder[i](h)
        if i < self.n_layers - 1:
            z = self.act(z)
        out = self.decoder[self.n_layers - 1 - i](z)
        if i > 0:
            out = self.act(out)
        return out


@contextlib.contextmanager
def exact_float32():
    """float32 matrix products and convolutions in full float32 for the block: cuDNN's convolutions
    may otherwise run in TF32 (10-bit mantissa) on a GPU by default, and a caller may have allowed
    TF32 matrix products; the CPU has no TF32, so the devices then train other models.  Restores
    the caller's settings."""
    b = torch.backends
    prev = (b.cuda.matmul.allow_tf32, b.cudnn.allow_tf32, torch.get_float32_matmul_precision())
    b.cuda.matmul.allow_tf32, b.cudnn.allow_tf32 = False, False
    torch.set_float32_matmul_precision("highest")
    try:
        yield
    finally:
        b.cuda.matmul.allow_tf32, b.cudnn.allow_tf32 = prev[0], prev[1]
        torch.set_float32_matmul_precision(prev[2])


def descend(opt, loss: torch.Tensor, *, value: bool = True):
    """One optimiser step on ``loss`` (zero the gradients, back-propagate, step); its value (a
    float, or with ``value`` False the detached tensor, which does not wait for a GPU to finish)."""
    opt.zero_grad()
    loss.backward()
    opt.step()
    return float(loss.detach()) if value else loss.detach()


def _batches(n: int, batch_size: int, *, shuffle: bool = True, drop_small: bool = True, device: str = "cpu"):
    """Index batches over ``n`` samples; a last batch smaller than half a batch joins the previous.
    The order is drawn with the CPU generator and, for another ``device``, moved there once."""
    order = torch.randperm(n) if shuffle else torch.arange(n)
    if device != "cpu":
        order = order.to(device)
    bs = max(1, min(int(batch_size), n))
    starts = list(range(0, n, bs))
    if drop_small and len(starts) > 1 and n - starts[-1] < bs // 2:
        starts.pop()
    for k, s in enumerate(starts):
        e = n if k == len(starts) - 1 else s + bs
        yield order[s:e]


class _EarlyStopping:
    """Keeps the best state dict; ``step(loss)`` returns True when training should stop."""

    def __init__(self, module: nn.Module, patience: int):
        self.module = module
        self.patience = int(patience)
        self.best = math.inf
        self.best_epoch = -1
        self.state = copy.deepcopy(module.state_dict())
        self.bad = 0

    def step(self, loss: float, epoch: int) -> bool:
        if not math.isfinite(self.best) or loss < self.best - 1e-7 * max(1.0, abs(self.best)):
            self.best, self.best_epoch, self.bad = float(loss), epoch, 0
            self.state = copy.deepcopy(self.module.state_dict())
        else:
            self.bad += 1
        return self.bad >= self.patience

    def restore(self) -> None:
        self.module.load_state_dict(self.state)

    def end_epoch(self, hist: dict, epoch: int, max_epochs: int, train_loss: float, valid_loss: float,
                  progress=None) -> bool:
        """Record the epoch's losses, report progress; True when training should stop."""
        hist["train"].append(train_loss)
        hist["valid"].append(valid_loss)
        if progress is not None:
            progress(epoch + 1, int(max_epochs), valid_loss)
        return self.step(valid_loss, epoch)

    def finish(self, hist: dict) -> dict:
        """Restore the best weights, switch to eval mode and record the best epoch."""
        self.restore()
        self.module.eval()
        hist["best_epoch"] = self.best_epoch
        return hist


def pretrain_layerwise(ae: StackedAutoencoder, x: torch.Tensor, *, epochs: int = 3,
                       batch_size: int = 256, lr: float = LEARNING_RATE, speed: Speed | None = None) -> list[float]:
    """Greedy layer-wise pre-training (§4.2): layer ``i`` is trained as a shallow autoencoder on
    the (fixed) output of layers ``0 … i−1``; on the device of ``x`` (``ae`` already there), as
    ``speed`` says (:class:`~headmotion.models.train_speed.Speed`; default: as given).
    Returns the final training loss of each step."""
    sp = speed or Speed()
    losses = []
    for i in range(ae.n_layers):
        with torch.no_grad():
            h_all = ae.encode(x, depth=i)
        params = list(ae.encoder[i].parameters()) + list(ae.decoder[ae.n_layers - 1 - i].parameters())
        opt = sp.adam(params, lr)
        last = float("nan")
        for _ in range(int(epochs)):
            tot, cnt = 0.0, 0
            for idx in _batches(len(h_all), sp.batch(batch_size), device=str(h_all.device)):
                h = h_all[idx]
                with sp.autocast():
                    out = ae._shallow(i, h)
                loss = torch.mean((out.float() - h) ** 2)
                tot += descend(opt, loss) * len(idx)
                cnt += len(idx)
            last = tot / max(cnt, 1)
        losses.append(last)
    return losses


def cccae_loss(ae: StackedAutoencoder, x: torch.Tensor, y: torch.Tensor | None, alpha: float, *,
               reg: float = DEFAULT_REG) -> tuple[torch.Tensor, float, float]:
    """Eq 1 on one batch: ``(objective, reconstruction MSE, CCA)``."""
    z = ae.encode(x)
    rec = torch.mean((ae.decode(z) - x) ** 2)
    if alpha and y is not None:
        corr = cca_objective(z, y, reg=reg)
        return rec - alpha * corr, float(rec.detach()), float(corr.detach())
    return rec, float(rec.detach()), float("nan")


def train_autoencoder(ae: StackedAutoencoder, x_train: torch.Tensor, y_train: torch.Tensor | None, *,
                      x_valid: torch.Tensor, y_valid: torch.Tensor | None, alpha: float = 1.0,
                      batch_size: int = DEFAULT_CCA_BATCH, lr: float = LEARNING_RATE, max_epochs: int = 30,
                      patience: int = 4, pretrain_epochs: int = 3, reg: float = DEFAULT_REG,
                      progress: Progress = None, speed: Speed | None = None) -> dict:
    """Layer-wise pre-training then fine-tuning on eq 1 with early stopping.

    Parameters
    ----------
    ae : StackedAutoencoder
    x_train : torch.Tensor [shape=(N, D)] — z-scored waveform frames (speaking frames only)
    y_train : torch.Tensor [shape=(N, 3)] or None — the head rotation of the same frames
    x_valid, y_valid : the validation frames, scored as one batch
    alpha : float — weight of the CCA term (0 = plain autoencoder)
    batch_size : int — frames per mini-batch (also the CCA batch)

    The tensors and ``ae`` are on one device (the CPU or a GPU); batches are drawn with the CPU
    generator whichever it is.  ``speed``: batch scaling and the optimiser
    (:class:`~headmotion.models.train_speed.Speed`); never autocast — the CCA term and the
    embedding it reads stay float32.

    Returns
    -------
    dict with ``pretrain`` losses, per-epoch ``train``/``valid`` objective, ``valid_rec``,
    ``valid_cca`` and ``best_epoch``.
    """
    sp = dataclasses.replace(speed or Speed(), precision="float32")
    hist: dict = {"pretrain": pretrain_layerwise(ae, x_train, epochs=pretrain_epochs, lr=lr, speed=sp),
                  "train": [], "valid": [], "valid_rec": [], "valid_cca": []}
    opt = sp.adam(ae.parameters(), lr)
    stopper = _EarlyStopping(ae, patience)
    use_cca = bool(alpha) and y_train is not None
    for epoch in range(int(max_epochs)):
        ae.train()
        tot, cnt = 0.0, 0
        for idx in _batches(len(x_train), sp.batch(batch_size), device=str(x_train.device)):
            obj, _, _ = cccae_loss(ae, x_train[idx], y_train[idx] if use_cca else None, alpha, reg=reg)
            tot += descend(opt, obj) * len(idx)
            cnt += len(idx)
        ae.eval()
        with torch.no_grad():
            v, rec, corr = cccae_loss(ae, x_valid, y_valid if use_cca else None, alpha, reg=reg)
        hist["valid_rec"].append(rec)
        hist["valid_cca"].append(corr)
        if stopper.end_epoch(hist, epoch, max_epochs, tot / max(cnt, 1), float(v), progress):
            break
    return stopper.finish(hist)


# -- (B) regressor ----------------------------------------------------------------------------------
def host_dropout_mask(shape, p: float) -> torch.Tensor:
    """The CPU's dropout mask for an input of ``shape`` (0 or ``1 / (1 - p)``, float32), drawn with
    the CPU generator exactly as ``nn.Dropout`` draws it on the CPU."""
    return nn.functional.dropout(torch.ones(tuple(shape)), float(p), True)


class HostDropout(nn.Dropout):
    """``nn.Dropout`` whose mask comes from the CPU generator on every device: on the CPU it is
    ``nn.Dropout``; elsewhere the input times :func:`host_dropout_mask`, so a GPU trains with the
    masks (and leaves the generator in the state) of the CPU path.  ``host`` False: the device's
    own masks (the large-batch path, which does not give the CPU model anyway, spares the copies)."""

    host = True

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not self.training or self.p == 0 or x.device.type == "cpu" or not self.host:
            return super().forward(x)
        return self.masked(x)

    def masked(self, x: torch.Tensor) -> torch.Tensor:
        """Training-mode dropout with the CPU's mask moved to ``x``'s device."""
        return x * host_dropout_mask(x.shape, self.p).to(x.device, non_blocking=True)


class ContextRegressor(nn.Module):
    """Feed-forward regression from a ±``context`` window of ``in_dim`` features to ``out_dim``.

    Function ``forward: (B, (2·context + 1)·in_dim) -> (B, out_dim)``.
    """

    def __init__(self, in_dim: int, *, context: int = DEFAULT_CONTEXT,
                 hidden: Sequence[int] = DEFAULT_REGRESSOR_HIDDEN, out_dim: int = 3, dropout: float = 0.1):
        super().__init__()
        self.in_dim, self.context, self.out_dim = int(in_dim), int(context), int(out_dim)
        layers: list[nn.Module] = []
        prev = (2 * self.context + 1) * self.in_dim
        for h in hidden:
            layers += [nn.Linear(prev, int(h)), nn.ReLU()]
            if dropout > 0:
                layers.append(HostDropout(float(dropout)))
            prev = int(h)
        layers.append(nn.Linear(prev, self.out_dim))
        self.net = nn.Sequential(*layers)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


# how sequences are padded beyond their ends (PAD_MODES, pad_indices) and how synthesis pads them
# (SYNTHESIS_PAD) live with the inference code, which does not import torch
from .numpy_nets import PAD_MODES, SYNTHESIS_PAD, pad_indices  # noqa: E402,F401


class PaddedSequences:
    """Several ``(T_i, D)`` sequences padded by ``context`` frames on both sides (``mode``: see
    :func:`pad_indices`) and concatenated, so that the window of any frame is a contiguous slice.

    ``starts(i, frames)`` maps frame numbers of sequence ``i`` to window start rows."""

    def __init__(self, sequences: Sequence[np.ndarray], context: int, *, mode: str = "edge"):
        self.context = int(context)
        parts, self.offsets, self.lengths = [], [], []
        off = 0
        for s in sequences:
            s = np.asarray(s, dtype=np.float32)
            c = self.context
            parts.append(s[pad_indices(np.arange(-c, len(s) + c), len(s), mode)] if len(s) else s)
            self.offsets.append(off)
            self.lengths.append(len(s))
            off += len(parts[-1])
        self.data = torch.from_numpy(np.ascontiguousarray(np.concatenate(parts, 0)))

    def starts(self, i: int, frames: np.ndarray) -> np.ndarray:
        """Row of ``data`` where the window of frame ``frames`` of sequence ``i`` begins."""
        return self.offsets[i] + np.asarray(frames, dtype=np.int64)


def gather_windows(data: torch.Tensor, starts: torch.Tensor, width: int) -> torch.Tensor:
    """``(B, width·D)`` rows ``data[s : s + width]`` flattened, for each start ``s`` (``data`` and
    ``starts`` on one device)."""
    idx = starts[:, None] + torch.arange(width, device=starts.device)[None, :]
    return data[idx].reshape(len(starts), -1)


def predict_regressor(net: ContextRegressor, features: np.ndarray, *, chunk: int = 4096,
                      pad: str | None = None) -> np.ndarray:
    """Apply the regressor to every frame of one sequence: ``(T, D) -> (T, out_dim)``; the
    context beyond the ends padded as ``pad`` says (:func:`pad_indices`; None:
    :data:`headmotion.models.numpy_nets.SYNTHESIS_PAD`).  Runs the inference code of
    :mod:`headmotion.models.numpy_nets` on the module's weights, as synthesis does."""
    from . import numpy_nets

    return numpy_nets.predict_regressor(net, features, chunk=chunk, pad=pad)


def train_regressor(net: ContextRegressor, train: PaddedSequences, train_starts: np.ndarray,
                    train_targets: np.ndarray, valid: PaddedSequences, valid_starts: np.ndarray,
                    valid_targets: np.ndarray, *, batch_size: int = 256, lr: float = LEARNING_RATE,
                    max_epochs: int = 30, patience: int = 4, progress: Progress = None,
                    device: str = "cpu", speed: Speed | None = None) -> dict:
    """MSE training of the regressor with early stopping on the validation frames.

    ``*_starts`` are window start rows (:meth:`PaddedSequences.starts`) of the frames used, and
    ``*_targets`` their z-scored rotation ``(N, 3)``.  ``device``: where the sequences, the
    windows and ``net`` (moved there by the caller) live; batches are drawn with the CPU generator.
    ``speed``: batches, optimiser, autocast, compilation (:class:`~headmotion.models.train_speed.Speed`)."""
    sp = speed or Speed(device)
    width = 2 * net.context + 1
    ts = torch.from_numpy(np.asarray(train_starts, dtype=np.int64)).to(device)
    ty = torch.from_numpy(np.asarray(train_targets, dtype=np.float32)).to(device)
    vs = torch.from_numpy(np.asarray(valid_starts, dtype=np.int64)).to(device)
    vy = torch.from_numpy(np.asarray(valid_targets, dtype=np.float32)).to(device)
    tdata, vdata = train.data.to(device), valid.data.to(device)
    opt = sp.adam(net.parameters(), lr)
    fwd = sp.forward(sp.prepare(net))
    stopper = _EarlyStopping(net, patience)
    hist: dict = {"train": [], "valid": []}
    for epoch in range(int(max_epochs)):
        net.train()
        tot, cnt = 0.0, 0
        for idx in _batches(len(ts), sp.batch(batch_size), device=device):
            with sp.autocast():
                pred = fwd(gather_windows(tdata, ts[idx], width))
            loss = torch.mean((pred.float() - ty[idx]) ** 2)
            tot += descend(opt, loss) * len(idx)
            cnt += len(idx)
        net.eval()
        with torch.no_grad():
            vl, vc = 0.0, 0
            for s in range(0, len(vs), 4096):
                p = net(gather_windows(vdata, vs[s:s + 4096], width))
                vl += float(torch.sum((p - vy[s:s + 4096]) ** 2)) / vy.shape[1]
                vc += len(p)
            v = vl / max(vc, 1)
        if stopper.end_epoch(hist, epoch, max_epochs, tot / max(cnt, 1), v, progress):
            break
    return stopper.finish(hist)


# -- (C) post-filter ----------------------------------------------------------------------------------
def make_postfilter(*, segment: int = DEFAULT_SEGMENT, dims: int = 3,
                    hidden: Sequence[int] = DEFAULT_POSTFILTER_HIDDEN,
                    code_dim: int = DEFAULT_POSTFILTER_CODE) -> StackedAutoencoder:
    """The denoising autoencoder of Fig. 1 (C) on flattened ``(segment, dims)`` blocks."""
    return StackedAutoencoder(segment * dims, hidden=hidden, code_dim=code_dim, activation="tanh")


def motion_segments(sequences: Sequence[np.ndarray], *, segment: int = DEFAULT_SEGMENT,
                    hop: int = 5) -> np.ndarray:
    """All ``segment``-frame blocks (every ``hop`` frames) of several ``(T, 3)`` sequences,
    each with its own mean removed: ``(N, segment, 3)``."""
    out = []
    for s in sequences:
        s = np.asarray(s, dtype=np.float32)
        if len(s) < segment:
            continue
        v = np.lib.stride_tricks.sliding_window_view(s, segment, axis=0)[::hop]  # (n, 3, seg)
        out.append(np.swapaxes(v, 1, 2))
    if not out:
        return np.zeros((0, segment, 3), dtype=np.float32)
    seg = np.concatenate(out, 0)
    return (seg - seg.mean(axis=1, keepdims=True)).astype(np.float32)


def train_postfilter(dae: StackedAutoencoder, train_segments: np.ndarray, valid_segments: np.ndarray, *,
                     noise: float = 0.3, batch_size: int = 256, lr: float = LEARNING_RATE,
                     max_epochs: int = 30, patience: int = 4, pretrain_epochs: int = 2,
                     progress: Progress = None, device: str = "cpu", speed: Speed | None = None) -> dict:
    """Train the post-filter to map ``clean + noise`` back to ``clean`` (z-scored motion).

    The noise is white and Gaussian with a standard deviation drawn per segment uniformly from
    ``[0, 2·noise]``, so the filter sees both nearly clean and very jittery inputs; the validation
    noise is fixed once (same draw every epoch) so that early stopping compares like with like.
    ``device``: where the segments and ``dae`` (moved there by the caller) live; the noise is drawn
    with the CPU generator whichever it is, so a GPU sees the noise the CPU would.  ``speed`` as
    :func:`train_regressor`.
    """
    sp = speed or Speed(device)
    n_seg, seg, dims = train_segments.shape if len(train_segments) else (0, 0, 0)
    x = torch.from_numpy(np.ascontiguousarray(train_segments.reshape(len(train_segments), -1)))
    xv = torch.from_numpy(np.ascontiguousarray(valid_segments.reshape(len(valid_segments), -1)))
    sd_v = torch.rand(len(xv), 1) * 2 * noise
    xv_noisy = (xv + sd_v * torch.randn_like(xv)).to(device)
    x, xv = x.to(device), xv.to(device)
    hist: dict = {"pretrain": pretrain_layerwise(dae, x, epochs=pretrain_epochs, lr=lr, speed=sp),
                  "train": [], "valid": []}
    opt = sp.adam(dae.parameters(), lr)
    fwd = sp.forward(dae)
    stopper = _EarlyStopping(dae, patience)
    for epoch in range(int(max_epochs)):
        dae.train()
        tot, cnt = 0.0, 0
        for idx in _batches(len(x), sp.batch(batch_size), device=device):
            clean = x[idx]
            sd = torch.rand(len(idx), 1) * 2 * noise
            with sp.autocast():
                out = fwd(clean + (sd * torch.randn(clean.shape)).to(device))
            loss = torch.mean((out.float() - clean) ** 2)
            tot += descend(opt, loss) * len(idx)
            cnt += len(idx)
        dae.eval()
        with torch.no_grad():
            v = float(torch.mean((dae(xv_noisy) - xv) ** 2)) if len(xv) else tot / max(cnt, 1)
        if stopper.end_epoch(hist, epoch, max_epochs, tot / max(cnt, 1), v, progress):
            break
    return stopper.finish(hist)


def apply_postfilter(dae: StackedAutoencoder, motion: np.ndarray, *, segment: int = DEFAULT_SEGMENT,
                     hop: int | None = None) -> np.ndarray:
    """Filter a ``(T, dims)`` trajectory in ``segment``-frame blocks joined by Hann overlap-add
    (:func:`headmotion.models.numpy_nets.apply_postfilter`, the inference code synthesis runs,
    on the module's weights)."""
    from . import numpy_nets

    return numpy_nets.apply_postfilter(dae, motion, segment=segment, hop=hop)


# -- state dicts as numpy (model files never pickle) ---------------------------------------------
def state_to_arrays(module: nn.Module, prefix: str) -> dict[str, np.ndarray]:
    """``{prefix + key: numpy array}`` for every tensor of the module's state dict."""
    return {f"{prefix}{k}": v.detach().cpu().numpy().copy() for k, v in module.state_dict().items()}


def arrays_to_state(module: nn.Module, arrays: dict[str, np.ndarray], prefix: str) -> None:
    """Load what :func:`state_to_arrays` wrote (strict: every key must be present, shapes must match)."""
    own = module.state_dict()
    state = {}
    for k, v in own.items():
        a = arrays[f"{prefix}{k}"]
        if tuple(a.shape) != tuple(v.shape):
            raise ValueError(f"array {prefix}{k} has shape {tuple(a.shape)}, expected {tuple(v.shape)}")
        state[k] = torch.from_numpy(np.array(a, dtype=np.float32))
    module.load_state_dict(state, strict=True)


__all__ = [
    "StackedAutoencoder", "ContextRegressor", "HostDropout", "host_dropout_mask", "PaddedSequences", "gather_windows",
    "exact_float32", "descend", "pretrain_layerwise", "cccae_loss", "train_autoencoder", "train_regressor", "predict_regressor",
    "make_postfilter", "motion_segments", "train_postfilter", "apply_postfilter",
    "state_to_arrays", "arrays_to_state",
    "DEFAULT_AE_HIDDEN", "DEFAULT_EMBEDDING_DIM", "DEFAULT_REGRESSOR_HIDDEN", "DEFAULT_CONTEXT",
    "DEFAULT_POSTFILTER_HIDDEN", "DEFAULT_POSTFILTER_CODE", "DEFAULT_SEGMENT", "LEARNING_RATE",
]
