"""A voice agent's audio held back by the model's lookahead, so that a head that reads the speech
ahead still moves with the voice that plays.

With ``lookahead_ms`` L (:class:`headmotion.synthesis.Controls`) a frame of head motion is final
only once L more of the speech has been made (plus the features' 39 ms).  A voice agent's TTS makes
its audio before it plays, but a streaming TTS may make it hardly faster than real time: were each
chunk played as it comes, the voice would lead the head by up to L.  :class:`AudioHold` holds each
chunk of the agent's audio until L more of the utterance's audio has come (its frames are then
made) or the utterance ends, and only then passes it on to the output; the pacer
(:class:`~headmotion.live.pacing.Pacer`) is told when each chunk went (:meth:`Pacer.handed
<headmotion.live.pacing.Pacer.handed>`) and sends the frames as their audio plays.  Whatever else
goes the same way in between waits behind the audio held before it, so nothing changes order.
The voice starts L later; with L = 0 nothing waits.
"""

from __future__ import annotations

import dataclasses
import os
from collections import deque
from collections.abc import Awaitable, Callable

import numpy as np

from ..errors import HeadMotionError, ParameterError
from ..shipped import resolve_model_path
from ..synthesis import Controls, load_model
from ..systems.decisions import run_alone
from . import AGENT_LOOKAHEAD_MS
from .core import HeadMotionCore, log
from .pacing import Pacer

#: what an item held is: the agent's audio, the mark before an utterance's first audio, anything else
AUDIO, START, OTHER = "audio", "start", "other"


class AudioHold:
    """The agent's audio on its way to the output, held by ``hold_s`` seconds of the utterance's
    audio (module docstring).  Items are the framework's own objects (audio frames, other frames);
    every method returns the entries ``(item, samples, sample_rate)`` to pass on now, in order
    (``samples`` 0 for an item that is not audio), which :meth:`pass_on` sends.

    Parameters
    ----------
    pacer : Pacer
        The agent's pacer: the audio's frames are made by it (:meth:`Pacer.audio` with
        ``handed=False``) and it learns when the audio went on (:meth:`pass_on`).
    hold_s : float
        Seconds of the utterance's audio that must follow a chunk before it goes on (the model's
        ``lookahead_ms`` / 1000).
    on_start : callable, optional
        ``on_start(utterance)`` → an item passed on right before an utterance's first audio (a
        message saying where its audio starts); None: none.
    """

    def __init__(self, pacer: Pacer, hold_s: float, *, on_start: Callable[[int], object] | None = None):
        self.pacer, self.hold_s, self.on_start = pacer, max(0.0, float(hold_s)), on_start
        self._items: deque = deque()  # (kind, item, samples, rate, end): end = samples received to its end
        self._received = 0  # samples of the audio received at ``_rate`` since the hold was last emptied
        self._rate: int | None = None

    @property
    def held(self) -> int:
        """Items held (audio and the rest)."""
        return len(self._items)

    def audio(self, item, samples, sample_rate: int, now=None) -> list:
        """The agent's audio chunk ``item`` with its ``samples`` (float32 mono at ``sample_rate``):
        its frames are made now (a failure is logged: the audio still goes on), and it goes on once
        ``hold_s`` more of the utterance's audio has come.  Returns the entries to pass on now."""
        return run_alone(self.audio_steps(item, samples, sample_rate, now))

    def audio_steps(self, item, samples, sample_rate: int, now=None):
        """:meth:`audio` step by step: a generator that yields the model's decisions for an engine
        to answer (:meth:`Pacer.audio_steps <headmotion.live.pacing.Pacer.audio_steps>`)."""
        rate = int(sample_rate)
        out = []
        if self._items and rate != self._rate:  # another rate ends the utterance: what is held goes first
            out = self.release()
            for _item, n, r in out:  # on the timeline now, before the pacer ends the utterance
                if n:
                    self.pacer.handed(n, r, now)
            out = [(item, 0, 0) for item, _n, _r in out]
        self.pacer.audio_started = None
        try:
            yield from self.pacer.audio_steps(samples, rate, now, handed=False)
        except HeadMotionError as exc:
            log.warning("headmotion: no head motion for this audio: %s", exc)
        if self.pacer.audio_started is not None and self.on_start is not None:
            self._items.append((START, self.on_start(self.pacer.audio_started), 0, 0, self._received))
        n = int(np.shape(samples)[0]) if np.ndim(samples) else 0
        self._rate = rate
        self._received += n
        self._items.append((AUDIO, item, n, rate, self._received))
        return out + self._take()

    def other(self, item) -> list:
        """Anything else that goes the audio's way: on at once, or behind the audio held."""
        if not self._items:
            return [(item, 0, 0)]
        self._items.append((OTHER, item, 0, 0, self._received))
        return []

    def release(self) -> list:
        """Everything held, to pass on now (the utterance ended, or the pipeline does)."""
        out = [(item, n, rate) for _kind, item, n, rate, _end in self._items]
        self._items.clear()
        self._received = 0
        return out

    def drop(self) -> list:
        """The agent was cut off: the audio held (and its utterance's start mark) never plays and
        is dropped, as the framework drops the audio it had; the other items held go on."""
        out = [(item, 0, 0) for kind, item, _n, _rate, _end in self._items if kind == OTHER]
        self._items.clear()
        self._received = 0
        return out

    def _take(self) -> list:
        out = []
        need = round(self.hold_s * (self._rate or 0))  # samples that must follow a chunk's end
        while self._items:
            kind, item, n, rate, end = self._items[0]
            if kind == START:  # goes with the audio it marks, which comes right after it
                end = self._items[1][4]
            if kind != OTHER and self._received - end < need:
                break
            self._items.popleft()
            out.append((item, n, rate))
        if not self._items:
            self._received = 0
        return out

    async def pass_on(self, entries: list, send: Callable[[object], Awaitable[None]], now=None) -> None:
        """``await send(item)`` for each entry, in order; after each chunk of audio the pacer
        learns that it went to the output (it plays from then on)."""
        for item, n, rate in entries:
            await send(item)
            if n:
                self.pacer.handed(n, rate, now)


