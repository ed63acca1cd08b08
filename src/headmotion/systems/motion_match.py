"""``motion-match``: head motion *sampled* from speech by choosing recorded movements
(speech-conditioned motion matching; docs/decisions/motion-matching.md).

A regressor predicts the average head; a generative network trembles where a head holds still.
Here the training motion itself is the vocabulary of movements, and the model is a
speech-conditioned way of walking through it (motion matching, Clavet 2016; for speech-driven
gesture, Habibie et al. 2022):

* **Library** (:meth:`MotionMatch.fit`): every training recording's pitch, yaw and roll at 25 fps
  in degrees, its mean pose removed (:func:`~headmotion.motion.angles.centred_degrees`), and, with
  ``mirror``, its copy with yaw and roll negated; beside each frame, its prosody — energy, log F0,
  their deltas and voicing (:data:`PROSODY`, selected by name; standardised).
* **Matching**: every ``hop`` frames the system scores each library frame by how far the prosody
  around it (``context`` frames back to ``lookahead`` frames ahead) is from the prosody around the
  current frame, and how far its pose and velocity are from where the motion is heading; while
  speaking (a voiced share of the hop ≥ 0.2), by how far its next ``hop`` frames miss the pitch
  *goal* (a ridge regression of the pose on the prosody descriptor, scaled to the library's SD;
  ``target_weight``) — frame by frame over the hop (``goal_path``) or at its end only — and in a
  pause by how much it moves (``pause_weight``; with ``pause_speed`` its mean squared speed over
  the hop, else its net displacement: clips that hold).  A frame other than the one that continues
  the clip already playing pays ``switch_cost`` (× ``pause_switch`` in a pause: a head settles or
  shifts between phrases).  One of the ``top_k`` cheapest is drawn from the seed with weight
  ``exp(-(cost - best) / temperature)`` — for a take's first movement among frames at least a hop
  apart (different clips, not one clip's neighbours) — and its motion plays from there.
* **Joins** (inertialisation): when the clip changes, the difference between where the motion was
  going (position and velocity) and where the new clip starts decays as a critically damped spring
  that settles over ``blend`` frames, so a join has neither a step nor a kink; nothing else
  changes the recorded motion.

Same seed, same motion; another seed makes other choices, so ``--samples K`` gives K takes made of
different movements.  Memory is the library (25 frames a second of training motion) and the
output; any length.  A decision reads the speech up to ``hop + lookahead`` frames ahead (1.0 s by
default: the goal over the hop).

**Live** (``live=True``, :class:`MotionMatchStream`): the prosody is the f0e-live set (YIN pitch,
energy, their deltas and voicing, computed incrementally with no lookahead: a frame is final
39 ms after its start), smoothed and described from the past only, in the library as at
synthesis; a decision reads the speech up to its own frame, its goal is the pose that speech
asks for, held over the hop, and a hop is a pause when the last ``hop`` frames were mostly
unvoiced.  The system then streams 39 ms behind the audio, and the stream equals ``predict``.

**Frame-by-frame prosody** (``prosody="f0e-live"``, not ``live``; the shipped default): the same
features, and every decision computed from a window of them around its frame (its reach back and
ahead, :attr:`MotionMatch._reach`) as :class:`WindowStream` computes it when the audio streams in:
the system streams with that lookahead (≈ 1.1 s), a long file is synthesised block by block, and
the stream equals ``predict``.  ``lowpass`` and ``posture_s`` (docs/decisions/default_models.md)
clean the library of a tracker's jitter and keep postures over seconds.
"""

from __future__ import annotations

import time
from typing import ClassVar

import numpy as np

from ..align import fit_length
from ..align import n_frames as _n_frames
from ..errors import ParameterError
from ..features import ANALYSIS_RATE
from ..models.numpy_nets import inference_threads
from ..motion.angles import centred_degrees
from ..motion.control import AMOUNT_RANGE, mean_pose_of
from ..rotations import pitch_yaw_roll_to_rotvec
from ..types import Audio, Motion
from .base import CAUSAL, STREAMING, Synthesizer
from .constraints import BOOLEAN, Options, check_params, real, whole

#: frames per second of the library and the output
FPS = 25.0
#: the prosody matched (``prosody="f0e"``), by feature set and name: the MFCC front end's energy and
#: its delta, Praat's log F0, energy, Δlog F0 and voicing
PROSODY = (("mfcc", {}, ("energy", "d_energy")), ("f0e", {"voicing": True}, ("logf0", "energy", "d_logf0", "voiced")))
#: a frame-to-frame change above this (degrees at 25 fps, 250 °/s) is a tracking glitch: clips end there
MAX_STEP_DEG = 10.0
#: the voicing column within PROSODY's columns
VOICING = 5
#: a hop is speech when at least this share of its frames is voiced (else a pause)
SPEAKING_SHARE = 0.2
#: the f0e-live prosody matched (the shipped models; ``live``), by name, and its settings: no
#: smoothing or delta lookahead, so a frame is final 39 ms after its start at 16 kHz
LIVE_NAMES = ("energy", "d_energy", "logf0", "d_logf0", "voiced")
LIVE_FEATURES = {"smooth_lookahead": 0, "delta_lookahead": 0, "voicing": True}
#: ``centred``: the smoothing (2 frames at 25 fps) and the 5-frame deltas centred on their frame
CENTRED_FEATURES = {"smooth_lookahead": 1, "delta_lookahead": 2}
#: frames of the moving average over the features before they are matched
SMOOTH = 5
#: ``amount``: how far the choice leans per doubling — a frame's cost changes by
#: ``AMOUNT_LEAN · log2(amount)`` times how much more (in SDs of log speed) its next hop moves than
#: the library's average hop (docs/decisions/amount.md)
AMOUNT_LEAN = 0.5
#: ``repeat_cost``: how long (seconds) a clip started is remembered
REPEAT_S = 10.0
#: ``wait_s``: the pause and repeat costs of a head that waits (docs/decisions/amount-and-adapt.md)
WAIT_PAUSE_WEIGHT = 3.0
WAIT_REPEAT_COST = 3.0


