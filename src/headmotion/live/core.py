"""The one live core: a model's stream of head motion for audio that arrives as it is spoken.

Every live path runs through :class:`HeadMotionCore`: ``headmotion stream`` (:mod:`.session`,
through :class:`CoreStream`), ``headmotion serve``'s ``/v1/stream`` (which ``view --live`` and the
avatar page speak) and the voice-agent integrations (:mod:`headmotion.integrations`).  It holds one
model and the stream of the *utterance* being spoken (:func:`headmotion.open_stream`, the library's
streaming path):

* :meth:`~HeadMotionCore.push` takes float32 mono samples at any rate (resampled to the model's:
  ``exact`` or ``fast``, :data:`RESAMPLE`) and returns the frames now final, with the controls
  (gain, offset, amount, listening) applied;
* :meth:`~HeadMotionCore.hear_along` gives the stream the other party's audio on the utterance's
  own timeline (a head that speaks and hears: ``synth --hear``), and :meth:`~HeadMotionCore.hear`
  opens a *listening turn* between an agent's utterances;
* :meth:`~HeadMotionCore.end` flushes the frames the lookahead held and
  :meth:`~HeadMotionCore.interrupt` drops them; both then *settle* the head (``settle_s``): a short
  run of frames easing from the last pose shown to the rest pose (plus the offset control), never a
  jump.  The next push opens a fresh stream.

When each frame goes out is :mod:`.pacing`'s: :class:`~headmotion.live.pacing.Pacer` holds the
frames until the audio they belong to plays and :class:`~headmotion.live.pacing.PacedSender` sends
them from an asyncio task (the agent integrations); ``headmotion stream`` paces by its input and
``/v1/stream`` leaves it to the client, which plays the audio.

The messages are those of ``headmotion serve``'s stream (docs/serve.md): ``{"type": "frames",
"first", "fps", "audio_time", "frames": [{"frame", "time", "rotvec", "pitch_yaw_roll_deg"}]}``
(the records of ``headmotion stream``, :func:`headmotion.live.frames.frame_records`), frames
numbered from 0 in each utterance, and ``{"type": "end", "frames", "audio_seconds"}`` after an
utterance's last frame (its settling included).  ``audio_time`` is the utterance's audio
received when the frames were made.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

import numpy as np

from .. import quaternions
from ..errors import HeadMotionError, ParameterError, SampleRateError
from ..io.resampler import QUALITY
from ..synthesis import DEFAULT_STREAM_MODEL, Controls, load_model, open_stream
from ..systems.decisions import run_alone
from ..types import Motion
from .blas import one_blas_thread

log = logging.getLogger("headmotion.live")

#: ``resample`` → soxr quality, the library's one table (:data:`headmotion.io.resampler.QUALITY`), as
#: for ``headmotion serve``'s stream: ``exact`` gives the frames the offline answer gives for the
#: same samples (~20 ms of resampling delay), ``fast`` ~10 ms less delay and frames that may differ
#: by a few degrees.  Audio at the model's rate is not resampled.
RESAMPLE = QUALITY
#: seconds the head takes to settle to the rest pose after an utterance (default) and the range
DEFAULT_SETTLE_S = 0.5
SETTLE_RANGE_S = (0.0, 5.0)
#: seconds of an utterance's frames kept to settle from (an interruption names the last frame
#: shown, which trails the frames made by the audio still to play)
KEEP_S = 60.0


def pcm16_to_float(data, channels: int = 1) -> np.ndarray:
    """Float32 mono samples in [-1, 1) of interleaved signed 16-bit little-endian PCM (bytes or a
    buffer such as a LiveKit frame's ``data``); several channels are mixed down (their mean)."""
    if isinstance(channels, bool) or not isinstance(channels, (int, np.integer)) or channels < 1:
        raise ParameterError(f"channels must be a whole number >= 1; got {channels!r}")
    x = np.frombuffer(memoryview(data).cast("B"), dtype="<i2")
    if len(x) % channels:
        raise ParameterError(f"{len(x)} samples are not a whole number of frames of {channels} channels")
    y = x.astype(np.float32) / np.float32(32768.0)
    if channels > 1:
        y = y.reshape(-1, channels).mean(axis=1, dtype=np.float32)
    return y


@dataclass(frozen=True)
class FrameBatch:
    """Frames ``first …`` of an utterance: ``rotvec (n, 3)`` radians at ``fps``; ``audio_time``:
    seconds of the utterance's audio received when they were made; ``settling``: frames easing to
    the rest pose (not the model's)."""

    first: int
    fps: float
    rotvec: np.ndarray
    audio_time: float
    settling: bool = False

    def __len__(self) -> int:
        return len(self.rotvec)

    def message(self) -> dict:
        """The frames message of ``headmotion serve``'s stream (JSON-ready)."""
        from ..live.frames import frame_records

        return {"type": "frames", "first": int(self.first), "fps": float(self.fps),
                "audio_time": round(float(self.audio_time), 4),
                "frames": frame_records(self.rotvec, self.fps, int(self.first))}


@dataclass(frozen=True)
class UtteranceEnd:
    """The end of an utterance: ``frames`` sent in all (settling included), ``audio_seconds`` of its
    audio received, ``interrupted`` when it was cut off."""

    frames: int
    audio_seconds: float
    interrupted: bool = False

    def message(self) -> dict:
        """The end message of ``headmotion serve``'s stream."""
        return {"type": "end", "frames": int(self.frames), "audio_seconds": round(float(self.audio_seconds), 4)}


def _mono(samples, sample_rate) -> np.ndarray:
    """Checked float32 mono samples (``(n, channels)`` mixed down) and a checked rate."""
    _rate(sample_rate)
    x = np.asarray(samples, dtype=np.float32)
    if x.ndim == 2:
        x = x.mean(axis=1, dtype=np.float32)
    elif x.ndim != 1:
        raise ParameterError(f"samples must be mono (n,) or (n, channels); got shape {x.shape}")
    # a float64 sum of float32 samples cannot overflow: it is finite iff every sample is
    if not math.isfinite(float(np.add.reduce(x, dtype=np.float64))):
        raise ParameterError("the samples hold NaN or infinite values")
    return x


def _rate(sample_rate) -> int:
    if isinstance(sample_rate, bool) or not isinstance(sample_rate, (int, np.integer)) or sample_rate <= 0:
        raise ParameterError(f"sample_rate must be a positive whole number of Hz; got {sample_rate!r:.40}")
    return int(sample_rate)


def _check_choice(value, choices, what: str) -> str:
    if not isinstance(value, str) or value not in choices:
        raise ParameterError(f"{what} must be one of {sorted(choices)}; got {value!r:.40}")
    return value


def check_seconds(value, bounds: tuple[float, float], what: str) -> float:
    lo, hi = bounds
    ok = not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))
    if not ok or not math.isfinite(value) or not lo <= value <= hi:
        raise ParameterError(f"{what} must be a number of seconds from {lo:g} to {hi:g}; got {value!r:.40}")
    return float(value)


