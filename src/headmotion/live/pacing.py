"""When a voice agent's head-motion frames go out: in time with the audio they belong to
(:class:`Pacer`), sent by an asyncio task (:class:`PacedSender`) — the pacing layer of
:mod:`headmotion.live.core`."""

from __future__ import annotations

import asyncio
import bisect
import itertools
import math
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

import numpy as np

from ..errors import SampleRateError
from ..systems.decisions import run_alone
from .core import FrameBatch, HeadMotionCore, UtteranceEnd, check_seconds, log


@dataclass(order=True)
class _Entry:
    due: float
    seq: int
    utt: int
    number: int = -1  # frame number; -1 for an end message
    row: object = None  # (3,) rotvec, or the UtteranceEnd
    audio_time: float = 0.0
    settling: bool = False


class Pacer:
    """When each frame message goes out (module docstring).  Not thread-safe; every method takes
    ``now`` (seconds of ``clock``; None: ``clock()``).

    Parameters
    ----------
    core : HeadMotionCore
    pace : bool
        True: a frame goes out when its audio plays (plus ``delay_s``); False: as soon as it is
        made (the page then times the frames itself, by their ``time``).
    delay_s : float
        Seconds the frames are held back beyond the audio's playback as this process sees it: the
        audio's way to the listener (e.g. a WebRTC jitter buffer) that the data does not take.
    clock : callable
        Seconds, monotonic (default :func:`time.monotonic`).
    """

    def __init__(self, core: HeadMotionCore, *, pace: bool = True, delay_s: float = 0.0,
                 clock: Callable[[], float] = time.monotonic):
        self.core, self.pace, self.clock = core, bool(pace), clock
        self.delay_s = check_seconds(delay_s, (0.0, 10.0), "delay_s")
        self._entries: list[_Entry] = []
        self._seq = itertools.count()
        self._utt = 0
        self._sent: dict[int, int] = {}  # utterance → frames sent (its frames go out in order)
        self._playhead = -math.inf  # when the audio handed to the output so far ends playing
        self._segments: list[tuple[float, float]] = []  # (audio offset, wall start) of the utterance
        self._paused_at: float | None = None
        self._listening_turns: set[int] = set()
        self._interrupted: set[int] = set()
        #: the utterance whose audio the last :meth:`audio` call began (None: it went on one)
        self.audio_started: int | None = None
        self._given, self._rate = 0, 0  # samples of the utterance's audio handed to the output, their rate
        self._waiting: list[tuple[int, np.ndarray, float]] = []  # frames made before their audio was handed
        self._cut_at_hand = False  # the utterance's first audio is held: the last settling gives way when it goes

    def _now(self, now):
        return self.clock() if now is None else float(now)

    @property
    def pending(self) -> int:
        """Messages' entries waiting to go out."""
        return len(self._entries)

    @property
    def utterance(self) -> int:
        """The number of the current (or last) utterance, from 1."""
        return self._utt

    def audio(self, samples, sample_rate: int, now=None, *, handed: bool = True) -> FrameBatch:
        """The agent's audio of the current utterance, as it goes to the output (the first after
        an end or an interruption starts a new utterance; audio at another rate than the
        utterance's so far ends it and starts another).  Returns the frames made.

        ``handed=False``: the audio is held back before the output (the model reads ahead of it,
        ``lookahead_ms``; :class:`~headmotion.live.hold.AudioHold`): its frames are made now and go
        out when it plays, once :meth:`handed` has said that it went to the output."""
        return run_alone(self.audio_steps(samples, sample_rate, now, handed=handed))

    def audio_steps(self, samples, sample_rate: int, now=None, *, handed: bool = True):
        """:meth:`audio` step by step: a generator that yields the core's decisions
        (:meth:`HeadMotionCore.push_steps`) for an engine to answer
        (:class:`~headmotion.live.engine.LiveEngine`); its value is the FrameBatch."""
        now = self._now(now)
        self.audio_started = None
        start = max(now, self._playhead)
        if self.core.listening:  # the agent takes the turn: the listening turn ends now
            for item in self.core.end_listening():
                self._schedule_end(item, now + self.delay_s if self.pace else -math.inf)
        if not self.core.speaking:
            self._utt += 1
            self._sent[self._utt] = 0
            self._sent = {u: n for u, n in self._sent.items() if u >= self._utt - 1}
            self._segments = []
            self._given, self._waiting = 0, []
            self.audio_started = self._utt
            self._cut_at_hand = self.pace and not handed
            if self.pace and handed:  # the last utterance's settling gives way to this one's speech
                self._cut(start + self.delay_s)
        try:
            batch = yield from self.core.push_steps(samples, sample_rate)  # raises before the timeline moves
        except SampleRateError:  # the audio changed rate: that utterance ends and another begins
            yield from self.end_steps(now)
            return (yield from self.audio_steps(samples, sample_rate, now, handed=handed))
        n = int(np.shape(samples)[0]) if np.ndim(samples) else 0
        self._rate = int(sample_rate)
        if self.pace and handed:
            self._segments.append((self.core.audio_seconds - n / int(sample_rate), start))
            self._playhead = start + n / int(sample_rate)
            self._given += n
        self._schedule(batch)
        return batch

    def handed(self, n: int, sample_rate: int, now=None) -> None:
        """The next ``n`` samples (at ``sample_rate``) of the utterance's audio given to
        :meth:`audio` with ``handed=False`` went to the output now: they play from now (or after
        the audio before them), and the frames of that audio go out as it plays."""
        now = self._now(now)
        if not self.pace or n <= 0:
            return
        start = max(now, self._playhead)
        if self._cut_at_hand:
            self._cut_at_hand = False
            self._cut(start + self.delay_s)
        rate = int(sample_rate)
        self._segments.append((self._given / rate, start))
        self._given += int(n)
        self._playhead = start + int(n) / rate
        self._release_waiting(rate)

    def _release_waiting(self, rate: int | None) -> None:
        """Schedule the frames waiting for their audio that is now on the timeline (all of them
        when ``rate`` is None: the utterance ends, they follow the audio handed so far)."""
        if not self._waiting:
            return
        ready = [w for w in self._waiting if rate is None or w[0] / self.core.fps < self._given / rate]
        self._waiting = self._waiting[len(ready):]
        for number, row, audio_time in ready:
            due = self._wall(number / self.core.fps) + self.delay_s
            self._add(_Entry(due, next(self._seq), self._utt, number, row, audio_time))

    def hear(self, samples, sample_rate: int, now=None) -> FrameBatch:
        """The user's audio as it arrives (live).  Once the agent's audio and its settling have
        gone out, the head listens (:meth:`HeadMotionCore.hear`): a listening turn, numbered as an
        utterance, whose frames go out at once (plus ``delay_s``) — they belong to audio already
        heard.  Before that, nothing (an empty batch)."""
        return run_alone(self.hear_steps(samples, sample_rate, now))

    def hear_steps(self, samples, sample_rate: int, now=None):
        """:meth:`hear` step by step (as :meth:`audio_steps`)."""
        now = self._now(now)
        if not self.core.listening and (self.core.speaking or now < self.busy_until()):
            return FrameBatch(0, self.core.fps, np.zeros((0, 3)), 0.0)
        if not self.core.listening:
            self._utt += 1
            self._sent[self._utt] = 0
            self._sent = {u: n for u, n in self._sent.items() if u >= self._utt - 1}
            self._segments = []
            self._listening_turns = {u for u in self._listening_turns if u >= self._utt - 1} | {self._utt}
        batch = yield from self.core.hear_steps(samples, sample_rate)
        due = now + self.delay_s if self.pace else -math.inf
        for k, row in enumerate(batch.rotvec):
            self._add(_Entry(due, next(self._seq), self._utt, batch.first + k, row, batch.audio_time))
        return batch

    def end(self, now=None) -> None:
        """The utterance ended (the TTS stopped): its last frames, its settling after its audio,
        and its end message."""
        run_alone(self.end_steps(now))

    def end_steps(self, now=None):
        """:meth:`end` step by step (as :meth:`audio_steps`)."""
        self._now(now)
        items = yield from self.core.end_steps()
        for item in items:
            if isinstance(item, FrameBatch):
                self._schedule(item)
            else:
                self._schedule_end(item, None)

    def interrupt(self, now=None) -> None:
        """The utterance was cut off.  Paced: the frames not yet out are dropped and the head
        settles from the last one that went out, starting now; an utterance whose audio has all
        played keeps its settling.  Unpaced: every frame made goes out, then the settling.  With
        nothing spoken, nothing happens."""
        now = self._now(now)
        utt = self._utt
        self._cut_at_hand = False
        if not self.pace:
            if self.core.speaking:
                for item in self.core.interrupt():
                    if isinstance(item, FrameBatch):
                        self._schedule(item)
                    else:
                        self._schedule_end(item, -math.inf)
            return
        speech_waiting = bool(self._waiting) or any(e.utt == utt and e.number >= 0 and not e.settling
                                                    for e in self._entries)
        if not (self.core.speaking or speech_waiting):
            return
        self._entries = [e for e in self._entries if e.utt != utt]
        self._waiting = []
        self._interrupted = {u for u in self._interrupted if u >= utt - 1} | {utt}
        items = self.core.interrupt(shown=self._sent.get(utt, 0))
        t0 = now + self.delay_s
        last = t0
        for item in items:
            if isinstance(item, FrameBatch):
                for k, row in enumerate(item.rotvec):
                    last = t0 + k / item.fps
                    self._add(_Entry(last, next(self._seq), utt, item.first + k, row, item.audio_time, True))
            else:
                self._schedule_end(item, last)
        self._playhead = now
        self._segments = []

    def pause(self, now=None) -> None:
        """The output paused its playback: nothing goes out until :meth:`resume`."""
        if self._paused_at is None:
            self._paused_at = self._now(now)

    def resume(self, now=None) -> None:
        """The output resumed: everything waiting moves later by the pause."""
        if self._paused_at is None:
            return
        shift = max(0.0, self._now(now) - self._paused_at)
        self._paused_at = None
        for e in self._entries:
            e.due += shift
        self._playhead += shift
        self._segments = [(a, p + shift) for a, p in self._segments]

    def busy_until(self) -> float:
        """When the audio handed to the output and every message waiting will have gone out."""
        return max([self._playhead] + [e.due for e in self._entries])

    def next_due(self) -> float | None:
        """When the next message is due (None: nothing waits, or paused)."""
        if self._paused_at is not None or not self._entries:
            return None
        return self._entries[0].due

    def due(self, now=None) -> list[dict]:
        """Pop the messages due by ``now``, in order (consecutive frames in one message)."""
        if self._paused_at is not None:
            return []
        now = self._now(now)
        k = 0
        while k < len(self._entries) and self._entries[k].due <= now:
            k += 1
        return self._messages(self._pop(k))

    def drain(self) -> list[dict]:
        """Pop every message waiting, due or not (the pipeline ends)."""
        return self._messages(self._pop(len(self._entries)))

    def _pop(self, k: int) -> list[_Entry]:
        out, self._entries = self._entries[:k], self._entries[k:]
        for e in out:
            if e.number >= 0:
                self._sent[e.utt] = max(self._sent.get(e.utt, 0), e.number + 1)
        return out

    def _messages(self, entries: list[_Entry]) -> list[dict]:
        out: list[dict] = []
        group: list[_Entry] = []

        def close():
            if group:
                rv = np.vstack([g.row for g in group])
                m = FrameBatch(group[0].number, self.core.fps, rv, group[-1].audio_time).message()
                out.append(self._mark(m, group[-1]))
                group.clear()

        for e in entries:
            if e.number < 0:
                close()
                out.append({**e.row.message(), "utterance": e.utt})
                continue
            if group and (e.utt != group[-1].utt or e.number != group[-1].number + 1
                          or e.settling != group[-1].settling):
                close()
            group.append(e)
        close()
        return out

    def _mark(self, message: dict, e: _Entry) -> dict:
        """A frames message with its utterance's number, and what its frames are when they do not
        follow the agent's audio: ``settling`` (easing to rest after it; ``interrupted``: after
        the audio was cut off, wherever it stopped), ``listening`` (a listening turn's, made from
        the user's audio)."""
        message["utterance"] = e.utt
        if e.settling:
            message["settling"] = True
            if e.utt in self._interrupted:
                message["interrupted"] = True
        if e.utt in self._listening_turns:
            message["listening"] = True
        return message

    def _wall(self, t: float) -> float:
        """When the utterance's audio time ``t`` plays (the timeline of its pushes)."""
        if not self._segments:
            return max(self.clock(), self._playhead)
        i = max(0, bisect.bisect_right([a for a, _ in self._segments], t) - 1)
        a, p = self._segments[i]
        return p + (t - a)

    def _add(self, e: _Entry) -> None:
        bisect.insort(self._entries, e)

    def _schedule(self, batch: FrameBatch) -> None:
        if batch.settling:  # after the speech: every frame of it is on the timeline first
            self._release_waiting(None)
        handed_s = self._given / self._rate if self._rate else math.inf  # the utterance's audio handed on
        for k, row in enumerate(batch.rotvec):
            number = batch.first + k
            if self.pace and not batch.settling and (self._waiting or number / batch.fps >= handed_s):
                self._waiting.append((number, row, batch.audio_time))  # its audio is still held
                continue
            due = self._wall(number / batch.fps) + self.delay_s if self.pace else -math.inf
            self._add(_Entry(due, next(self._seq), self._utt, number, row, batch.audio_time, batch.settling))

    def _schedule_end(self, end: UtteranceEnd, due: float | None) -> None:
        self._release_waiting(None)
        if due is None:
            if not self.pace:
                due = -math.inf
            else:  # after the utterance's last frame, or its audio
                mine = [e.due for e in self._entries if e.utt == self._utt]
                due = max(mine) if mine else self._wall(end.audio_seconds) + self.delay_s
        self._add(_Entry(due, next(self._seq), self._utt, -1, end))

    def _cut(self, at: float) -> None:
        """Drop earlier utterances' frames due from ``at`` on; their end messages go out at ``at``."""
        keep = []
        for e in self._entries:
            if e.due >= at and e.utt != self._utt:
                if e.number >= 0:
                    continue
                e.due = at
            keep.append(e)
        self._entries = sorted(keep)