def _smooth(x: np.ndarray, width: int, *, causal: bool = False) -> np.ndarray:
    """Moving average over ``width`` frames along axis 0, centred or (``causal``) ending at each
    frame; edges repeated."""
    if width <= 1 or len(x) == 0:
        return x
    before = width - 1 if causal else width // 2
    pad = np.concatenate([np.repeat(x[:1], before, 0), x, np.repeat(x[-1:], width - 1 - before, 0)])
    c = np.cumsum(np.concatenate([np.zeros((1, x.shape[1])), pad]), axis=0)
    return (c[width:] - c[:-width]) / width


def speech_descriptors(feats: np.ndarray, taps: np.ndarray, *, causal: bool = False) -> np.ndarray:
    """``(T, len(taps) * D)``: the (smoothed) features of each frame at the offsets ``taps``
    (frames; edges repeated) — the speech around a frame, as matched.  ``causal``: the smoothing
    reads no frame after the one it is for (with taps ≤ 0, nothing after the frame is read)."""
    T = len(feats)
    s = _smooth(feats.astype(np.float64), SMOOTH, causal=causal)
    idx = np.clip(np.arange(T)[:, None] + taps[None, :], 0, max(T - 1, 0))
    return s[idx].reshape(T, -1).astype(np.float32)


def clip_starts(motion: np.ndarray) -> np.ndarray:
    """``(T,)`` bool: the frames of one recording's motion (degrees, 25 fps) where a clip starts —
    the first frame, and each frame after a jump above :data:`MAX_STEP_DEG` (a tracking glitch)."""
    starts = np.zeros(len(motion), bool)
    starts[:1] = True
    starts[1:] = np.abs(np.diff(motion, axis=0)).max(axis=1) > MAX_STEP_DEG
    return starts


def clean_clips(motion: np.ndarray, starts: np.ndarray, hz: float, *, fps: float = FPS) -> np.ndarray:
    """One recording's motion with each clip (``starts``: :func:`clip_starts`) low-passed at ``hz``
    by a zero-phase 4th-order Butterworth filter (``scipy.signal.sosfiltfilt``), so a face
    tracker's frame-to-frame jitter is not replayed; clips too short for the filter's padding are
    padded less, clips under 4 frames kept as they are."""
    from scipy.signal import butter, sosfiltfilt

    sos = butter(4, hz, fs=fps, output="sos")
    out = np.array(motion, dtype=np.float64)
    bounds = np.r_[np.flatnonzero(starts), len(motion)]
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a >= 4:
            out[a:b] = sosfiltfilt(sos, out[a:b], axis=0, padlen=min(b - a - 1, 15))
    return out.astype(np.asarray(motion).dtype)


