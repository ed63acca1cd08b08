"""The listening layer: over a model's head motion, what a head does while it hears someone else.

The model makes the head's motion from its own speech as always (while it is silent that is the
model's waiting head).  :class:`ListeningLayer` hears the other party's audio as well and, while
the other speaks and this head does not, adds

* an **attentive posture** (``posture_deg``, pitch/yaw/roll degrees) that eases in and out over
  ``ease_s`` (a smoothstep of a ramp: neither the pose nor its speed jumps at a turn change);
* **back-channel nods** at the other's prosodic cues (:mod:`.cues`, Ward & Tsukahara 2000: the
  nod starts when the cue's back-channel is due), each a recorded nod of the model's library
  (:mod:`.nods`) drawn by a seeded generator, scaled by the listening weight at each frame.

``listening`` scales both (0: nothing is added; the frames are the model's, bit for bit).  Silent
heard audio, or none, adds nothing either.

Timing, the same offline and on a stream: frame ``t`` (at ``t / fps`` s) listens with the other's
voicing heard up to ``t / fps − hear_delay_s`` and this head's own speech up to ``t / fps``, and
starts the nods whose back-channel is due by ``t / fps`` (up to ``late_s`` late: heard audio that
arrived late).  A stream that gets each chunk's heard audio no later than its speech therefore
gives the frames of the offline :func:`listen`.

The analysis of both inputs waits until frames are asked for (:meth:`ListeningLayer.apply`), and
the heard audio's until those frames could reach it (:meth:`ListeningLayer._heard_needed`: while
the other speaks, a frame depends on the heard pitch only through the cues due by then, found
0.59 s before; while the other is silent, only through the voicing of the heard frames up to
``hear_delay_s`` before it), then runs on all the audio given since, in one batch: a live stream hands the
layer 10 ms at a time, and the pitch tracker's per-call work cost more than the pitch itself.  The
frames are those of analysing each chunk as it comes, however the audio was chunked.
"""

from __future__ import annotations

import math

import numpy as np

from ..rotations import quaternion_to_rotvec_one
from . import DEFAULT_LISTENING, check_listening
from .cues import CueDetector, CueRule
from .nods import nod_bank

#: the rate the other party's audio is analysed at (pitch: :data:`HEARD_READER`)
HEAR_RATE = 8000
#: analysis frames per second (10 ms frames, Ward & Tsukahara's pitch step)
ANALYSIS_FPS = 100.0
#: how the other party's pitch is read: as the shipped ``stream`` reads its own speech — Praat's
#: candidates of each 10 ms analysis frame read once, their path searched forward over everything
#: heard (a frame is final 40 ms after its start).  Per-frame YIN missed the voice on a telephone
#: line and half the cues of several voices; Praat in 0.25 s blocks, each read with the 0.3 s
#: before it, followed fewer cues (docs/decisions/listen-to-anyone.md)
HEARD_READER = {"reader": "praat-path"}
#: the attentive posture at listening 1: chin 2° down, the head 3° towards the right shoulder —
#: a design choice (no recorded listener is reachable here), eased in while listening
POSTURE_DEG = (2.0, 0.0, 3.0)
EASE_S = 0.6             # posture in/out
HOLD_S = 1.0             # the other still counts as speaking this long after a voiced frame
OWN_HOLD_S = 0.3         # this head counts as speaking this long after a loud frame
OWN_SPEECH_DB = -45.0    # a 10 ms frame of the own speech louder than this (dB re full scale) is speech
HEAR_DELAY_S = 0.3       # the heard voicing a frame uses is this much older than the frame (the reading's delay)
LATE_S = 0.3             # a back-channel this late (heard audio that came late) is still made
PENDING_S = 1.0          # audio held for analysis is analysed once this much has gathered
#: while listening (at 1), this share of the model's own movement about its slow course is taken
#: out, per axis (pitch, yaw, roll): of the pitch, so that the waiting head's sways do not read as
#: nods and the nods stand out; not of the turns and tilts, which no one reads as a nod and which
#: keep the listening head as lively as people in their pauses
CALM = (0.9, 0.0, 0.0)
#: the slow course: a one-pole low-pass of this time constant, from where listening begins; long
#: enough that the waiting head's slow sways (a second or two each) are calmed too, not kept in it
CALM_TAU_S = 6.0
#: a recorded nod shallower than this (degrees of pitch) is scaled up to it, one deeper scaled down
NOD_MIN_DEG, NOD_MAX_DEG = 2.5, 5.0
#: the recorded nods a listener makes: those at least this long (a speaker's quick nods do not read
#: as a nod when listening)
NOD_MIN_S = 0.4