class PacedSender:
    """Sends a :class:`Pacer`'s messages at their time with ``await send(message)`` from an asyncio
    task (started by :meth:`start` in the running loop).  A failing send is logged and the next
    messages still go out: the head's data never stops the agent's voice."""

    def __init__(self, pacer: Pacer, send: Callable[[dict], Awaitable[None]]):
        self.pacer, self.send = pacer, send
        self._wake: asyncio.Event | None = None
        self._task: asyncio.Task | None = None

    def start(self) -> None:
        """Start the task (once; in a running event loop)."""
        if self._task is None or self._task.done():
            self._wake = asyncio.Event()
            self._task = asyncio.get_running_loop().create_task(self._run(), name="headmotion-sender")

    def wake(self) -> None:
        """The pacer changed: look again at what is due."""
        if self._wake is not None:
            self._wake.set()

    async def _run(self) -> None:
        while True:
            self._wake.clear()
            for message in self.pacer.due():
                await self._send(message)
            nxt = self.pacer.next_due()
            timeout = None if nxt is None else max(0.0, nxt - self.pacer.clock())
            try:
                await asyncio.wait_for(self._wake.wait(), timeout)
            except TimeoutError:
                pass

    async def _send(self, message: dict) -> None:
        try:
            await self.send(message)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # noqa: BLE001 - a lost data message must not stop the voice
            log.warning("headmotion: could not send a %s message: %s: %s", message.get("type"),
                        type(exc).__name__, exc)

    async def wait_idle(self, timeout: float | None = None) -> bool:
        """Wait until every message has gone out (True), or ``timeout`` seconds (False)."""
        loop = asyncio.get_running_loop()
        deadline = None if timeout is None else loop.time() + timeout
        while self.pacer.pending:
            if self._task is None or self._task.done():
                return False
            nxt = self.pacer.next_due()
            wait = 0.02 if nxt is None else max(0.002, nxt - self.pacer.clock() + 0.002)
            if deadline is not None:
                if loop.time() >= deadline:
                    return False
                wait = min(wait, deadline - loop.time())
            await asyncio.sleep(wait)
        await asyncio.sleep(0)  # the last message popped is being sent
        return True

    async def aclose(self, *, drain: bool = False) -> None:
        """Stop the task; ``drain``: first send every message still waiting, due or not."""
        if self._task is not None:
            self._task.cancel()
            try:
                await self._task
            except (asyncio.CancelledError, Exception):  # noqa: BLE001 - stopping
                pass
            self._task = None
        if drain:
            for message in self.pacer.drain():
                await self._send(message)


__all__ = ["Pacer", "PacedSender"]