def descriptor_of_last(past: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """The causal descriptor (:func:`speech_descriptors` with ``causal=True``) of the last row of
    ``past`` — the rows up to that frame, at least as many as the taps and the smoothing reach
    back, or every row since the start (which is then repeated before it, as there)."""
    need = int(-taps.min()) + SMOOTH
    p = np.asarray(past[-need:])
    if len(p) < need:
        p = np.concatenate([np.repeat(p[:1], need - len(p), 0), p])
    return speech_descriptors(p, taps, causal=True)[-1]


class MotionMatch(Synthesizer):
    """Speech-conditioned motion matching over the training motion (see the module docstring).

    Parameters
    ----------
    hop : int, frames (25 fps) between decisions
    context, lookahead : int, frames of speech before and after a frame that are matched
    speech_weight, pose_weight, velocity_weight : float, weights of the three costs
    switch_cost : float, cost of leaving the clip that is playing
    top_k : int, candidates drawn from; temperature : float, of the draw's weights
    blend : int, frames over which a join's offset settles
    mirror : bool, add every training motion with yaw and roll negated
    target_weight : float, weight of the pitch goal while speaking; ridge : float, its regularisation
    goal_path : bool, match the goal frame by frame over the hop (else at the hop's end)
    pause_weight : float, weight of holding still in a pause
    pause_speed : bool, a pause's cost is the mean squared speed over the hop (else net displacement)
    pause_switch : float, factor on ``switch_cost`` in a pause
    live : bool, read the speech only up to each decision (f0e-live features, causal descriptors,
        the goal and the pause test from the past): the system streams, 39 ms behind the audio
    lowpass : float, Hz; > 0: every library clip is low-passed there (zero-phase) before it is
        played — a face tracker's frame-to-frame jitter is not replayed, a nod is kept; 0: as recorded
    posture_s : float, seconds; > 0: at a join the pose offset settles over this time constant
        (the velocity still over ``blend`` frames), so a posture the head has reached is kept for
        seconds, not pulled to the new clip's within a few frames; 0: both over ``blend`` frames
    amount : float in [0, 3], how much the head moves, by choice: 1 as the library moves, above 1
        the choice leans to clips that move more and faster over the next hop (and joins come
        more often), below 1 to calmer ones; 0 holds the mean pose.  No angle is scaled: every
        movement played is a recorded one (:data:`AMOUNT_LEAN`)
    ease_in : float, seconds; > 0: a take opens from the mean pose at rest — its first movement is
        chosen as if the head were there, and the offset to it settles as a join does (a critically
        damped spring over ``blend`` frames, at most ``ease_in``) — so no take opens at a pose far
        from the mean; 0: the first movement plays from its own pose
    voicing_threshold : float in (0, 1], f0e-live prosody: the largest YIN aperiodicity of a voiced
        frame (:class:`~headmotion.features.streaming.StreamingF0e`); 0.35 is strict on noisy or
        reverberant recordings, where it calls speech unvoiced and a hop of speech a pause
        (docs/decisions/follow-any-voice.md)
    pitch_jump : float, semitones, f0e-live prosody: a voiced frame this far from the last voiced
        frames' median is taken for an octave error and called unvoiced (the extractor's
        ``max_jump_semitones``; 0: no guard); 5 also drops real pitch accents and tones, which
        move more than that within 0.3 s (docs/decisions/follow-any-voice.md)
    centred : bool, f0e-live prosody: smoothing and deltas centred on their frame (they read
        :data:`CENTRED_FEATURES`' frames ahead, 200 ms at 25 fps), not ending at it — causal
        features lag the speech by up to 80 ms (the deltas' window centre), a lag the choice then
        carries into the motion; False: causal (39 ms behind the audio)
    repeat_cost : float, cost of starting a clip within a hop of one started in the last
        :data:`REPEAT_S` seconds: a take does not loop over the few movements that match a long
        silence or a small library (0: no memory)
    wait_s : float, seconds; > 0: once the speech has paused this long, the head *waits*: a pause
        prefers clips that hold more (``pause_weight`` :data:`WAIT_PAUSE_WEIGHT`) and avoids the
        clips started lately (``repeat_cost`` at least :data:`WAIT_REPEAT_COST`) — slow drifts and
        a posture shift now and then instead of one matched movement over and over; 0: pauses of
        any length are treated alike
    base_cost : float, an adapted model (:mod:`headmotion.systems.adapt`): cost of a frame from the
        base library, not from the speaker's own recordings (0: no preference)
    prosody : str or None, the speech features matched: ``"f0e"`` (Praat F0, energy and voicing,
        read over the whole file), ``"f0e-live"`` (YIN F0, energy and voicing computed frame by frame:
        the system then streams — with ``live``, 39 ms behind the audio; otherwise with the lookahead
        its decisions read — and a long file is synthesised block by block); None: ``"f0e-live"``
        when ``live``, else ``"f0e"``
    seed : int, default synthesis seed

    The defaults were chosen on held-out speakers (docs/decisions/motion-matching.md).
    """

    name: ClassVar[str] = "motion-match"

    def __init__(self, *, hop: int = 15, context: int = 10, lookahead: int = 10, speech_weight: float = 1.0,
                 pose_weight: float = 1.0, velocity_weight: float = 1.0, switch_cost: float = 3.0,
                 top_k: int = 8, temperature: float = 0.3, blend: int = 8, mirror: bool = True,
                 target_weight: float = 2.0, ridge: float = 10.0, pause_weight: float = 1.0, goal_path: bool = True,
                 pause_switch: float = 0.0, pause_speed: bool = True, live: bool = False, lowpass: float = 0.0,
                 posture_s: float = 0.0, prosody: str | None = None, amount: float = 1.0,
                 base_cost: float = 0.0, repeat_cost: float = 0.0, wait_s: float = 0.0,
                 voicing_threshold: float = 0.35, pitch_jump: float = 5.0, centred: bool = False,
                 ease_in: float = 0.0, seed: int = 0):
        self.hop, self.context, self.lookahead, self.goal_path = hop, context, lookahead, goal_path
        self.lowpass, self.posture_s, self.prosody = lowpass, posture_s, prosody
        self.pause_switch, self.pause_speed = pause_switch, pause_speed
        self.target_weight, self.ridge, self.pause_weight = target_weight, ridge, pause_weight
        self.speech_weight, self.pose_weight, self.velocity_weight = speech_weight, pose_weight, velocity_weight
        self.switch_cost, self.top_k, self.temperature, self.blend = switch_cost, top_k, temperature, blend
        self.mirror, self.seed, self.live = mirror, seed, live
        self.amount, self.base_cost, self.repeat_cost, self.wait_s = amount, base_cost, repeat_cost, wait_s
        self.voicing_threshold, self.centred, self.ease_in = voicing_threshold, centred, ease_in
        self.pitch_jump = pitch_jump

    @property
    def capabilities(self) -> frozenset[str]:  # type: ignore[override]
        """Causal when ``live``, streaming with lookahead on the f0e-live prosody; either way the
        stream equals ``predict``."""
        live = isinstance(self.live, (bool, np.bool_)) and bool(self.live)  # not a truthy "yes"
        if live:
            return frozenset({CAUSAL})
        return frozenset({STREAMING}) if self.prosody == "f0e-live" else frozenset()

    @property
    def _live_prosody(self) -> bool:
        """The prosody is f0e-live (computed frame by frame), not the whole-file f0e."""
        return bool(self.live) or self.prosody == "f0e-live"
    # -- parameters ------------------------------------------------------------------------------
    #: what each parameter may be (:mod:`.constraints`)
    _parameter_constraints: ClassVar[dict] = {
        **{k: [whole(1)] for k in ("hop", "top_k", "blend")},
        **{k: [whole(0)] for k in ("context", "lookahead", "seed")},
        **{k: [real(0)] for k in ("speech_weight", "pose_weight", "velocity_weight", "switch_cost", "target_weight",
                                  "ridge", "pause_weight", "pause_switch", "lowpass", "posture_s", "base_cost",
                                  "repeat_cost", "wait_s", "ease_in", "pitch_jump")},
        "temperature": [real(0, closed="neither")],
        "voicing_threshold": [real(0, 1, closed="right")],
        "amount": [real(*AMOUNT_RANGE)],
        "prosody": [Options(("f0e", "f0e-live")), None],
        **{k: [BOOLEAN] for k in ("mirror", "goal_path", "pause_speed", "live", "centred")},
    }

    def _validate_params(self) -> None:
        check_params(self, self._parameter_constraints)
        if self.live and self.prosody == "f0e":
            raise ParameterError(f"the 'live' parameter of {self.name} needs prosody 'f0e-live' (Praat's f0e reads "
                                 "the whole file)")
        if self.lowpass and not 0.5 <= self.lowpass < FPS / 2:
            raise ParameterError(f"the 'lowpass' parameter of {self.name} must be 0 (off) or in [0.5, {FPS / 2:g}) Hz; "
                                 f"got {self.lowpass!r}")

    @property
    def _goal_steps(self) -> np.ndarray:
        """Frames after a decision at which the goal is matched: every frame of the hop, or its end."""
        H = int(self.hop)
        return np.arange(1, H + 1) if self.goal_path else np.array([H])

    @property
    def _taps(self) -> np.ndarray:
        ahead = 0 if self.live else int(self.lookahead)
        step = max(1, (int(self.context) + ahead) // 4)
        return np.unique(np.r_[np.arange(-int(self.context), ahead + 1, step), ahead])

    @property
    def _live_back(self) -> int:
        """``live``: the frames of prosody a decision reads (its descriptor's reach, the pause test's hop)."""
        return max(int(-self._taps.min()) + SMOOTH, int(self.hop))

    @property
    def _reach(self) -> tuple[int, int]:
        """Frames of prosody a decision at frame t reads: from t − back to t + ahead (``live``:
        ahead 0; else the descriptors over the hop, their taps and smoothing)."""
        if self.live:
            return self._live_back, 0
        return int(self.context) + SMOOTH, int(self.hop) + int(self.lookahead) + SMOOTH // 2

    @property
    def _feature_params(self) -> dict:
        """The f0e-live extractor's settings (:class:`~headmotion.features.streaming.StreamingF0e`)."""
        params = {**LIVE_FEATURES, "voicing_threshold": float(self.voicing_threshold),
                  "max_jump_semitones": float(self.pitch_jump)}
        return {**params, **CENTRED_FEATURES} if self.centred else params

    @property
    def _voicing(self) -> int:
        return len(LIVE_NAMES) - 1 if self._live_prosody else VOICING

    # -- fitting ---------------------------------------------------------------------------------
    def fit(self, corpus, *, progress=None) -> "MotionMatch":
        """Build the library from ``corpus`` (see the module docstring).

        Parameters
        ----------
        corpus : Corpus
        progress : callable ``progress(done, total, description)`` or None
        """
        recs = self._training_recordings(corpus)
        t0 = time.perf_counter()
        motions, feats = [], []
        for i, r in enumerate(recs):
            n = _n_frames(len(r.audio.samples), r.audio.sample_rate, FPS)
            if n < int(self.hop) + 2:
                continue
            motions.append(centred_degrees(r.motion, n, FPS).astype(np.float32))
            feats.append(self._prosody(r.audio, n))
            if progress is not None:
                progress(i + 1, len(recs), f"motion-match library {i + 1}/{len(recs)}")
        if not motions:
            raise ParameterError(f"{self.name}: no training recording is longer than {(int(self.hop) + 2) / FPS:.2f} s")
        allf = np.concatenate(feats).astype(np.float64)
        self.feat_mean_, self.feat_std_ = allf.mean(axis=0), np.maximum(allf.std(axis=0), 1e-6)
        self.lib_starts_ = np.concatenate([clip_starts(m) for m in motions])
        if self.lowpass:  # each clip low-passed once, here: loading a model needs no filter
            motions = [clean_clips(m, s, float(self.lowpass)) for m, s in
                       zip(motions, np.split(self.lib_starts_, np.cumsum([len(m) for m in motions])[:-1]))]
        self.lib_motion_ = np.concatenate(motions)
        self.lib_feats_ = ((allf - self.feat_mean_) / self.feat_std_).astype(np.float32)
        self.lib_lengths_ = np.array([len(m) for m in motions], dtype=np.int64)
        self.mean_pose_ = mean_pose_of([r.motion.rotvec for r in recs])
        # f0e-live: the features analyse (and the stream takes) audio at the analysis rate
        self.sample_rate_ = ANALYSIS_RATE if self._live_prosody else int(recs[0].audio.sample_rate)
        self.fps_ = FPS
        self.corpus_summary_ = corpus.summary() if hasattr(corpus, "summary") else None
        self.fit_warnings_ = []
        self._index()
        self.fit_seconds_ = time.perf_counter() - t0
        self.fitted_ = True
        return self

    def _index(self) -> None:
        """The search tables: per library frame its speech descriptor, pose, velocity, the pose
        change over the next ``hop`` frames, where its clip ends (``lib_starts_``: the end of its
        recording, or a jump above ``MAX_STEP_DEG`` in the recorded motion — a tracking glitch is
        never played) and whether a clip may start there (``hop`` frames must follow before that end)."""
        S, P, V, ok, A, end, Q, mine = [], [], [], [], [], [], [], []
        start, offset, H = 0, 0, int(self.hop)
        starts_all = getattr(self, "lib_starts_", None)  # files written before clips were stored: found here
        own = getattr(self, "lib_own_", None)  # an adapted model: which recordings are the speaker's
        taps, steps = self._taps, self._goal_steps  # once, not per recording
        for r, n in enumerate(self.lib_lengths_):
            m = self.lib_motion_[start:start + n].astype(np.float64)
            d = speech_descriptors(self.lib_feats_[start:start + n], taps, causal=bool(self.live))
            starts = starts_all[start:start + n] if starts_all is not None else clip_starts(m)
            bounds = np.r_[np.flatnonzero(starts), n]
            clip_end = np.repeat(bounds[1:], np.diff(bounds))  # per frame: where its clip ends
            good = np.arange(n) + H + 1 < clip_end
            ahead = np.clip(np.arange(n)[:, None] + steps[None, :], 0, n - 1)
            nxt = np.clip(np.arange(n)[:, None] + np.arange(1, H + 1)[None, :], 0, n - 1)
            v = np.vstack([m[1:2] - m[:1], np.diff(m, axis=0)])
            q = (v[nxt] ** 2).mean(axis=1)  # (n, 3): mean squared velocity over the next hop (a mirror's too)
            flips = [np.ones(3), np.array([1.0, -1.0, -1.0])] if self.mirror else [np.ones(3)]
            for f in flips:
                c = m * f
                S.append(d)
                P.append(c)
                A.append(c[ahead] - c[:, None, :])  # (n, len(goal steps), 3): the pose change k frames on
                V.append(v * f)
                Q.append(q)
                mine.append(np.full(n, own is None or bool(own[r])))
                ok.append(good)
                end.append(clip_end + offset)
                offset += n
            start += n
        self._S = np.concatenate(S).astype(np.float32)
        self._P = np.concatenate(P)
        self._V = np.concatenate(V)
        self._ok = np.concatenate(ok)
        self._end = np.concatenate(end)  # where each frame's recording (copy) ends
        # an adapted model's range, posture and goal are the speaker's: fitted on their frames only
        own = np.concatenate(mine)
        fit = slice(None) if own.all() else own
        #: an adapted model: 1 on the base library's frames (the ones ``base_cost`` is paid on); else None
        self._base_frames = None if own.all() else (~own).astype(np.float64)
        self._pose_sd = np.maximum(self._P[fit].std(axis=0), 1e-3)
        self._vel_sd = np.maximum(self._V[fit].std(axis=0), 1e-4)
        speed2 = (np.concatenate(Q) / self._vel_sd ** 2).sum(axis=1) / 3.0
        # ``amount``: how much each frame's next hop moves, in SDs of the library's log speed
        ls = np.log(speed2 + 1e-3)
        self._lively = ((ls - ls.mean()) / max(ls.std(), 1e-6)).astype(np.float32)
        path = np.concatenate(A) / self._pose_sd  # (N, steps, 3)
        moved = path[:, -1, :]
        # the pose path the speech asks for: ridge regression of the pose on the speech around a
        # frame, each axis scaled to the library's SD (a regression predicts the average head)
        X = np.c_[self._S.astype(np.float64), np.ones(len(self._S))][fit]
        reg = float(self.ridge) * np.eye(X.shape[1])
        reg[-1, -1] = 0.0
        self._W = np.linalg.solve(X.T @ X + reg, X.T @ self._P[fit])
        pred_sd = (X @ self._W).std(axis=0)
        # a goal stays among the poses the library holds (speech unlike any training speech, e.g.
        # the silence before a file's first word, would otherwise ask for a pose no one took)
        self._goal_range = np.percentile(self._P[fit], [1.0, 99.0], axis=0)
        # axes the speech predicts (with ``mirror``, yaw and roll are predicted as 0: no goal for them)
        self._goal_axes = pred_sd > 0.02 * self._pose_sd
        self._W *= np.where(self._goal_axes, np.minimum(self._pose_sd / np.maximum(pred_sd, 1e-12), 10.0), 0.0)
        scaled = {"S": self._S, "P": self._P / self._pose_sd, "V": self._V / self._vel_sd,
                  "A": moved, "G": path[:, :, self._goal_axes].reshape(len(path), -1)}
        self._tables = {"Q2": speed2}
        for k, x in scaled.items():
            x = np.ascontiguousarray(x, dtype=np.float32)
            self._tables[k], self._tables[k + "2"] = x, np.einsum("ij,ij->i", x, x, dtype=np.float64)

    # -- synthesis -------------------------------------------------------------------------------
    def _costs(self, s: np.ndarray, pose: np.ndarray | None, vel: np.ndarray | None,
               goal: np.ndarray | None = None, speaking: float = 1.0, only: int | None = None,
               pause_weight: float | None = None):
        """The cost of starting a clip at every library frame (or at the frame ``only``, a float)
        for the speech descriptor ``s``, the next pose and velocity the motion is heading for,
        the pose ``goal`` at the goal steps (``(len(_goal_steps), 3)``) and whether the hop is
        speech (1) or a pause (0).
        Squared distances are expanded (|a|² − 2a·b + |b|²) around the library's stored norms."""
        at = slice(None) if only is None else slice(only, only + 1)
        t = self._tables

        def sq(name: str, q: np.ndarray) -> np.ndarray:
            return t[name + "2"][at] - 2.0 * (t[name][at] @ q) + float(q @ q)

        c = float(self.speech_weight) / len(s) * sq("S", s)
        if goal is not None and self.target_weight > 0 and speaking > 0 and self._goal_axes.any():
            ax = self._goal_axes
            step = ((goal - (pose if pose is not None else 0.0)) / self._pose_sd)[..., ax].astype(np.float32).ravel()
            c = c + float(self.target_weight) / len(step) * sq("G", step)
        pw = float(self.pause_weight if pause_weight is None else pause_weight)
        if pw > 0 and speaking < 1.0:  # in a pause, clips that hold
            c = c + pw * (1.0 - speaking) * (
                t["Q2"][at] if self.pause_speed else t["A2"][at] / 3.0)
        if pose is not None:
            c = c + float(self.pose_weight) / 3.0 * sq("P", (pose / self._pose_sd).astype(np.float32))
            c = c + float(self.velocity_weight) / 3.0 * sq("V", (vel / self._vel_sd).astype(np.float32))
        if self.amount > 0 and self.amount != 1:  # lean to clips that move more (amount > 1) or less
            c = c - AMOUNT_LEAN * float(np.log2(self.amount)) * self._lively[at]
        if self.base_cost > 0 and self._base_frames is not None:  # an adapted model prefers the speaker's own
            c = c + float(self.base_cost) * self._base_frames[at]
        return float(c[0]) if only is not None else np.where(self._ok, c, np.inf)

    def _draw(self, cost: np.ndarray, rng: np.random.Generator, *, distinct: bool = False) -> int:
        """One of the ``top_k`` cheapest library frames, drawn with weight exp(−Δcost / temperature);
        ``distinct``: candidates at least a hop apart (different movements, not one clip's neighbours)."""
        k = min(int(self.top_k), int(np.isfinite(cost).sum()))
        if distinct:
            m = min(len(cost), 20 * k)
            pool = np.argpartition(cost, m - 1)[:m]
            pool = pool[np.argsort(cost[pool], kind="stable")]
            keep: list[int] = []
            for j in pool:
                if np.isfinite(cost[j]) and all(abs(int(j) - i) >= int(self.hop) for i in keep):
                    keep.append(int(j))
                    if len(keep) == k:
                        break
            idx = np.array(keep)
            k = len(idx)
        else:
            idx = np.argpartition(cost, k - 1)[:k]
            idx = idx[np.argsort(cost[idx], kind="stable")]
        w = np.exp(-(cost[idx] - cost[idx[0]]) / float(self.temperature))
        return int(idx[rng.choice(k, p=w / w.sum())])

    def goals(self, desc: np.ndarray) -> np.ndarray:
        """The pose goal ``(T, 3)`` (degrees; 0 on axes without a goal) for speech descriptors
        ``desc`` (:func:`speech_descriptors`): the ridge prediction, clipped to the 1st–99th
        percentile of the library's poses."""
        return np.clip(np.c_[desc.astype(np.float64), np.ones(len(desc))] @ self._W, *self._goal_range)

    def generate(self, feats: np.ndarray, seed: int) -> np.ndarray:
        """Motion ``(T, 3)`` in degrees about the mean pose for standardised prosody ``(T, D)``."""
        T, H = len(feats), int(self.hop)
        walk = _Walk(self, seed)
        out = np.zeros((T, 3))
        if self.live:  # every decision from the speech up to its frame, as the stream makes it
            back = self._live_back
            for t in range(0, T, H):
                out[t:t + H] = walk.hop(*self.live_inputs(feats[max(0, t + 1 - back):t + 1]), H)[:T - t]
            return out
        if self._live_prosody:  # every decision from a window of the speech around it, as the stream makes it
            back, ahead = self._reach
            for t in range(0, T, H):
                lo = max(0, t - back)
                n = min(H, T - t)
                out[t:t + n] = walk.hop(*self.window_inputs(feats[lo:t + ahead + 1], t - lo), n)
            return out
        desc = speech_descriptors(feats, self._taps)
        goals = self.goals(desc) if self.target_weight > 0 else None
        voiced = np.clip(feats[:, VOICING] * self.feat_std_[VOICING] + self.feat_mean_[VOICING], 0.0, 1.0)
        for t in range(0, T, H):
            goal = goals[np.minimum(t + self._goal_steps, T - 1)] if goals is not None else None
            speaking = float(voiced[t:t + H].mean() >= SPEAKING_SHARE)  # 0 in a pause
            n = min(H, T - t)
            out[t:t + n] = walk.hop(desc[t], goal, speaking, n)
        return out

    def window_inputs(self, window: np.ndarray, at: int) -> tuple[np.ndarray, np.ndarray | None, float]:
        """A decision's speech descriptor, goal path and pause test from the standardised prosody
        ``window`` around it (row ``at`` is the decision's frame; the rows reach :attr:`_reach`
        frames back and ahead, or to the file's start or end): as :meth:`generate` computes them
        from the whole file, with the edges of the window taken as the file's."""
        desc = speech_descriptors(window, self._taps)
        last = len(window) - 1
        goal = self.goals(desc[np.minimum(at + self._goal_steps, last)]) if self.target_weight > 0 else None
        v = self._voicing
        voiced = np.clip(window[at:at + int(self.hop), v] * self.feat_std_[v] + self.feat_mean_[v], 0.0, 1.0)
        return desc[at], goal, float(voiced.mean() >= SPEAKING_SHARE)

    def live_inputs(self, past: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, float]:
        """``live``: a decision's speech descriptor, goal and pause test from the standardised
        prosody up to its frame (``past``, the last row is the frame): the goal is the one the
        speech so far asks for, held over the hop; a pause is a hop whose last ``hop`` frames
        had a voiced share below 0.2."""
        desc = descriptor_of_last(past, self._taps)
        goal = None
        if self.target_weight > 0:
            goal = np.repeat(self.goals(desc[None]), len(self._goal_steps), axis=0)
        v = self._voicing
        voiced = np.clip(past[-int(self.hop):, v] * self.feat_std_[v] + self.feat_mean_[v], 0.0, 1.0)
        return desc, goal, float(voiced.mean() >= SPEAKING_SHARE)

    def _prosody(self, audio: Audio, n: int) -> np.ndarray:
        """The raw prosody columns matched, ``(n, 6)`` at 25 fps (f0e-live: ``(n, 5)``)."""
        if self._live_prosody:  # resampled to the analysis rate, the rate the stream is pushed at
            from ..features import extract

            return np.asarray(extract("f0e-live", audio, fps=FPS, n_frames=n, **self._feature_params)
                              .select(LIVE_NAMES).values, dtype=np.float32)
        from ..features import extract

        return np.concatenate([np.asarray(extract(name, audio, fps=FPS, n_frames=n, **params).select(names).values,
                                          dtype=np.float32) for name, params, names in PROSODY], axis=1)

    def _degrees_to_motion(self, x: np.ndarray) -> Motion:
        pyr = np.radians(x) + self.mean_pose_
        return Motion(pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]), FPS)

    def _predict(self, audio: Audio, *, seed: int | None) -> Motion:
        seed = int(seed)  # filled by the contract (Synthesizer._synthesis_seed)
        n = _n_frames(len(audio.samples), audio.sample_rate, FPS)
        if n == 0:
            return Motion(np.zeros((0, 3)), FPS)
        f = ((self._prosody(audio, n) - self.feat_mean_) / self.feat_std_).astype(np.float32)
        with inference_threads(1):  # the search is matrix-vector products: fastest on one BLAS thread
            return self._degrees_to_motion(self.generate(f, seed))

    def _stream(self, *, seed: int | None) -> "MotionMatchStream | WindowStream":
        return MotionMatchStream(self, seed=int(seed)) if self.live else WindowStream(self, seed=int(seed))

    # -- persistence -----------------------------------------------------------------------------
    def _get_state(self):
        config = {"params": self.get_params(), "sample_rate": self.sample_rate_, "fps": FPS}
        arrays = {"feat_mean": self.feat_mean_, "feat_std": self.feat_std_, "lib_motion": self.lib_motion_,
                  "lib_feats": self.lib_feats_, "lib_lengths": self.lib_lengths_}
        if getattr(self, "lib_starts_", None) is not None:
            arrays["lib_starts"] = self.lib_starts_
        if getattr(self, "lib_own_", None) is not None:  # an adapted model (headmotion.systems.adapt)
            arrays["lib_own"] = self.lib_own_
            config["adapted_from"] = self.adapted_from_
        return config, arrays

    def _set_state(self, config, arrays):
        params = dict(config["params"])
        # a model file written without these settings keeps the choices it was built with: the
        # goal at the hop's end, the full switch cost in pauses, the pause cost on net displacement
        for k, v in (("goal_path", False), ("pause_switch", 1.0), ("pause_speed", False), ("live", False)):
            params.setdefault(k, v)
        for k in self._param_names():
            setattr(self, k, params.get(k, getattr(type(self)(), k)))
        self.sample_rate_, self.fps_ = int(config["sample_rate"]), float(config.get("fps", FPS))
        self.feat_mean_ = np.asarray(arrays["feat_mean"], dtype=np.float64)
        self.feat_std_ = np.asarray(arrays["feat_std"], dtype=np.float64)
        self.lib_motion_ = np.asarray(arrays["lib_motion"], dtype=np.float32)
        self.lib_feats_ = np.asarray(arrays["lib_feats"], dtype=np.float32)
        self.lib_lengths_ = np.asarray(arrays["lib_lengths"], dtype=np.int64)
        self.lib_starts_ = np.asarray(arrays["lib_starts"], dtype=bool) if "lib_starts" in arrays else None
        self.lib_own_ = np.asarray(arrays["lib_own"], dtype=bool) if "lib_own" in arrays else None
        self.adapted_from_ = config.get("adapted_from")
        self.fit_warnings_ = []
        self._index()


