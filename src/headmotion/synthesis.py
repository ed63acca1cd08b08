"""Head motion for speech: the one synthesis path of the library, the commands and the live page.

:func:`synthesize` is what ``headmotion synth`` does, :func:`open_stream` what ``headmotion
stream`` and the live page do; a Python user calling them gets the motion those commands write.
Every front end parses its options once into :class:`Controls`, and the controls act in one
order (docs/design.md "CLI"; the seeds are silent on user controls):

1. the model's motion for the speech (sample ``k`` of ``samples`` with seed ``seed + k``; a
   deterministic model samples its parameters, ``stochastic="params"``, when ``samples > 1``),
   with ``amount``: how much the head moves, by which recorded movements a motion-matching model
   chooses (0 holds still, 1 the model's own, up to 3) — no angle is scaled — and ``lookahead_ms``:
   how far ahead a live model reads the speech (a stream then comes that much later);
2. ``style_from``: made to move like a reference (:mod:`headmotion.motion.style`);
3. ``gain`` about the mean pose — the styled one (the reference's) when a style is applied, else
   the model's training mean pose — then ``offset`` (:mod:`headmotion.motion.control`);
4. ``still``: every frame at the rest pose plus the offset, instead of 2–3;
5. ``fps``: resampled to the output rate.

Audio given as a path longer than :data:`headmotion.systems.long_input.LONG_INPUT_SECONDS` is
read block by block through the model's stream, in bounded memory, when the model streams
(:func:`headmotion.systems.long_input.predict_file_in_blocks`).  Shipped models are taken by
name (:mod:`headmotion.shipped`).  Importing this module imports neither torch nor the systems.
"""

from __future__ import annotations

import copy
import math
import os
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import AudioLoadingError, ParameterError
from .io._limits import FPS_RANGE
from .motion.control import AMOUNT_RANGE
from .seeds import DEFAULT_SEED, SEED_MAX, check_seed, resolve_seed
from .shipped import ShippedModel, list_models
from .types import Audio, Motion

#: the shipped model :func:`synthesize` uses unless told otherwise (offline)
DEFAULT_MODEL = "default"
#: the shipped model :func:`open_stream` uses unless told otherwise (causal)
DEFAULT_STREAM_MODEL = "stream"

#: the ranges of the controls, checked here for every front end (the command line, Python,
#: ``headmotion serve``'s HTTP and stream): gain per axis (0 holds the mean pose; a negative gain
#: would mirror the motion and is refused), offset per axis in degrees; seeds: :mod:`headmotion.seeds`
GAIN_RANGE = (0.0, 10.0)
OFFSET_RANGE_DEG = (-90.0, 90.0)
LOOKAHEAD_RANGE_MS = (0.0, 1080.0)  # ms: up to the reach of the shipped default (not live; 27 frames)


def _triple(value, what: str, *, degrees: bool = False) -> tuple[float, float, float]:
    """A number, a ``(pitch, yaw, roll)`` triple or a string ``"x"`` / ``"p,y,r"`` as 3 floats
    (``degrees``: given in degrees, returned in radians)."""
    from .motion.control import as_triple

    if isinstance(value, str):
        try:
            vals = [float(v) for v in value.split(",")]
        except ValueError:
            raise ParameterError(f"{what} must be a number or three comma-separated numbers (pitch,yaw,roll); "
                                 f"got {value!r}") from None
        if len(vals) not in (1, 3):
            raise ParameterError(f"{what} must be one number or three (pitch,yaw,roll); got {value!r}")
        value = vals[0] if len(vals) == 1 else vals
    a = as_triple(value, what)
    return tuple(math.radians(v) if degrees else float(v) for v in a)


def _is_triple(value) -> bool:
    """A value already normalised: a tuple of three finite floats."""
    return (isinstance(value, tuple) and len(value) == 3
            and all(type(v) is float and math.isfinite(v) for v in value))


def _per_axis(base: tuple, axes, what: str, *, degrees: bool = False) -> tuple[float, float, float]:
    """``base`` with the axes given in ``axes`` (pitch, yaw, roll; None = keep) replaced."""
    out = list(base)
    for j, v in enumerate(axes):
        if v is not None:
            out[j] = _triple(v, what, degrees=degrees)[0]
    return tuple(out)


