"""What the two template-warping systems share (thesis §5.4–5.8): feature handling, training
(vectors, limits, then the subclass's models), generation, streaming and persistence.

The parts live in :mod:`.features` (blocked extraction), :mod:`.vectors` (training vectors at change
points), :mod:`.limits` (safety limits), :mod:`.generator` (the causal generator and stream) and
:mod:`.post` (the post-processing tables); the speech detector is
:mod:`headmotion.features.speech_activity`.

Product defaults, each a parameter whose other value gives the thesis's behaviour:

* ``stochastic="params"`` — the warping parameters are sampled from the regression Gaussian (thesis
  §5.5's modification), seeded by ``seed``; ``"none"`` reproduces the thesis's ML tables, whose
  deterministic choices settle into a fixed point (a 2.5 Hz limit cycle on real data);
* ``min_swing_deg=0.5`` — training motion is segmented with a minimum swing of 0.5° between
  extrema (:func:`headmotion.motion.segmentation.segment_axis`), so video tracking jitter does not
  become hundreds of 0.1–0.2 s segments; 0 is the thesis's segmentation;
* ``soft_limit=True`` — the pull back towards the mean pose of :mod:`.limits`; False = hard clip only;
* ``log_params`` — model (and sample) the duration and amplitude in log space instead of linearly;
* ``features="f0e-live"`` — F0 + energy computed frame by frame
  (:mod:`headmotion.features.streaming`), the same code offline and on a stream, so a stream is
  final 64 ms after a frame's start and equals offline synthesis; model files with ``"f0e"``
  keep working (blocked stream, 0.7 s latency; :class:`.generator.TwsStream`).

After the generator, the post-processing chain of :mod:`headmotion.motion.post`
(``docs/decisions/post-chain.md``), in this order:

* ``idle=0.4`` — in pauses the head's speed is scaled by ``idle`` (causal settling); 1 = none;
* ``amplitude_match=True`` — each axis scaled about the training mean pose by a gain that gives
  the calibration synthesis the training heads' SD (:func:`.post.amplitude_gains`);
* ``speed_shaping=True`` — the speed shaper with a quantile map fitted in closed loop on the
  calibration synthesis against the training heads, at most
  :data:`~headmotion.motion.post.speed_shaping.WIDE_SPEED_MAX_GAIN` × faster
  (``docs/decisions/speed-shaping.md``);
* ``slow_band_restore=True`` — the slow band's share of power moved onto the training heads'
  share, the total variance kept (:func:`.post.slow_band_bank`).

Training reads every recording's features and motion into memory, so on a corpus longer than
``max_train_hours`` (4 h) it learns from a seeded, speaker-balanced subsample of whole recordings of
that much speech (:mod:`headmotion.systems.budget`; ``docs/decisions/bounded-training.md``); the
model's corpus summary says so (``trained_on``).

The calibration synthesis is this system's synthesis of its training speech (recording k with
seed k, without the stages), or with ``cross_fit`` that of a model trained on the other half of
the recordings (``docs/decisions/cross-fitting.md``).  Model files written before a stage existed
load with it off.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ...align import n_frames as _n_frames
from ...errors import ParameterError
from ...features import ANALYSIS_RATE
from ...features.speech_activity import SpeechDetector
from ...motion.control import apply_gain_angles, mean_pose_of
from ...motion.post import PostChain
from ...motion.post import speed_shaping
from ...motion.post.restore import band_variance
from ...motion.segmentation import min_segment_frames
from ...rotations import rotvec_to_pitch_yaw_roll
from ...types import Audio, Motion
from ..budget import check_hours
from ..base import CAUSAL, Synthesizer, check_stochastic, cross_fitted, pair_shortest
from ..constraints import BOOLEAN, Options, check_params, real, whole
from .features import extract_blocked, make_feature_config
from .generator import LIVE_FEATURES, Generator, TwsStream
from .limits import Limits
from .post import AMPLITUDE_CAP, amplitude_gains, slow_band_bank
from .post import post_tables as _post_tables
from .vectors import collect


#: the parameters tws-basic and tws-hier share, documented once (their docstrings read it at
#: ``{post_parameters}``)
POST_PARAMETERS_DOC = """min_swing_deg : smallest swing (degrees) between extrema when segmenting training motion
        (0.5; 0 = the thesis's segmentation; see :mod:`headmotion.systems.tws.base`)
    soft_limit : pull back towards the mean pose before the hard clip (True; False = literal)
    idle : speed in pauses as a fraction of speech, decided causally (0.4; 1 = no settling)
    log_params : regress and sample (d, a) in log space (False = linear, the thesis)
    speed_shaping : re-time the output so that its speeds are the training heads' (True; False = the
        thesis; see :mod:`headmotion.systems.tws.base`)
    slow_band_restore : move the output's share of slow (< 0.5 Hz) posture motion up to the training heads',
        keeping its variance
        (True; False = the thesis; see :mod:`headmotion.systems.tws.base`)
    amplitude_match : scale the output about the mean pose so that each axis's SD is the training
        heads' (per-axis gains measured on the synthesis the post stages are fitted on; True; see
        :mod:`headmotion.systems.tws.base`)"""


class TwsBase(Synthesizer):
    """Feature handling, training-data collection, generation, streaming and persistence shared
    by :class:`~headmotion.systems.tws.basic.TwsBasic` and
    :class:`~headmotion.systems.tws.hier.TwsHier`.  Subclasses implement ``_fit_axes(data)``,
    ``_choose(...)``, ``_model_state()`` and ``_load_model_state(config, arrays)``."""

    capabilities = frozenset({CAUSAL})
    _with_frames = False
    #: the values of ``method``: how (d, a) is taken from the conditional distribution
    METHODS = ("ml", "mmse", "sample")

    #: what each parameter may be (:mod:`..constraints`; ``stochastic``: :func:`..base.check_stochastic`,
    #: ``max_train_hours``: :func:`..budget.check_hours`)
    _parameter_constraints: ClassVar[dict] = {
        "feature_block": [whole(1)], "feature_context": [whole(0)],
        "min_swing_deg": [real(0, 90, closed="left")], "idle": [real(0, 1)],
        **{k: [BOOLEAN] for k in ("log_params", "speed_shaping", "slow_band_restore", "amplitude_match", "cross_fit",
                                  "soft_limit")},
        "fps": [real(0, closed="neither"), None],
    }

    def _validate_params(self) -> None:
        check_params(self, {"method": [Options(tuple(self.METHODS))]})
        check_stochastic(self.stochastic, self.name)
        check_params(self, self._parameter_constraints)
        check_hours(self)

    #: smallest amplitude (radians) taken to log space with ``log_params`` (0.006°)
    _LOG_FLOOR = 1e-4

    def _y_in(self, y: np.ndarray) -> np.ndarray:
        """Training targets ``(d, a)`` in the space the regression models them (log with ``log_params``)."""
        y = np.asarray(y, dtype=np.float64)
        return np.log(np.maximum(y, self._LOG_FLOOR)) if getattr(self, "log_params", False) else y

    def _y_out(self, y) -> tuple[float, float]:
        """``(d, a)`` back from the regression's space."""
        y = np.asarray(y, dtype=np.float64)
        if getattr(self, "log_params", False):
            y = np.exp(y)
        return float(y[0]), float(y[1])

    @property
    def _stochastic(self) -> str:
        return check_stochastic(self.stochastic, self.name)

    # -- features ---------------------------------------------------------------------------
    def _config(self):
        if not hasattr(self, "feature_config_"):
            self.feature_config_ = make_feature_config(self.features, self.fps_)
        return self.feature_config_

    def _features_full(self, audio: Audio, T: int) -> np.ndarray:
        tr = self._config().extract(audio, n_frames=T)
        return np.asarray(self.normalizer_.transform(np.asarray(tr.values, dtype=np.float64)), dtype=np.float64)

    def _features_blocks(self, audio: Audio, T: int, *, start_block: int = 0, stop_frame: int | None = None,
                         sample_offset: int = 0):
        F = extract_blocked(audio, self._config(), T, block=self.feature_block, context=self.feature_context,
                            start_block=start_block, stop_frame=stop_frame, sample_offset=sample_offset)
        if F.size == 0:
            return np.zeros((0, self.n_features_))
        return np.asarray(self.normalizer_.transform(F), dtype=np.float64)

    # -- training ---------------------------------------------------------------------------
    def fit(self, corpus, *, progress=None):
        from ...features import Normalizer
        from ..budget import corpus_summary

        recs = self._training_recordings(corpus, budget=True)
        fps_set = sorted({float(r.motion.fps) for r in recs})
        self.fps_ = float(self.fps) if self.fps else fps_set[0]
        self.feature_config_ = make_feature_config(self.features, self.fps_)
        # a live feature set analyses 16 kHz: that is the rate the stream's push expects
        self.sample_rate_ = (ANALYSIS_RATE if self.feature_config_.name in LIVE_FEATURES
                             else int(recs[0].audio.sample_rate))
        total = len(recs) + 2
        from ...feature_cache import features_for
        from ...features.vad import speaking_mask

        motions, raw, names, masks, kept = [], [], [], [], []
        for i, r in enumerate(recs):
            m = r.motion.resample(self.fps_)
            T = len(m)
            if T < 2 * min_segment_frames(self.fps_):
                continue
            tr = features_for(r, self.feature_config_, T)
            motions.append(np.asarray(m.rotvec))
            kept.append(r)
            raw.append(np.asarray(tr.values, dtype=np.float64))
            masks.append(speaking_mask(r.audio, fps=self.fps_, n_frames=T))
            names = list(tr.names)
            if progress:
                progress(i + 1, total, f"features {r.id}")
        if not motions:
            raise ParameterError(
                f"no recording in the corpus is long enough to train {self.name} "
                f"(need at least {2 * min_segment_frames(self.fps_)} frames)")
        self.train_seconds_ = sum(len(m) for m in motions) / self.fps_
        self.normalizer_ = Normalizer().fit(raw)
        feats = [np.asarray(self.normalizer_.transform(f), dtype=np.float64) for f in raw]
        self.n_features_ = feats[0].shape[1]
        self.feature_names_ = names
        data = collect(motions, feats, self.fps_, with_frames=self._with_frames,
                       min_swing=float(np.radians(self.min_swing_deg)))
        self.speech_detector_ = SpeechDetector.for_features(names, self.normalizer_, self.fps_)
        if self.speech_detector_ is not None:
            self.speech_detector_.score(feats, masks)
        n_seg = [len(d.y) for d in data]
        if min(n_seg) < 4:
            raise ParameterError(
                f"too little motion to train {self.name}: segments per axis {n_seg} (need >= 4 each); "
                "give longer recordings or more of them")
        self.limits_ = Limits.from_training(motions, data, self.fps_)
        self.mean_pose_ = mean_pose_of(motions)
        if progress:
            progress(len(recs) + 1, total, "models")
        self._fit_axes(data, progress=progress)
        self.corpus_summary_ = corpus_summary(self, corpus)
        self.speed_map_ = None
        self.slow_band_gains_ = None
        self.amplitude_gains_ = None
        self.fitted_ = True
        if self.speed_shaping or self.slow_band_restore or self.amplitude_match:
            self._fit_post_stages(kept, motions)
        if progress:
            progress(total, total, "done")
        return self

    def _change_points(self, corpus) -> list:
        """The change points of ``corpus``'s recordings, at the model's rate, with the model's
        features (:func:`.vectors.collect` as in training): what the confusion tables score."""
        self._check_fitted()
        motions, feats = [], []
        for r in corpus:
            m = r.motion.resample(self.fps_)
            motions.append(np.asarray(m.rotvec))
            feats.append(self._features_full(r.audio, len(m)))
        return collect(motions, feats, self.fps_, with_frames=self._with_frames,
                       min_swing=float(np.radians(self.min_swing_deg)))

    def _fit_post_stages(self, recs, motions) -> None:
        """The post stages' tables, from this system's synthesis of the speech of the training
        recordings ``recs`` (recording k with seed k, so that they are not one seed's draws; made
        while the tables are None, i.e. without any post stage) against their motion ``motions``
        (rotation vectors at ``fps_``): the per-axis amplitude gains (``amplitude_match``), then
        the speed shaper's map (``speed_shaping``) on that synthesis scaled by them, then the slow
        band's gains (``slow_band_restore``) on it shaped as synthesis will shape it.  The shaper's
        faster moves widen the output (its SD by 10–15 % on the ZEGGS folds), so the amplitude
        gains are corrected once by the ratio the finished output still has and the later tables
        refitted."""
        if self.cross_fit and len(recs) >= 2:
            pred, targ = self._cross_fit_synthesis(recs, motions)
        else:
            pred, targ = self._own_synthesis(recs, motions)
        if not self.amplitude_match:
            self._fit_shaping_tables(pred, targ)
            return
        gains = amplitude_gains(pred, targ)
        for _ in range(2):
            self.amplitude_gains_ = gains
            out = self._fit_shaping_tables([apply_gain_angles(x, self.limits_.mean, gains) for x in pred], targ)
            gains = np.clip(gains * amplitude_gains(out, targ), 1.0 / AMPLITUDE_CAP, AMPLITUDE_CAP)

    def _fit_shaping_tables(self, pred, targ) -> list[np.ndarray]:
        """The speed map and the slow band's gains fitted on ``pred`` against ``targ`` (as the
        parameters ask); returns ``pred`` after both stages, as synthesis will give it."""
        if self.speed_shaping:
            self.speed_map_ = speed_shaping.delivered_speed_map(
                pred, targ, fps=self.fps_, lag=speed_shaping.shaping_lag(self.fps_),
                max_gain=speed_shaping.WIDE_SPEED_MAX_GAIN)
            pred = [speed_shaping.product_shaper(self.speed_map_, self.fps_).push(x) for x in pred]
        if self.slow_band_restore:
            self.slow_band_gains_ = slow_band_bank(band_variance(pred, fps=self.fps_),
                                                   band_variance(targ, fps=self.fps_))
            tables = _post_tables(self, self.fps_).only("restore")
            pred = [PostChain(tables).push(x) for x in pred]
        return pred

    def _cross_fit_synthesis(self, recs, motions) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """``cross_fit``: the synthesis the post stages are fitted on, recording k (seed k) made by a
        model of the same parameters (without the stages) trained on the *other* half of the
        recordings (:func:`~headmotion.systems.base.cross_fitted`) — speech its template
        models have not seen, as at synthesis; paired with ``motions`` as :meth:`_own_synthesis`."""
        import warnings

        with warnings.catch_warnings():   # a half has fewer change points per cluster: said by the full fit
            warnings.simplefilter("ignore", UserWarning)
            synth = cross_fitted(self, recs, {"speed_shaping": False, "slow_band_restore": False,
                                                    "amplitude_match": False, "cross_fit": False},
                                 lambda half, r, k: half._predict(r.audio, seed=k).rotvec)
        return pair_shortest(synth, motions)

    # -- synthesis ----------------------------------------------------------------------------
    def _predict(self, audio: Audio, *, seed: int) -> Motion:
        """Generation over the whole utterance; features over the whole utterance (as in
        training).  With a live feature set (``f0e-live``, the default) these are the very values
        the stream computes, so the output equals the streamed output; with a whole-utterance set
        (``f0e``, older model files) ``blocked=True`` computes them block by block as the stream does."""
        T = _n_frames(len(audio.samples), audio.sample_rate, self.fps_)
        if T == 0:
            return Motion(np.zeros((0, 3)), self.fps_, meta={"system": self.name})
        gen = Generator(self, rng=np.random.default_rng(seed), fps=self.fps_)
        blocked = self.blocked and self._config().name not in LIVE_FEATURES
        gen.push_features(self._features_blocks(audio, T) if blocked else self._features_full(audio, T))
        gen.run()
        return Motion(gen.render_settled(0, T), self.fps_, meta={"system": self.name, "seed": seed})

    def _stream(self, *, seed: int) -> TwsStream:
        return TwsStream(self, seed=seed)

    def _init_generation(self) -> dict:
        """Per-utterance state handed to ``_choose`` (none by default)."""
        return {}

    def reachable_range(self) -> np.ndarray:
        """The hard clip of :meth:`Limits.clip`: the training range widened by 10 % on each side
        (``(3, 2)``, rotation-vector components ≈ pitch, yaw, roll in radians)."""
        self._check_fitted()
        lo, hi = np.asarray(self.limits_.lo, float), np.asarray(self.limits_.hi, float)
        span = hi - lo
        return np.stack([lo - 0.1 * span, hi + 0.1 * span], axis=1)

    # -- persistence --------------------------------------------------------------------------
    def _legacy_mean_pose(self) -> np.ndarray:
        return rotvec_to_pitch_yaw_roll(self.limits_.mean[None])[0]

    def _get_state(self):
        cfg, arrays = self._model_state()
        cfg = dict(cfg)
        params = self.get_params()
        if hasattr(params["features"], "to_dict"):
            params["features"] = params["features"].to_dict()
        cfg.update({"params": params, "fps": self.fps_, "sample_rate": self.sample_rate_,
                    "features": self.feature_config_.to_dict(), "n_features": self.n_features_,
                    "feature_names": list(self.feature_names_)})
        arrays = dict(arrays)
        arrays.update(self.limits_.to_arrays())
        arrays.update(self.normalizer_.to_arrays("norm_"))
        if getattr(self, "speech_detector_", None) is not None:
            arrays.update(self.speech_detector_.to_arrays())
        if getattr(self, "speed_map_", None) is not None:
            arrays["speed_map"] = np.asarray(self.speed_map_, dtype=np.float64)
        if getattr(self, "slow_band_gains_", None) is not None:
            arrays["slow_band_gains"] = np.asarray(self.slow_band_gains_, dtype=np.float64)
        if getattr(self, "amplitude_gains_", None) is not None:
            arrays["amplitude_gains"] = np.asarray(self.amplitude_gains_, dtype=np.float64)
        return cfg, arrays

    def _set_state(self, config, arrays):
        from ...features import FeatureConfig, Normalizer

        params = dict(config["params"])
        params.pop("gain", None)  # older files: a per-model gain (always 1.0 in practice)
        # older files: trained with the thesis's segmentation, no soft limit, no pause settling
        params.setdefault("min_swing_deg", 0.0)
        params.setdefault("soft_limit", False)
        params.setdefault("idle", 1.0)
        params.setdefault("log_params", False)
        params.setdefault("speed_shaping", False)  # older files: no speed map
        params.setdefault("slow_band_restore", False)  # older files: no slow-band gains
        params.setdefault("cross_fit", False)  # older files: tables from their own synthesis
        params.setdefault("amplitude_match", False)  # older files: no amplitude gains
        self.__init__(**params)
        self.fps_ = float(config["fps"])
        self.sample_rate_ = int(config["sample_rate"])
        self.feature_config_ = FeatureConfig.from_dict(config["features"])
        self.n_features_ = int(config["n_features"])
        self.feature_names_ = list(config.get("feature_names", []))
        self.limits_ = Limits.from_arrays(arrays)
        self.normalizer_ = Normalizer.from_arrays(arrays, "norm_")
        self.speech_detector_ = SpeechDetector.from_arrays(arrays)
        self.speed_map_ = np.asarray(arrays["speed_map"], dtype=np.float64) if "speed_map" in arrays else None
        self.slow_band_gains_ = (np.asarray(arrays["slow_band_gains"], dtype=np.float64)
                                 if "slow_band_gains" in arrays else None)
        self.amplitude_gains_ = (np.asarray(arrays["amplitude_gains"], dtype=np.float64)
                                 if "amplitude_gains" in arrays else None)
        self._load_model_state(config, arrays)


__all__ = ["TwsBase"]
