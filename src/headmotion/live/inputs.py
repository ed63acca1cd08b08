"""Live audio inputs (the seeds are silent on live use).

Every source is an iterator of mono float32 chunks, each about ``chunk_ms`` long, at its own
``sample_rate`` — or, given ``out_rate``, resampled on the fly to that rate by :class:`Resampler`
(``soxr.ResampleStream``).  ``headmotion stream`` takes the chunks at their own rate and lets its
:class:`headmotion.synthesis.SpeechStream` resample them (the one resampling of every live path);
``resample`` is the source's choice of :data:`headmotion.io.resampler.QUALITY` for that:

* :class:`PcmSource` — raw 16-bit little-endian mono PCM from a binary stream (stdin) or a named
  pipe (opened when read).  A stream that stops in the middle of a sample drops the odd byte and
  says so through ``on_message``.
* :class:`FileSource` — any audio file :func:`headmotion.io.load_audio` reads; ``realtime=True``
  releases each chunk when its last sample would have been spoken (for demos, tests and the
  end-to-end latency benchmark).
* :class:`MicSource` — a microphone through sounddevice (PortAudio).  ``device`` picks the input
  by index or by a part of its name; no PortAudio library, no input device, or an unknown device
  raise :class:`~headmotion.errors.AudioDeviceError` naming the devices that are there.  The
  ``sounddevice`` module can be injected (``sd=``), which is how it is tested without hardware.

Each source has ``t0``: the monotonic wall time at which audio time 0 was reached (set once the
first chunk is in), or ``None`` when the input is not paced (stdin at full speed, an unpaced
file).  The end-to-end latency of a frame at audio time ``τ`` is ``emit_wall − (t0 + τ)``.

Resampling latency (measured here with 10 ms chunks, 48 kHz → 16 kHz): soxr releases output in
internal blocks, so the stream's output trails its input by a median 11 ms (max 20 ms) with
``"fast"`` (soxr's LQ) — the choice for stdin, a named pipe, the microphone and a paced file — and
21 ms (max 37 ms) with ``"exact"`` (HQ; a file read at full speed: the samples ``synth`` resamples,
so the same frames).  LQ's pass band (to ~0.8 · Nyquist = 6.4 kHz at 16 kHz out) covers the F0
and energy the features use.  Same rate in and out: no resampler, no delay.

Libraries considered: sounddevice (PortAudio; maintained, numpy buffers) rather than PyAudio
(no wheels with PortAudio for recent Pythons); soxr's stream resampler rather than per-chunk
``resample`` (which clicks at chunk edges).
"""

from __future__ import annotations

import abc
import os
import queue
import stat
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from ..io.resampler import Resampler, check_resample
from ..errors import AudioDeviceError, ParameterError

Message = Callable[[str], None]


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


class AudioSource(abc.ABC):
    """Base of the sources: iterate for chunks at ``out_rate`` (the input's own ``sample_rate``
    when None); ``close()`` stops early; ``resample`` the :data:`~headmotion.io.resampler.QUALITY`
    name a stream resampling the chunks should use."""

    sample_rate: int
    out_rate: int | None = None
    resample: str = "fast"
    t0: float | None = None
    paced: bool = False
    name: str = "audio"

    @abc.abstractmethod
    def __iter__(self) -> Iterator[np.ndarray]:
        """The chunks (float32, mono, at ``out_rate`` or ``sample_rate``) until the input ends or ``close()``."""

    @property
    def chunk_rate(self) -> int:
        """The rate of the chunks: ``out_rate``, or the input's own."""
        return int(self.out_rate or self.sample_rate)

    def _resampler(self) -> Resampler:
        return Resampler(self.sample_rate, self.chunk_rate, quality=check_resample(self.resample))

    def close(self) -> None:  # noqa: B027 (an optional hook: a source with nothing to release keeps it)
        pass


