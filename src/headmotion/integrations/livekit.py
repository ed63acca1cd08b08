"""Head motion in a LiveKit agent: :class:`HeadMotionAudioOutput`, a link in the agent session's
audio output chain.

``pip install "headmotion[livekit]"``.  The output hands every audio frame on to the next output
(the room's track) unchanged and makes head motion from it in-process; the frames go to the room
as data packets on the topic ``headmotion`` — the JSON messages of ``headmotion serve``'s stream
(docs/serve.md, docs/integrations.md)::

    await session.start(agent=MyAgent(), room=ctx.room)
    attach_head_motion(session, ctx.room)          # after start: wraps session.output.audio

* Each frame goes out when its audio plays (``pace=True``, the default; the room's output plays the
  agent's audio in real time), so a page applies each frame as it arrives; ``pace=False`` sends
  the frames as soon as they are made (the page times them itself).
* ``flush()`` (the end of the agent's reply): the frames the lookahead held, then the head settles
  to the rest pose over ``settle_s`` after the audio, then ``{"type": "end", ...}``.
* ``clear_buffer()`` (the user interrupted): the frames not yet sent are dropped and the head
  settles from the last pose sent, at once; ``pause()``/``resume()`` (a possible false
  interruption) hold and release the frames with the audio.  The next reply starts a fresh stream.
* :meth:`~HeadMotionAudioOutput.hear` takes the user's audio frames (e.g. ``async for ev in
  rtc.AudioStream(user_track): out.hear(ev.frame)``): once the agent's audio and its settling have
  gone out, the head listens to them (:mod:`headmotion.listener`: an attentive posture, recorded
  nods at the user's back-channel cues) until the agent speaks again.
* ``lookahead_ms`` (default :data:`headmotion.live.AGENT_LOOKAHEAD_MS` for the shipped
  ``stream``): the model reads the agent's audio that far ahead of each frame, and the output holds
  each audio frame until that much more audio has come or the reply ends (``flush``), so the voice
  plays in step with the head (:mod:`headmotion.live.hold`).

The part that makes and paces the frames is :mod:`headmotion.live.core`, so the
output runs without a LiveKit server: give ``send`` any ``async def send(message: dict)``.
Importing this module without LiveKit Agents raises
:class:`~headmotion.errors.MissingDependencyError`.
"""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Awaitable, Callable

from ..errors import HeadMotionError, MissingDependencyError, ParameterError

try:
    from livekit import rtc
    from livekit.agents.voice import io
except ImportError as exc:  # pragma: no cover - exercised in a fresh process by the tests
    raise MissingDependencyError(
        f"the LiveKit integration needs LiveKit Agents ({exc}); install it with: pip install \"headmotion[livekit]\""
    ) from exc

from ..live.core import DEFAULT_SETTLE_S, log, pcm16_to_float
from ..live.engine import EngineUse
from ..live.hold import AudioHold, agent_core
from ..live.pacing import PacedSender, Pacer

#: the data topic the messages go on unless told otherwise
TOPIC = "headmotion"


def room_sender(room: rtc.Room, *, topic: str = TOPIC, reliable: bool = True,
                destination_identities: list[str] | None = None) -> Callable[[dict], Awaitable[None]]:
    """``async send(message)`` that publishes the message as JSON text in a data packet of the
    room's local participant on ``topic`` (to every participant, or to ``destination_identities``)."""

    async def send(message: dict) -> None:
        await room.local_participant.publish_data(json.dumps(message, separators=(",", ":")), reliable=reliable,
                                                  topic=topic, destination_identities=destination_identities or [])

    return send