class _Walk:
    """The decisions of one take (:meth:`MotionMatch.generate`, :class:`MotionMatchStream`): the
    draws from the seed, the clip playing, the spring of the last join and the last two frames."""

    def __init__(self, model: MotionMatch, seed: int):
        self.m, self.rng = model, np.random.default_rng(int(seed))
        self.t, self.pos, self.age = 0, -1, 0
        self.x0, self.v0 = np.zeros(3), np.zeros(3)
        self.last = np.zeros((0, 3))
        self.recent: list[tuple[int, int]] = []  # (frame, library frame) of the clips started lately
        self.quiet = 0  # frames the speech has paused so far
        self.opening = False  # the offset playing out is the take's opening (ease_in)
        self.lam = 4.0 / float(model.blend)
        #: > 0: the rate (per frame) at which a join's pose offset settles (``posture_s``)
        self.settle = 1.0 / (float(model.posture_s) * FPS) if model.posture_s else 0.0

    def hop(self, desc: np.ndarray, goal: np.ndarray | None, speaking: float, n: int) -> np.ndarray:
        """The next ``n`` frames (degrees): one decision for the speech descriptor ``desc``, the
        pose ``goal`` at the goal steps and whether the hop is speech (1) or a pause (0)."""
        m, pos = self.m, self.pos
        if m.amount == 0:  # holds the mean pose
            self.t += n
            return np.zeros((n, 3))
        # the head waits in a pause that has already lasted wait_s before this hop
        waiting = m.wait_s > 0 and not speaking and self.quiet >= float(m.wait_s) * FPS
        self.quiet = 0 if speaking else self.quiet + n  # frames of pause so far
        pw = WAIT_PAUSE_WEIGHT if waiting else None
        repeat = max(float(m.repeat_cost), WAIT_REPEAT_COST) if waiting else float(m.repeat_cost)
        if self.t == 0:  # with ease_in, as if the head were at the mean pose, at rest
            rest = np.zeros(3) if m.ease_in > 0 else None
            cost = m._costs(desc, rest, rest, goal, speaking, pause_weight=pw)
        else:
            vel = self.last[-1] - self.last[-2] if len(self.last) >= 2 else np.zeros(3)
            ahead = self.last[-1] + vel
            switch = float(m.switch_cost) * (1.0 if speaking else float(m.pause_switch))
            cost = m._costs(desc, ahead, vel, goal, speaking, pause_weight=pw) + switch
            if 0 <= pos < len(cost) and pos + n <= m._end[pos - 1]:  # the clip playing goes on
                cost[pos] = m._costs(desc, ahead, vel, goal, speaking, only=pos, pause_weight=pw)
            base_pos = cost[pos] if 0 <= pos < len(cost) else np.inf
        if repeat > 0 and self.recent:  # clips started in the last REPEAT_S seconds cost more
            H = int(m.hop)
            for _t0, j0 in self.recent:  # ``cost`` is this decision's own array
                lo, hi = max(0, j0 - H), j0 + H
                cost[lo:hi] += repeat
            if 0 <= pos < len(cost) and pos + n <= m._end[pos - 1]:
                cost[pos] = base_pos
        j = m._draw(cost, self.rng, distinct=self.t == 0)  # a take's first movement: from different clips
        if (m.repeat_cost > 0 or m.wait_s > 0) and j != pos:
            self.recent = [(t0, j0) for t0, j0 in self.recent if self.t - t0 < REPEAT_S * FPS] + [(self.t, j)]
        if self.t > 0 and j != pos:  # a join: carry on from where the motion was going
            self.x0 = ahead - m._P[j]
            self.v0 = vel - m._V[j]
            self.age, self.opening = 0, False
        elif self.t == 0 and m.ease_in > 0:  # the take opens from the mean pose, at rest
            self.x0, self.v0, self.age = -m._P[j], -m._V[j], 0
            self.opening = True
        a = np.arange(self.age, self.age + n, dtype=np.float64)[:, None]
        if self.opening:  # the opening settles within ease_in, as one critically damped spring
            lam = max(self.lam, 4.0 / (float(m.ease_in) * FPS))
            off = (self.x0 + (self.v0 + lam * self.x0) * a) * np.exp(-lam * a)
        elif self.settle:  # the pose offset settles slowly, the velocity offset over the blend
            off = self.x0 * np.exp(-self.settle * a) + self.v0 * a * np.exp(-self.lam * a)
        else:  # both settle as one critically damped spring
            off = (self.x0 + (self.v0 + self.lam * self.x0) * a) * np.exp(-self.lam * a)
        frames = m._P[j:j + n] + off
        self.age += n
        self.pos = j + n
        self.t += n
        self.last = np.concatenate([self.last, frames])[-2:]
        return frames


