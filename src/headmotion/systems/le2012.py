"""The Le et al. (2012) baseline, "le2012" (thesis §2.3 eq 2.19–2.21; §5.5.1 eq 5.15).

Head rotation as Euler angles (pitch, yaw, roll; intrinsic yaw → pitch → roll, see
:mod:`headmotion.rotations`); speech features pitch and loudness (the ``prosody-live`` feature
set).  Five 10-component GMMs, trained by EM (scikit-learn):

* one per angle κ over ``(κ_t, p_t, l_t)``;
* one over the angular-velocity norm ``v_t = ‖θ_t − θ_{t−1}‖`` (eq 2.19) with ``(p_t, l_t)``;
* one over the angular-acceleration norm ``a_t = ‖θ_t − 2θ_{t−1} + θ_{t−2}‖`` (eq 2.20) with
  ``(p_t, l_t)``.

Synthesis is causal: for every frame, ``θ_t`` maximises the product of eq 2.21 given the two
previously synthesised frames, by gradient ascent (analytic gradients of the GMM log densities;
started from a constant-velocity prediction).  The "fair" variant (``joint=True``, eq 5.15)
replaces the five GMMs by one over ``(pitch, yaw, roll, v, a, p, l)``.

Additions that are in neither Le et al. (2012) nor the thesis, each a parameter whose "off" value
gives the literal system (``pull_tau_s=None, start_sd=0, idle=None, post_restore=False``;
``docs/decisions/le2012-additions.md``):

* ``pull_tau_s`` (2 s): a leaky pull towards the training mean pose inside the ascent — every frame
  starts from ``p1 + (p1 - p2) - (p1 - mean) / (pull_tau_s · fps)``; without it the ascent has
  momentum and nothing that brings the head back;
* ``start_sd`` (0.5): seeded Gaussian noise of ``start_sd`` × the training motion's mean per-frame
  speed on every frame's starting point (``numpy.random.default_rng(seed)``), so different seeds
  end in different local maxima;
* then the post-processing chain of :mod:`headmotion.motion.post` in
  :data:`~headmotion.motion.post.chain.LE2012_ORDER`: pause settling at ``idle`` (causal speech
  flags from :mod:`headmotion.features.speech_activity` on the loudness, or
  :func:`headmotion.features.vad.speaking_mask` for the whole-clip ``prosody`` set of older model
  files), the rotation, and with ``post_restore`` per-band variance restoration about the running
  mean (gains at most :data:`POST_BAND_CAP`) and the speed shaper (map corrected in closed loop);
* ``idle="auto"``: the idle level measured at training — the grid value (:data:`IDLE_GRID`) whose
  synthesis of the training speech has the pooled pause/speech speed ratio nearest the training
  heads' (:data:`IDLE_FALLBACK` when the speech has no pause);
* ``cross_fit``: the post stages and ``idle="auto"`` fitted on the synthesis of each training
  recording by a model trained on the other half of the speakers
  (:func:`headmotion.systems.base.cross_fitted`; ``docs/decisions/cross-fitting.md``).

Training on a corpus longer than ``max_train_hours`` (4 h) uses a seeded, speaker-balanced
subsample of whole recordings (:mod:`headmotion.systems.budget`), before the EM frame sample.

Streaming: with ``prosody-live`` (YIN pitch + cIntensity loudness, computed by the same code
offline and on a stream) the ascent, the seeded noise (drawn frame by frame from one generator) and
the post-processing chain are causal, so :meth:`Le2012.stream` gives offline ``predict``'s frames
with the features' latency alone (24.2 ms).  Model files with the whole-clip ``prosody`` set
predict as before but cannot stream.

Library considered: scikit-learn's GaussianMixture (fitting); the per-frame optimiser is
hand-written (a compiled numba kernel, :mod:`._le2012_kernel`) because calling scipy.optimize per
frame is ~100× slower.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..errors import ParameterError
from ..features import ANALYSIS_RATE
from ..features import feature_config as make_feature_config
from ..features.live import LIVE_SETS as LIVE_FEATURES
from ..models.gmm import GMMRegression
from ..motion.control import mean_pose_of
from ..rotations import rotvec_to_pitch_yaw_roll
from ..types import Audio, Motion
from .base import CAUSAL, Synthesizer, cross_fitted, pair_shortest
from .budget import DEFAULT_TRAIN_HOURS, check_hours, corpus_summary
from .constraints import BOOLEAN, Options, check_params, real, whole


_LOG2PI = float(np.log(2.0 * np.pi))
#: largest per-band gain of ``post_restore`` (the held-out SD deficit is 2–2.5×; the DNN's cap is 8)
POST_BAND_CAP = 3.0
#: the idle levels ``idle="auto"`` chooses from, and the level kept when the training speech has no pause
IDLE_GRID = np.round(np.linspace(0.0, 1.0, 21), 2)
IDLE_FALLBACK = 0.6


def _fit_gmm(Z: np.ndarray, n_dims_z: int, n_components: int, random_state) -> GMMRegression:
    """EM on standardised rows ``Z = [z, f]`` (scikit-learn), as a :class:`GMMRegression` of ``z``
    (motion, first ``n_dims_z`` columns) given ``f`` (speech)."""
    from sklearn.mixture import GaussianMixture

    k = int(max(1, min(n_components, len(Z) // 20)))
    g = GaussianMixture(k, covariance_type="full", reg_covar=1e-3, random_state=random_state,
                        max_iter=50, tol=1e-3).fit(Z)
    return _as_regression(g.weights_, g.means_, g.covariances_, n_dims_z)


def _as_regression(w, mu, cov, n_dims_z: int) -> GMMRegression:
    """A joint GMM stored ``[z, f]``-first (the model file's layout) as a regression of z on f."""
    mu, cov = np.asarray(mu, float), np.asarray(cov, float)
    D = mu.shape[1]
    perm = list(range(n_dims_z, D)) + list(range(n_dims_z))
    return GMMRegression.from_params(w, mu[:, perm], cov[:, perm][:, :, perm], dim_x=D - n_dims_z)


def _joint_arrays(g: GMMRegression) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(weights, means, covariances)`` back in the ``[z, f]`` layout."""
    D, dz = g.means_.shape[1], g.dim_y_
    perm = list(range(D - dz, D)) + list(range(D - dz))
    return g.weights_, g.means_[:, perm], g.covariances_[:, perm][:, :, perm]


class Le2012(Synthesizer):
    """Le et al. (2012) frame-wise GMM synthesis.

    Parameters
    ----------
    features : str, default "prosody-live" (pitch + loudness computed frame by frame, streamable;
        "prosody" is the whole-clip openSMILE-like set of older model files)
    fps : float or None
    n_components : int, components per GMM (10)
    joint : bool, the "fair" joint variant of eq 5.15
    n_steps : int, gradient-ascent steps per frame
    step : float, step size (in standardised units)
    max_train_frames : int, frames sampled for EM (speed)
    random_state : int, training seed (EM, frame sampling)
    seed : int, default synthesis seed (the synthesis is deterministic; kept for the contract)
    compiled : bool, run the per-frame ascent as a compiled numba kernel (same arithmetic as the
        numpy reference loop, ~100× faster); False uses the numpy loop
    pull_tau_s : float or None, time constant (s) of the pull towards the training mean pose
        (None or 0: none, as in the paper)
    start_sd : float >= 0, seeded noise on each frame's starting point, in units of the training
        motion's mean per-frame speed (0: deterministic, as in the paper)
    idle : "auto", float in [0, 1] or None, speed in pauses as a fraction of the motion's own
        ("auto": measured on the training data, ``idle_``; None: no pause handling, as in the paper)
    post_restore : bool, restore the training heads' band variances and speed distribution after
        synthesis (module docstring; False: as in the paper)
    cross_fit : bool, fit the post stages and ``idle="auto"`` on synthesis of training speech by
        a model trained on the other half of the recordings (module docstring; False: on this
        model's synthesis of its own training speech)
    max_train_hours : float or None, on a longer corpus train on a seeded subsample of its
        recordings of this much speech (4; None: every recording; :mod:`headmotion.systems.budget`)
    """

    name = "le2012"

    capabilities = frozenset({CAUSAL})

    def __init__(self, features="prosody-live", *, fps: float | None = None, n_components: int = 10,
                 joint: bool = False, n_steps: int = 12, step: float = 0.05,
                 max_train_frames: int = 10000, random_state: int = 0, seed: int | None = 0,
                 compiled: bool = True, pull_tau_s: float | None = 2.0, start_sd: float = 0.5,
                 idle: float | str | None = "auto", post_restore: bool = True, cross_fit: bool = True,
                 max_train_hours: float | None = DEFAULT_TRAIN_HOURS):
        self._store_params(locals())

    #: what each parameter may be (:mod:`.constraints`; ``max_train_hours``: :func:`.budget.check_hours`)
    _parameter_constraints: ClassVar[dict] = {
        **{k: [whole(1)] for k in ("n_components", "n_steps", "max_train_frames")},
        "step": [real(0, closed="neither")], "pull_tau_s": [real(0), None], "start_sd": [real(0)],
        "idle": [Options(("auto",)), None, real(0, 1)],
        "cross_fit": [BOOLEAN], "post_restore": [BOOLEAN], "fps": [real(0, closed="neither"), None],
    }

    def _validate_params(self) -> None:
        check_hours(self)
        check_params(self, self._parameter_constraints)

    def _config(self):
        return make_feature_config(self.features, self.fps_)

    def fit(self, corpus, *, progress=None):
        from ..features import Normalizer
        from ..feature_cache import features_for

        recs = self._training_recordings(corpus, budget=True)
        self.fps_ = float(self.fps) if self.fps else float(recs[0].motion.fps)
        cfg = self._config()
        self._set_capabilities(cfg)
        # a live feature set analyses 16 kHz: that is the rate the stream's push expects
        self.sample_rate_ = ANALYSIS_RATE if cfg.name in LIVE_FEATURES else int(recs[0].audio.sample_rate)
        ang, feats, rvs = [], [], []
        for i, r in enumerate(recs):
            m = r.motion.resample(self.fps_)
            if len(m) < 3:
                continue
            ang.append(rotvec_to_pitch_yaw_roll(m.rotvec))
            rvs.append(m.rotvec)
            feats.append(np.asarray(features_for(r, cfg, len(m)).values, dtype=np.float64))
            if progress:
                progress(i + 1, len(recs) + 1, f"features {r.id}")
        if not ang:
            raise ParameterError("le2012 needs recordings of at least 3 frames")
        self.normalizer_ = Normalizer().fit(feats)
        rows = []
        for A, F in zip(ang, feats):
            F = np.asarray(self.normalizer_.transform(F), dtype=np.float64)
            v = np.r_[0.0, np.linalg.norm(np.diff(A, axis=0), axis=1)]
            acc = np.r_[0.0, 0.0, np.linalg.norm(A[2:] - 2 * A[1:-1] + A[:-2], axis=1)]
            rows.append(np.hstack([A, v[:, None], acc[:, None], F])[2:])
        Z = np.vstack(rows)
        self.n_features_ = Z.shape[1] - 5
        rng = np.random.default_rng(self.random_state)
        if len(Z) > self.max_train_frames:
            Z = Z[rng.choice(len(Z), self.max_train_frames, replace=False)]
        self.z_mu_ = Z.mean(axis=0)
        self.z_sd_ = np.maximum(Z.std(axis=0), 1e-6)
        Zs = (Z - self.z_mu_) / self.z_sd_
        Fi = list(range(5, Z.shape[1]))
        if self.joint:
            self.gmms_ = {"joint": _fit_gmm(Zs, 5, self.n_components, self.random_state)}
        else:
            self.gmms_ = {f"angle{k}": _fit_gmm(Zs[:, [k] + Fi], 1, self.n_components, self.random_state)
                          for k in range(3)}
            self.gmms_["vel"] = _fit_gmm(Zs[:, [3] + Fi], 1, self.n_components, self.random_state)
            self.gmms_["acc"] = _fit_gmm(Zs[:, [4] + Fi], 1, self.n_components, self.random_state)
        allA = np.vstack(ang)
        self.start_ = allA.mean(axis=0)
        self.lo_, self.hi_ = allA.min(axis=0), allA.max(axis=0)
        self.mean_pose_ = mean_pose_of(rvs)
        self.corpus_summary_ = corpus_summary(self, corpus)
        self.post_bank_ = self.speed_map_ = None
        self.idle_ = IDLE_FALLBACK if self.idle == "auto" else None
        self.fitted_ = True
        if self.post_restore or self.idle == "auto":
            kept = [r for r in recs if len(r.motion) >= 3]
            raws = self._calibration_synthesis(kept, getattr(corpus, "sample_rate", None))
            if self.post_restore:
                self._fit_post_stages(raws, rvs)
            if self.idle == "auto":
                from ..features.vad import speaking_mask

                masks = [speaking_mask(r.audio, fps=self.fps_, n_frames=len(m)) for r, m in zip(kept, rvs)]
                for _ in range(2 if self.post_restore else 1):   # the stages refitted with each level
                    self.idle_ = self._calibrate_idle(masks, raws, rvs)
                    if self.post_restore:
                        self._fit_post_stages(raws, rvs)
        return self

    def _calibration_synthesis(self, recs, sample_rate) -> list:
        """The ascent (:meth:`_raw_synthesis`) of each training recording's speech that the post
        stages and ``idle="auto"`` are fitted on (recording k with seed k).  With ``cross_fit`` and
        at least two recordings it is made by a model of the same parameters trained on the other
        half of the recordings — speech the GMMs have not seen, as at synthesis (module
        docstring); otherwise by this model."""
        flags = self._settle()
        if not self.cross_fit or len(recs) < 2:
            return [self._raw_synthesis(r.audio, seed=k, flags=flags) for k, r in enumerate(recs)]
        return cross_fitted(self, recs, {"post_restore": False, "idle": None, "cross_fit": False},
                            lambda half, r, k: half._raw_synthesis(r.audio, seed=k, flags=flags),
                            sample_rate=sample_rate)

    def _calibrate_idle(self, masks, raws, motions) -> float:
        """``idle="auto"``: the grid value whose synthesis of the training speech (the ascent
        ``raws``, settled, through the current post stages) has the pooled pause/speech speed ratio
        nearest the training heads' ``motions``, both measured with the speech ``masks`` of the
        evaluation's VAD (module docstring)."""
        import warnings

        from ..motion.pauses import pause_speech_speeds, pooled_pause_ratio

        target = pooled_pause_ratio(pause_speech_speeds(m, k, fps=self.fps_) for m, k in zip(motions, masks))
        if not np.isfinite(target):
            warnings.warn(f"le2012: no pause of at least 0.5 s in the training speech; idle kept at {IDLE_FALLBACK}",
                          UserWarning, stacklevel=3)
            return IDLE_FALLBACK
        best, err = IDLE_FALLBACK, np.inf
        for idle in IDLE_GRID:
            got = pooled_pause_ratio(pause_speech_speeds(self._finish(*raw, idle=float(idle)),
                                                         k, fps=self.fps_) for raw, k in zip(raws, masks))
            if np.isfinite(got) and abs(got - target) < err:
                best, err = float(idle), abs(got - target)
        return best

    def _fit_post_stages(self, raws, motions) -> None:
        """``post_restore``'s tables from this system's synthesis of the training speech (the
        ascent ``raws`` of recording k with seed k, settled at the current idle, without the
        stages) against the training heads ``motions`` (rotation vectors at ``fps_``): the band
        gains, then the speed map on that synthesis passed through the band stage as synthesis
        will pass it."""
        from ..motion.post import speed_shaping
        from ..motion.post.restore import CausalPost, band_gains

        pred, targ = pair_shortest((self._finish(*raw, idle=self._idle_value(), post=False) for raw in raws), motions)
        self.post_bank_ = band_gains(pred, targ, fps=self.fps_, cap=POST_BAND_CAP)
        pred = [CausalPost(band_gains=self.post_bank_, fps=self.fps_).push(x) for x in pred]
        self.speed_map_ = speed_shaping.delivered_speed_map(pred, targ, fps=self.fps_,
                                                            lag=speed_shaping.shaping_lag(self.fps_),
                                                            max_gain=speed_shaping.SPEED_MAX_GAIN)

    def _post_chain(self, idle: float | None, pose, *, post: bool = True):
        """The post-processing chain with fresh state (:data:`~headmotion.motion.post.chain.
        LE2012_ORDER`): settling at ``idle`` (None or 1: none) towards ``pose``, the rotation, and
        with ``post`` (and ``post_restore`` and the tables) the band gains and the speed shaper."""
        from ..motion.post import LE2012_ORDER, PostChain, PostTables

        tables = post and self.post_restore and getattr(self, "post_bank_", None) is not None
        return PostChain(PostTables(fps=self.fps_, order=LE2012_ORDER, idle=idle, pause_pose=pose,
                                    band_gains=self.post_bank_ if tables else None,
                                    speed_map=self.speed_map_ if tables else None))

    # -- synthesis ----------------------------------------------------------------------------
    def _conditionals(self, Fs: np.ndarray):
        """Condition every GMM on the speech features of every frame (vectorised over T and the
        components; eq 2.5–2.8 as :meth:`GMMRegression.condition`, whose per-component loop costs
        ~3 ms per call — too much for a 10 ms stream chunk).  The numpy form, read by the reference
        ascent (``compiled=False``); compiled models condition with
        :func:`._le2012_kernel.conditionals` on the same arrays (:meth:`_kernel_model`), the same
        products summed in the same order (~2 µs per frame instead of ~80).

        Returns per GMM: log weights (T, M) = ``log p(f_t, m) - 0.5 log |C_m|`` (so that
        ``logw - 0.5 (z - cm)' P (z - cm)`` is the log density up to a constant), conditional means
        (T, M, Dz) and conditional precisions P (M, Dz, Dz)."""
        X = np.asarray(Fs, dtype=np.float64)
        out = {}
        for key, (c0, mx, Px, A, my, P) in self._prepared().items():
            d = X[:, None, :] - mx[None]                                  # (T, M, dx)
            y = np.einsum("nmi,mij->nmj", d, Px)
            lw = c0[None] - 0.5 * (X.shape[1] * _LOG2PI + np.einsum("nmj,nmj->nm", y, y))
            out[key] = (lw, my[None] + np.einsum("myx,nmx->nmy", A, d), P)
        return out

    def _prepared(self) -> dict:
        """Per GMM, what conditioning on a frame needs, computed once per model: ``(c0, mx, Px, A,
        my, P)`` — the log weight with the feature density's normaliser and ``-0.5 log |C_m|``, the
        feature means, the Cholesky factor of the feature precision, the regression matrix, the
        motion means and the conditional precision."""
        cache = getattr(self, "_cond_prep", None)
        if cache is None or cache[0] is not self.gmms_:
            prep = {}
            for key, g in self.gmms_.items():
                log_det = 2.0 * np.log(np.diagonal(g._chol_c, axis1=1, axis2=2)).sum(axis=1)
                prep[key] = (g._log_w + g._ldx - 0.5 * log_det, g._mx, g._Px, g._A, g._my, np.linalg.inv(g._cov_c))
            cache = self._cond_prep = (self.gmms_, prep)
        return cache[1]

    def _kernel_model(self):
        """The compiled kernels' model arrays, stacked over the GMMs and made contiguous once per
        model: ``(c0 (G, M), mx (G, M, dx), Px (G, M, dx, dx), A (G, M, dz, dx), my (G, M, dz),
        P, mu, sd, lo, hi)`` with ``P`` the joint GMM's conditional precisions (M, 5, 5) or the five
        univariate ones (5, M), ``mu``/``sd`` the standardisation and ``lo``/``hi`` the clip of the
        ascent; None when the GMMs have different numbers of components (then numpy conditions)."""
        cache = getattr(self, "_kernel_prep", None)
        if cache is None or cache[0] is not self.gmms_:
            prep = self._prepared()
            keys = ["joint"] if self.joint else ["angle0", "angle1", "angle2", "vel", "acc"]
            arrays = None
            if len({prep[k][0].shape for k in keys}) == 1:
                c = np.ascontiguousarray
                stack = [c(np.stack([prep[k][i] for k in keys]), dtype=np.float64) for i in range(5)]
                P = (prep["joint"][5] if self.joint else np.stack([prep[k][5][:, 0, 0] for k in keys], axis=0))
                span = self.hi_ - self.lo_
                arrays = (*stack, c(P, dtype=np.float64), c(self.z_mu_, dtype=np.float64),
                          c(self.z_sd_, dtype=np.float64), c(self.lo_ - 0.1 * span, dtype=np.float64),
                          c(self.hi_ + 0.1 * span, dtype=np.float64))
            cache = self._kernel_prep = (self.gmms_, arrays)
        return cache[1]

    def _start_terms(self, T: int, seed: int | None):
        """``(pull, pose, jitter)`` of each frame's starting point (see the module docstring)."""
        tau = self.pull_tau_s
        pull = 1.0 / (float(tau) * self.fps_) if tau else 0.0
        jitter = np.zeros((T, 3))
        if self.start_sd:
            rng = np.random.default_rng(None if seed is None else int(seed))
            jitter = float(self.start_sd) * float(self.z_mu_[3]) * rng.standard_normal((T, 3))
        return pull, np.asarray(self.start_, dtype=np.float64), jitter

    def _set_capabilities(self, cfg) -> None:
        """Streamable only with a live feature set (an instance attribute overrides the class's)."""
        self.capabilities = frozenset({CAUSAL}) if cfg.name in LIVE_FEATURES else frozenset()

    def _idle_value(self) -> float | None:
        """The idle level in use: ``idle``, or with ``"auto"`` the one measured at training."""
        if self.idle == "auto":
            return getattr(self, "idle_", None)
        return None if self.idle is None else float(self.idle)

    def _settle(self) -> bool:
        v = self._idle_value()
        return v is not None and v < 1.0

    def _loudness_db(self, F_raw: np.ndarray) -> np.ndarray:
        """The raw ``loudness`` column ``(I / 1e-6) ** exponent`` back to the intensity in dB."""
        cfg = self._config()
        ex = float(dict(cfg.params).get("exponent", 0.3))
        loud = np.maximum(np.asarray(F_raw, dtype=np.float64)[:, 1], 1e-30)
        return np.maximum(10.0 / ex * np.log10(loud) - 60.0, -100.0)

    def _speech_tracker(self):
        from ..features.speech_activity import SpeechDetector

        return SpeechDetector(col=0, mu=0.0, sd=1.0, db_per_unit=1.0, fps=float(self.fps_)).start()

    def _cond_rows(self, F_raw: np.ndarray, pad: int = 0):
        """Per-frame conditional mixtures of raw (float32-cast) feature rows, stacked for the
        kernels: ``("joint", lw, cm, P)`` or ``("independent", LW, CM, PR)``, each per-frame array
        with ``pad`` leading rows of zeros (a stream's two history frames).  Compiled: conditioned
        by :func:`._le2012_kernel.conditionals` (``cond`` is None); otherwise with numpy, ``cond``
        the per-GMM dict the reference ascent reads."""
        F = np.asarray(self.normalizer_.transform(np.asarray(F_raw, dtype=np.float64)), dtype=np.float64)
        Fs = (F - self.z_mu_[5:]) / self.z_sd_[5:]
        km = self._kernel_model() if self.compiled else None
        if km is not None:
            from ._le2012_kernel import conditionals

            c0, mx, Px, A, my, P = km[:6]
            T, (G, M), dz = len(Fs), c0.shape, my.shape[2]
            LW, CM = np.zeros((T + pad, G, M)), np.zeros((T + pad, G, M, dz))
            conditionals(np.ascontiguousarray(Fs), c0, mx, Px, A, my, Fs.shape[1] * _LOG2PI, LW, CM, pad)
            if self.joint:
                return None, ("joint", LW.reshape(T + pad, M), CM.reshape(T + pad, M, dz), P)
            return None, ("independent", LW, CM.reshape(T + pad, G, M), P)

        def padded(a):
            z = np.zeros((len(a) + pad,) + a.shape[1:])
            z[pad:] = a
            return z

        cond = self._conditionals(Fs)
        if pad:
            cond = {key: (padded(v[0]), padded(v[1]), v[2]) for key, v in cond.items()}
        if self.joint:
            lw, cm, P = cond["joint"]
            return cond, ("joint", np.ascontiguousarray(lw), np.ascontiguousarray(cm), np.ascontiguousarray(P))
        keys = ["angle0", "angle1", "angle2", "vel", "acc"]
        LW = np.ascontiguousarray(np.stack([cond[k][0] for k in keys], axis=1))
        CM = np.ascontiguousarray(np.stack([cond[k][1][..., 0] for k in keys], axis=1))
        PR = np.ascontiguousarray(np.stack([cond[k][2][:, 0, 0] for k in keys], axis=0))
        return cond, ("independent", LW, CM, PR)

    def _ascend(self, out, cond, stacked, pull, pose, jitter) -> None:
        """Fill ``out[2:]`` given ``out[0:2]`` (the ascent, compiled or the numpy reference)."""
        if self.compiled:
            from ._le2012_kernel import ascent_independent, ascent_joint

            km = self._kernel_model()
            if km is not None:
                mu, sd, lo, hi = km[6:]
            else:
                span = self.hi_ - self.lo_
                c = np.ascontiguousarray
                mu, sd = c(self.z_mu_, dtype=np.float64), c(self.z_sd_, dtype=np.float64)
                lo, hi = c(self.lo_ - 0.1 * span, dtype=np.float64), c(self.hi_ + 0.1 * span, dtype=np.float64)
            args = (mu, sd, lo, hi, float(self.step), int(self.n_steps), float(pull),
                    np.ascontiguousarray(pose, dtype=np.float64), np.ascontiguousarray(jitter, dtype=np.float64))
            (ascent_joint if stacked[0] == "joint" else ascent_independent)(out, *stacked[1:], *args)
        else:
            mu, sd = self.z_mu_, self.z_sd_
            span = self.hi_ - self.lo_
            lo, hi = self.lo_ - 0.1 * span, self.hi_ + 0.1 * span
            from ._le2012_reference import ascent_reference

            ascent_reference(out, cond, mu, sd, lo, hi, joint=self.joint, n_steps=self.n_steps, step=self.step,
                             pull=pull, pose=pose, jitter=jitter if self.start_sd else None)

    def _predict(self, audio: Audio, *, seed: int) -> Motion:
        """Causal frame-by-frame maximisation of eq 2.21 (or eq 5.15 with ``joint``); see the
        module docstring for the pull, the seeded start and pauses."""
        from ..align import n_frames as _n

        T = _n(len(audio.samples), audio.sample_rate, self.fps_)
        if T == 0:
            return Motion(np.zeros((0, 3)), self.fps_)
        rv = self._finish(*self._raw_synthesis(audio, seed, flags=self._settle()), idle=self._idle_value())
        return Motion(rv, self.fps_, meta={"system": self.name})

    def _raw_synthesis(self, audio: Audio, seed: int | None, *, flags: bool):
        """``(angles, speech flags, mean pose)``: the ascent's pitch, yaw, roll before the pauses and
        the post stages, and (with ``flags``; else None) the speech flags the settling reads."""
        from ..align import n_frames as _n

        T = _n(len(audio.samples), audio.sample_rate, self.fps_)
        cfg = self._config()
        F_raw = np.asarray(cfg.extract(audio, n_frames=T).values, dtype=np.float64)
        cond, stacked = self._cond_rows(F_raw)
        out = np.empty((T, 3))
        out[0] = out[min(1, T - 1)] = self.start_
        pull, pose, jitter = self._start_terms(T, seed)
        self._ascend(out, cond, stacked, pull, pose, jitter)
        if not flags:
            mask = None
        elif cfg.name in LIVE_FEATURES:
            mask = self._speech_tracker().push_db(self._loudness_db(F_raw))
        else:
            from ..features.vad import speaking_mask

            mask = np.asarray(speaking_mask(audio, fps=self.fps_, n_frames=T), dtype=bool)
        return out, mask, pose

    def _finish(self, out, mask, pose, *, idle: float | None, post: bool = True) -> np.ndarray:
        """Rotation vectors from the ascent's angles through the post-processing chain
        (:meth:`_post_chain`): settled in pauses at ``idle``, with ``post`` the post stages."""
        return self._post_chain(idle, pose, post=post).push(out, mask)

    def stream_seeded(self, seed: int):
        """:meth:`Synthesizer.stream_seeded`, with the reason when this model's features cannot stream."""
        if getattr(self, "fitted_", False) and self._config().name not in LIVE_FEATURES:
            self._stream(seed=seed)  # raises with the reason
        return super().stream_seeded(seed)

    def _stream(self, *, seed: int):
        cfg = self._config()
        if cfg.name not in LIVE_FEATURES:
            raise ParameterError(f"this le2012 model was trained with the whole-clip {cfg.name!r} features and "
                                 "cannot stream; retrain it with features='prosody-live'")
        from .le2012_stream import Le2012Stream

        return Le2012Stream(self, seed=seed)

    # -- persistence --------------------------------------------------------------------------
    def _legacy_mean_pose(self) -> np.ndarray:
        return np.asarray(self.start_, dtype=np.float64)

    def reachable_range(self) -> np.ndarray:
        """The clip of the ascent: the training range widened by 10 % on each side (``(3, 2)``,
        pitch, yaw, roll in radians)."""
        self._check_fitted()
        span = self.hi_ - self.lo_
        return np.stack([self.lo_ - 0.1 * span, self.hi_ + 0.1 * span], axis=1)

    def _get_state(self):
        arrays = {"z_mu": self.z_mu_, "z_sd": self.z_sd_, "start": self.start_, "lo": self.lo_, "hi": self.hi_}
        for k, g in self.gmms_.items():
            w, mu, cov = _joint_arrays(g)
            arrays.update({f"{k}_w": w, f"{k}_mu": mu, f"{k}_cov": cov})
        arrays.update(self.normalizer_.to_arrays("norm_"))
        if getattr(self, "post_bank_", None) is not None:
            arrays.update(post_bank=np.asarray(self.post_bank_, np.float64), speed_map=np.asarray(self.speed_map_, np.float64))
        return {"params": self.get_params(), "fps": self.fps_, "sample_rate": self.sample_rate_,
                "idle_value": getattr(self, "idle_", None),
                "gmms": sorted(self.gmms_), "features": make_feature_config(self.features, self.fps_).to_dict()}, arrays

    def _set_state(self, config, arrays):
        from ..features import Normalizer

        params = dict(config["params"])
        if "pull_tau_s" not in params:  # files written before these options: the paper's system
            params.update(pull_tau_s=None, start_sd=0.0, idle=None)
        params.setdefault("post_restore", False)  # older files: no post tables
        params.setdefault("cross_fit", False)     # older files: fitted on their own synthesis
        self.__init__(**params)
        self.fps_ = float(config["fps"])
        self.sample_rate_ = int(config["sample_rate"])
        self.z_mu_, self.z_sd_ = arrays["z_mu"], arrays["z_sd"]
        self.start_, self.lo_, self.hi_ = arrays["start"], arrays["lo"], arrays["hi"]
        self.gmms_ = {k: _as_regression(arrays[f"{k}_w"], arrays[f"{k}_mu"], arrays[f"{k}_cov"], 5 if k == "joint" else 1)
                      for k in config["gmms"]}
        self.normalizer_ = Normalizer.from_arrays(arrays, "norm_")
        self.post_bank_ = np.asarray(arrays["post_bank"], np.float64) if "post_bank" in arrays else None
        self.speed_map_ = np.asarray(arrays["speed_map"], np.float64) if "speed_map" in arrays else None
        self.idle_ = config.get("idle_value")
        self._set_capabilities(self._config())


__all__ = ["Le2012"]
