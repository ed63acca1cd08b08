"""Training the DNN systems' networks (paper §3.1–3.3) in memory: the CCCAE / AE embedding, the
±context regressor and the denoising post-filter, with seeded, deterministic torch, on the CPU or a
GPU (``device``; the networks come back on the CPU).  Batches and noise are drawn with the CPU
generator on either device, so the CPU models are those of the CPU-only code, bit for bit."""

from __future__ import annotations

import contextlib
import math

import numpy as np

from ...errors import ParameterError
from ...models.train_speed import Speed


def clean_json(x):
    """Replace non-finite floats by None (model configs are strict JSON)."""
    if isinstance(x, dict):
        return {str(k): clean_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean_json(v) for v in x]
    if isinstance(x, (float, np.floating)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    return x


@contextlib.contextmanager
def torch_context(seed: int, n_threads: int | None, *, deterministic: bool = True):
    """Seeded torch for the duration of the block (restores the caller's state): the CPU
    generator seeded with ``seed`` (training draws from it on every device; a GPU's generator is
    left alone), float32 products in full float32 (:func:`headmotion.models.nets.exact_float32`).

    ``deterministic`` also switches on torch's deterministic algorithms — for training.  Inference
    (eval mode, no dropout, CPU linear layers) is deterministic without it, and switching it on
    imports torch's compiler stack (seconds on the first call of a process), so synthesis passes False."""
    import torch

    from ...models.nets import exact_float32

    prev_threads = torch.get_num_threads()
    prev_det = torch.are_deterministic_algorithms_enabled() if deterministic else None
    with torch.random.fork_rng(devices=[]), exact_float32():
        torch.random.default_generator.manual_seed(int(seed))  # the CPU's: every device draws from it
        if deterministic:
            torch.use_deterministic_algorithms(True, warn_only=True)
        if n_threads:
            torch.set_num_threads(int(n_threads))
        try:
            yield
        finally:
            if deterministic:
                torch.use_deterministic_algorithms(prev_det)
            if n_threads:
                torch.set_num_threads(prev_threads)


def fit_embedding(system, train, valid, progress, device: str = "cpu"):
    """The CCCAE / AE (paper §3.1) on ``device``; sets ``p.z`` and ``p.r`` (the normalised embedding)."""
    import torch

    from ...features import Normalizer
    from ...models import nets

    ae = nets.StackedAutoencoder(train[0].x.shape[1], hidden=tuple(system.ae_hidden),
                                 code_dim=int(system.embedding_dim), activation=str(system.ae_activation)).to(device)
    xt, yt, xv, yv = (torch.from_numpy(np.concatenate([getattr(p, a)[p.speaking] for p in ps])).to(device)
                      for ps, a in ((train, "x"), (train, "y"), (valid, "x"), (valid, "y")))
    hist = nets.train_autoencoder(
        ae, xt, yt, x_valid=xv, y_valid=yv, alpha=float(system.alpha_value),
        batch_size=int(system.cca_batch_size), lr=float(system.learning_rate),
        max_epochs=int(system.ae_max_epochs), patience=int(system.patience),
        pretrain_epochs=int(system.pretrain_epochs), reg=float(system.cca_reg), progress=progress,
        speed=Speed.of(system, device))
    ae = ae.cpu()
    with torch.no_grad():
        for p in train + valid:
            p.z = ae.encode(torch.from_numpy(p.x)).numpy()
    emb_norm = Normalizer().fit([p.z[p.speaking] for p in train])
    for p in train + valid:
        p.r = np.asarray(emb_norm.transform(p.z), dtype=np.float32)
    return ae, emb_norm, hist


def fit_regressor(system, train, valid, progress, device: str = "cpu"):
    """The ±context frame regressor (paper §3.2) from ``p.r`` to ``p.y`` on speaking frames, on ``device``."""
    from ...models import nets

    reg = nets.ContextRegressor(train[0].r.shape[1], context=int(system.context),
                                hidden=tuple(system.regressor_hidden), dropout=float(system.dropout)).to(device)
    tr_seq = nets.PaddedSequences([p.r for p in train], int(system.context))
    va_seq = nets.PaddedSequences([p.r for p in valid], int(system.context))
    tr_starts = np.concatenate([tr_seq.starts(i, np.flatnonzero(p.speaking)) for i, p in enumerate(train)])
    va_starts = np.concatenate([va_seq.starts(i, np.flatnonzero(p.speaking)) for i, p in enumerate(valid)])
    hist = nets.train_regressor(
        reg, tr_seq, tr_starts, np.concatenate([p.y[p.speaking] for p in train]),
        va_seq, va_starts, np.concatenate([p.y[p.speaking] for p in valid]),
        batch_size=int(system.batch_size), lr=float(system.learning_rate), max_epochs=int(system.max_epochs),
        patience=int(system.patience), progress=progress, device=device, speed=Speed.of(system, device))
    return reg.cpu(), hist


def fit_postfilter(system, train, valid, progress, device: str = "cpu"):
    """The denoising motion autoencoder on ``segment``-frame windows (paper §3.3), on ``device``;
    when no validation recording holds a whole segment, every ``k``-th training segment (about
    200) is the validation set."""
    from ...models import nets

    seg = int(system.segment)
    pf = nets.make_postfilter(segment=seg, dims=3, hidden=tuple(system.postfilter_hidden),
                              code_dim=int(system.postfilter_code)).to(device)
    tr_seg = nets.motion_segments([p.y for p in train], segment=seg, hop=max(1, seg // 10))
    va_seg = nets.motion_segments([p.y for p in valid], segment=seg, hop=max(1, seg // 10))
    if len(tr_seg) == 0:
        raise ParameterError(
            f"{system.name}: the training motion is shorter than one post-filter segment ({seg} frames)")
    if len(va_seg) == 0:
        va_seg = tr_seg[:: max(1, len(tr_seg) // 200)]
    hist = nets.train_postfilter(
        pf, tr_seg, va_seg, noise=float(system.postfilter_noise), batch_size=int(system.batch_size),
        lr=float(system.learning_rate), max_epochs=int(system.max_epochs), patience=int(system.patience),
        progress=progress, device=device, speed=Speed.of(system, device))
    return pf.cpu(), hist


def fit_networks(system, train, valid, report, device: str = "cpu") -> tuple:
    """``(autoencoder or None, embedding normaliser or None, regressor, post-filter or None,
    history)`` trained in order on ``device`` under :func:`torch_context` seeded with ``random_state``; without
    an embedding the regressor reads the normalised features (``p.r = p.x``).  ``report(desc)``
    gives a per-stage progress callback; ``report.next()`` moves to the next stage."""
    history: dict = {}
    speed = Speed.of(system, device)
    if speed != Speed(device):
        history["speed"] = speed.describe()
    with torch_context(int(system.random_state), system.n_threads):
        ae, emb_norm = None, None
        if system.uses_embedding:
            ae, emb_norm, history["autoencoder"] = fit_embedding(system, train, valid, report("autoencoder"), device)
            report.next()
        else:
            for p in train + valid:
                p.r = p.x
        reg, history["regressor"] = fit_regressor(system, train, valid, report("regressor"), device)
        report.next()
        pf = None
        if system.postfilter:
            pf, history["postfilter"] = fit_postfilter(system, train, valid, report("post-filter"), device)
            report.next()
    return ae, emb_norm, reg, pf, history


__all__ = ["clean_json", "torch_context", "fit_embedding", "fit_regressor", "fit_postfilter", "fit_networks"]