class HeadMotionCore:
    """A model and the stream of the utterance being spoken (module docstring).

    Parameters
    ----------
    model : str, Path or Synthesizer
        A model that streams: ``"stream"`` (the default: causal, 50 ms latency, 25 frames/s), a
        model file, or a model already loaded (shared, not copied: one loaded model may serve many
        agents).
    seed : int
        Synthesis seed; every utterance starts a fresh stream with it.
    resample : ``"exact"`` or ``"fast"``
        How audio at another rate than the model's is resampled (:data:`RESAMPLE`).
    settle_s : float
        Seconds the head takes to ease back to the rest pose after an utterance (0: no settling).
    controls : Controls, optional
        Gain, offset, still, amount, lookahead_ms … (or give them as keywords: ``gain=1.2,
        offset_degrees="-3,0,0"``); the head settles to the rest pose plus the offset.  With
        ``lookahead_ms`` the utterance's frames come that much later (:attr:`latency_ms`); a
        listening turn (:meth:`hear`) reads no further ahead than the user's audio that came.
    heard_rate : int, optional
        The rate of the audio given to :meth:`hear_along` (each utterance's stream then hears
        the other party on its own timeline); None: no such audio.
    """

    def __init__(self, model=DEFAULT_STREAM_MODEL, *, seed: int = 0, resample: str = "exact",
                 settle_s: float = DEFAULT_SETTLE_S, controls: Controls | None = None,
                 heard_rate: int | None = None, **controls_kwargs):
        if controls is not None and controls_kwargs:
            raise ParameterError(f"give the controls as `controls=` or as keywords, not both; "
                                 f"got {sorted(controls_kwargs)}")
        self.controls = Controls.parse(**controls_kwargs) if controls is None else controls
        self.model = load_model(model)
        one_blas_thread()  # every live path streams through here (headmotion.live.blas)
        self.seed = seed
        self.resample = _check_choice(resample, RESAMPLE, "resample")
        self.settle_s = check_seconds(settle_s, SETTLE_RANGE_S, "settle_s")
        self.heard_rate = heard_rate
        probe = self._open()  # checks the seed, the controls and that the model streams, once
        self.fps = float(probe.frame_rate)
        self.latency_ms = float(probe.latency_ms)
        self.sample_rate = int(self.model.sample_rate)
        #: frames of a settling (0 when ``settle_s`` is 0)
        self.settle_frames = int(math.ceil(self.settle_s * self.fps - 1e-9))
        from ..rotations import pitch_yaw_roll_to_rotvec

        #: the pose the head settles to: the rest pose (facing ahead) plus the offset control
        self.rest_pose = np.asarray(pitch_yaw_roll_to_rotvec(*self.controls.offset), dtype=np.float64).reshape(3)
        self._stream = None
        self._rate = None
        self._samples_in = 0
        self._history: list[np.ndarray] = []
        self._made = 0
        self._kept_from = 0   # the utterance's first frame still in _history (KEEP_S)
        self._settled = True  # the last utterance has had its settling (or there was none)
        self._listen = None   # the listening stream (the user's audio, silence as the agent's own)
        self._listen_rate = None
        self._turn = False    # a listening turn is open (frames of the listening stream go out)
        self._ease: tuple[np.ndarray, int] | None = None  # (pose eased from, frames left)

    def _open(self, sample_rate: int | None = None, heard_rate: int | None = None, *, lookahead: bool = True):
        controls = self.controls
        if not lookahead and controls.lookahead_ms:  # the user's audio comes live: nothing to read ahead of
            controls = dataclasses.replace(controls, lookahead_ms=0.0)
        try:
            return open_stream(self.model, seed=self.seed, controls=controls, sample_rate=sample_rate,
                               resample=self.resample, heard_rate=heard_rate)
        except HeadMotionError:
            raise
        except (AttributeError, NotImplementedError) as exc:  # a model without a stream
            raise ParameterError(f"model {getattr(self.model, 'name', self.model)!r} does not stream: "
                                 f"{exc}") from None

    @property
    def listening(self) -> bool:
        """True while a listening turn is open (the user's audio moves the head; no utterance)."""
        return self._turn

    @property
    def speaking(self) -> bool:
        """True while an utterance is open (pushed to, not yet ended or interrupted)."""
        return self._stream is not None

    @property
    def audio_seconds(self) -> float:
        """Seconds of audio received in the current (or last) utterance."""
        return self._samples_in / self._rate if self._rate else 0.0

    @property
    def frames_made(self) -> int:
        """The model's frames made in the current (or last) utterance (settling not counted)."""
        return self._made

    def frames(self) -> np.ndarray:
        """``(n, 3)`` the model's frames of the current (or last) utterance so far: the last
        :data:`KEEP_S` seconds of them, from frame :attr:`kept_from` on."""
        return np.vstack(self._history) if self._history else np.zeros((0, 3))

    @property
    def kept_from(self) -> int:
        """The number of the first frame :meth:`frames` still holds."""
        return self._kept_from

    def begin(self, sample_rate: int) -> None:
        """Open an utterance whose audio comes at ``sample_rate`` (the first :meth:`push` does it
        too); nothing when one is open at that rate."""
        if self._stream is None:
            self._open_utterance(_rate(sample_rate))
        elif int(sample_rate) != self._rate:
            raise SampleRateError(f"the utterance's audio changed rate from {self._rate} Hz to {int(sample_rate)} Hz; "
                                  "end the utterance before changing the rate")

    def _open_utterance(self, rate: int) -> None:
        if self._turn:  # the agent takes the turn: its speech eases in from the listening pose
            self._turn = False
            self._ease = (self.frames()[-1], self.settle_frames) if self._made else None
        self._stream = self._open(rate, heard_rate=self.heard_rate)
        self._rate = rate
        self._samples_in = 0
        self._history, self._made, self._kept_from = [], 0, 0
        self._settled = False

    def push(self, samples, sample_rate: int) -> FrameBatch:
        """Push speech samples (float32 mono; ``(n, channels)`` is mixed down) at ``sample_rate``;
        the first push after an end or an interruption opens a fresh stream.  Returns the frames
        made final (maybe none).  Raises :class:`~headmotion.errors.SampleRateError` when the rate
        changes within an utterance."""
        return run_alone(self.push_steps(samples, sample_rate))

    def push_steps(self, samples, sample_rate: int):
        """:meth:`push` step by step: a generator of the model's decisions' asks, answered by the
        process's engine together with every other stream's (:mod:`headmotion.live.engine`), or
        each alone by :meth:`push`; returns the FrameBatch."""
        x = _mono(samples, sample_rate)
        self.begin(sample_rate)
        self._samples_in += len(x)
        return self._speech((yield from self._stream.push_steps(x)).rotvec)

    def hear_along(self, samples) -> None:
        """The other party's audio (float32 mono at ``heard_rate``) on the open utterance's own
        timeline: the stream listens to it between the speech's words (:mod:`headmotion.listener`;
        ``synth --hear``).  Raises :class:`~headmotion.errors.ParameterError` without
        ``heard_rate`` or an open utterance."""
        if self.heard_rate is None:
            raise ParameterError("this core was made without heard_rate: it takes no heard audio on the "
                                 "utterance's timeline")
        if self._stream is None:
            raise ParameterError("no utterance is open to hear along: push (or begin) the speech first")
        self._stream.hear(_mono(samples, self.heard_rate))

    def hear(self, samples, sample_rate: int) -> FrameBatch:
        """The user's audio as it comes (float32 mono at ``sample_rate``).  While the agent does
        not speak, the head listens (:mod:`headmotion.listener`: an attentive posture, nods at the
        user's back-channel cues, the model's waiting head beneath): the first call after an
        utterance opens a *listening turn* — frames numbered from 0 like an utterance's, easing in
        from the last pose shown — and returns its frames; the agent's next push ends the turn
        (:meth:`end_listening`).  While the agent speaks the user's audio is not listened to
        (an empty batch)."""
        return run_alone(self.hear_steps(samples, sample_rate))

    def hear_steps(self, samples, sample_rate: int):
        """:meth:`hear` step by step (as :meth:`push_steps`)."""
        x = _mono(samples, sample_rate)
        if self._stream is not None:
            return FrameBatch(self._made, self.fps, np.zeros((0, 3)), self.audio_seconds)
        rate = int(sample_rate)
        if self._listen is None or rate != self._listen_rate:
            self._listen, self._listen_rate = self._open(rate, heard_rate=rate, lookahead=False), rate
        if not self._turn:
            shown = self.frames()[-1] if self._made and not self._settled else self.rest_pose
            self._turn, self._settled = True, False
            self._rate, self._samples_in, self._history, self._made, self._kept_from = rate, 0, [], 0, 0
            self._ease = (np.asarray(shown, dtype=np.float64), self.settle_frames)
        self._listen.hear(x)
        self._samples_in += len(x)
        return self._speech((yield from self._listen.push_steps(np.zeros(len(x), np.float32))).rotvec)

    def end_listening(self) -> list:
        """Close the listening turn: ``[UtteranceEnd]`` (nothing when none is open).  The agent's
        next utterance eases in from the turn's last pose."""
        if not self._turn:
            return []
        self._turn = False
        self._ease = (self.frames()[-1], self.settle_frames) if self._made else None
        self._settled = True
        return [UtteranceEnd(self._made, self.audio_seconds, False)]

    def _speech(self, rotvec) -> FrameBatch:
        rv = np.array(rotvec, dtype=np.float64).reshape(-1, 3)
        if self._ease is not None and len(rv):
            rv = self._eased(rv)
        batch = FrameBatch(self._made, self.fps, rv, self.audio_seconds)
        if len(rv):
            self._history.append(rv)
            self._made += len(rv)
            keep = max(2, int(KEEP_S * self.fps))
            if self._made - self._kept_from > 2 * keep:  # bounded memory on a long utterance
                self._history = [self.frames()[-keep:]]
                self._kept_from = self._made - keep
        return batch

    def end(self) -> list:
        """End the utterance (the TTS stopped): ``[tail, settling, UtteranceEnd]`` — the frames the
        lookahead held, then the settling to the rest pose (batches left out when empty).
        Nothing when no utterance is open."""
        return run_alone(self.end_steps())

    def end_steps(self):
        """:meth:`end` step by step (as :meth:`push_steps`)."""
        if self._stream is None:
            return []
        stream, self._stream = self._stream, None
        out = []
        batch = self._speech((yield from stream.flush_steps()).rotvec)
        if len(batch):
            out.append(batch)
        settle = self._settling(self._made)
        self._settled = True
        if len(settle):
            out.append(settle)
        out.append(UtteranceEnd(self._made + len(settle), self.audio_seconds, False))
        return out

    def interrupt(self, shown: int | None = None) -> list:
        """Cut the utterance off (the user interrupted): the stream and the frames it held are
        dropped, and the head settles from the last frame shown: ``[settling, UtteranceEnd]``.

        ``shown`` is how many of the utterance's frames went out (None: all that were made); the
        settling starts from frame ``shown - 1`` and is numbered from ``shown``.  An utterance
        already ended may be cut off too while its audio still plays (``shown`` below its frame
        count); otherwise, with no utterance open, nothing happens."""
        was_open = self._stream is not None
        self._stream = None
        if shown is None:
            if not was_open:
                return []
            shown = self._made
        shown = max(0, min(int(shown), self._made))
        if shown and shown <= self._kept_from:  # older than the frames kept: from the oldest kept
            shown = self._kept_from + 1
        if not was_open and (self._settled and shown >= self._made):
            return []
        settle = self._settling(shown)
        self._settled = True
        out = [settle] if len(settle) else []
        out.append(UtteranceEnd(shown + len(settle), self.audio_seconds, True))
        return out

    def _eased(self, rv: np.ndarray) -> np.ndarray:
        """The first frames of a turn, eased from the pose shown before it (a smoothstep blend)."""
        start, left = self._ease
        n = self.settle_frames
        k = np.arange(n - left, min(n, n - left + len(rv)), dtype=np.float64)
        if len(k):
            w = ((k + 1) / (n + 1))[:, None]
            w = w * w * (3 - 2 * w)
            rv = rv.copy()
            rv[:len(k)] = (1 - w) * start + w * rv[:len(k)]
        left -= len(k)
        self._ease = (start, left) if left > 0 else None
        return rv

    def _settling(self, shown: int) -> FrameBatch:
        """The settling after frame ``shown - 1``, numbered from ``shown``."""
        n = self.settle_frames
        if shown <= 0 or n == 0:
            return FrameBatch(shown, self.fps, np.zeros((0, 3)), self.audio_seconds, True)
        frames = self.frames()
        i = shown - 1 - self._kept_from  # frame shown - 1 in the frames kept
        last = frames[i]
        prev = frames[i - 1] if i >= 1 else last
        return FrameBatch(shown, self.fps, settle_path(last, prev, self.rest_pose, n), self.audio_seconds, True)