class _Held:
    """Samples given and not yet analysed, in order; ``add`` says when ``PENDING_S`` of them at
    ``rate`` have gathered (the layer then analyses them without waiting for frames)."""

    def __init__(self, rate: int):
        self.parts: list[np.ndarray] = []
        self.n, self.limit = 0, PENDING_S * rate

    def add(self, samples) -> bool:
        x = np.array(samples, dtype=np.float32).reshape(-1)
        if len(x):
            self.parts.append(x)
            self.n += len(x)
        return self.n >= self.limit

    def take(self) -> list[np.ndarray]:
        parts, self.parts, self.n = self.parts, [], 0
        return parts


class _Frames:
    """Per-10-ms flags of a channel, growing as its audio comes."""

    def __init__(self):
        self.flags = bytearray()
        self.last_true = -1  # index of the last true flag so far

    def extend(self, flags) -> None:
        for f in np.asarray(flags, dtype=bool).tolist():
            if f:
                self.last_true = len(self.flags)
            self.flags.append(1 if f else 0)

    def any_in(self, lo: int, hi: int) -> bool:
        """A true flag among frames ``lo … hi`` (inclusive; only those heard so far)."""
        hi = min(hi, len(self.flags) - 1)
        if hi < 0 or hi < lo:
            return False
        if self.last_true <= hi:
            return self.last_true >= lo
        return 1 in self.flags[max(lo, 0):hi + 1]


