"""Input → motion stream → outputs, with bounded queues and measured latency (issue 16; the
seeds are silent on live use).

:class:`LiveSession` reads an :class:`~headmotion.live.inputs.AudioSource` in a reader thread
(chunks already resampled to the model's rate) into a bounded queue (``max_queue`` chunks; a
paced source blocks on a full queue rather than losing audio), pushes each chunk into a
*motion stream* — any object with ``push(samples) -> Motion`` and ``flush() -> Motion``, e.g.
``model.stream(seed=0)`` of a causal system — and sends the frame records
(:func:`~headmotion.live.frames.frame_records`) to every output (``send(records)``,
``close()``): :class:`~headmotion.live.frames.JsonLinesOutput`,
:class:`~headmotion.live.vmc.VmcSender`, :class:`~headmotion.live.websocket.WebSocketBroadcaster`.
An output that fails is reported once and dropped; the others keep receiving.

End-to-end latency: when the source is paced (``source.t0`` set: a real-time file or a
microphone), every frame's latency is ``wall time of emission − (t0 + frame time)``, the frame
time being ``frame / fps`` (the ``time`` of its JSON line).  :class:`LatencyMeter` keeps them;
:meth:`LiveSession.run` returns the median and 95th percentile.
"""

from __future__ import annotations

import queue
import sys
import threading
import time

import numpy as np

from ..errors import HeadMotionError
from .frames import frame_records

_END = object()


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


class LatencyMeter:
    """Per-frame end-to-end latency (seconds) of a paced stream."""

    def __init__(self):
        self.values: list[float] = []

    def add(self, emit_wall: float, t0: float, times) -> None:
        self.values.extend(emit_wall - (t0 + float(t)) for t in times)

    def summary(self) -> dict:
        if not self.values:
            return {"frames": 0, "median_ms": None, "p95_ms": None, "max_ms": None}
        v = 1000.0 * np.asarray(self.values)
        return {"frames": int(v.size), "median_ms": float(np.median(v)), "p95_ms": float(np.percentile(v, 95)),
                "max_ms": float(v.max())}


class LiveSession:
    """Run a source through a motion stream into outputs.

    Parameters
    ----------
    source : AudioSource (iterable of float32 chunks at the stream's rate; ``t0``, ``close()``)
    stream : object with ``push(samples) -> Motion`` and ``flush() -> Motion``
    outputs : list of objects with ``send(records)`` and ``close()``
    fps : float, the motion's frame rate (for the frame times)
    max_queue : chunks buffered between the reader thread and the synthesis loop
    """

    def __init__(self, source, stream, outputs, *, fps: float, max_queue: int = 50,
                 clock=time.monotonic, on_message=_stderr):
        self.source, self.stream = source, stream
        self.outputs = list(outputs)
        self.fps = float(fps)
        self.clock = clock
        self.on_message = on_message
        self.latency = LatencyMeter()
        self.frames = 0
        self.chunks = 0
        self._q: queue.Queue = queue.Queue(maxsize=max(2, int(max_queue)))
        self._stop = threading.Event()

    def _reader(self) -> None:
        try:
            for chunk in self.source:
                while not self._stop.is_set():
                    try:
                        self._q.put(chunk, timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if self._stop.is_set():
                    break
            self._q.put(_END)
        except BaseException as exc:  # forwarded to run()
            self._q.put(exc)

    def _emit(self, motion) -> None:
        rv = np.asarray(motion.rotvec if hasattr(motion, "rotvec") else motion).reshape(-1, 3)
        if len(rv) == 0:
            return
        records = frame_records(rv, self.fps, self.frames)
        self.frames += len(records)
        t0 = getattr(self.source, "t0", None)
        for out in list(self.outputs):
            try:
                out.send(records)
            except Exception as exc:  # a failing output must not stop the others
                self.on_message(f"{getattr(out, 'name', type(out).__name__)} output failed and was stopped: {exc}")
                self.outputs.remove(out)
                try:
                    out.close()
                except Exception:
                    pass
        if t0 is not None:
            self.latency.add(self.clock(), t0, [r["time"] for r in records])

    def stop(self) -> None:
        """Ask :meth:`run` to finish (from another thread or a signal handler)."""
        self._stop.set()
        self.source.close()

    def run(self, *, max_seconds: float | None = None) -> dict:
        """Process until the source ends (or ``max_seconds`` of wall time, or :meth:`stop`);
        flushes the stream; returns ``{frames, chunks, latency: {frames, median_ms, p95_ms,
        max_ms}}``.  Outputs are not closed (the caller owns them)."""
        reader = threading.Thread(target=self._reader, name="headmotion-input", daemon=True)
        start = self.clock()
        reader.start()
        try:
            while True:
                if max_seconds is not None and self.clock() - start > max_seconds:
                    self.stop()
                    break
                try:
                    item = self._q.get(timeout=0.1)
                except queue.Empty:
                    if self._stop.is_set():
                        break
                    continue
                if item is _END:
                    break
                if isinstance(item, BaseException):
                    if isinstance(item, HeadMotionError):
                        raise item
                    raise item
                self.chunks += 1
                self._emit(self.stream.push(item))
            self._emit(self.stream.flush())
        finally:
            self._stop.set()
            self.source.close()
            reader.join(timeout=2.0)
        return {"frames": self.frames, "chunks": self.chunks, "latency": self.latency.summary()}


__all__ = ["LiveSession", "LatencyMeter"]
