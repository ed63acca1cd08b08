"""The DNN systems' shared implementation, :class:`DnnSystem` (paper §3–4): training in stages
(:mod:`.data`, :mod:`.training`, :mod:`.calibration`), synthesis (:mod:`.inference` for the
networks, :mod:`.synthesis` for the post-processing chain), streaming (:mod:`.streaming`) and model
files (:mod:`.persistence`).  The registered systems are in :mod:`.registered`.

Which data path a fit takes is ``train_path``: "memory" (every recording's features in memory,
:mod:`.training`), "streamed" (read from disk a buffer at a time, memory bounded,
:mod:`.stream_fit`; not for cccae / ae-dnn, whose CCA loss wants their whole training set at
hand) or "auto" (the default: streamed for a corpus on disk with more than an hour of training
speech, :data:`.streamed.STREAM_MIN_SECONDS`, else in memory).  Both paths train on ``device``
("cpu" by default, "auto" = CUDA when torch sees one, "cuda"), as ``batch_scale``, ``precision``
and ``compile_networks`` say (:mod:`headmotion.models.train_speed`: batches k times larger at a
√k learning rate with warm-up; bf16 autocast and ``torch.compile`` on a GPU only; the defaults
change nothing).  Synthesis runs the numpy networks on the CPU whatever ``device`` says.  See
``docs/decisions/bounded-training.md`` and ``docs/decisions/gpu-training.md``."""

from __future__ import annotations

import time
from typing import ClassVar

import numpy as np

from ...align import fit_length as _fit_length
from ...align import n_frames as _n_frames
from ...errors import ParameterError
from ...motion.control import mean_pose_of
from ...motion.post.range_limit import range_from_training
from ...rotations import rotvec_to_pitch_yaw_roll
from ...seeds import resolve_seed
from ...types import Audio, FeatureTrack, Motion
from ..base import STREAMING, Synthesizer
from . import calibration, data, inference, persistence, streamed, training
from .params import (DEFAULT_DRIFT_SHARE, DEFAULT_DRIFT_TAU_S, DEFAULT_SLOW_BAND_GAIN, DNN_IDLE, MODEL_FPS,
                     check_network_params, check_post_params)
from .synthesis import DnnPost, frame_energy_db, post_tables


class _StageProgress:
    """Per-stage progress callbacks of :meth:`DnnSystem.fit`."""

    def __init__(self, progress, n_stages: int):
        self.progress, self.n, self.stage = progress, n_stages, 0

    def __call__(self, desc):
        def cb(epoch, total, v):
            if self.progress is not None:
                self.progress(self.stage + epoch / max(total, 1), self.n, f"{desc}: epoch {epoch}, valid loss {v:.4f}")
        return cb

    def next(self) -> None:
        self.stage += 1