def _tail_rows(last: np.ndarray | None, raw: np.ndarray, n: int) -> np.ndarray:
    """The feature rows still to come at a stream's end, ``n`` of them, as ``predict``'s features
    are fitted to the audio's length: ``raw`` trimmed, or padded by repeating its last row — or,
    when ``raw`` is empty, the last row seen before (``last``; None when nothing was seen)."""
    if last is None:
        return fit_length(raw, n)
    return fit_length(np.concatenate([last[None], raw]), n + 1)[1:]


class MotionMatchStream:
    """:meth:`MotionMatch.stream` (``live`` models): push float samples at the model's
    ``sample_rate``; a frame is final once its f0e-live features are (``latency_ms``, 39 ms at
    16 kHz), and the frames equal ``predict``'s.  Every ``hop`` frames a decision is made from the
    prosody so far and its frames are emitted as their features arrive.  State: the feature
    extractor, the last frames of prosody a decision reads, the take's walk — bounded."""

    def __init__(self, model: MotionMatch, *, seed: int):
        from ..features.streaming import StreamingF0e

        self.m = model
        self.ex = StreamingF0e(sample_rate=int(model.sample_rate_), fps=FPS, **model._feature_params)
        self.latency_ms = self.ex.latency_ms
        self.walk = _Walk(model, seed)
        self.back = model._live_back
        self.cols = [list(self.ex.names).index(n) for n in LIVE_NAMES]  # the matched columns, by name
        self.past = np.zeros((0, len(LIVE_NAMES)), np.float32)
        self.pending = np.zeros((0, 3))
        self.k = 0            # frames emitted
        self.samples = 0      # samples pushed
        self.raw_last = None  # the last raw feature row (repeated if the file ends before its frames)

    def _frames(self, raw: np.ndarray) -> Motion:
        m, H = self.m, int(self.m.hop)
        out = np.zeros((len(raw), 3))
        for i, row in enumerate(raw):
            f = ((row[self.cols] - m.feat_mean_) / m.feat_std_).astype(np.float32)
            self.past = np.concatenate([self.past, f[None]])[-self.back:]
            if self.k % H == 0:
                self.pending = self.walk.hop(*m.live_inputs(self.past), H)
            out[i] = self.pending[self.k % H]
            self.k += 1
        if len(raw):
            self.raw_last = raw[-1]
        return m._degrees_to_motion(out)

    def push(self, samples: np.ndarray) -> Motion:
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        self.samples += len(x)
        return self._frames(self.ex.push(x))

    def flush(self) -> Motion:
        """The remaining frames: as many in all as ``predict`` gives for the audio pushed."""
        raw = np.asarray(self.ex.flush()).reshape(-1, len(self.ex.names))
        n = max(_n_frames(self.samples, int(self.m.sample_rate_), FPS) - self.k, 0)
        return self._frames(_tail_rows(self.raw_last, raw, n))


