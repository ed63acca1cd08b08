"""Input → motion stream → outputs, with bounded queues and measured latency (the
seeds are silent on live use).

:class:`LiveSession` reads an :class:`~headmotion.live.inputs.AudioSource` in a reader thread
(chunks already resampled to the model's rate) into a bounded queue (``max_queue`` chunks; a
paced source blocks on a full queue rather than losing audio), pushes each chunk into a
*motion stream* — any object with ``push(samples) -> Motion`` and ``flush() -> Motion``, e.g.
:func:`headmotion.synthesis.open_stream` — and sends the frame records
(:func:`~headmotion.live.frames.frame_records`) to every output (``send(records)``,
``close()``): :class:`~headmotion.live.frames.JsonLinesOutput`,
:class:`~headmotion.live.vmc.VmcSender`, :class:`~headmotion.live.websocket.WebSocketBroadcaster`.
An output that fails is reported once and dropped; the others keep receiving.  A second source,
``heard`` (:class:`~headmotion.live.heard.HeardInput`), is what the head hears: the other party's
audio, given to the stream's ``hear`` on the speech's timeline.

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
from .heard import feed

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
    heard : HeardInput, optional, the other party's audio (the stream needs ``hear(samples)``)
    """

    def __init__(self, source, stream, outputs, *, fps: float, max_queue: int = 50,
                 clock=time.monotonic, on_message=_stderr, heard=None):
        self.source, self.stream, self.heard = source, stream, heard
        self.speech_samples = 0  # at the chunks' rate
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
            feed(self.source, self._q, self._stop)
            self._q.put(_END)
        except BaseException as exc:  # forwarded to run()
            self._q.put(exc)

    def _emit(self, motion) -> None:
        rv = np.asarray(motion.rotvec if hasattr(motion, "rotvec") else motion).reshape(-1, 3)
        if len(rv) == 0:
            return
        records = frame_records(rv, float(getattr(motion, "fps", self.fps)), self.frames)
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
                if not self.outputs:
                    self.on_message("no output left: stopping")
                    self.stop()
        if t0 is not None:
            self.latency.add(self.clock(), t0, [r["time"] for r in records])

    def stop(self) -> None:
        """Ask :meth:`run` to finish (from another thread or a signal handler)."""
        self._stop.set()
        self.source.close()
        if self.heard is not None:
            self.heard.stop()

    def run(self, *, max_seconds: float | None = None) -> dict:
        """Process until the source ends (or ``max_seconds`` of wall time, or :meth:`stop`);
        flushes the stream; returns ``{frames, chunks, latency: {frames, median_ms, p95_ms,
        max_ms}}`` (and ``heard_seconds`` with a heard input).  Outputs are not closed (the caller
        owns them)."""
        reader = threading.Thread(target=self._reader, name="headmotion-input", daemon=True)
        start = self.clock()
        reader.start()
        if self.heard is not None:
            self.heard.start()
        ended = False
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
                    ended = True
                    break
                if isinstance(item, BaseException):
                    if isinstance(item, HeadMotionError):
                        raise item
                    raise item
                self.chunks += 1
                self._hear_up_to(len(item))
                self._emit(self.stream.push(item))
            if ended and self.heard is not None:  # the head listens to the end of the heard audio
                def keep_going():
                    return not self._stop.is_set() and (max_seconds is None or self.clock() - start <= max_seconds)

                self.speech_samples = self.heard.silence_after_speech(self.stream, self.speech_samples,
                                                                      self._speech_rate(), self._emit, keep_going)
            self._emit(self.stream.flush())
        finally:
            self._stop.set()
            self.source.close()
            reader.join(timeout=2.0)
            if self.heard is not None:
                self.heard.close()
        stats = {"frames": self.frames, "chunks": self.chunks, "latency": self.latency.summary()}
        if self.heard is not None:
            stats["heard_seconds"] = round(self.heard.seconds, 4)
        return stats

    def _speech_rate(self) -> int:
        return int(getattr(self.source, "chunk_rate", None) or self.stream.sample_rate)

    def _hear_up_to(self, n: int) -> None:
        """Before ``n`` more speech samples: the heard audio up to their end (waited for unless the
        speech is paced: :mod:`headmotion.live.heard`)."""
        self.speech_samples += n
        if self.heard is not None:
            self.heard.up_to(self.stream, self.speech_samples / self._speech_rate(),
                             wait=not getattr(self.source, "paced", False))


