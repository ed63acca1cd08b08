"""Head motion in a Pipecat pipeline: :class:`HeadMotionProcessor`, placed after the TTS.

``pip install "headmotion[pipecat]"``.  The processor passes every frame on unchanged; from the
TTS audio (``TTSAudioRawFrame``) it makes head motion in-process and sends the frames to the
client as transport messages — the JSON messages of ``headmotion serve``'s stream (docs/serve.md,
docs/integrations.md)::

    pipeline = Pipeline([transport.input(), stt, user_agg, llm, tts,
                         HeadMotionProcessor(), transport.output(), assistant_agg])

* ``pace=True`` (default): each frame goes out as an ``OutputTransportMessageUrgentFrame`` when
  its audio plays (the output plays the TTS audio in real time, one utterance after the other),
  so a page applies each frame as it arrives.  ``pace=False``: an ``OutputTransportMessageFrame``
  after each audio frame, in order with the audio (the page times the frames itself).
* ``TTSStoppedFrame`` ends the utterance: the frames held by the lookahead, then the head settles
  to the rest pose over ``settle_s`` after the audio, then ``{"type": "end", ...}``.
* ``InterruptionFrame`` (the user cut the agent off): the frames not yet sent are dropped and the
  head settles from the last pose sent, at once.  The next TTS audio starts a fresh stream.
* The user's audio (``InputAudioRawFrame``, passed on by the transport's input and the STT): once
  the agent's audio and its settling have gone out, the head *listens* to it
  (:mod:`headmotion.listener`: an attentive posture, recorded nods at the user's back-channel
  cues) in a listening turn numbered as an utterance, until the agent speaks again
  (``hear_frames=()`` turns this off).
* ``rtvi=True``: the messages go as ``RTVIServerMessageFrame`` (a Pipecat client's
  ``onServerMessage``) instead of transport messages.
* ``send=``: the frames and end messages go to ``await send(message)`` instead (paced as above),
  e.g. a robot's head in the same process (``headmotion.integrations.reachy.ReachyHead.send``).
* Each utterance's audio is preceded by ``{"type": "audio-start", "utterance": n}``, in order with
  the audio (an ``OutputTransportMessageFrame``; with ``rtvi``, in RTVI's server-message form), and
  every message carries its ``utterance``: where audio and messages share one ordered channel (the
  WebSocket transports) a page finds each frame's place in the audio it plays by it, however the
  audio is delayed on its way (docs/integrations.md, Timing).
* ``lookahead_ms`` (default :data:`headmotion.live.AGENT_LOOKAHEAD_MS` for the shipped
  ``stream``): the model reads the TTS audio that far ahead of each frame, and the processor holds
  the audio frames (and the frames behind them) until that much more audio has come or the TTS
  stops, so the voice plays in step with the head (:mod:`headmotion.live.hold`).
* ``engine`` (default True): the processors of one process make their decisions together, one
  matrix product over the model's library for all (:func:`headmotion.live.engine.loop_engine`);
  each processor's frames are those it makes alone.

Importing this module without Pipecat raises :class:`~headmotion.errors.MissingDependencyError`.
"""

from __future__ import annotations

import time

from ..errors import HeadMotionError, MissingDependencyError

try:
    from pipecat.frames.frames import (
        CancelFrame,
        EndFrame,
        InputAudioRawFrame,
        InterruptionFrame,
        OutputTransportMessageFrame,
        OutputTransportMessageUrgentFrame,
        StartFrame,
        SystemFrame,
        TTSAudioRawFrame,
        TTSStoppedFrame,
    )
    from pipecat.processors.frame_processor import FrameDirection, FrameProcessor
except ImportError as exc:  # pragma: no cover - exercised in a fresh process by the tests
    raise MissingDependencyError(
        f"the Pipecat integration needs Pipecat ({exc}); install it with: pip install \"headmotion[pipecat]\""
    ) from exc

from ..live.core import DEFAULT_SETTLE_S, log, pcm16_to_float
from ..live.engine import EngineUse
from ..live.hold import AudioHold, agent_core
from ..live.pacing import PacedSender, Pacer