class PcmSource(AudioSource):
    """16-bit little-endian mono PCM from a binary stream (default: stdin).

    Parameters
    ----------
    stream : binary file object (``read(n)``), default ``sys.stdin.buffer``, or the path of a
        named pipe (opened when the source is read, so that opening it waits for its writer there)
    sample_rate : int, rate of the PCM
    out_rate : int, optional, rate of the chunks produced (default: ``sample_rate``)
    chunk_ms : float, read size
    resample : ``"fast"`` or ``"exact"`` (:data:`headmotion.io.resampler.QUALITY`)
    """

    def __init__(self, stream=None, *, sample_rate: int, out_rate: int | None = None, chunk_ms: float = 10.0,
                 resample: str = "fast", on_message: Message = _stderr):
        if chunk_ms <= 0:
            raise ParameterError(f"chunk_ms must be positive; got {chunk_ms}")
        self.path = stream if isinstance(stream, (str, os.PathLike)) else None
        self.stream = sys.stdin.buffer if stream is None else stream
        self.sample_rate, self.out_rate, self.resample = int(sample_rate), out_rate, resample
        self.nbytes = max(2, int(round(self.sample_rate * chunk_ms / 1000.0)) * 2)
        self.resampler = self._resampler()
        self.on_message = on_message
        self.name = str(self.path) if self.path is not None else getattr(self.stream, "name", "stdin")
        self.dropped_bytes = 0
        self._closed = False

    def __iter__(self):
        if self.path is None:
            yield from self._chunks()
            return
        try:
            self.stream = open(self.path, "rb")  # noqa: SIM115 (closed below, read chunk by chunk)
        except OSError as exc:
            raise AudioDeviceError(f"{self.path}: cannot open the pipe ({exc.strerror})") from None
        try:
            yield from self._chunks()
        finally:
            self.stream.close()

    def _chunks(self):
        leftover = b""
        while not self._closed:
            data = self.stream.read(self.nbytes)
            if not data:
                break
            data = leftover + data
            n = len(data) // 2 * 2
            leftover = data[n:]
            if n:
                yield self.resampler(np.frombuffer(data[:n], dtype="<i2").astype(np.float32) / 32768.0)
        if leftover:
            self.dropped_bytes = len(leftover)
            self.on_message(f"{self.name}: the PCM stream stopped in the middle of a 16-bit sample; "
                            f"dropped the last {len(leftover)} byte (expected whole s16le samples)")
        tail = self.resampler(np.zeros(0, np.float32), last=True)
        if tail.size:
            yield tail

    def close(self) -> None:  # noqa: B027 (an optional hook: a source with nothing to release keeps it)
        self._closed = True


class FileSource(AudioSource):
    """An audio file in chunks, optionally paced at speech speed.

    Parameters
    ----------
    path : audio or video file
    out_rate : int, optional (default: the file's rate)
    chunk_ms : float
    realtime : bool, release each chunk when its last sample would have been spoken
    resample : ``"fast"`` or ``"exact"``; default ``"fast"`` when ``realtime`` (latency), else
        ``"exact"`` — the resampling :func:`headmotion.io.audio.resample` does for ``synth``, and
        soxr's stream resampler gives its samples exactly, so a file streamed at full speed gives
        ``synth``'s frames (with ``"fast"`` the template systems' choices diverge on the tiny
        feature differences: 0.35 rad within 9 s)
    clock, sleep : injectable time functions (tests)
    """

    def __init__(self, path, *, out_rate: int | None = None, chunk_ms: float = 10.0, realtime: bool = False,
                 resample: str | None = None, clock=time.monotonic, sleep=time.sleep):
        from ..io import load_audio

        if chunk_ms <= 0:
            raise ParameterError(f"chunk_ms must be positive; got {chunk_ms}")
        self.path = Path(path)
        self.audio = load_audio(self.path)
        self.sample_rate, self.out_rate = int(self.audio.sample_rate), out_rate
        self.chunk = max(1, int(round(self.audio.sample_rate * chunk_ms / 1000.0)))
        # paced: low latency; at full speed: synth's resampling, so the frames are synth's
        self.resample = resample or ("fast" if realtime else "exact")
        self.resampler = self._resampler()
        self.paced = bool(realtime)
        self.clock, self.sleep = clock, sleep
        self.name = str(self.path)
        self._closed = False

    def __iter__(self):
        x, sr = self.audio.samples, self.audio.sample_rate
        if self.paced:
            self.t0 = self.clock()
        for i in range(0, len(x), self.chunk):
            if self._closed:
                return
            seg = x[i:i + self.chunk]
            if self.paced:
                due = self.t0 + (i + len(seg)) / sr
                wait = due - self.clock()
                if wait > 0:
                    self.sleep(wait)
            yield self.resampler(seg, last=i + self.chunk >= len(x))

    def close(self) -> None:  # noqa: B027 (an optional hook: a source with nothing to release keeps it)
        self._closed = True