_LOADED: dict = {}  # (model file, its modification time) → the model loaded


def shared_model(model):
    """:func:`~headmotion.synthesis.load_model`, once per process for a shipped name or a model file
    (a file again when it changed; a name and its file are one model): the agents of a process
    share one model, its libraries (read once, held once) and so the engine's one product per
    library for their decisions.  A loaded model is returned as it is."""
    if not isinstance(model, (str, os.PathLike)):
        return load_model(model)
    path = resolve_model_path(model).resolve()
    key = (str(path), path.stat().st_mtime_ns)
    if key not in _LOADED:
        _LOADED[key] = load_model(path)
    return _LOADED[key]


def agent_core(model, *, lookahead_ms: float | None = None, controls: Controls | None = None, seed: int = 0,
               resample: str = "exact", settle_s: float, **controls_kwargs) -> HeadMotionCore:
    """A voice agent's live core (:class:`HeadMotionCore` with these arguments) whose model reads
    ``lookahead_ms`` ahead: None — the value in ``controls`` when it sets one, else
    :data:`~headmotion.live.AGENT_LOOKAHEAD_MS` for a live model that reads ahead by this setting
    (the shipped ``stream``) and 0 for the others.  Hold the agent's audio by
    ``core.controls.lookahead_ms`` (:class:`AudioHold`)."""
    if controls is not None and controls_kwargs:
        raise ParameterError(f"give the controls as `controls=` or as keywords, not both; got {sorted(controls_kwargs)}")
    m = shared_model(model)
    c = Controls.parse(**controls_kwargs) if controls is None else controls
    if lookahead_ms is None:
        params = m.get_params()
        lookahead_ms = c.lookahead_ms or (AGENT_LOOKAHEAD_MS if params.get("live") and "lookahead_ms" in params
                                          else 0.0)
    c = dataclasses.replace(c, lookahead_ms=lookahead_ms)
    return HeadMotionCore(m, seed=seed, resample=resample, settle_s=settle_s, controls=c)


__all__ = ["AudioHold", "AUDIO", "START", "OTHER", "agent_core", "shared_model"]