class HeadMotionAudioOutput(io.AudioOutput):
    """An audio output that makes head motion from the agent's audio and passes it on (module
    docstring).

    Parameters
    ----------
    next_in_chain : AudioOutput
        The output the audio goes on to (``session.output.audio`` after ``session.start``).
    send : async callable
        ``await send(message)`` for each message (:func:`room_sender` for a room's data packets).
    model, seed, resample, settle_s, controls, **controls_kwargs
        As :class:`~headmotion.live.core.HeadMotionCore` (default model
        ``"stream"``: 40 ms latency, 25 frames/s).
    pace : bool
        Send each frame when its audio plays (True) or when it is made (False).
    delay_s : float
        Hold the paced frames this much longer (the audio's jitter buffer on the listener's side).
    lookahead_ms : float or None
        How far ahead the model reads the agent's audio; the audio is held by as much
        (:func:`headmotion.live.hold.agent_core`; None: :data:`headmotion.live.AGENT_LOOKAHEAD_MS`).
    engine : bool or LiveEngine
        True (default): the decisions for the agent's audio are made together with every other
        live stream of the event loop that shares its engine
        (:func:`headmotion.live.engine.loop_engine`: all outputs of a process), one matrix product
        for all; False: each alone.  The frames are the same.  (:meth:`hear` and the reply's end,
        called without an await, make theirs alone.)
    """

    def __init__(self, next_in_chain: io.AudioOutput, *, send: Callable[[dict], Awaitable[None]],
                 model="stream", seed: int = 0, resample: str = "exact", settle_s: float = DEFAULT_SETTLE_S,
                 pace: bool = True, delay_s: float = 0.0, controls=None, label: str = "HeadMotion",
                 lookahead_ms: float | None = None, engine=True, **controls_kwargs):
        super().__init__(label=label, next_in_chain=next_in_chain,
                         capabilities=io.AudioOutputCapabilities(pause=True))
        self.engine = EngineUse(engine)
        self.core = agent_core(model, lookahead_ms=lookahead_ms, seed=seed, resample=resample, settle_s=settle_s,
                               controls=controls, **controls_kwargs)
        self.pacer = Pacer(self.core, pace=pace, delay_s=delay_s, clock=time.monotonic)
        self.sender = PacedSender(self.pacer, send)
        self.hold = AudioHold(self.pacer, self.core.controls.lookahead_ms / 1000.0)
        self._flushing: asyncio.Future | None = None  # the held audio going on at a reply's end
        self._passed = False  # audio of this reply went on to the next output

    @property
    def sample_rate(self) -> int | None:
        if self._sample_rate is not None:
            return self._sample_rate
        return self.next_in_chain.sample_rate if self.next_in_chain else None

    def _motion(self, step, *args) -> None:
        """A pacer step, its decisions alone; a failure is logged and the audio goes on."""
        self.engine.finish(self.core)  # the core's call waiting for the engine ends first
        try:
            step(*args)
        except HeadMotionError as exc:
            log.warning("headmotion: no head motion for this audio: %s", exc)
        self.sender.wake()

    async def capture_frame(self, frame: rtc.AudioFrame) -> None:
        self.sender.start()
        if self._flushing is not None:  # the last reply's held audio goes first
            await asyncio.wait([self._flushing])
        await super().capture_frame(frame)
        if frame.samples_per_channel:  # its frames are made now; it goes on once the hold lets it
            samples = pcm16_to_float(frame.data, frame.num_channels)
            entries = await self.engine.run(self.core,
                                            lambda: self.hold.audio_steps(frame, samples, int(frame.sample_rate)))
        else:
            entries = self.hold.other(frame)
        self.sender.wake()
        await self._pass_on(entries)

    async def _pass_on(self, entries: list) -> None:
        """The audio the hold lets go, to the next output (it plays from then on)."""
        if self.next_in_chain is not None:
            await self.hold.pass_on(entries, self.next_in_chain.capture_frame)
        else:  # nothing to play it: it counts as played now
            await self.hold.pass_on(entries, _nowhere)
        self._passed = self._passed or any(n for _item, n, _rate in entries)
        self.sender.wake()

    def hear(self, frame: rtc.AudioFrame) -> None:
        """The user's audio as it arrives: listened to while the agent is silent."""
        self.sender.start()
        if frame.samples_per_channel:
            self._motion(lambda: self.pacer.hear(pcm16_to_float(frame.data, frame.num_channels),
                                                 int(frame.sample_rate)))

    def flush(self) -> None:
        super().flush()
        self.engine.finish(self.core)
        held = self.hold.release()
        if held or self._flushing is not None:  # the held audio goes on first (an await), then the reply ends
            self._flushing = asyncio.ensure_future(self._flush_after(held, self._flushing))
            return
        self._end_reply()

    def _end_reply(self) -> None:
        if self.next_in_chain is not None:
            self.next_in_chain.flush()
        self._passed = False
        self._motion(self.pacer.end)

    async def _flush_after(self, held: list, before: asyncio.Future | None) -> None:
        try:
            if before is not None:
                await asyncio.wait([before])
            await self._pass_on(held)
            self._end_reply()
        finally:
            if self._flushing is asyncio.current_task():
                self._flushing = None

    def clear_buffer(self) -> None:
        pending, self._flushing = self._flushing, None
        if pending is not None:  # the reply ended with audio held: it ends there, that audio dropped
            pending.cancel()
            if self.next_in_chain is not None:
                self.next_in_chain.flush()
        self.engine.finish(self.core)
        dropped = pending is not None or self.hold.held > 0
        self.hold.drop()  # the audio held never plays
        if self.next_in_chain is not None:
            self.next_in_chain.clear_buffer()
        if dropped and not self._passed:  # the next output never had this reply: its playback ends here
            self.on_playback_finished(playback_position=0.0, interrupted=True)
        self._passed = False
        self._motion(self.pacer.interrupt)

    def pause(self) -> None:
        super().pause()
        self.engine.finish(self.core)
        self.pacer.pause()
        self.sender.wake()

    def resume(self) -> None:
        super().resume()
        self.engine.finish(self.core)
        self.pacer.resume()
        self.sender.wake()

    async def wait_sent(self, timeout: float | None = None) -> bool:
        """Wait until every message made so far has gone out (True) or ``timeout`` (False)."""
        return await self.sender.wait_idle(timeout)

    async def aclose(self, *, drain: bool = False) -> None:
        """Stop sending (``drain``: first send what still waits, due or not)."""
        if self._flushing is not None:
            self._flushing.cancel()
        await self.sender.aclose(drain=drain)


async def _nowhere(_item) -> None:
    """An output chain's end that plays nothing."""


def attach_head_motion(session, room: rtc.Room | None = None, *, send: Callable[[dict], Awaitable[None]] | None = None,
                       topic: str = TOPIC, **kwargs) -> HeadMotionAudioOutput:
    """Put a :class:`HeadMotionAudioOutput` in front of ``session.output.audio`` (call after
    ``await session.start(...)``), sending to ``room`` on ``topic`` (or through ``send``); it stops
    when the session closes.  ``kwargs`` go to :class:`HeadMotionAudioOutput`."""
    if session.output.audio is None:
        raise ParameterError("the session has no audio output yet: call attach_head_motion after "
                              "`await session.start(...)`")
    if send is None:
        if room is None:
            raise ParameterError("give the room (its data packets carry the messages) or send=")
        send = room_sender(room, topic=topic)
    out = HeadMotionAudioOutput(session.output.audio, send=send, **kwargs)
    session.output.audio = out

    def _closed(_event=None) -> None:
        asyncio.ensure_future(out.aclose())

    try:
        session.on("close", _closed)
    except Exception:  # noqa: BLE001 - a session without that event: the caller closes it
        pass
    return out


__all__ = ["HeadMotionAudioOutput", "attach_head_motion", "room_sender", "TOPIC"]
