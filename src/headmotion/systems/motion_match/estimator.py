"""The estimator :class:`MotionMatch`: its parameters, its library fitted from a corpus, synthesis and its model file."""

from __future__ import annotations

import time
from typing import ClassVar

import numpy as np

from ...align import n_frames as _n_frames
from ...errors import ParameterError
from ...features import ANALYSIS_RATE
from ...features.readers import READERS
from ...models.numpy_nets import inference_threads
from ...motion.angles import centred_degrees
from ...motion.control import AMOUNT_RANGE, mean_pose_of
from ...rotations import pitch_yaw_roll_to_rotvec
from ...types import Audio, Motion
from ..base import CAUSAL, STREAMING, Synthesizer
from ..constraints import BOOLEAN, Options, check_params, real, whole
from .library import (CENTRED_FEATURES, FPS, LIVE_FEATURES, LIVE_NAMES, PRAAT_LIVE, PRAAT_OFFLINE, PROSODY, SMOOTH, SPEAKING_SHARE, VOICING,
                      Library, clean_clips, clip_starts, descriptor_of_last, read_ahead, speech_descriptors)
from .streams import MotionMatchStream, WindowStream
from .walk import _Walk

#: search tables kept per model (and its copies) for as many ``lookahead_ms`` settings
KEPT_LIBRARIES = 4