class CoreStream:
    """One utterance of a :class:`HeadMotionCore` as a motion stream (``push(samples) -> Motion``,
    ``flush() -> Motion``, ``hear(samples)``): what :class:`~headmotion.live.session.LiveSession`
    runs for ``headmotion stream``.  The samples come at ``sample_rate``; :meth:`flush` gives the
    frames the lookahead held and then the settling (none with ``settle_s=0``)."""

    def __init__(self, core: HeadMotionCore, sample_rate: int):
        self.core, self.sample_rate = core, _rate(sample_rate)
        self.latency_ms, self.frame_rate = core.latency_ms, core.fps
        core.begin(self.sample_rate)

    def _motion(self, batches) -> Motion:
        rows = [b.rotvec for b in batches if isinstance(b, FrameBatch) and len(b)]
        return Motion(np.vstack(rows) if rows else np.zeros((0, 3)), self.core.fps)

    def push(self, samples) -> Motion:
        return self._motion([self.core.push(samples, self.sample_rate)])

    def hear(self, samples) -> None:
        self.core.hear_along(samples)

    def flush(self) -> Motion:
        return self._motion(self.core.end())


def settle_path(last, prev, rest, n: int) -> np.ndarray:
    """``(n, 3)`` poses easing from ``last`` (reached from ``prev`` one frame earlier) to ``rest``
    over ``n`` frames, the last one ``rest`` exactly.

    The rotation from the rest pose is taken in the rest pose's frame (a rotation vector ``x``)
    and moved by a cubic Hermite curve: it leaves ``last`` with the head's own speed (the step
    ``last - prev``) and arrives at ``rest`` at rest, so neither the pose nor its speed jumps.  Each
    step is at most ``1.5 |x| / n`` plus the last step."""
    q_rest = quaternions.rotvec_to_quat(np.asarray(rest, dtype=np.float64).reshape(1, 3))
    inv = q_rest * np.array([-1.0, -1.0, -1.0, 1.0])

    def rel(r):
        return quaternions.quat_to_rotvec(quaternions.compose(inv, quaternions.rotvec_to_quat(r)))[0]

    x0, xp = rel(last), rel(prev)
    s = np.arange(1, n + 1, dtype=np.float64) / n
    h00 = 2 * s ** 3 - 3 * s ** 2 + 1
    h10 = s ** 3 - 2 * s ** 2 + s
    x = h00[:, None] * x0 + h10[:, None] * (n * (x0 - xp))  # tangent: n frames × the last step
    out = quaternions.quat_to_rotvec(quaternions.compose(np.repeat(q_rest, n, axis=0),
                                                         quaternions.rotvec_to_quat(x)))
    out[-1] = np.asarray(rest, dtype=np.float64).reshape(3)
    return out


__all__ = ["HeadMotionCore", "CoreStream", "KEEP_S", "FrameBatch", "UtteranceEnd", "settle_path",
           "pcm16_to_float", "RESAMPLE", "DEFAULT_SETTLE_S", "SETTLE_RANGE_S"]