class ListeningLayer:
    """Streaming listening layer (module docstring).

    Parameters
    ----------
    model : the loaded model whose frames are listened over (its library lends the nods)
    fps : its frame rate
    speech_rate, heard_rate : rates of the samples given to :meth:`speech` and :meth:`hear`
    listening : 0 to 3 (:data:`~headmotion.listener.LISTENING_RANGE`)
    seed : draws the nods
    rule : the cue rule (:class:`~headmotion.listener.cues.CueRule`)
    """

    def __init__(self, model, *, fps: float, speech_rate: int, heard_rate: int = HEAR_RATE,
                 listening: float = DEFAULT_LISTENING, seed: int = 0, rule: CueRule | None = None):
        from ..features.readers import f0e_stream
        from ..io.resampler import Resampler

        self.amount = check_listening(listening)
        self.fps = float(fps)
        self.speech_rate, self.heard_rate = int(speech_rate), int(heard_rate)
        self._rs = Resampler(self.heard_rate, HEAR_RATE, quality="LQ")
        self._pitch = f0e_stream(sample_rate=HEAR_RATE, fps=ANALYSIS_FPS, smooth_frames=1, smooth_lookahead=0,
                                 delta_lookahead=0, voicing=True, **HEARD_READER)
        self.cues = CueDetector(rule, fps=ANALYSIS_FPS)
        self._heard = _Frames()
        self._own = _Frames()
        self._own_hop = max(1, int(round(self.speech_rate / ANALYSIS_FPS)))
        self._own_rest = np.zeros(0, np.float32)
        self._heard_held, self._own_held = _Held(self.heard_rate), _Held(self.speech_rate)  # not yet analysed
        self._due: list[tuple[float, float]] = []  # cues not yet made into nods
        self._playing: list[tuple[int, np.ndarray]] = []  # (first frame, curve at fps)
        self._rng = np.random.default_rng(int(seed))
        self._ramp = 0.0
        self._step = 1.0 / max(1.0, EASE_S * self.fps)
        self._posture = np.asarray(POSTURE_DEG, dtype=np.float64)
        self._model = model
        self._bank = None
        self._last_nod = -1
        self._slow_keep = math.exp(-1.0 / max(1.0, CALM_TAU_S * self.fps))  # one pole per frame
        self._slow = None  # the slow course of the model's frames (their last frame while not listening)
        self.nod_starts: list[int] = []  # frames at which nods started (for measures and tests)
        self.nod_spans: list[tuple[int, int]] = []  # frames [start, end) of each nod

    # -- the two inputs --------------------------------------------------------------------------
    def hear(self, samples) -> None:
        """The other party's samples (float32 mono at ``heard_rate``), in order."""
        if self._heard_held.add(samples):  # bounded memory without frames
            self._analyse_heard()

    def end_hearing(self) -> None:
        """No more heard audio: the analysis gives its last frames."""
        self._analyse_heard()
        self._analyse(self._rs(np.zeros(0, np.float32), last=True), flush=True)

    def _analyse_heard(self) -> None:
        parts = self._heard_held.take()
        if parts:
            self._analyse(self._rs(np.concatenate(parts) if len(parts) > 1 else parts[0]))

    def _heard_needed(self, tau: float) -> bool:
        """Whether a frame at ``tau`` s (and every earlier one) could differ were the heard audio
        held analysed now: it may hold a cue due by ``tau`` (a cue is found ``min_region`` frames
        after its region starts, and is due ``delay_s`` after that start: at the defaults 0.59 s
        after it is found), or, when no voiced frame analysed so far lies within ``HOLD_S`` of the
        heard time the frame uses and the frames analysed do not reach that time yet, a voiced frame
        that would make the other count as speaking."""
        n = len(self._heard.flags)
        cue_found_by = math.floor((tau - self.cues.rule.delay_s) * ANALYSIS_FPS) + self.cues._min_region + 1
        if n <= cue_found_by:
            return True
        h = int(math.floor((tau - HEAR_DELAY_S) * ANALYSIS_FPS))
        return n <= h and self._heard.last_true < max(h - int(HOLD_S * ANALYSIS_FPS), 0)  # (-1: none voiced yet)

    def _analyse(self, x: np.ndarray, flush: bool = False) -> None:
        rows = self._pitch.push(x) if len(x) else np.zeros((0, 7))
        if flush:
            rows = np.vstack([rows, self._pitch.flush()])
        if len(rows):
            voiced = rows[:, -1] > 0.5
            self._heard.extend(voiced)
            self._due += self.cues.push(rows[:, 0], voiced)

    def skip_speech(self, samples: int) -> int:
        """Start the own speech ``samples`` in (rounded up to a whole 10 ms frame, which is
        returned): a layer built on a stream under way, given the speech from there on.  The frames
        skipped count as silent; a frame made later looks back at most ``OWN_HOLD_S`` at them."""
        self._analyse_own()
        n = -(-int(samples) // self._own_hop)
        self._own.flags.extend(bytes(n))
        return n * self._own_hop

    def speech(self, samples) -> None:
        """This head's own speech (float32 mono at ``speech_rate``), in order."""
        if self._own_held.add(samples):
            self._analyse_own()

    def _analyse_own(self) -> None:
        parts = self._own_held.take()
        if not parts:
            return
        x = np.concatenate([self._own_rest, *parts])
        n = len(x) // self._own_hop
        self._own_rest = x[n * self._own_hop:]
        if n:
            f = x[:n * self._own_hop].reshape(n, self._own_hop).astype(np.float64)
            db = 10.0 * np.log10(np.mean(f * f, axis=1) + 1e-12)
            self._own.extend(db > OWN_SPEECH_DB)

    # -- the frames ------------------------------------------------------------------------------
    def apply(self, rotvec: np.ndarray, first: int) -> np.ndarray:
        """Frames ``first …`` of the model's motion (``(n, 3)`` rotation vectors) as the listening
        head moves them (the array itself when nothing is added)."""
        rv = np.asarray(rotvec, dtype=np.float64).reshape(-1, 3)
        if self._heard_held.parts and self._heard_needed((first + len(rv) - 1) / self.fps):
            self._analyse_heard()  # (else these frames do not reach what is held: later, in a batch)
        self._analyse_own()
        if self.amount == 0.0 or not len(rv):
            return rotvec
        if self._heard.last_true < 0 and self._ramp == 0.0:
            self._slow = rv[-1].copy()
            return rotvec  # nothing heard yet: the model's frames as they are
        delta, calm, slow = np.zeros((len(rv), 3)), np.zeros((len(rv), 3)), np.zeros((len(rv), 3))
        c = np.asarray(CALM, dtype=np.float64) * min(1.0, self.amount)
        for k in range(len(rv)):
            delta[k], w = self._frame(first + k)
            # the slow course of the model's frames since the listening began (at rest before it)
            self._slow = rv[k].copy() if w == 0.0 or self._slow is None else \
                self._slow_keep * self._slow + (1.0 - self._slow_keep) * rv[k]
            slow[k], calm[k] = self._slow, c * w
        moved = np.flatnonzero(np.any((delta != 0.0) | (calm > 0.0), axis=1))
        if not len(moved):
            return rotvec
        out = rv.copy()
        for k in moved:
            out[k] = turned(slow[k] + (1.0 - calm[k]) * (rv[k] - slow[k]), np.radians(delta[k]))
        return out

    def _frame(self, t: int) -> tuple[np.ndarray, float]:
        """(what frame ``t`` adds, pitch/yaw/roll degrees; the listening weight at it)."""
        tau = t / self.fps
        a = int(math.floor(tau * ANALYSIS_FPS))
        own = self._own.any_in(a - int(OWN_HOLD_S * ANALYSIS_FPS), a)
        h = int(math.floor((tau - HEAR_DELAY_S) * ANALYSIS_FPS))
        other = self._heard.any_in(h - int(HOLD_S * ANALYSIS_FPS), h)
        target = 1.0 if other and not own else 0.0
        self._ramp = min(target, self._ramp + self._step) if target > self._ramp else max(target, self._ramp - self._step)
        w = self._ramp * self._ramp * (3.0 - 2.0 * self._ramp)
        while self._due and self._due[0][1] <= tau:
            _, out_s = self._due.pop(0)
            if tau - out_s <= LATE_S and w > 0.0 and not own:
                self._start_nod(t)
        d = np.zeros(3)
        if w == 0.0 and not self._playing:
            return d, w
        d += w * self.amount * self._posture
        keep = []
        for start, curve in self._playing:
            i = t - start
            if i < len(curve):
                d += w * self.amount * curve[i]
                keep.append((start, curve))
        self._playing = keep
        return d, w

    def _start_nod(self, t: int) -> None:
        if self._bank is None:
            self._bank = nod_bank(self._model)
            long = [i for i, c in enumerate(self._bank.nods) if len(c) >= NOD_MIN_S * self._bank.fps]
            self._choices = long or list(range(len(self._bank)))
        n = len(self._choices)
        if n == 0:
            return
        k = int(self._rng.integers(n - 1 if n > 1 and self._last_nod >= 0 else n))
        if self._last_nod >= 0 and n > 1 and k >= self._last_nod:  # never the same nod twice running
            k += 1
        self._last_nod = k
        curve = self._bank.nods[self._choices[k]]
        depth = float(curve[:, 0].max())
        if depth > 0.0:
            curve = curve * (min(max(depth, NOD_MIN_DEG), NOD_MAX_DEG) / depth)
        if self._bank.fps != self.fps:
            ts = np.arange(int(round(len(curve) * self.fps / self._bank.fps))) / self.fps * self._bank.fps
            src = np.arange(len(curve))
            curve = np.stack([np.interp(ts, src, curve[:, j]) for j in range(3)], axis=1)
        self._playing.append((t, curve))
        self.nod_starts.append(t)
        self.nod_spans.append((t, t + len(curve)))


def turned(rotvec, pyr) -> list[float]:
    """The pose ``rotvec`` turned by pitch, yaw, roll ``pyr`` (radians, intrinsic ``"YXZ"``) in
    the head's own frame: ``q(rotvec) ⊗ q(pyr)`` as a rotation vector — one frame in closed form
    (the numpy conversions cost ~50 µs a call on one frame; this ~5 µs)."""
    hp, hy, hr = 0.5 * float(pyr[0]), 0.5 * float(pyr[1]), 0.5 * float(pyr[2])
    sx, cx, sy, cy, sz, cz = math.sin(hp), math.cos(hp), math.sin(hy), math.cos(hy), math.sin(hr), math.cos(hr)
    qw = cy * cx * cz + sy * sx * sz
    qx = cy * sx * cz + sy * cx * sz
    qy = sy * cx * cz - cy * sx * sz
    qz = cy * cx * sz - sy * sx * cz
    rx, ry, rz = float(rotvec[0]), float(rotvec[1]), float(rotvec[2])
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    a2 = angle * angle
    k = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0 if angle <= 1e-3 else math.sin(0.5 * angle) / angle
    px, py, pz, pw = k * rx, k * ry, k * rz, math.cos(0.5 * angle)
    w = pw * qw - px * qx - py * qy - pz * qz
    x = pw * qx + qw * px + py * qz - pz * qy
    y = pw * qy + qw * py + pz * qx - px * qz
    z = pw * qz + qw * pz + px * qy - py * qx
    return quaternion_to_rotvec_one(w, x, y, z)


def listen(motion, speech, heard, model, *, listening: float = DEFAULT_LISTENING, seed: int = 0):
    """The offline listening head: ``motion`` (the model's, for ``speech``) as it moves while
    hearing ``heard`` (:class:`~headmotion.types.Audio`, the same timeline).  Returns a Motion."""
    from ..types import Motion

    layer = ListeningLayer(model, fps=motion.fps, speech_rate=speech.sample_rate, heard_rate=heard.sample_rate,
                           listening=listening, seed=seed)
    layer.hear(heard.samples.astype(np.float32))
    layer.end_hearing()
    layer.speech(speech.samples.astype(np.float32))
    rv = layer.apply(motion.rotvec, 0)
    out = Motion(np.asarray(rv), motion.fps, translation=motion.translation, meta=dict(motion.meta))
    out.meta["nod_frames"] = list(layer.nod_starts)
    out.meta["nod_spans"] = list(layer.nod_spans)
    return out


__all__ = ["ListeningLayer", "listen", "HEAR_RATE", "POSTURE_DEG"]