def _check_range(values: tuple, bounds: tuple, what: str, unit: str) -> None:
    lo, hi = bounds
    if not all(lo - 1e-9 <= v <= hi + 1e-9 for v in values):
        got = ", ".join(f"{v:.6g}" for v in values)
        raise ParameterError(f"{what} must be between {lo:g} and {hi:g}{unit} on every axis (pitch, yaw, roll); "
                             f"got ({got}){unit}")


@dataclass(frozen=True)
class Controls:
    """What a user may change about the synthesised motion, validated once (see the module
    docstring for the order in which they act).

    Parameters
    ----------
    amount : number in :data:`AMOUNT_RANGE`
        How much the head moves, by choice: 1 = the model's natural amount, larger = larger,
        faster recorded movements and more of them, smaller = calmer ones, 0 = held still.  Each
        movement stays a recorded one (a motion-matching model; others refuse an amount other than 1).
    gain : number, (pitch, yaw, roll) or string ``"G"`` / ``"P,Y,R"``
        Amplitude scale about the mean pose (1 = as the model moves, 0 = held at the mean pose):
        every angle multiplied — a nod made twice as deep, not a bigger nod (``amount``).
    offset : number, (pitch, yaw, roll) or string
        Radians added to pitch, yaw and roll after the gain.
    still : bool
        A head that does not move: the rest pose plus ``offset`` on every frame.
    style_from : str, Path, Motion or None
        Move like this reference: a motion file, a talking video or a :class:`Motion`.
    style_strength : float in [0, 1]
        0 = the model's style, 1 = the reference's.
    style_keep_pose : bool
        Keep the model's mean pose (take only amplitude and spectral balance from the reference).
    fps : float or None
        Output frame rate, within :data:`FPS_RANGE` (None: the model's).
    stochastic : str or None
        What the model samples (``none``, ``choice``, ``params``, ``both``; None: the model's
        setting), validated by the model.
    listening : number in :data:`headmotion.listener.LISTENING_RANGE`
        How much the head listens while it hears another person speak (``hear``): 1 an attentive
        posture and back-channel nods at the other's cues, 0 nothing added, up to 3.
    lookahead_ms : number in :data:`LOOKAHEAD_RANGE_MS`
        How far ahead a live model reads the speech (a voice agent's is made before it plays;
        the stream comes that much later); 0 = causal.
    """

    gain: tuple = (1.0, 1.0, 1.0)
    offset: tuple = (0.0, 0.0, 0.0)
    still: bool = False
    amount: float = 1.0
    style_from: object = None
    style_strength: float = 1.0
    style_keep_pose: bool = False
    fps: float | None = None
    stochastic: str | None = None
    listening: float = 1.0
    lookahead_ms: float = 0.0

    def __post_init__(self):
        set_ = object.__setattr__
        for name in ("gain", "offset"):  # parse's triples are final; anything else is parsed here, once
            v = getattr(self, name)
            if not _is_triple(v):
                set_(self, name, _triple(v, name))
        _check_range(self.gain, GAIN_RANGE, "gain (--gain)", "")
        _check_range(tuple(math.degrees(v) for v in self.offset), OFFSET_RANGE_DEG, "offset (--offset)", " degrees")
        set_(self, "still", bool(self.still))
        a = self.amount
        if isinstance(a, bool) or not isinstance(a, (int, float, np.floating, np.integer)) \
                or not AMOUNT_RANGE[0] <= a <= AMOUNT_RANGE[1]:
            raise ParameterError(f"amount (--amount) must be a number from {AMOUNT_RANGE[0]:g} to {AMOUNT_RANGE[1]:g}; "
                                 f"got {a!r:.40}")
        set_(self, "amount", float(a))
        set_(self, "style_keep_pose", bool(self.style_keep_pose))
        s = self.style_strength
        if isinstance(s, bool) or not isinstance(s, (int, float, np.floating, np.integer)) or not 0.0 <= s <= 1.0:
            raise ParameterError(f"style_strength (--style-strength) must be between 0 and 1; got {s!r}")
        set_(self, "style_strength", float(s))
        if self.fps is not None:
            f = self.fps
            if isinstance(f, bool) or not isinstance(f, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(f) or not FPS_RANGE[0] <= f <= FPS_RANGE[1]:
                raise ParameterError(f"fps (--fps) must be between {FPS_RANGE[0]:g} and {FPS_RANGE[1]:g} frames per "
                                     f"second; got {f!r}")
            set_(self, "fps", float(f))
        from .listener import check_listening

        set_(self, "listening", check_listening(self.listening))
        la, (lo, hi) = self.lookahead_ms, LOOKAHEAD_RANGE_MS
        if isinstance(la, bool) or not isinstance(la, (int, float, np.floating, np.integer)) or not lo <= la <= hi:
            raise ParameterError(f"lookahead_ms (--lookahead-ms) must be a number of milliseconds from {lo:g} to "
                                 f"{hi:g}; got {la!r:.40}")
        set_(self, "lookahead_ms", float(la))
        if self.stochastic is not None and not isinstance(self.stochastic, str):
            raise ParameterError(f"stochastic (--stochastic) must be one of none, choice, params, both; "
                                 f"got {self.stochastic!r}")
        if self.style_from is not None and not isinstance(self.style_from, (str, os.PathLike, Motion)):
            raise ParameterError(f"style_from (--style-from) must be a file path or a Motion; "
                                 f"got {type(self.style_from).__name__}")

    @classmethod
    def parse(cls, *, gain=None, offset=None, offset_degrees=None, gain_pyr=(None, None, None),
              offset_pyr_degrees=(None, None, None), amount=None, **rest) -> "Controls":
        """Controls from a front end's options, each parsed once.

        Parameters
        ----------
        gain : number, triple, string ``"G"`` / ``"P,Y,R"`` or None (1)
        offset : number or triple in radians, or None
        offset_degrees : number, triple, string or None
            The offset in degrees (the command line's ``--offset``); not with ``offset``.
        gain_pyr, offset_pyr_degrees : three of number or None
            Per-axis overrides (``--gain-pitch`` …, ``--offset-roll`` in degrees): an axis given
            here replaces that axis of ``gain`` / the offset.
        amount : number or None (1)
        **rest
            The other fields of :class:`Controls`.

        Returns
        -------
        Controls
        """
        if offset is not None and offset_degrees is not None:
            raise ParameterError("give the offset in radians (offset) or in degrees (offset_degrees), not both")
        g = _per_axis(_triple(1.0 if gain is None else gain, "gain"), gain_pyr, "gain")
        if offset_degrees is not None:
            o = _triple(offset_degrees, "offset", degrees=True)
        else:
            o = _triple(0.0 if offset is None else offset, "offset")
        o = _per_axis(o, offset_pyr_degrees, "offset", degrees=True)
        return cls(gain=g, offset=o, amount=1.0 if amount is None else amount, **rest)

    @property
    def moves_pose(self) -> bool:
        """True when gain or offset changes the motion (not 1 and 0 on every axis)."""
        return self.gain != (1.0, 1.0, 1.0) or self.offset != (0.0, 0.0, 0.0)


def _controls(controls: Controls | None, kwargs: dict) -> Controls:
    if controls is None:
        return Controls.parse(**kwargs)
    if kwargs:
        raise ParameterError(f"give the controls as `controls=` or as keywords, not both; got {sorted(kwargs)}")
    if not isinstance(controls, Controls):
        raise ParameterError(f"controls must be a headmotion.Controls; got {type(controls).__name__}")
    return controls


def load_model(model=DEFAULT_MODEL):
    """A model ready to synthesise.

    Parameters
    ----------
    model : str, Path or Synthesizer
        A shipped name (``"default"``, ``"stream"``; :func:`list_models`), a model file, or a
        model already loaded (returned as it is).

    Returns
    -------
    Synthesizer

    Raises :class:`~headmotion.errors.ModelFileError` for an unknown name that is not a file (the
    message lists the shipped names) or a damaged file."""
    if isinstance(model, (str, os.PathLike)):
        from .systems.base import load_model as load_file

        return load_file(model)  # a shipped name or a file
    if hasattr(model, "frame_rate") and hasattr(model, "predict_seeded"):
        return model
    raise ParameterError(f"model must be a shipped name, a model file or a loaded model; got {type(model).__name__}")


def _with_stochastic(model, mode: str | None, samples: int):
    """``model``, or a shallow copy with its ``stochastic`` parameter set (the caller's model is left
    as it was): ``mode`` when given, ``"params"`` when ``samples > 1`` of a deterministic setting
    would be copies of one motion."""
    if mode is None and samples > 1 and model.get_params().get("stochastic") == "none":
        mode = "params"
    if mode is None:
        return model
    return copy.copy(model).set_params(stochastic=mode)


def _with_lookahead(model, lookahead_ms: float):
    """``model``, or a shallow copy reading ``lookahead_ms`` ahead (the caller's model is left as it
    was); ParameterError for a model without this setting."""
    if lookahead_ms == 0.0:
        return model
    params = model.get_params()
    if "lookahead_ms" not in params or not params.get("live"):
        raise ParameterError(f"lookahead_ms (--lookahead-ms) is how far a live model reads ahead; a {model.name} "
                             "model that is not live reads ahead already or not at all: use the shipped 'stream'")
    return copy.copy(model).set_params(lookahead_ms=float(lookahead_ms))


def _with_amount(model, amount: float):
    """``model``, or a shallow copy with its ``amount`` set (the caller's model is left as it was);
    ParameterError for a model that does not choose recorded movements."""
    if amount == 1.0:
        return model
    if "amount" not in model.get_params():
        raise ParameterError(f"amount (--amount) chooses larger or calmer recorded movements, which a "
                             f"{model.name} model does not do; use a motion-matching model (the shipped "
                             f"'default' and 'stream'), or --gain to scale this model's motion")
    return copy.copy(model).set_params(amount=amount)


def reads_in_blocks(model, audio) -> bool:
    """True when :func:`synthesize` reads ``audio`` block by block: a path to a recording longer
    than ``LONG_INPUT_SECONDS`` and a model that streams."""
    if isinstance(audio, Audio) or not getattr(model, "can_stream", False):
        return False
    from .io.audio_blocks import audio_duration
    from .systems import long_input

    return audio_duration(audio) > long_input.LONG_INPUT_SECONDS


def _speech(audio, model):
    """(Audio or the path to read in blocks, its duration in seconds, whether in blocks)."""
    if isinstance(audio, Audio):
        return audio, audio.duration, False
    if not isinstance(audio, (str, os.PathLike)):
        raise ParameterError(f"audio must be a headmotion.Audio or a file path; got {type(audio).__name__}")
    if reads_in_blocks(model, audio):
        from .io.audio_blocks import audio_duration

        return Path(audio), audio_duration(audio), True
    from .io import load_audio

    a = load_audio(audio)
    return a, a.duration, False


def _conversation(speech, hear) -> tuple[Audio, Audio]:
    """(speech, heard) as Audio of one length: the shorter padded with silence."""
    from .io import load_audio

    if isinstance(speech, Path):
        speech = load_audio(speech)
    if isinstance(hear, (str, os.PathLike)):
        hear = load_audio(hear)
    if not isinstance(hear, Audio):
        raise ParameterError(f"hear must be a headmotion.Audio or a file path; got {type(hear).__name__}")
    end = max(speech.duration, hear.duration)

    def pad(a: Audio) -> Audio:
        n = int(round(end * a.sample_rate)) - len(a.samples)
        return a if n <= 0 else Audio(np.concatenate([a.samples, np.zeros(n, a.samples.dtype)]), a.sample_rate)

    return pad(speech), pad(hear)


def _style_reference(controls: Controls):
    """The style profile of ``controls.style_from`` (None without one), measured once per call."""
    ref = controls.style_from
    if ref is None:
        return None
    from .motion.style import style_profile
    from .video.reference import load_style_reference

    return style_profile(ref if isinstance(ref, Motion) else load_style_reference(ref))


def apply_controls(motion: Motion, model, controls: Controls, reference=None) -> Motion:
    """Steps 2–5 of the module docstring on one of ``model``'s motions (``reference``: the style
    profile of ``controls.style_from``)."""
    from .motion.control import apply_gain, mean_pose_of, still

    if controls.still:
        motion = still(motion, controls.offset)
    else:
        mean = model.mean_pose_
        if reference is not None:
            from .motion.style import apply_style

            keep = controls.style_keep_pose
            motion = apply_style(motion, reference, strength=controls.style_strength, match_mean=not keep)
            if not keep and controls.moves_pose:
                mean = mean_pose_of([motion.rotvec])  # the styled mean pose (the reference's)
        if controls.moves_pose:
            motion = apply_gain(motion, mean, controls.gain, controls.offset)
    if controls.fps is not None:
        motion = motion.resample(controls.fps)
    return motion


def _check_long_enough(audio, duration: float, fps: float) -> None:
    """:class:`AudioLoadingError` (exit 1) naming the file when the speech is too short for one frame."""
    if duration * fps >= 1.0:
        return
    what = str(audio) if isinstance(audio, (str, os.PathLike)) else "the speech"
    raise AudioLoadingError(f"{what}: {duration * 1000:.1f} ms of speech is too short for one frame of head motion "
                            f"(the model makes {fps:g} frames a second: give at least {1000.0 / fps:.0f} ms)")


def synthesize(audio, model=DEFAULT_MODEL, *, seed: int | None = None, samples: int = 1, controls: Controls | None = None,
               progress=None, hear=None, **controls_kwargs) -> list[Motion]:
    """Head motion for speech: what ``headmotion synth`` writes.

    Parameters
    ----------
    audio : Audio, str or Path
        The speech; a path to a long recording is read block by block in bounded memory.
    model : str, Path or Synthesizer
        A shipped name (``"default"``, ``"stream"``), a model file or a loaded model.
    seed : int or None
        Synthesis seed of the first sample; sample ``k`` uses ``seed + k``.  None: the model's own
        ``seed`` parameter, or 0 (:mod:`headmotion.seeds`).
    samples : int
        How many different motions to make.
    controls : Controls, optional
        The controls; or give their fields as keywords (``gain=1.2, still=True`` …, parsed by
        :meth:`Controls.parse`).
    progress : callable, optional
        ``progress(done_seconds, total_seconds)`` of speech synthesised over all samples.
    hear : Audio, str or Path, optional
        What this head hears: the other party of a conversation, on the same timeline as
        ``audio`` (either may be silent at any time; the shorter is taken as silent to the end of
        the longer).  While the other speaks and this head does not, it listens
        (:mod:`headmotion.listener`; ``controls.listening`` says how much).

    Returns
    -------
    list of Motion
        ``samples`` motions, at ``controls.fps`` or the model's frame rate.
    """
    c = _controls(controls, controls_kwargs)
    m = load_model(model)
    seed = resolve_seed(m, seed, samples)
    speech, duration, in_blocks = _speech(audio, m)
    _check_long_enough(audio, duration, m.frame_rate)
    heard = None
    if hear is not None:
        speech, heard = _conversation(speech, hear)
        duration, in_blocks = speech.duration, False
    reference = _style_reference(c)
    m = _with_lookahead(_with_amount(_with_stochastic(m, c.stochastic, samples), c.amount), c.lookahead_ms)
    total = duration * samples
    out = []
    for k in range(samples):
        if in_blocks:
            from .systems.long_input import predict_file_in_blocks

            done = k * duration
            report = None if progress is None else (lambda s, d=done: progress(d + s, total))
            motion = predict_file_in_blocks(m, speech, seed=seed + k, progress=report)
        else:
            motion = m.predict_seeded(speech, seed + k)
        if heard is not None:
            from .listener.head import listen

            motion = listen(motion, speech, heard, m, listening=c.listening, seed=seed + k)
        if len(motion) == 0:
            _check_long_enough(audio, 0.0, m.frame_rate)
        out.append(apply_controls(motion, m, c, reference))
        if progress is not None:
            progress((k + 1) * duration, total)
    return out


#: seconds of a stream's own speech kept for a listening layer built when the head first hears
#: (more than the layer looks back, OWN_HOLD_S, plus the model's lookahead and the resampler's delay)
SPOKEN_KEPT_S = 2.0


class SpeechStream:
    """Speech in as it comes, head motion out: :meth:`push` samples, get the frames now final —
    the one stream of every live path (``headmotion stream``, the live page, ``headmotion
    serve``'s stream, the agent integrations).

    Made by :func:`open_stream`; ``sample_rate`` is the rate of the samples pushed (resampled on
    the stream to the model's, ``resample`` of :data:`headmotion.io.resampler.QUALITY`),
    ``frame_rate`` the rate of the frames returned, ``latency_ms`` the model's algorithmic
    latency (``lookahead_ms`` included), ``frames`` how many frames it has returned.  :meth:`hear`
    takes what the head hears (the other party's audio, on the same timeline), ``heard_rate`` its rate."""

    def __init__(self, model, inner, controls: Controls, sample_rate: int, *, resample: str = "fast",
                 heard_rate: int | None = None, seed: int = 0):
        from .io.resampler import Resampler, check_resample

        self.model, self.controls = model, controls
        self.sample_rate, self.frame_rate = int(sample_rate), float(model.frame_rate)
        self.heard_rate = self.sample_rate if heard_rate is None else int(heard_rate)
        self.latency_ms = float(getattr(inner, "latency_ms", 0.0))
        self.frames = 0
        self._inner = inner
        self._resample = Resampler(self.sample_rate, int(model.sample_rate), quality=check_resample(resample))
        self._identity = not (controls.still or controls.moves_pose)  # decided once, not per 10 ms push
        self._made = 0  # the model's frames so far (the listening layer's frame numbers)
        # The listening layer is built when the head first hears (until then it would add nothing):
        # the own speech's last seconds are kept for it, in the chunks pushed.
        self._listener = None
        self._seed = seed
        self._spoken: deque = deque()
        self._spoken_kept = self._spoken_before = 0

    def push(self, samples) -> Motion:
        """Frames made final by these float32 mono samples (at :attr:`sample_rate`; may be none)."""
        return _run_alone(self.push_steps(samples))

    def push_steps(self, samples):
        """:meth:`push` step by step: a generator of the model's decisions' asks, answered by
        whoever drives it — one engine for many streams (:mod:`headmotion.live.engine`) or
        each alone (:meth:`push`); returns the Motion (:mod:`headmotion.systems.decisions`)."""
        from .systems.decisions import steps_of

        if self._listener is not None:
            self._listener.speech(samples)
        elif self.controls.listening > 0:
            self._keep_spoken(samples)
        return self._controlled((yield from steps_of(self._inner, "push", self._resample(samples))))

    def hear(self, samples) -> None:
        """What the head hears: float32 mono samples at :attr:`heard_rate`, from the start of the
        stream on (the frames made after them listen to them)."""
        if self.controls.listening <= 0:  # listening 0: nothing heard changes the frames
            return
        if self._listener is None:
            self._listener = self._listening_layer()
        self._listener.hear(samples)

    def _keep_spoken(self, samples) -> None:
        x = np.array(samples, dtype=np.float32).reshape(-1)
        self._spoken.append(x)
        self._spoken_kept += len(x)
        while self._spoken and self._spoken_kept - len(self._spoken[0]) >= SPOKEN_KEPT_S * self.sample_rate:
            self._spoken_kept -= len(self._spoken[0])
            self._spoken_before += len(self._spoken.popleft())

    def _listening_layer(self):
        """The listening layer as if it had been given the speech from the start: the seconds of it
        kept, after frames counted silent that no frame to come looks back at."""
        from .listener.head import ListeningLayer

        layer = ListeningLayer(self.model, fps=self.frame_rate, speech_rate=self.sample_rate,
                               heard_rate=self.heard_rate, listening=self.controls.listening, seed=self._seed)
        x = np.concatenate(list(self._spoken)) if self._spoken else np.zeros(0, np.float32)
        start = layer.skip_speech(self._spoken_before)
        layer.speech(x[start - self._spoken_before:])
        self._spoken.clear()
        return layer

    def flush(self) -> Motion:
        """The frames still held, at the end of the speech."""
        return _run_alone(self.flush_steps())

    def flush_steps(self):
        """:meth:`flush` step by step (as :meth:`push_steps`)."""
        from .systems.decisions import steps_of

        tail = yield from steps_of(self._inner, "push", self._resample(np.zeros(0, np.float32), last=True))
        rest = yield from steps_of(self._inner, "flush")
        rv = np.vstack([np.asarray(tail.rotvec).reshape(-1, 3), np.asarray(rest.rotvec).reshape(-1, 3)])
        return self._controlled(rest if len(tail) == 0 else Motion(rv, rest.fps, meta=dict(rest.meta)))

    def _controlled(self, motion: Motion) -> Motion:
        n = len(motion)
        if self._listener is not None and n:
            rv = self._listener.apply(motion.rotvec, self._made)
            if rv is not motion.rotvec:
                motion = Motion(np.asarray(rv), motion.fps, meta=dict(motion.meta))
        self._made += n
        self.frames += n
        if self._identity or not n:
            return motion
        return apply_controls(motion, self.model, self.controls)


def _run_alone(steps):
    """A stream's steps run to their end, each decision answered alone."""
    from .systems.decisions import run_alone

    return run_alone(steps)


def open_stream(model=DEFAULT_STREAM_MODEL, *, seed: int | None = None, sample_rate: int | None = None,
                controls: Controls | None = None, resample: str = "fast", heard_rate: int | None = None,
                **controls_kwargs) -> SpeechStream:
    """A stream of head motion from speech pushed as it comes: what ``headmotion stream`` and the
    live page run.

    Parameters
    ----------
    model : str, Path or Synthesizer
        A model that streams: a shipped name (``"stream"``, the default), a file or a loaded model.
    seed : int or None
        Synthesis seed (None: the model's own ``seed`` parameter, or 0).
    sample_rate : int, optional
        Rate of the samples to be pushed (default: the model's); other rates are resampled on
        the stream.
    controls : Controls, optional
        Gain, offset, still, amount, stochastic, listening and lookahead_ms apply; a style
        reference and another output rate need the whole recording (:func:`synthesize`) and are refused.
    resample : ``"fast"`` or ``"exact"``
        How samples at another rate than the model's are resampled
        (:data:`headmotion.io.resampler.QUALITY`; ``"exact"``: the frames of :func:`synthesize`).
    heard_rate : int, optional
        Rate of the samples given to ``hear`` (default: ``sample_rate``).

    Returns
    -------
    SpeechStream
        ``push(samples) -> Motion`` (the frames now final, maybe none), ``hear(samples)``,
        ``flush() -> Motion``.
    """
    c = _controls(controls, controls_kwargs)
    m = load_model(model)
    seed = resolve_seed(m, seed)
    if c.style_from is not None:
        raise ParameterError("style_from needs the whole recording: use synthesize, not a stream")
    if c.fps is not None and c.fps != float(m.frame_rate):
        raise ParameterError(f"a stream gives the model's {float(m.frame_rate):g} frames/s; fps={c.fps:g} "
                             "needs the whole recording (synthesize)")
    if sample_rate is not None and (isinstance(sample_rate, bool) or not isinstance(sample_rate, (int, np.integer))
                                    or sample_rate <= 0):
        raise ParameterError(f"sample_rate must be a positive whole number of Hz; got {sample_rate!r}")
    if heard_rate is not None and (isinstance(heard_rate, bool) or not isinstance(heard_rate, (int, np.integer))
                                   or heard_rate < 1000):
        raise ParameterError(f"heard_rate must be a whole number of Hz >= 1000; got {heard_rate!r}")
    m = _with_lookahead(_with_amount(_with_stochastic(m, c.stochastic, 1), c.amount), c.lookahead_ms)
    inner = m.stream_seeded(seed)
    return SpeechStream(m, inner, c, int(m.sample_rate) if sample_rate is None else int(sample_rate),
                        resample=resample, heard_rate=heard_rate, seed=seed)


__all__ = ["AMOUNT_RANGE", "DEFAULT_MODEL", "DEFAULT_SEED", "DEFAULT_STREAM_MODEL", "FPS_RANGE", "GAIN_RANGE", "OFFSET_RANGE_DEG", "LOOKAHEAD_RANGE_MS", "SEED_MAX", "check_seed",
           "Controls", "ShippedModel", "SpeechStream", "apply_controls",
           "list_models", "load_model", "open_stream", "reads_in_blocks", "synthesize"]