def _import_sounddevice():
    try:
        import sounddevice as sd
    except OSError as exc:  # sounddevice imports, but finds no libportaudio
        raise AudioDeviceError(
            f"--input mic needs the PortAudio library, which was not found ({exc}); install it "
            "(e.g. apt install libportaudio2) or use --input FILE or --input -") from None
    except ImportError:
        raise AudioDeviceError("--input mic needs the sounddevice package: pip install 'headmotion[live]'") from None
    return sd


def input_devices(sd=None) -> list[tuple[int, str, float]]:
    """``(index, name, default rate)`` of every input device PortAudio reports."""
    sd = _import_sounddevice() if sd is None else sd
    try:
        devs = list(sd.query_devices())
    except Exception as exc:  # PortAudio errors are not a common class
        raise AudioDeviceError(f"cannot list audio devices: {exc}") from None
    return [(i, str(d.get("name", i)), float(d.get("default_samplerate") or 0))
            for i, d in enumerate(devs) if int(d.get("max_input_channels", 0) or 0) > 0]


def pick_device(device, sd=None) -> tuple[int, str, float]:
    """The input device for ``device`` (None: the default input; int: index; str: part of a name)."""
    sd = _import_sounddevice() if sd is None else sd
    devs = input_devices(sd)
    if not devs:
        raise AudioDeviceError("no audio input device found (PortAudio lists none); connect a microphone "
                               "or use --input FILE / --input -")
    listing = "; ".join(f"{i}: {n}" for i, n, _ in devs)
    if device is None or device == "":
        try:
            default = sd.default.device
            idx = default[0] if isinstance(default, (list, tuple)) else default
            idx = int(idx)
        except Exception:
            idx = -1
        for d in devs:
            if d[0] == idx:
                return d
        return devs[0]
    key = str(device).strip()
    if key.lstrip("-").isdigit():
        for d in devs:
            if d[0] == int(key):
                return d
        raise AudioDeviceError(f"--device {key}: no input device has that index; input devices: {listing}")
    hits = [d for d in devs if key.lower() in d[1].lower()]
    if len(hits) == 1:
        return hits[0]
    if not hits:
        raise AudioDeviceError(f"--device {key!r}: no input device name contains it; input devices: {listing}")
    raise AudioDeviceError(f"--device {key!r} matches several input devices ({'; '.join(n for _, n, _ in hits)}); "
                           "give the index or a longer part of the name")


