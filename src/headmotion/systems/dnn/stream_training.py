"""The DNN systems' regressor and post-filter (paper §3.2–3.3) trained from streamed batches
(:mod:`.streamed`), on the CPU or a GPU.

Each epoch reads the training recordings in a fresh random order (torch's generator, seeded by
:func:`.training.torch_context`), a buffer of :data:`.streamed.BUFFER_FRAMES` frames at a time; a
buffer's frames (the regressor's speaking frames, the post-filter's segments) are shuffled and cut
into batches as the in-memory path cuts the whole set (:func:`headmotion.models.nets._batches`),
so every frame is used once per epoch.  The losses, the optimiser, early stopping on the
validation frames and the post-filter's layer-wise pre-training are those of
:mod:`headmotion.models.nets`; the validation pieces are read the same way in their own order,
the post-filter's validation noise drawn once per piece from a fixed seed (the same draw every
epoch, as in memory).  Only the order of the batches differs from the in-memory path, so the
models are close to, not equal to, its models (``tests/test_scale_path.py``).
"""

from __future__ import annotations

import numpy as np

from ...errors import ParameterError

VALID_NOISE_SEED = 777


def _windows(buf, context: int):
    """``(padded sequences, window starts, targets)`` of a buffer's speaking frames."""
    from ...models import nets

    seq = nets.PaddedSequences([p.r for p in buf], context)
    starts = np.concatenate([seq.starts(i, np.flatnonzero(p.speaking)) for i, p in enumerate(buf)])
    targets = np.concatenate([p.y[p.speaking] for p in buf])
    return seq, starts, targets


def _regressor_valid_loss(net, data, width: int, device) -> float:
    import torch

    from ...models import nets

    net.eval()
    vl, vc = 0.0, 0
    with torch.no_grad():
        for buf in data.buffers(data.valid, valid=True):
            seq, vs, vy = _windows(buf, net.context)
            vs, vy = torch.from_numpy(vs), torch.from_numpy(vy)
            for s in range(0, len(vs), 4096):
                p = net(nets.gather_windows(seq.data, vs[s:s + 4096], width).to(device))
                vl += float(torch.sum((p - vy[s:s + 4096].to(device)) ** 2)) / vy.shape[1]
                vc += len(p)
    return vl / max(vc, 1)


def train_regressor(system, data, device: str, tick) -> tuple:
    """The ±context regressor from streamed batches; ``tick(fraction, description)`` reports
    progress within the stage.  Returns ``(regressor on the CPU, history)``."""
    import torch

    from ...models import nets

    context = int(system.context)
    net = nets.ContextRegressor(data.input_dim, context=context, hidden=tuple(system.regressor_hidden),
                                dropout=float(system.dropout)).to(device)
    width = 2 * context + 1
    opt = torch.optim.Adam(net.parameters(), lr=float(system.learning_rate))
    stopper = nets._EarlyStopping(net, int(system.patience))
    hist: dict = {"train": [], "valid": []}
    epochs, n_train = int(system.max_epochs), len(data.train)
    for epoch in range(epochs):
        net.train()
        tot, cnt, done = 0.0, 0, 0
        for buf in data.buffers(data.train, torch.randperm(n_train).tolist()):
            seq, ts, ty = _windows(buf, context)
            ts, ty = torch.from_numpy(ts), torch.from_numpy(ty)
            for idx in nets._batches(len(ts), int(system.batch_size)):
                pred = net(nets.gather_windows(seq.data, ts[idx], width).to(device))
                loss = torch.mean((pred - ty[idx].to(device)) ** 2)
                tot += nets.descend(opt, loss) * len(idx)
                cnt += len(idx)
            done += len(buf)
            tick((epoch + done / max(n_train, 1)) / epochs, f"regressor: epoch {epoch + 1}/{epochs}")
        v = _regressor_valid_loss(net, data, width, device)
        if stopper.end_epoch(hist, epoch, epochs, tot / max(cnt, 1), v):
            break
    hist = stopper.finish(hist)
    return net.cpu(), hist