class DnnSystem(Synthesizer):
    """Shared implementation of the DNN systems; use the registered subclasses (:mod:`.registered`)."""

    name: ClassVar[str] = ""
    capabilities: ClassVar[frozenset[str]] = frozenset({STREAMING})
    default_feature: ClassVar[str] = "wav"
    #: whether the system learns a waveform embedding (CCCAE / AE) before the regressor
    uses_embedding: ClassVar[bool] = False
    #: the weight of the CCA term when ``alpha`` is not given, and whether it may be changed
    default_alpha: ClassVar[float | None] = None
    alpha_fixed: ClassVar[bool] = False
    #: ``cross_fit=None`` means this (True for mfcc-dnn, the product's system)
    default_cross_fit: ClassVar[bool] = False

    def __init__(self, *, features: str | None = None, feature_params: dict | None = None,
                 alpha: float | None = None, embedding_dim: int = 30,
                 ae_hidden: tuple[int, ...] = (256, 128), ae_activation: str = "relu",
                 regressor_hidden: tuple[int, ...] = (256, 256),
                 context: int = 25, dropout: float = 0.1, postfilter: bool = True,
                 postfilter_hidden: tuple[int, ...] = (256,), postfilter_code: int = 64, segment: int = 50,
                 postfilter_noise: float = 0.3, model_fps: float = MODEL_FPS, batch_size: int = 256,
                 cca_batch_size: int = 1000, cca_reg: float = 1e-3, learning_rate: float = 2e-4,
                 max_epochs: int = 30, ae_max_epochs: int = 60, pretrain_epochs: int = 3, patience: int = 4,
                 valid_fraction: float = 0.15, holdout_test: bool = True, random_state: int = 0,
                 n_threads: int | None = 1, variance_restore: bool = True, restore_bands: bool = True,
                 drift_share: float = DEFAULT_DRIFT_SHARE, drift_tau_s: float = DEFAULT_DRIFT_TAU_S,
                 slow_band_gain: float = DEFAULT_SLOW_BAND_GAIN, speed_shaping: bool = True, idle: float | None = DNN_IDLE,
                 range_limit: bool = True, cross_fit: bool | None = None, speed_max_gain: float | None = None,
                 seed: int | None = 0, device: str = "cpu", train_path: str = "auto", batch_scale: int = 1,
                 precision: str = "float32", compile_networks: bool = False):
        self._store_params(locals())

    # -- parameters ---------------------------------------------------------------------------
    @property
    def alpha_value(self) -> float | None:
        """The CCA weight in use: ``alpha``, or the system's default when it is None."""
        return self.default_alpha if self.alpha is None else self.alpha

    @property
    def cross_fit_value(self) -> bool:
        """Whether the speed map is cross-fitted: ``cross_fit``, or the system's default when None."""
        return bool(self.default_cross_fit if self.cross_fit is None else self.cross_fit)

    def _validate_params(self) -> None:
        from ...devices import check_device

        check_network_params(self)
        check_post_params(self)
        check_device(self.device, self.name)
        streamed.check_train_path(self)

    @property
    def feature_name(self) -> str:
        return self.features or self.default_feature

    def _feature_config(self):
        from ...features import FeatureConfig

        return FeatureConfig(self.feature_name, fps=float(self.model_fps), params=dict(self.feature_params or {}))

    @property
    def shaping_lag(self) -> int:
        """The speed shaper's window in frames at the model rate."""
        from ...motion.post.speed_shaping import shaping_lag

        return shaping_lag(self.model_fps)

    # -- fitting ----------------------------------------------------------------------------------
    def _extract(self, audio: Audio, T: int, config=None) -> np.ndarray:
        return data.extract(audio, T, config if config is not None else self.feature_config_)

    def _prepare(self, rec, config) -> data.Prepared:
        return data.prepare(rec, config, float(self.model_fps))

    def fit(self, corpus, *, progress=None) -> "DnnSystem":
        """Train embedding (CCCAE / AE systems), regressor and post-filter on ``corpus``, then the
        post-processing tables (:mod:`.calibration`).

        Parameters
        ----------
        corpus : Corpus — one speaker's recordings (speaker-dependent models, paper §4.1)
        progress : callable ``progress(done, total, description)`` or None

        The data path is ``train_path`` (module docstring); the networks train on ``device``.
        """
        self._validate_params()
        t0 = time.perf_counter()
        if len(corpus) == 0:
            raise ParameterError(f"cannot fit {self.name} on an empty corpus")
        config = self._feature_config()
        split = data.split(corpus, random_state=self.random_state, holdout_test=self.holdout_test)
        train_idx = [i for i, rid in enumerate(corpus.ids) if split[rid] == "train"]
        if train_idx and streamed.uses_stream(self, corpus, train_idx):
            from .stream_fit import fit_streamed

            return fit_streamed(self, corpus, split, config, progress, t0)
        train_recs = [r for r in corpus if split[r.id] == "train"]
        valid_recs = [r for r in corpus if split[r.id] == "valid"]
        if not train_recs:
            raise ParameterError(f"no training recordings in the corpus (splits: {split})")
        from ...devices import resolve_device

        device = resolve_device(self.device)
        n_stages = (1 if self.uses_embedding else 0) + 1 + (1 if self.postfilter else 0)
        if progress is not None:
            progress(0, n_stages, f"{self.name}: extracting {self.feature_name} features")
        train, valid = data.training_data(self, train_recs, valid_recs, config)
        feat_norm, mot_norm = data.normalise(train, valid)
        ae, emb_norm, reg, pf, history = training.fit_networks(self, train, valid, _StageProgress(progress, n_stages),
                                                               device)
        if device != "cpu":
            history["device"] = device
        self.motion_sd_, self.gv_, self.band_gains_, hraw, hy = calibration.restoration_tables(self, train, valid, reg, pf)
        self.feature_config_ = config
        self.input_dim_ = int(train[0].feats.shape[1])
        self.feature_norm_, self.motion_norm_, self.embedding_norm_ = feat_norm, mot_norm, emb_norm
        self.autoencoder_, self.regressor_, self.postfilter_ = ae, reg, pf
        fit_recs = [r for r in corpus if split[r.id] != "test"]
        if self.cross_fit_value and self.speed_shaping and len(fit_recs) >= 2:
            self.speed_map_ = calibration.cross_fit_speed_map(self, fit_recs)
        else:
            self.speed_map_ = calibration.validation_speed_map(self, hraw, hy)
        fps_list = sorted({float(r.motion.fps) for r in train_recs})
        self.output_fps_ = fps_list[0] if len(fps_list) == 1 else float(self.model_fps)  # informational
        self.splits_ = {r.id: split[r.id] for r in corpus}
        self.fps_ = float(self.model_fps)
        self.sample_rate_ = int(train_recs[0].audio.sample_rate)
        self.mean_pose_ = mean_pose_of([p.motion for p in train])
        self.range_ = range_from_training([p.motion for p in train], self.motion_norm_.mean_)
        self.history_ = training.clean_json(history)
        self.fit_seconds_ = time.perf_counter() - t0
        self.corpus_summary_ = corpus.summary()
        self.fitted_ = True
        if progress is not None:
            progress(n_stages, n_stages, f"{self.name}: done in {self.fit_seconds_:.1f} s")
        return self

    # -- synthesis ----------------------------------------------------------------------------------
    def _check_features(self, values: np.ndarray, what: str) -> None:
        if values.ndim != 2 or values.shape[1] != self.input_dim_:
            raise ParameterError(
                f"this {self.name} model was trained on {self.feature_config_.name!r} features with "
                f"{self.input_dim_} dims per frame; {what} has shape {tuple(values.shape)}")

    def _regressor_input(self, feats: np.ndarray) -> np.ndarray:
        """Model-rate features ``(T, D)`` → the regressor's normalised input (the normalised
        embedding for the CCCAE / AE systems), float32."""
        x = np.asarray(self.feature_norm_.transform(feats), dtype=np.float32)
        if self.autoencoder_ is not None:
            x = np.asarray(self.embedding_norm_.transform(inference.encode(self.autoencoder_, x)), dtype=np.float32)
        return x

    def _network_values(self, feats: np.ndarray) -> np.ndarray:
        """Model-rate features ``(T, D)`` → normalised network output ``(T, 3)`` (float32):
        embedding (CCCAE / AE systems), regressor, post-filter."""
        self._check_features(feats, "the feature track")
        return inference.network_output(self.regressor_, self.postfilter_, self._regressor_input(feats),
                                         segment=int(self.segment))

    def post_tables(self):
        """The post-processing chain's tables (:func:`.synthesis.post_tables`)."""
        return post_tables(self)

    def _post(self, seed: int | None) -> DnnPost:
        """The post-processing chain with fresh state, its drift seeded with ``seed`` (filled by the contract)."""
        return DnnPost(post_tables(self), seed=seed)

    def _predict_values(self, feats: np.ndarray, *, seed: int | None = None, post: bool = True) -> np.ndarray:
        """Model-rate features ``(T, D)`` → rotation vectors ``(T, 3)`` at the model rate; with
        ``post``, the post-processing chain without pauses (there is no audio)."""
        y = self._network_values(feats)
        if post:
            return self._post(seed).push(np.asarray(y, dtype=np.float64), None)
        return np.asarray(self.motion_norm_.inverse_transform(y), dtype=np.float64)

    def predict_features(self, features: FeatureTrack, *, seed: int | None = None) -> Motion:
        """Head motion from an already extracted feature track at the model frame rate
        (the post-processing chain as in :meth:`predict`; no pauses: there is no audio).

        Raises ParameterError when the track's dimension or frame rate is not what the model was
        trained on (e.g. FBank features given to an MFCC model)."""
        self._check_fitted()
        values = np.asarray(features.values if isinstance(features, FeatureTrack) else features, dtype=np.float32)
        self._check_features(values, "the given feature track")
        fps = float(getattr(features, "fps", self.model_fps))
        if abs(fps - float(self.model_fps)) > 1e-6:
            raise ParameterError(
                f"this {self.name} model works at {float(self.model_fps):g} frames/s; the feature track is at {fps:g}")
        self._validate_params()
        with inference.threads(self.n_threads):
            rv = self._predict_values(values, seed=resolve_seed(self, seed))
        return Motion(rv, float(self.model_fps), meta={"system": self.name})

    def _predict(self, audio: Audio, *, seed: int) -> Motion:
        """Head motion for ``audio`` at the model rate (:func:`headmotion.align.n_frames` frames);
        ``seed`` drives the posture drift."""
        mfps = float(self.model_fps)
        T = _n_frames(len(audio.samples), audio.sample_rate, mfps)
        feats = self._extract(audio, T)
        with inference.threads(self.n_threads):
            y = self._network_values(feats)
        post = self._post(seed)
        energy = None
        if post.needs_energy:
            x = audio.samples
            if audio.sample_rate != int(self.sample_rate_):
                from ...io.audio import resample

                x = resample(x, audio.sample_rate, int(self.sample_rate_))
            energy = frame_energy_db(x, sample_rate=int(self.sample_rate_), fps=mfps, n_frames=T)
        rv = post.push(np.asarray(y, dtype=np.float64), energy)
        return Motion(rv, mfps, meta={"system": self.name})

    def _stream(self, *, seed: int):
        """The stream of :mod:`.streaming` (lookahead ``latency_ms``)."""
        from .streaming import DnnStream

        return DnnStream(self, seed=seed)

    def embed(self, audio: Audio, *, fps: float | None = None, n_frames: int | None = None) -> FeatureTrack:
        """The learned waveform embedding (Wav_CCCAE / Wav_AE, paper Table 1) of ``audio``.

        Parameters
        ----------
        audio : Audio
        fps : float, optional — frame rate of the result (default: the model rate, 100 fps);
            other rates are linearly interpolated.
        n_frames : int, optional — force the number of frames (edge-pad / trim).

        Returns
        -------
        FeatureTrack [shape=(T, embedding_dim)] with names ``e00 …``.
        """
        self._check_fitted()
        if self.autoencoder_ is None:
            raise ParameterError(f"system {self.name!r} has no learned embedding; use cccae or ae-dnn")
        from ...align import resample_track

        mfps = float(self.model_fps)
        T = _n_frames(len(audio.samples), audio.sample_rate, mfps)
        feats = self._extract(audio, T)
        self._check_features(feats, "the feature track")
        with inference.threads(self.n_threads):
            z = inference.encode(self.autoencoder_, np.asarray(self.feature_norm_.transform(feats), dtype=np.float32))
        names = tuple(f"e{i:02d}" for i in range(z.shape[1]))
        track = FeatureTrack(z, mfps, names)
        if fps is not None and abs(float(fps) - mfps) > 1e-9:
            n = n_frames if n_frames is not None else _n_frames(len(audio.samples), audio.sample_rate, float(fps))
            return resample_track(track, float(fps), n)
        if n_frames is not None:
            return FeatureTrack(_fit_length(z, int(n_frames)), mfps, names)
        return track

    # -- persistence --------------------------------------------------------------------------------
    def _legacy_mean_pose(self) -> np.ndarray:
        return rotvec_to_pitch_yaw_roll(np.asarray(self.motion_norm_.mean_, dtype=np.float64)[None])[0]

    def _get_state(self):
        return persistence.get_state(self)

    def _set_state(self, config, arrays):
        persistence.set_state(self, config, arrays)


__all__ = ["DnnSystem"]