class MicSource(AudioSource):
    """A microphone through sounddevice (PortAudio), chunks resampled to ``out_rate``.

    Parameters
    ----------
    device : None (default input), an index, or a part of the device's name
    out_rate : int, optional (default: the capture rate)
    chunk_ms : float, PortAudio block size
    sample_rate : int, optional, capture rate (default: the device's default rate)
    max_queue : int, chunks buffered between the audio thread and the consumer; when the consumer
        falls behind, the oldest chunk is dropped (counted in ``overflows``) rather than letting the
        delay grow
    sd : the ``sounddevice`` module, or a stand-in with ``query_devices``, ``default`` and
        ``InputStream`` (tests)
    """

    def __init__(self, device=None, *, out_rate: int | None = None, chunk_ms: float = 10.0,
                 sample_rate: int | None = None, max_queue: int = 50, resample: str = "fast", sd=None,
                 clock=time.monotonic, on_message: Message = _stderr):
        self.sd = _import_sounddevice() if sd is None else sd
        self.index, self.device_name, default_rate = pick_device(device, self.sd)
        self.sample_rate = int(sample_rate or default_rate or 48000)
        self.out_rate, self.resample = out_rate, resample
        self.block = max(1, int(round(self.sample_rate * chunk_ms / 1000.0)))
        self.resampler = self._resampler()
        self.paced = True
        self.name = f"microphone {self.index}: {self.device_name}"
        self.clock = clock
        self.on_message = on_message
        self.overflows = 0
        self._q: queue.Queue = queue.Queue(maxsize=max(2, int(max_queue)))
        self._stop = threading.Event()
        self._samples = 0

    def _callback(self, indata, frames, _time_info, _status):  # PortAudio's thread
        now = self.clock()
        if self.t0 is None:
            self.t0 = now - frames / self.sample_rate
        x = np.array(indata, dtype=np.float32).reshape(frames, -1)[:, 0]
        try:
            self._q.put_nowait(x)
        except queue.Full:
            try:
                self._q.get_nowait()
            except queue.Empty:
                pass
            self.overflows += 1
            self._q.put_nowait(x)

    def __iter__(self):
        try:
            stream = self.sd.InputStream(device=self.index, channels=1, samplerate=self.sample_rate,
                                         blocksize=self.block, dtype="float32", callback=self._callback)
        except Exception as exc:
            raise AudioDeviceError(f"cannot open {self.name} at {self.sample_rate} Hz: {exc}") from None
        with stream:
            while not self._stop.is_set():
                try:
                    x = self._q.get(timeout=0.1)
                except queue.Empty:
                    if not getattr(stream, "active", True):
                        break
                    continue
                yield self.resampler(x)
        tail = self.resampler(np.zeros(0, np.float32), last=True)
        if tail.size:
            yield tail
        if self.overflows:
            self.on_message(f"{self.name}: dropped {self.overflows} audio blocks because processing fell behind")

    def close(self) -> None:  # noqa: B027 (an optional hook: a source with nothing to release keeps it)
        self._stop.set()


def is_pipe(spec) -> bool:
    """True when ``spec`` names a named pipe (FIFO)."""
    try:
        return stat.S_ISFIFO(os.stat(spec).st_mode)
    except (OSError, ValueError):
        return False


def open_input(spec: str, *, out_rate: int | None = None, sample_rate: int | None = None, realtime: bool = False,
               device=None, chunk_ms: float = 10.0, resample: str | None = None, stdin=None,
               on_message: Message = _stderr, sd=None, pcm_rate: int | None = None) -> AudioSource:
    """The source for ``--input`` (or ``--hear``): ``-`` (PCM on stdin at ``sample_rate``, default
    ``pcm_rate``, then ``out_rate``), ``mic`` (at ``sample_rate``, default the device's), a named
    pipe of PCM (as stdin), or an audio file.  Chunks at
    ``out_rate``, or at the input's own rate when None.  ``resample``
    (:data:`headmotion.io.resampler.QUALITY`): by default ``"fast"`` for stdin, a pipe and the
    microphone (latency) and :class:`FileSource`'s choice for a file."""
    if spec == "-" or is_pipe(spec):
        rate = sample_rate or pcm_rate or out_rate
        if rate is None:
            raise ParameterError(f"{'stdin' if spec == '-' else spec}: raw PCM needs its sample rate")
        return PcmSource(stdin if spec == "-" else spec, sample_rate=rate, out_rate=out_rate, chunk_ms=chunk_ms,
                         resample=resample or "fast", on_message=on_message)
    if spec == "mic":
        return MicSource(device, out_rate=out_rate, chunk_ms=chunk_ms, sample_rate=sample_rate,
                         resample=resample or "fast", sd=sd, on_message=on_message)
    return FileSource(spec, out_rate=out_rate, chunk_ms=chunk_ms, realtime=realtime, resample=resample)


__all__ = ["Resampler", "AudioSource", "PcmSource", "FileSource", "MicSource", "open_input", "is_pipe",
           "input_devices", "pick_device"]