def open_outputs(*, json_stream=None, vmc: str | None = None, websocket: str | None = None,
                 neck_share: float | None = None) -> list:
    """The outputs of ``headmotion stream``: JSON lines on ``json_stream`` (None: none),
    ``vmc="HOST:PORT"`` (VMC over OSC), ``websocket="HOST:PORT"`` (started here).  Raises
    :class:`~headmotion.errors.NetworkError` with the address on a bad address or a port in use
    (outputs opened so far are closed)."""
    from .frames import JsonLinesOutput
    from .vmc import VMC_DEFAULT_PORT, VmcSender, parse_host_port

    outs = []
    try:
        if json_stream is not None:
            outs.append(JsonLinesOutput(json_stream))
        if vmc:
            host, port = parse_host_port(vmc, default_port=VMC_DEFAULT_PORT, what="--vmc")
            outs.append(VmcSender(host, port, neck_share=neck_share))
        if websocket:
            from .websocket import WebSocketBroadcaster

            host, port = parse_host_port(websocket, what="--websocket")
            outs.append(WebSocketBroadcaster(host, port).start())
    except BaseException:
        for o in outs:
            o.close()
        raise
    return outs


def stream_live(model, *, input: str = "-", sample_rate: int | None = None, realtime: bool = False,
                device=None, chunk_ms: float = 10.0, json_stream=None, vmc: str | None = None,
                websocket: str | None = None, neck_share: float | None = None, seed: int | None = None,
                controls=None, stdin=None, max_seconds: float | None = None,
                on_message=_stderr, sd=None, hear: str | None = None, hear_rate: int | None = None,
                settle_s: float = 0.0) -> dict:
    """Everything ``headmotion stream`` does, as one call: open the input (``"-"`` PCM on
    ``stdin`` at ``sample_rate``, ``"mic"`` with ``device``, a named pipe of PCM, or a file,
    ``realtime`` pacing it) and, with ``hear``, the other party's audio the head listens to (the
    same kinds of input; PCM at ``hear_rate``, default ``sample_rate``); the live core
    (:class:`~headmotion.live.core.HeadMotionCore`) with ``seed`` and ``controls``
    (:class:`~headmotion.synthesis.Controls`), resampling the inputs to the model's rate and, at the
    end, settling the head to rest over ``settle_s`` seconds; the outputs of :func:`open_outputs`;
    run until the input ends or Ctrl-C; close the outputs.
    Returns the statistics of :meth:`LiveSession.run`."""
    from ..errors import ParameterError
    from .inputs import open_input

    if not getattr(model, "can_stream", getattr(model, "causal", False)):
        raise ParameterError(f"system {getattr(model, 'name', '?')!r} cannot stream (neither causal nor "
                             "streaming); use a tws-basic, tws-hier, le2012, DNN or motion-match[live=true] model")
    if hear is not None and hear in ("-", "mic") and hear == input:
        raise ParameterError(f"--hear {hear} and --input {input}: the speech and the heard audio need two inputs")
    rate = int(model.sample_rate)
    fps = float(model.frame_rate)
    from .core import CoreStream, HeadMotionCore

    source = open_input(input, sample_rate=sample_rate, pcm_rate=rate, realtime=realtime, device=device,
                        chunk_ms=chunk_ms, stdin=stdin, on_message=on_message, sd=sd)
    heard = None
    if hear is not None:
        from .heard import HeardInput

        heard = HeardInput(open_input(hear, sample_rate=hear_rate, pcm_rate=sample_rate or rate, realtime=realtime,
                                      device=device, chunk_ms=chunk_ms, stdin=stdin, on_message=on_message, sd=sd))
    core = HeadMotionCore(model, seed=seed, controls=controls, resample=source.resample, settle_s=settle_s,
                          heard_rate=None if heard is None else heard.rate)
    stream = CoreStream(core, source.chunk_rate)
    outputs = open_outputs(json_stream=json_stream, vmc=vmc, websocket=websocket, neck_share=neck_share)
    names = ", ".join(getattr(o, "name", type(o).__name__) for o in outputs) or "no output"
    ws = [o for o in outputs if hasattr(o, "port") and getattr(o, "name", "") == "WebSocket"]
    where = f" (ws://{ws[0].host}:{ws[0].port})" if ws else ""
    heard_from = "" if heard is None else f", hearing {heard.source.name}"
    on_message(f"streaming with {getattr(model, 'name', '?')}: {source.name}{heard_from} → {names}{where}; "
               f"algorithmic latency {float(getattr(stream, 'latency_ms', float('nan'))):.0f} ms")
    session = LiveSession(source, stream, outputs, fps=fps, on_message=on_message, heard=heard)
    try:
        stats = session.run(max_seconds=max_seconds)
    except KeyboardInterrupt:
        session.stop()
        stats = {"frames": session.frames, "chunks": session.chunks, "latency": session.latency.summary()}
    finally:
        for o in outputs:
            try:
                o.close()
            except Exception:
                pass
    lat = stats["latency"]
    if lat["frames"]:
        on_message(f"{stats['frames']} frames; end-to-end latency median {lat['median_ms']:.0f} ms, "
                   f"p95 {lat['p95_ms']:.0f} ms")
    return stats


__all__ = ["LiveSession", "LatencyMeter", "open_outputs", "stream_live"]