def _segments(buf, segment: int):
    """The buffer's post-filter training blocks, flattened: ``(N, segment · 3)`` float32."""
    import torch

    from ...models import nets

    seg = nets.motion_segments([p.y for p in buf], segment=segment, hop=max(1, segment // 10))
    return torch.from_numpy(np.ascontiguousarray(seg.reshape(len(seg), segment * seg.shape[2])))  # (0, ·) when none


def _segment_count(frames: int, segment: int) -> int:
    """How many segments :func:`headmotion.models.nets.motion_segments` cuts from ``frames`` frames."""
    return max(0, (frames - segment) // max(1, segment // 10) + 1) if frames >= segment else 0


def fallback_valid_segments(data, segment: int):
    """The post-filter's validation segments when no validation piece holds a whole segment (short
    validation recordings): every ``k``-th training segment in corpus order, about 200 of them —
    the set the in-memory path takes (:func:`.training.fit_postfilter`).  Early stopping then
    watches (noisy) training segments; the regressor still stops on the validation frames."""
    import torch

    counts = [_segment_count(p.frames, segment) for p in data.train]
    step = max(1, sum(counts) // 200)
    out, off = [], 0
    for p, n in zip(data.train, counts):
        first = (-off) % step
        if n and first < n:
            out.append(_segments([data.load(p)], segment)[first::step])
        off += n
    return torch.cat(out) if out else torch.zeros((0, segment * 3))


def _pretrain(dae, data, segment: int, epochs: int, batch_size: int, lr: float, device) -> list[float]:
    """:func:`headmotion.models.nets.pretrain_layerwise` over streamed buffers of segments."""
    import torch

    from ...models import nets

    losses = []
    for i in range(dae.n_layers):
        params = list(dae.encoder[i].parameters()) + list(dae.decoder[dae.n_layers - 1 - i].parameters())
        opt = torch.optim.Adam(params, lr=lr)
        last = float("nan")
        for _ in range(int(epochs)):
            tot, cnt = 0.0, 0
            for buf in data.buffers(data.train, torch.randperm(len(data.train)).tolist()):
                with torch.no_grad():
                    h_all = dae.encode(_segments(buf, segment).to(device), depth=i)
                for idx in nets._batches(len(h_all), batch_size):
                    h = h_all[idx.to(device)]
                    loss = torch.mean((dae._shallow(i, h) - h) ** 2)
                    tot += nets.descend(opt, loss) * len(idx)
                    cnt += len(idx)
            last = tot / max(cnt, 1)
        losses.append(last)
    return losses


def _valid_segment_sets(data, segment: int, fallback):
    """``(k, segments)`` per validation piece (pieces shorter than a segment give none), or
    ``(0, fallback)`` when there is a fallback set."""
    if fallback is not None:
        yield 0, fallback
        return
    for k, piece in enumerate(data.valid):
        if piece.frames >= segment:
            yield k, _segments([data.load(piece, all_speaking=True)], segment)


def _postfilter_valid_loss(dae, data, segment: int, noise: float, device, fallback=None) -> tuple[float, int]:
    """``(sum of squared errors, values)`` on the validation pieces, each piece's noise drawn from
    its own fixed seed (or on ``fallback``, :func:`fallback_valid_segments`, with one seed)."""
    import torch

    dae.eval()
    sse, n = 0.0, 0
    with torch.no_grad():
        for k, xv in _valid_segment_sets(data, segment, fallback):
            if not len(xv):
                continue
            g = torch.Generator().manual_seed(VALID_NOISE_SEED + k)
            noisy = xv + torch.rand(len(xv), 1, generator=g) * 2 * noise * torch.randn(xv.shape, generator=g)
            sse += float(torch.sum((dae(noisy.to(device)) - xv.to(device)) ** 2))
            n += xv.numel()
    return sse, n


def train_postfilter(system, data, device: str, tick) -> tuple:
    """The denoising post-filter from streamed buffers of segments (as
    :func:`headmotion.models.nets.train_postfilter`).  Recordings shorter than a segment add no
    segment; when no validation piece holds one, early stopping watches
    :func:`fallback_valid_segments` (``history["valid_from_training"]`` is True).  Returns
    ``(post-filter on the CPU, history)``."""
    import torch

    from ...models import nets

    seg, noise, bs = int(system.segment), float(system.postfilter_noise), int(system.batch_size)
    if not any(p.frames >= seg for p in data.train):
        raise ParameterError(
            f"{system.name}: the training motion is shorter than one post-filter segment ({seg} frames)")
    dae = nets.make_postfilter(segment=seg, dims=3, hidden=tuple(system.postfilter_hidden),
                               code_dim=int(system.postfilter_code)).to(device)
    lr, epochs = float(system.learning_rate), int(system.max_epochs)
    fallback = None if any(p.frames >= seg for p in data.valid) else fallback_valid_segments(data, seg)
    hist: dict = {"pretrain": _pretrain(dae, data, seg, 2, bs, lr, device), "train": [], "valid": [],
                  "valid_from_training": fallback is not None}
    opt = torch.optim.Adam(dae.parameters(), lr=lr)
    stopper = nets._EarlyStopping(dae, int(system.patience))
    for epoch in range(epochs):
        dae.train()
        tot, cnt, done = 0.0, 0, 0
        for buf in data.buffers(data.train, torch.randperm(len(data.train)).tolist()):
            x = _segments(buf, seg)
            for idx in nets._batches(len(x), bs):
                clean = x[idx].to(device)
                sd = (torch.rand(len(idx), 1) * 2 * noise).to(device)
                loss = torch.mean((dae(clean + sd * torch.randn(clean.shape).to(device)) - clean) ** 2)
                tot += nets.descend(opt, loss) * len(idx)
                cnt += len(idx)
            done += len(buf)
            tick((epoch + done / max(len(data.train), 1)) / epochs, f"post-filter: epoch {epoch + 1}/{epochs}")
        sse, n = _postfilter_valid_loss(dae, data, seg, noise, device, fallback)
        if stopper.end_epoch(hist, epoch, epochs, tot / max(cnt, 1), sse / max(n, 1)):
            break
    hist = stopper.finish(hist)
    return dae.cpu(), hist


__all__ = ["train_regressor", "train_postfilter", "fallback_valid_segments", "VALID_NOISE_SEED"]
