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
models are close to, not equal to, its models (``tests/test_scale_training.py``,
``tests/test_train_paths.py``).

The data pipeline: a background thread reads and batches the next buffers while the loop trains
(:data:`PREFETCH` ahead per device); a buffer's padded features (or the post-filter's segments)
are copied to the device once, from pinned memory on a GPU, and each batch's windows gathered
there; the post-filter reads the motion only; on a GPU the epoch's loss is summed on the device
(no wait per batch) and validation runs in chunks of :data:`VALID_CHUNK`.  Batches and noise are
drawn with the CPU generator on any device, so on the CPU the models are those of the plain loop,
bit for bit.  Batch scaling, the optimiser, autocast and compilation are the system's
:class:`~headmotion.models.train_speed.Speed`.  :class:`EpochClock` records where a stage's time goes.
"""

from __future__ import annotations

import queue
import threading
import time

import numpy as np

from ...errors import ParameterError
from ...models.train_speed import Speed

VALID_NOISE_SEED = 777
#: buffers read and batched ahead of the training loop, in a background thread, per device
PREFETCH = {"cpu": 1, "cuda": 2}
#: validation frames per forward pass, per device (no gradients: as large as memory allows)
VALID_CHUNK = {"cpu": 4096, "cuda": 65536}
#: the parts of :class:`EpochClock`
CLOCK_PARTS = ("read", "batches", "transfer", "compute", "wait", "valid")


class EpochClock:
    """Seconds of one streamed training stage by part (``history[stage]["seconds"]``): ``read``
    (recordings from the scratch folder, normalised), ``batches`` (a buffer's padded windows or
    segments, each batch's windows), ``transfer`` (to the device), ``compute`` (forward, backward,
    step), ``wait`` (the loop idle until the next buffer is ready: reading and batching run ahead
    in a background thread, so ``read`` and ``batches`` overlap the loop's parts) and ``valid``
    (the validation passes).  A GPU runs copies and kernels asynchronously: their time lands where
    the loop next waits on a result (the epoch's loss, under ``compute``)."""

    def __init__(self):
        self.seconds = dict.fromkeys(CLOCK_PARTS, 0.0)
        self.started = time.perf_counter()

    def add(self, part: str, since: float) -> float:
        """Add the time since ``since`` (a :func:`time.perf_counter` value) to ``part``; now."""
        now = time.perf_counter()
        self.seconds[part] += now - since
        return now

    def summary(self, epochs: int) -> dict:
        """``{"epochs", "total" (the stage's wall time), one entry per part}`` in seconds."""
        return {"epochs": int(epochs), "total": round(time.perf_counter() - self.started, 4),
                **{k: round(v, 4) for k, v in self.seconds.items()}}


class _LossSum:
    """Σ loss × batch size over an epoch.  On a GPU the sum stays there, so that the loop does not
    wait for each batch's result; on the CPU it is summed as floats, as the in-memory path does."""

    def __init__(self, device: str):
        self.lazy, self.total, self.count = device != "cpu", 0.0, 0

    def step(self, opt, loss, n: int) -> None:
        from ...models import nets

        if self.lazy:
            self.total = self.total + nets.descend(opt, loss, value=False).double() * n
        else:
            self.total += nets.descend(opt, loss) * n
        self.count += n

    def mean(self) -> float:
        return float(self.total) / max(self.count, 1)


def _ahead(items, depth: int, clock: EpochClock):
    """Iterate ``items`` (a generator) in a background thread, up to ``depth`` items ahead (0: in
    this thread); the time spent waiting for an item is the clock's ``wait``."""
    if depth <= 0:
        t = time.perf_counter()
        for item in items:
            t = clock.add("wait", t)
            yield item
            t = time.perf_counter()
        return
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def put(msg) -> bool:
        while not stop.is_set():
            try:
                q.put(msg, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def run() -> None:
        try:
            for item in items:
                if not put(("item", item)):
                    return
            put(("end", None))
        except BaseException as exc:  # handed to the training loop, which raises it
            put(("end", exc))

    worker = threading.Thread(target=run, name="headmotion-prefetch", daemon=True)
    worker.start()
    try:
        while True:
            t = time.perf_counter()
            kind, item = q.get()
            clock.add("wait", t)
            if kind == "end":
                if item is not None:
                    raise item
                return
            yield item
    finally:
        stop.set()
        worker.join()


def _timed_buffers(data, pieces, order, clock: EpochClock, **kw):
    """:meth:`.streamed.StreamedData.buffers`, the time to read each one added to ``read``."""
    it = data.buffers(pieces, order, **kw)
    while True:
        t = time.perf_counter()
        buf = next(it, None)
        clock.add("read", t)
        if buf is None:
            return
        yield buf


def _windows(buf, context: int):
    """``(padded sequences, window starts, targets)`` of a buffer's speaking frames."""
    from ...models import nets

    seq = nets.PaddedSequences([p.r for p in buf], context)
    starts = np.concatenate([seq.starts(i, np.flatnonzero(p.speaking)) for i, p in enumerate(buf)])
    targets = np.concatenate([p.y[p.speaking] for p in buf])
    return seq, starts, targets


def _to_device(tensors, device: str, clock: EpochClock):
    """``tensors`` on ``device`` (from pinned memory, without blocking, on a GPU); as they are on the CPU."""
    if device == "cpu":
        return tensors
    t = time.perf_counter()
    out = [a.to(device, non_blocking=True) for a in tensors]
    clock.add("transfer", t)
    return out


def _regressor_buffers(data, pieces, order, context: int, device: str, clock: EpochClock, *, valid: bool = False):
    """``(padded features, window starts, targets, pieces)`` per buffer, on ``device``: read and
    batched ahead (:data:`PREFETCH`), the padded features copied once per buffer — a batch's
    windows are then gathered where they are used."""
    import torch

    def prepared():
        for buf in _timed_buffers(data, pieces, order, clock, valid=valid):
            t = time.perf_counter()
            seq, starts, targets = _windows(buf, context)
            out = [seq.data, torch.from_numpy(starts), torch.from_numpy(targets)]
            if device == "cuda":
                out = [a.pin_memory() for a in out]
            clock.add("batches", t)
            yield out, len(buf)

    for arrays, n in _ahead(prepared(), PREFETCH.get(device, 1), clock):
        yield (*_to_device(arrays, device, clock), n)


def _regressor_valid_loss(net, data, width: int, device, clock: EpochClock) -> float:
    import torch

    from ...models import nets

    t0 = time.perf_counter()
    before = dict(clock.seconds)
    net.eval()
    vl, vc, chunk = 0.0, 0, VALID_CHUNK.get(device, 4096)
    with torch.no_grad():
        for x, vs, vy, _ in _regressor_buffers(data, data.valid, None, net.context, device, clock, valid=True):
            for s in range(0, len(vs), chunk):
                p = net(nets.gather_windows(x, vs[s:s + chunk], width))
                vl += float(torch.sum((p - vy[s:s + chunk]) ** 2)) / vy.shape[1]
                vc += len(p)
    clock.seconds = before  # the whole validation pass counts as ``valid``
    clock.add("valid", t0)
    return vl / max(vc, 1)


def train_regressor(system, data, device: str, tick) -> tuple:
    """The ±context regressor from streamed batches; ``tick(fraction, description)`` reports
    progress within the stage.  Returns ``(regressor on the CPU, history)``; the history's
    ``seconds`` is the stage's :class:`EpochClock`."""
    import torch

    from ...models import nets

    context = int(system.context)
    sp = Speed.of(system, device)
    net = sp.prepare(nets.ContextRegressor(data.input_dim, context=context, hidden=tuple(system.regressor_hidden),
                                           dropout=float(system.dropout)).to(device))
    width = 2 * context + 1
    opt, fwd = sp.adam(net.parameters(), float(system.learning_rate)), sp.forward(net)
    stopper = nets._EarlyStopping(net, int(system.patience))
    hist: dict = {"train": [], "valid": []}
    epochs, n_train = int(system.max_epochs), len(data.train)
    clock, ran = EpochClock(), 0
    for epoch in range(epochs):
        net.train()
        acc, done = _LossSum(device), 0
        order = torch.randperm(n_train).tolist()
        for x, ts, ty, n in _regressor_buffers(data, data.train, order, context, device, clock):
            for idx in nets._batches(len(ts), sp.batch(system.batch_size), device=device):
                t = time.perf_counter()
                xb = nets.gather_windows(x, ts[idx], width)
                t = clock.add("batches", t)
                with sp.autocast():
                    pred = fwd(xb)
                loss = torch.mean((pred.float() - ty[idx]) ** 2)
                acc.step(opt, loss, len(idx))
                clock.add("compute", t)
            done += n
            tick((epoch + done / max(n_train, 1)) / epochs, f"regressor: epoch {epoch + 1}/{epochs}")
        t = time.perf_counter()
        train_loss = acc.mean()
        clock.add("compute", t)
        v = _regressor_valid_loss(net, data, width, device, clock)
        ran = epoch + 1
        if stopper.end_epoch(hist, epoch, epochs, train_loss, v):
            break
    hist = stopper.finish(hist)
    hist["seconds"] = clock.summary(ran)
    return net.cpu(), hist


def _segments(buf, segment: int):
    """The buffer's post-filter training blocks, flattened: ``(N, segment · 3)`` float32."""
    import torch

    from ...models import nets

    seg = nets.motion_segments([p.y for p in buf], segment=segment, hop=max(1, segment // 10))
    return torch.from_numpy(np.ascontiguousarray(seg.reshape(len(seg), segment * seg.shape[2])))  # (0, ·) when none


def _segment_buffers(data, order, segment: int, device: str, clock: EpochClock):
    """``(segments, pieces)`` per buffer of training motion (features not read), on ``device``,
    read and cut ahead (:data:`PREFETCH`)."""
    def prepared():
        for buf in _timed_buffers(data, data.train, order, clock, features=False):
            t = time.perf_counter()
            x = _segments(buf, segment)
            if device == "cuda":
                x = x.pin_memory()
            clock.add("batches", t)
            yield x, len(buf)

    for x, n in _ahead(prepared(), PREFETCH.get(device, 1), clock):
        yield _to_device([x], device, clock)[0], n


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
            out.append(_segments([data.load(p, features=False)], segment)[first::step])
        off += n
    return torch.cat(out) if out else torch.zeros((0, segment * 3))


def _pretrain(dae, data, segment: int, epochs: int, batch_size: int, lr: float, device,
              clock: EpochClock, sp: Speed) -> list[float]:
    """:func:`headmotion.models.nets.pretrain_layerwise` over streamed buffers of segments."""
    import torch

    from ...models import nets

    losses = []
    for i in range(dae.n_layers):
        params = list(dae.encoder[i].parameters()) + list(dae.decoder[dae.n_layers - 1 - i].parameters())
        opt = sp.adam(params, lr)
        last = float("nan")
        for _ in range(int(epochs)):
            acc = _LossSum(device)
            for x, _n in _segment_buffers(data, torch.randperm(len(data.train)).tolist(), segment, device, clock):
                t = time.perf_counter()
                with torch.no_grad():
                    h_all = dae.encode(x, depth=i)
                for idx in nets._batches(len(h_all), sp.batch(batch_size), device=device):
                    h = h_all[idx]
                    with sp.autocast():
                        out = dae._shallow(i, h)
                    loss = torch.mean((out.float() - h) ** 2)
                    acc.step(opt, loss, len(idx))
                clock.add("compute", t)
            last = acc.mean()
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
            yield k, _segments([data.load(piece, all_speaking=True, features=False)], segment)


def _postfilter_valid_loss(dae, data, segment: int, noise: float, device, fallback=None,
                           clock: EpochClock | None = None) -> tuple[float, int]:
    """``(sum of squared errors, values)`` on the validation pieces, each piece's noise drawn from
    its own fixed seed (or on ``fallback``, :func:`fallback_valid_segments`, with one seed)."""
    import torch

    t0 = time.perf_counter()
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
    if clock is not None:
        clock.add("valid", t0)
    return sse, n


def train_postfilter(system, data, device: str, tick) -> tuple:
    """The denoising post-filter from streamed buffers of segments (as
    :func:`headmotion.models.nets.train_postfilter`).  Recordings shorter than a segment add no
    segment; when no validation piece holds one, early stopping watches
    :func:`fallback_valid_segments` (``history["valid_from_training"]`` is True).  Returns
    ``(post-filter on the CPU, history)``; the history's ``seconds`` is the stage's
    :class:`EpochClock` (pre-training included)."""
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
    clock, ran, sp = EpochClock(), 0, Speed.of(system, device)
    hist: dict = {"pretrain": _pretrain(dae, data, seg, 2, bs, lr, device, clock, sp), "train": [], "valid": [],
                  "valid_from_training": fallback is not None}
    opt, fwd = sp.adam(dae.parameters(), lr), sp.forward(dae)
    stopper = nets._EarlyStopping(dae, int(system.patience))
    for epoch in range(epochs):
        dae.train()
        acc, done = _LossSum(device), 0
        for x, n in _segment_buffers(data, torch.randperm(len(data.train)).tolist(), seg, device, clock):
            t = time.perf_counter()
            for idx in nets._batches(len(x), sp.batch(bs), device=device):
                clean = x[idx]
                # the noise is drawn on the CPU on every device: the CPU generator's stream, as in memory
                sd = (torch.rand(len(idx), 1) * 2 * noise).to(device)
                with sp.autocast():
                    out = fwd(clean + sd * torch.randn(clean.shape).to(device))
                loss = torch.mean((out.float() - clean) ** 2)
                acc.step(opt, loss, len(idx))
            clock.add("compute", t)
            done += n
            tick((epoch + done / max(len(data.train), 1)) / epochs, f"post-filter: epoch {epoch + 1}/{epochs}")
        t = time.perf_counter()
        train_loss = acc.mean()
        clock.add("compute", t)
        sse, n = _postfilter_valid_loss(dae, data, seg, noise, device, fallback, clock)
        ran = epoch + 1
        if stopper.end_epoch(hist, epoch, epochs, train_loss, sse / max(n, 1)):
            break
    hist = stopper.finish(hist)
    hist["seconds"] = clock.summary(ran)
    return dae.cpu(), hist


__all__ = ["train_regressor", "train_postfilter", "fallback_valid_segments", "EpochClock", "CLOCK_PARTS",
           "PREFETCH", "VALID_CHUNK", "VALID_NOISE_SEED"]