class WindowStream:
    """:meth:`MotionMatch.stream` for models on the f0e-live prosody that read ahead (not ``live``):
    push float samples at the model's ``sample_rate``; a decision is made once the prosody of its
    window (:attr:`MotionMatch._reach`) is final, and its hop of frames is emitted then, so a frame
    comes ``latency_ms`` after its start (the features' 39 ms and the window's reach ahead, about
    1.1 s by default).  The frames equal ``predict``'s: the same windows, the same decisions.
    State: the feature extractor, the prosody rows a decision can still read, the take's walk."""

    def __init__(self, model: MotionMatch, *, seed: int):
        from ..features.streaming import StreamingF0e

        self.m = model
        self.ex = StreamingF0e(sample_rate=int(model.sample_rate_), fps=FPS, **model._feature_params)
        self.back, self.ahead = model._reach
        self.latency_ms = self.ex.latency_ms + 1000.0 * self.ahead / FPS
        self.walk = _Walk(model, seed)
        self.cols = [list(self.ex.names).index(n) for n in LIVE_NAMES]  # the matched columns, by name
        self.rows = np.zeros((0, len(LIVE_NAMES)), np.float32)  # standardised prosody from frame row0
        self.row0 = 0
        self.t = 0            # the next decision's frame
        self.samples = 0      # samples pushed
        self.raw_last = None  # the last raw feature row (repeated if the file ends before its frames)

    def _add(self, raw: np.ndarray) -> None:
        if len(raw):
            m = self.m
            f = ((np.asarray(raw)[:, self.cols] - m.feat_mean_) / m.feat_std_).astype(np.float32)
            self.rows = np.concatenate([self.rows, f])
            self.raw_last = raw[-1]

    def _decide(self, total: int | None) -> Motion:
        """Every decision whose window is final: all rows to ``t + ahead`` are known and will be
        in the file (fewer than the frames of the samples pushed), or ``total`` (the file's frames) is known."""
        H, out = int(self.m.hop), []
        known = self.row0 + len(self.rows)
        while self.t < (total if total is not None else 0) or (
                total is None and self.t + self.ahead < min(known, _n_frames(self.samples, int(self.m.sample_rate_), FPS))):
            lo = max(0, self.t - self.back)
            window = self.rows[lo - self.row0:self.t + self.ahead + 1 - self.row0]
            n = H if total is None else min(H, total - self.t)
            out.append(self.walk.hop(*self.m.window_inputs(window, self.t - lo), n))
            self.t += H
        keep = max(0, self.t - self.back) - self.row0  # rows no later decision reads
        if keep > 0:
            self.rows, self.row0 = self.rows[keep:], self.row0 + keep
        return self.m._degrees_to_motion(np.vstack(out) if out else np.zeros((0, 3)))

    def push(self, samples: np.ndarray) -> Motion:
        x = np.asarray(samples, dtype=np.float64).reshape(-1)
        self.samples += len(x)
        self._add(self.ex.push(x))
        return self._decide(None)

    def flush(self) -> Motion:
        """The remaining frames: as many in all as ``predict`` gives for the audio pushed."""
        raw = np.asarray(self.ex.flush()).reshape(-1, len(self.ex.names))
        total = _n_frames(self.samples, int(self.m.sample_rate_), FPS)
        have = self.row0 + len(self.rows)
        self._add(_tail_rows(self.raw_last, raw, total if self.raw_last is None else max(total - have, 0)))
        self.rows = self.rows[:max(total - self.row0, 0)]
        return self._decide(total)


__all__ = ["MotionMatch", "MotionMatchStream", "WindowStream", "PROSODY", "LIVE_NAMES", "speech_descriptors"]
