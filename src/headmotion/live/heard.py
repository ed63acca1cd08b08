"""What the head hears in a live session: the other party's audio, a second
:class:`~headmotion.live.inputs.AudioSource`, fed to the stream's
:meth:`~headmotion.synthesis.SpeechStream.hear` on the speech's timeline (the seeds are silent on
live use).

Both inputs start at audio time 0.  Before each speech chunk the session hands the stream the
heard audio up to that chunk's end (:meth:`HeardInput.up_to`):

* speech that is not paced (a file at full speed, PCM on stdin or a pipe read as fast as it comes)
  waits for the heard audio up to the chunk's end, so the two line up sample for sample and the
  frames are ``synthesize(speech, hear=other)``'s (``headmotion synth SPEECH --hear OTHER``);
* paced speech (the microphone, ``--realtime``) takes the heard audio that has arrived and goes
  on: heard audio that comes late is used when it comes (the stream makes a nod whose time passed
  less than 0.3 s ago, drops later ones).

When the speech ends first, the session speaks silence for the rest of the heard audio
(:meth:`HeardInput.silence_after_speech`), as ``synth`` pads the shorter of the two: the head
listens to the end.
"""

from __future__ import annotations

import queue
import threading

import numpy as np

_END = object()


def feed(source, q: queue.Queue, stop: threading.Event) -> bool:
    """Put each chunk of ``source`` on ``q`` (a reader thread's work), waiting while it is full;
    True once the source ended, False when ``stop`` was set first."""
    for chunk in source:
        while not stop.is_set():
            try:
                q.put(chunk, timeout=0.1)
                break
            except queue.Full:
                continue
        if stop.is_set():
            return False
    return True


class HeardInput:
    """A reader thread over ``source`` (chunks at its own rate, ``source.chunk_rate``) and the
    bookkeeping of how much of it the stream has heard."""

    def __init__(self, source, *, max_queue: int = 200):
        self.source = source
        self.rate = int(source.chunk_rate)
        self.samples = 0  # heard samples handed to the stream
        self.ended = False
        self._q: queue.Queue = queue.Queue(maxsize=max(2, int(max_queue)))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, name="headmotion-heard", daemon=True)

    @property
    def seconds(self) -> float:
        return self.samples / self.rate

    def start(self) -> "HeardInput":
        self._thread.start()
        return self

    def _read(self) -> None:
        try:
            if feed(self.source, self._q, self._stop):
                self._q.put(_END)
        except BaseException as exc:  # forwarded to the session's thread
            self._q.put(exc)

    def _next(self, wait: bool, keep_going=lambda: True):
        """The next chunk; None when none is there (``wait=False``), the input ended, or waiting
        stopped (:meth:`close`, ``keep_going()`` false)."""
        while not self.ended:
            try:
                item = self._q.get(timeout=0.1) if wait else self._q.get_nowait()
            except queue.Empty:
                if wait and not self._stop.is_set() and keep_going():
                    continue
                return None
            if item is _END:
                self.ended = True
                return None
            if isinstance(item, BaseException):
                self.ended = True
                raise item
            return item
        return None

    def up_to(self, stream, seconds: float, *, wait: bool) -> None:
        """Hand ``stream`` the heard audio up to ``seconds`` (waiting for it when ``wait``; else what
        has arrived)."""
        while self.samples < seconds * self.rate and not self.ended:
            chunk = self._next(wait)
            if chunk is None:
                return
            stream.hear(chunk)
            self.samples += len(chunk)

    def silence_after_speech(self, stream, speech_samples: int, speech_rate: int, emit,
                             keep_going=lambda: True) -> int:
        """Once the speech has ended: the rest of the heard audio, each chunk with as much silence
        pushed as speech (``emit`` takes the frames), so that the speech lasts as long as the heard
        audio — ``round(heard seconds × speech_rate)`` samples, as ``synth`` pads it — or until
        ``keep_going()`` is false.  Returns the speech samples pushed in all."""
        while True:
            target = int(round(self.samples / self.rate * speech_rate))
            if target > speech_samples:
                emit(stream.push(np.zeros(target - speech_samples, np.float32)))
                speech_samples = target
            chunk = self._next(wait=True, keep_going=keep_going)
            if chunk is None:
                return speech_samples
            stream.hear(chunk)
            self.samples += len(chunk)

    def stop(self) -> None:
        """Stop reading and waiting (from any thread)."""
        self._stop.set()
        self.source.close()

    def close(self) -> None:
        self.stop()
        self._thread.join(timeout=2.0)


__all__ = ["HeardInput"]