class HeadMotionProcessor(FrameProcessor):
    """Head motion from the TTS audio, sent to the client as messages (module docstring).

    Parameters
    ----------
    model : str, Path or Synthesizer
        A model that streams (default ``"stream"``: 40 ms latency, 25 frames/s); a loaded model is
        shared, not copied.
    seed, resample, settle_s, controls, **controls_kwargs
        As :class:`~headmotion.live.core.HeadMotionCore` (``gain``,
        ``offset_degrees``, ``still`` …).
    lookahead_ms : float or None
        How far ahead the model reads the TTS audio; the audio is held by as much
        (:func:`headmotion.live.hold.agent_core`; None: :data:`headmotion.live.AGENT_LOOKAHEAD_MS`).
    pace : bool
        Send each frame when its audio plays (True) or after the audio frame it came from (False).
    delay_s : float
        Hold the paced frames this much longer (the audio's jitter buffer on the client).
    audio_frames : tuple of frame classes
        The audio that is speech (default ``(TTSAudioRawFrame,)``; other audio passes untouched).
    rtvi : bool
        Send ``RTVIServerMessageFrame(data=message)`` rather than transport message frames.
    hear_frames : tuple of frame classes
        The user's audio the head listens to (default ``(InputAudioRawFrame,)``; ``()``: none).
    send : async callable, optional
        ``await send(message)`` for each frames and end message instead of a frame downstream
        (the ``audio-start`` marks still go in order with the audio).
    engine : bool or LiveEngine
        True (default): the decisions are made together with every other live stream of the event
        loop that shares its engine (:func:`headmotion.live.engine.loop_engine`: all processors of
        a process), one matrix product for all; False: each alone.  The frames are the same.
    """

    def __init__(self, model="stream", *, seed: int = 0, resample: str = "exact",
                 settle_s: float = DEFAULT_SETTLE_S, pace: bool = True, delay_s: float = 0.0,
                 audio_frames: tuple = (TTSAudioRawFrame,), rtvi: bool = False, controls=None,
                 name: str | None = None, hear_frames: tuple = (InputAudioRawFrame,),
                 lookahead_ms: float | None = None, send=None, engine=True, **controls_kwargs):
        super().__init__(name=name)
        self.engine = EngineUse(engine)
        self.core = agent_core(model, lookahead_ms=lookahead_ms, seed=seed, resample=resample, settle_s=settle_s,
                               controls=controls, **controls_kwargs)
        self.pacer = Pacer(self.core, pace=pace, delay_s=delay_s, clock=time.monotonic)
        self.hold = AudioHold(self.pacer, self.core.controls.lookahead_ms / 1000.0,
                              on_start=lambda n: self._in_band({"type": "audio-start", "utterance": n}))
        self.audio_frames = tuple(audio_frames)
        self.hear_frames = tuple(hear_frames)
        self.rtvi = bool(rtvi)
        self._send = send
        self._sender = PacedSender(self.pacer, self._send_now) if pace else None

    @property
    def fps(self) -> float:
        return self.core.fps

    @property
    def latency_ms(self) -> float:
        return self.core.latency_ms

    def _frame(self, message: dict, *, urgent: bool):
        if self.rtvi:
            from pipecat.processors.frameworks.rtvi import RTVIServerMessageFrame

            return RTVIServerMessageFrame(data=message)
        return (OutputTransportMessageUrgentFrame if urgent else OutputTransportMessageFrame)(message=message)

    def _in_band(self, message: dict):
        """A message that goes in order with the audio (RTVI's server-message form with ``rtvi``)."""
        if self.rtvi:
            from pipecat.processors.frameworks.rtvi.models import ServerMessage

            message = ServerMessage(data=message).model_dump(exclude_none=True)
        return OutputTransportMessageFrame(message=message)

    async def _send_now(self, message: dict) -> None:
        if self._send is not None:
            await self._send(message)
        else:
            await self.push_frame(self._frame(message, urgent=True))

    async def _pass_on(self, entries: list) -> None:
        """The frames the audio hold lets go, downstream in order."""
        if self._sender is not None:
            self._sender.wake()
        await self.hold.pass_on(entries, lambda f: self.push_frame(f, FrameDirection.DOWNSTREAM))
        if self._sender is not None:
            self._sender.wake()

    async def _send_in_order(self) -> None:
        """Unpaced: the messages made so far, as data frames in order with the audio."""
        if self._sender is None:
            for message in self.pacer.due():
                if self._send is not None:
                    await self._send(message)
                else:
                    await self.push_frame(self._frame(message, urgent=False))

    def _motion(self, step, *args) -> None:
        """A pacer step that makes no decision; a failure is logged and the audio goes on."""
        self.engine.finish(self.core)  # the core's call waiting for the engine ends first
        try:
            step(*args)
        except HeadMotionError as exc:
            log.warning("headmotion: no head motion for this audio: %s", exc)
        if self._sender is not None:
            self._sender.wake()

    async def _decide(self, make_steps):
        """A pacer step that makes decisions, through the engine; a failure is logged (None) and
        the audio goes on."""
        try:
            return await self.engine.run(self.core, make_steps)
        except HeadMotionError as exc:
            log.warning("headmotion: no head motion for this audio: %s", exc)
        finally:
            if self._sender is not None:
                self._sender.wake()

    async def process_frame(self, frame, direction: FrameDirection):
        await super().process_frame(frame, direction)
        if isinstance(frame, StartFrame):
            await self.push_frame(frame, direction)
            if self._sender is not None:
                self._sender.start()
        elif isinstance(frame, InterruptionFrame):
            await self.push_frame(frame, direction)
            self.engine.finish(self.core)
            held = self.hold.drop()  # the audio held never plays
            self._motion(self.pacer.interrupt)
            await self._pass_on(held)
            await self._send_in_order()
        elif direction == FrameDirection.DOWNSTREAM and isinstance(frame, self.audio_frames):
            if frame.audio:  # its frames are made now; it goes on (after its audio-start) once the hold lets it
                samples = pcm16_to_float(frame.audio, frame.num_channels)
                await self._pass_on(await self.engine.run(
                    self.core, lambda: self.hold.audio_steps(frame, samples, int(frame.sample_rate))))
            else:
                await self._pass_on(self.hold.other(frame))
            await self._send_in_order()
        elif direction == FrameDirection.DOWNSTREAM and self.hear_frames and isinstance(frame, self.hear_frames):
            if frame.audio:
                samples = pcm16_to_float(frame.audio, frame.num_channels)
                await self._decide(lambda: self.pacer.hear_steps(samples, int(frame.sample_rate)))
            await self.push_frame(frame, direction)
            await self._send_in_order()
        elif direction == FrameDirection.DOWNSTREAM and isinstance(frame, TTSStoppedFrame):
            await self._pass_on(self.hold.release())
            await self._decide(self.pacer.end_steps)
            await self._send_in_order()
            await self.push_frame(frame, direction)
        elif isinstance(frame, EndFrame):
            await self._pass_on(self.hold.release())
            await self._decide(self.pacer.end_steps)
            if self._sender is not None:  # the last frames go out as their audio plays, then the pipeline ends
                wait = max(0.0, self.pacer.busy_until() - self.pacer.clock()) + 1.0
                await self._sender.wait_idle(timeout=wait)
                await self._sender.aclose(drain=True)
            await self._send_in_order()
            await self.push_frame(frame, direction)
        elif isinstance(frame, CancelFrame):
            if self._sender is not None:
                await self._sender.aclose()
            await self.push_frame(frame, direction)
        elif direction == FrameDirection.DOWNSTREAM and not isinstance(frame, SystemFrame):
            await self._pass_on(self.hold.other(frame))  # behind the audio held before it
        else:
            await self.push_frame(frame, direction)

    async def cleanup(self):
        await super().cleanup()
        if self._sender is not None:
            await self._sender.aclose()


__all__ = ["HeadMotionProcessor"]
