"""Live head motion: audio inputs, a streaming session and real-time outputs.

* :mod:`.core`      — the one live core of every live path: a model's stream per utterance, at
  any input rate, the heard audio, the end, interruption and settling (:class:`.core.HeadMotionCore`);
* :mod:`.pacing`    — when a voice agent's frames go out: in time with the audio they belong to;
* :mod:`.hold`      — a voice agent's audio held back by the model's lookahead (``lookahead_ms``);
* :mod:`.blas`      — one BLAS thread in a process that streams;
* :mod:`.inputs`    — PCM on stdin, audio files (optionally paced), microphone (sounddevice);
* :mod:`.heard`     — the other party's audio, read beside the speech on its timeline;
* :mod:`.session`   — input → the live core → outputs, bounded queues, end-to-end latency;
* :mod:`.frames`    — the frame record (the JSON line of ``headmotion stream``) and JSON lines;
* :mod:`.vmc`       — VMC protocol over OSC/UDP (VSeeFace, Warudo, VMagicMirror, EVMC4U);
* :mod:`.websocket` — frames to any number of WebSocket clients.

The streaming features these rely on for low latency are in :mod:`headmotion.features.streaming`.
python-osc, websockets and sounddevice are the ``live`` extra; each is imported only when used.

Integration with ``headmotion stream`` (the command itself lives with the system contract):
the command parses its options and makes one call, ::

    from headmotion.live.session import stream_live
    stream_live(model, input=input_spec,            # "-" (PCM s16le on stdin), "mic", or a file
                sample_rate=sample_rate,            # rate of stdin PCM / capture rate of the mic
                realtime=realtime, device=device, chunk_ms=chunk_ms,
                json_stream=sys.stdout,             # JSON lines (None for none)
                vmc=vmc, websocket=websocket,       # "HOST:PORT" strings or None
                neck_share=neck_share, seed=seed,
                controls=Controls.parse(gain=gain, offset_degrees=offset))   # headmotion.synthesis

which resamples on the stream to ``model.sample_rate``, runs the live core
(:class:`.core.HeadMotionCore` over :func:`headmotion.synthesis.open_stream`; ``seed``, ``controls``)
and closes every output at the end; the errors it raises are :class:`~headmotion.errors.HeadMotionError` subclasses
(``AudioDeviceError``, ``NetworkError``, ``ParameterError``) that the CLI prints as one line.
"""

#: milliseconds a voice agent's live model reads its speech ahead unless told otherwise (the
#: integrations' ``lookahead_ms``, the avatar page's): the agent's TTS makes its audio before it
#: plays, and the integration holds the audio by as much (:mod:`.hold`), so head and voice stay in step.
#: 100 ms is the least budget at which the shipped ``stream`` is tied to held-out speech at 0.8× the
#: Praat-read library or more (0.92–1.02×; causal 0.46–0.53×); the voice starts 100 ms later
#: (docs/decisions/read-any-voice.md, the latency curve)
AGENT_LOOKAHEAD_MS = 100.0