class MotionMatch(Synthesizer):
    """Speech-conditioned motion matching over the training motion (see :mod:`headmotion.systems.motion_match`).

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
    lookahead_ms : float >= 0, ``live`` models: how far ahead of its frames a decision may read the
        speech (a voice agent's text-to-speech makes its audio before it is played).  The decision
        for frames t… reads the prosody up to frame t + A, A = floor(lookahead_ms · 25 / 1000):
        the query's and the library's descriptors (from ``context`` frames before their frame to A
        after it) and the goal's regression all read A frames ahead
        (the library is re-indexed, not retrained), a stream emits a frame A frames (A · 40 ms)
        later, and past a file's end the last prosody row is repeated.  0: causal.  A model that
        is not ``live`` already reads its ``lookahead`` frames ahead and refuses a non-zero value
    reader : ``"yin"``, ``"praat"`` or ``"praat-path"``, f0e-live prosody: how pitch and voicing are
        read — per-frame YIN (``voicing_threshold``, ``pitch_jump``); Praat (its own voicing
        threshold and path search; :mod:`headmotion.features.praat_stream`) in blocks of 30 s read
        with 1 s on each side, or with ``live`` frame by frame on the last 0.3 s of audio; or
        Praat's candidates of each 20 ms analysis frame read once, its path searched forward over
        everything heard (:mod:`headmotion.features.praat_path`; final 40 ms after a frame's start)
        (docs/decisions/read-any-voice.md)
    speaker_s : float, f0e-live prosody: > 0 — pitch and level read relative to the voice so far
        (causal speaker normalisation, :mod:`headmotion.features.speaker_level`), the running level's
        half-life in seconds of voiced speech; 0: absolute (docs/decisions/read-any-voice.md)
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
                 ease_in: float = 0.0, lookahead_ms: float = 0.0, reader: str = "yin", speaker_s: float = 0.0,
                 seed: int = 0):
        self._store_params(locals())

    @property
    def capabilities(self) -> frozenset[str]:  # type: ignore[override]
        """Causal when ``live`` (streaming with a lookahead when it reads ``lookahead_ms`` ahead),
        streaming with lookahead on the f0e-live prosody; either way the stream equals ``predict``."""
        live = isinstance(self.live, (bool, np.bool_)) and bool(self.live)  # not a truthy "yes"
        if live:
            return frozenset({STREAMING}) if self._shift else frozenset({CAUSAL})
        return frozenset({STREAMING}) if self.prosody == "f0e-live" else frozenset()

    @property
    def _live_prosody(self) -> bool:
        """The prosody is f0e-live (computed frame by frame), not the whole-file f0e."""
        return bool(self.live) or self.prosody == "f0e-live"

    @property
    def _shift(self) -> int:
        """``live``: frames a decision reads the speech ahead of its own, A = floor(``lookahead_ms``
        · 25 / 1000) (0 when not ``live``, or for a value :meth:`_validate_params` refuses)."""
        try:
            ms = float(self.lookahead_ms)
        except (TypeError, ValueError):
            return 0
        if not self.live or not np.isfinite(ms) or ms <= 0:
            return 0
        return int(np.floor(ms * FPS / 1000.0 + 1e-9))
    # -- parameters ------------------------------------------------------------------------------
    #: what each parameter may be (:mod:`.constraints`)
    _parameter_constraints: ClassVar[dict] = {
        **{k: [whole(1)] for k in ("hop", "top_k", "blend")},
        **{k: [whole(0)] for k in ("context", "lookahead", "seed")},
        **{k: [real(0)] for k in ("speech_weight", "pose_weight", "velocity_weight", "switch_cost", "target_weight",
                                  "ridge", "pause_weight", "pause_switch", "lowpass", "posture_s", "base_cost",
                                  "repeat_cost", "wait_s", "ease_in", "pitch_jump", "speaker_s")},
        "temperature": [real(0, closed="neither")],
        "voicing_threshold": [real(0, 1, closed="right")],
        "amount": [real(*AMOUNT_RANGE)],
        "lookahead_ms": [real(0)],
        "prosody": [Options(("f0e", "f0e-live")), None],
        "reader": [Options(READERS)],
        **{k: [BOOLEAN] for k in ("mirror", "goal_path", "pause_speed", "live", "centred")},
    }

    def _validate_params(self) -> None:
        check_params(self, self._parameter_constraints)
        if self.live and self.prosody == "f0e":
            raise ParameterError(f"the 'live' parameter of {self.name} needs prosody 'f0e-live' (Praat's f0e reads "
                                 "the whole file)")
        if self.speaker_s and not self._live_prosody:
            raise ParameterError(f"the 'speaker_s' parameter of {self.name} reads the f0e-live prosody relative to "
                                 "the voice; give prosody 'f0e-live' (or a live model)")
        if self.lookahead_ms and not self.live:
            raise ParameterError(f"the 'lookahead_ms' parameter of {self.name} is how far a live model reads ahead; "
                                 f"this model is not live and already reads {1000.0 * self._reach[1] / FPS:g} ms "
                                 "ahead (its 'lookahead' and 'hop'): give 0 or a live model (e.g. the shipped "
                                 "'stream')")
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
        """Offsets (frames) of a descriptor's taps.  ``live``: relative to the last frame read,
        ``context`` frames back from the decision's own frame to the :attr:`_shift` frames it reads
        ahead — the speech it reads ahead is added to the speech around the decision, which the
        descriptor keeps (it is not moved wholly into the future).  Kept for the settings they
        were made for (a live stream asks at every decision)."""
        key = (bool(self.live), int(self.context), int(self.lookahead), self._shift)
        kept = self.__dict__.get("_taps_kept")
        if kept is not None and kept[0] == key:
            return kept[1]
        if self.live:
            back = int(self.context) + self._shift
            taps = np.array(sorted({*range(-back, 1, max(1, back // 4)), 0}))
        else:
            ahead = int(self.lookahead)
            step = max(1, (int(self.context) + ahead) // 4)
            taps = np.array(sorted({*range(-int(self.context), ahead + 1, step), ahead}))
        taps.setflags(write=False)
        self.__dict__["_taps_kept"] = (key, taps)
        return taps

    @property
    def _live_back(self) -> int:
        """``live``: the frames of prosody a decision reads, ending at its frame plus :attr:`_shift`
        (its descriptor's reach, the pause test's hop)."""
        return max(int(-self._taps.min()) + SMOOTH, int(self.hop))

    @property
    def _reach(self) -> tuple[int, int]:
        """Frames of prosody a decision at frame t reads: from t − back to t + ahead (``live``:
        ahead :attr:`_shift`, ``lookahead_ms``; else the descriptors over the hop, their taps and smoothing)."""
        if self.live:
            return self._live_back, self._shift
        return int(self.context) + SMOOTH, int(self.hop) + int(self.lookahead) + SMOOTH // 2

    @property
    def _feature_params(self) -> dict:
        """The f0e-live extractor's settings (:func:`~headmotion.features.readers.f0e_stream`)."""
        if self.reader == "praat":  # Praat's own voicing threshold and path search (no octave guard)
            params = {**LIVE_FEATURES, **(PRAAT_LIVE if self.live else PRAAT_OFFLINE)}
        elif self.reader == "praat-path":  # Praat's candidates frame by frame, its path searched forward
            params = {**LIVE_FEATURES, "reader": "praat-path"}
        else:
            params = {**LIVE_FEATURES, "voicing_threshold": float(self.voicing_threshold),
                      "max_jump_semitones": float(self.pitch_jump)}
        if self.speaker_s:
            params = {**params, "speaker_half_life_s": float(self.speaker_s)}
        return {**params, **CENTRED_FEATURES} if self.centred else params

    def _feature_stream(self):
        """A new incremental extractor of the prosody this model reads, at its ``sample_rate_``."""
        from ...features.readers import f0e_stream

        return f0e_stream(sample_rate=int(self.sample_rate_), fps=FPS, **self._feature_params)

    @property
    def _voicing(self) -> int:
        return len(LIVE_NAMES) - 1 if self._live_prosody else VOICING

    # -- fitting ---------------------------------------------------------------------------------
    def fit(self, corpus, *, progress=None) -> "MotionMatch":
        """Build the library from ``corpus`` (see :mod:`headmotion.systems.motion_match`;
        ``progress`` as in :meth:`Synthesizer.fit <headmotion.systems.base.Synthesizer.fit>`)."""
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
        self.lib_feats_ = self.standardised(allf)
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
        """The search tables (:class:`~.library.Library`) over the library's frames, their
        descriptors read :attr:`_shift` frames ahead; tables built before for other lookaheads are
        dropped (the library or the settings may have changed)."""
        self._libraries_: dict[int, Library] = {}
        self.library_ = self._library_for(self._shift)

    def _library_for(self, shift: int) -> Library:
        """The search tables with descriptors ``shift`` frames ahead: built once and kept (for
        :data:`KEPT_LIBRARIES` lookaheads) by this model and its copies — :func:`headmotion.synthesize`
        and every stream of ``headmotion serve`` give a copy with the ``lookahead_ms`` asked for."""
        kept = self._libraries_
        lib = kept.get(shift)
        if lib is None:
            lib = Library(self.lib_motion_, self.lib_feats_, self.lib_lengths_,
                          starts=getattr(self, "lib_starts_", None),  # files written before clips were stored
                          own=getattr(self, "lib_own_", None),  # an adapted model: the speaker's recordings
                          hop=int(self.hop), taps=self._taps, goal_steps=self._goal_steps,
                          mirror=self.mirror, ridge=float(self.ridge), causal=bool(self.live), shift=shift)
            while len(kept) >= KEPT_LIBRARIES:
                kept.pop(next(iter(kept)), None)
            kept[shift] = lib
        return lib

    def _indexed(self) -> None:
        """``library_`` for the ``lookahead_ms`` now set: a runtime setting of a trained model
        (``set_params``, or a copy with another value), so the search tables are re-indexed for it
        here, before a synthesis or a stream, not retrained."""
        if getattr(self.library_, "shift", 0) != self._shift:
            if not hasattr(self, "_libraries_"):
                self._libraries_ = {}
            self.library_ = self._library_for(self._shift)

    # -- synthesis -------------------------------------------------------------------------------
    def goals(self, desc: np.ndarray) -> np.ndarray:
        """The pose goal ``(T, 3)`` (degrees; 0 on axes without a goal) for speech descriptors
        ``desc`` (:func:`speech_descriptors`): the ridge prediction, clipped to the 1st–99th
        percentile of the library's poses (:meth:`Library.goals <.library.Library.goals>`)."""
        return self.library_.goals(desc)

    def generate(self, feats: np.ndarray, seed: int) -> np.ndarray:
        """Motion ``(T, 3)`` in degrees about the mean pose for standardised prosody ``(T, D)``."""
        self._indexed()
        T, H = len(feats), int(self.hop)
        walk = _Walk(self, seed)
        out = np.zeros((T, 3))
        if self.live:  # every decision from the speech up to its frame (+ lookahead_ms), as the stream makes it
            back, A = self._live_back, self._shift
            rows = read_ahead(feats, A)  # past the end, the last row repeated
            for t in range(0, T, H):
                out[t:t + H] = walk.hop(*self.live_inputs(rows[max(0, t + A + 1 - back):t + A + 1]), H)[:T - t]
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
        prosody up to its frame plus :attr:`_shift` (``past``, the last row is that frame): the
        goal is the one the speech so far asks for, held over the hop; a pause is a hop whose last
        ``hop`` frames read had a voiced share below 0.2."""
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
            from ...features import extract

            return np.asarray(extract("f0e-live", audio, fps=FPS, n_frames=n, **self._feature_params)
                              .select(LIVE_NAMES).values, dtype=np.float32)
        from ...features import extract

        return np.concatenate([np.asarray(extract(name, audio, fps=FPS, n_frames=n, **params).select(names).values,
                                          dtype=np.float32) for name, params, names in PROSODY], axis=1)

    def _degrees_to_motion(self, x: np.ndarray) -> Motion:
        pyr = np.radians(x) + self.mean_pose_
        return Motion(pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]), FPS)

    def standardised(self, raw: np.ndarray) -> np.ndarray:
        """Raw prosody columns (:meth:`_prosody`'s, or a stream's rows of them) as the library
        matches them: rounded to float32 first, then standardised, as float32 — the same bits
        offline and on a stream, whatever precision the extractor gave."""
        return ((np.asarray(raw, dtype=np.float32) - self.feat_mean_) / self.feat_std_).astype(np.float32)

    def _predict(self, audio: Audio, *, seed: int) -> Motion:
        n = _n_frames(len(audio.samples), audio.sample_rate, FPS)
        if n == 0:
            return Motion(np.zeros((0, 3)), FPS)
        f = self.standardised(self._prosody(audio, n))
        with inference_threads(1):  # the goals' small products: fastest on one BLAS thread
            return self._degrees_to_motion(self.generate(f, seed))

    def _stream(self, *, seed: int) -> "MotionMatchStream | WindowStream":
        self._indexed()
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
