"""What the two template-warping systems share (thesis §5.4–5.8): training-vector extraction
from segmented motion, the causal generator that warps templates at each change point, blocked
feature extraction for streaming, and the safety limits learned from the training data.

Vectors at a change point (frame ``t`` where axis ``j`` starts a new segment ``k``):

* ``y``        — the new segment's warping parameters ``(d, a)``: duration in seconds, amplitude
  ``a = |s|`` in radians (the template, rising or falling, alternates and is not predicted);
* ``prev``     — the previous segment of this axis ``(d, a)`` and the offset ``c`` (the current
  position; part of the warping parameters ``λ = (d, a, c)``; it lets the model learn how the head
  returns towards its rest pose);
* ``others``   — the current segments' ``(d, a)`` of the two other axes at time ``t``;
* speech       — the feature frame at the change (``F[t]``), the 10 frames before it
  (``F[t-9 … t]``, §5.7.2), and the frames of the previous segment (HMM observations, §5.7.4).

The generator (thesis §5.8) starts every axis from the training means, then repeatedly takes the
axis whose current segment ends first, builds its input vector from what has been generated so
far and the speech up to that frame, asks the system for ``(d, a)``, and appends the warped
template.  It is causal: frames before the earliest pending change point are final, which is what
:class:`TwsStream` emits.

Safety limits (so generated motion never jumps and stays in a head's range): durations are clipped
to ``[min segment, 99.5th percentile of training]``; amplitudes to the training maximum, to the
fastest per-frame change seen in (smoothed) training data (a half-cosine of amplitude ``a`` over
``n`` frames changes by at most ``pi a / (2 n)`` per frame), and so that the segment's end stays
within the training range widened by 10 % on each side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..align import n_frames as _n_frames
from ..errors import ParameterError
from ..motion.segmentation import min_segment_frames, segment_axis, smooth
from ..types import Audio, FeatureTrack, Motion

CONTEXT = 10  # speech frames before the change (thesis §5.7.2)
MAX_HMM_FRAMES = 60  # previous-segment frames scored by the HMMs (the most recent ones)


# ---------------------------------------------------------------------------------------------
# features
# ---------------------------------------------------------------------------------------------
def make_feature_config(features, fps: float):
    from ..features import FeatureConfig

    if isinstance(features, FeatureConfig):
        return features
    if isinstance(features, dict):
        return FeatureConfig.from_dict(features)
    return FeatureConfig(str(features), fps=float(fps))


def extract_blocked(audio: Audio, config, n_frames: int, *, block: int, context: int,
                    start_block: int = 0, stop_frame: int | None = None) -> np.ndarray:
    """Features ``(T, D)`` computed block by block (``block`` frames, ``context`` frames of audio on
    each side), so streamed and offline synthesis see identical features.

    Frames ``[start_block*block, stop_frame)`` are returned; ``n_frames`` is the total length."""
    fps = float(config.fps)
    sr = audio.sample_rate
    stop = n_frames if stop_frame is None else stop_frame
    out = []
    b = start_block
    while b * block < stop:
        f0 = b * block
        f1 = min(f0 + block, n_frames)
        a0 = max(0, f0 - context)
        a1 = min(n_frames, f1 + context)
        s0 = int(round(a0 * sr / fps))
        s1 = min(len(audio.samples), int(round(a1 * sr / fps)))
        seg = Audio(audio.samples[s0:s1], sr)
        tr = config.extract(seg, n_frames=a1 - a0)
        out.append(np.asarray(tr.values, dtype=np.float64)[f0 - a0:f1 - a0])
        b += 1
    if not out:
        return np.zeros((0, 0))
    return np.vstack(out)[: stop - start_block * block]


# ---------------------------------------------------------------------------------------------
# training vectors
# ---------------------------------------------------------------------------------------------
@dataclass
class AxisData:
    """Training vectors of one axis, one row per change point (segments after the first)."""

    y: list = field(default_factory=list)        # (d, a)
    prev: list = field(default_factory=list)     # (d_prev, a_prev, c)
    others: list = field(default_factory=list)   # (d, a) of the other two axes' current segments
    frame: list = field(default_factory=list)    # F[t]
    ctx: list = field(default_factory=list)      # F[t-9..t] flattened
    template: list = field(default_factory=list)  # 0 rising, 1 falling
    rec: list = field(default_factory=list)       # recording index
    seg_frames: list = field(default_factory=list)  # previous segment's frames (L, D)

    def arrays(self):
        D = len(self.frame[0]) if self.frame else 0
        return dict(
            y=np.asarray(self.y, dtype=np.float64).reshape(-1, 2),
            prev=np.asarray(self.prev, dtype=np.float64).reshape(-1, 3),
            others=np.asarray(self.others, dtype=np.float64).reshape(-1, 4),
            frame=np.asarray(self.frame, dtype=np.float64).reshape(-1, D),
            ctx=np.asarray(self.ctx, dtype=np.float64).reshape(-1, D * CONTEXT),
            template=np.asarray(self.template, dtype=np.int64),
            rec=np.asarray(self.rec, dtype=np.int64),
        )


def context_frames(F: np.ndarray, t: int) -> np.ndarray:
    """F[t-9 … t] (edge-padded at the start), flattened."""
    idx = np.clip(np.arange(t - CONTEXT + 1, t + 1), 0, len(F) - 1)
    return F[idx].ravel()


def segment_motion(rotvec: np.ndarray, fps: float):
    """Per axis: boundaries (K+1,) and smoothed values at them."""
    xs = smooth(rotvec, fps=fps)
    out = []
    for j in range(3):
        b = segment_axis(xs[:, j], fps=fps, smoothed=True)
        out.append((b, xs[b, j]))
    return out, xs


def current_segment_params(bounds: np.ndarray, values: np.ndarray, t: int, fps: float) -> tuple[float, float]:
    """(d, a) of the segment of another axis in progress at frame t."""
    if len(bounds) < 2:
        return 0.0, 0.0
    k = int(np.searchsorted(bounds, t, side="right")) - 1
    k = min(max(k, 0), len(bounds) - 2)
    return (bounds[k + 1] - bounds[k]) / fps, abs(values[k + 1] - values[k])


def collect(motions: list[np.ndarray], feats: list[np.ndarray], fps: float, *, with_frames: bool = False):
    """Training vectors for the three axes from aligned motions (T, 3) and features (T, D)."""
    data = [AxisData() for _ in range(3)]
    for r, (rv, F) in enumerate(zip(motions, feats)):
        segs, _ = segment_motion(rv, fps)
        for j in range(3):
            b, v = segs[j]
            for k in range(1, len(b) - 1):
                t = int(b[k])
                s = v[k + 1] - v[k]
                dj = data[j]
                dj.y.append(((b[k + 1] - b[k]) / fps, abs(s)))
                dj.prev.append(((b[k] - b[k - 1]) / fps, abs(v[k] - v[k - 1]), v[k]))
                o = []
                for i in range(3):
                    if i != j:
                        o.extend(current_segment_params(segs[i][0], segs[i][1], t, fps))
                dj.others.append(o)
                dj.frame.append(F[t])
                dj.ctx.append(context_frames(F, t))
                dj.template.append(0 if s >= 0 else 1)
                dj.rec.append(r)
                if with_frames:
                    lo = max(int(b[k - 1]), t - MAX_HMM_FRAMES + 1)
                    dj.seg_frames.append(F[lo:t + 1])
    return data


# ---------------------------------------------------------------------------------------------
# limits
# ---------------------------------------------------------------------------------------------
@dataclass
class Limits:
    """Per-axis limits learned from the training data (see the module docstring)."""

    d_min: float            # seconds
    d_max: np.ndarray       # (3,) seconds
    a_max: np.ndarray       # (3,) radians
    v_max: np.ndarray       # (3,) radians per frame
    lo: np.ndarray          # (3,) radians
    hi: np.ndarray
    mean: np.ndarray        # (3,) mean position
    d_mean: np.ndarray      # (3,)
    a_mean: np.ndarray      # (3,)

    @classmethod
    def from_training(cls, motions, data: list[AxisData], fps: float) -> "Limits":
        allr = np.vstack(motions)
        sm = [smooth(m, fps=fps) for m in motions]
        v = np.max(np.vstack([np.abs(np.diff(s, axis=0)) for s in sm if len(s) > 1]), axis=0)
        d_max, a_max, d_mean, a_mean = [], [], [], []
        for j in range(3):
            y = np.asarray(data[j].y).reshape(-1, 2)
            if len(y) == 0:
                y = np.array([[0.3, 0.0]])
            d_max.append(np.percentile(y[:, 0], 99.5))
            a_max.append(np.max(y[:, 1]))
            d_mean.append(y[:, 0].mean())
            a_mean.append(y[:, 1].mean())
        lo, hi = allr.min(axis=0), allr.max(axis=0)
        return cls(d_min=min_segment_frames(fps) / fps, d_max=np.asarray(d_max), a_max=np.asarray(a_max),
                   v_max=v, lo=lo, hi=hi, mean=allr.mean(axis=0), d_mean=np.asarray(d_mean),
                   a_mean=np.asarray(a_mean))

    def to_arrays(self) -> dict:
        return {f"lim_{k}": np.asarray(getattr(self, k), dtype=np.float64) for k in self.__dataclass_fields__}

    @classmethod
    def from_arrays(cls, arrays) -> "Limits":
        kw = {k: np.asarray(arrays[f"lim_{k}"], dtype=np.float64) for k in cls.__dataclass_fields__}
        kw["d_min"] = float(kw["d_min"])
        return cls(**kw)

    def clip(self, j: int, d: float, a: float, c: float, sign: float, fps: float) -> tuple[int, float]:
        """Frames and signed amplitude of a new segment after applying the limits."""
        n = int(round(min(max(d, self.d_min), max(self.d_max[j], self.d_min)) * fps))
        n = max(n, 1)
        a = min(max(a, 0.0), self.a_max[j], 2.0 * n * self.v_max[j] / math.pi)
        span = self.hi[j] - self.lo[j]
        lo, hi = self.lo[j] - 0.1 * span, self.hi[j] + 0.1 * span
        end = min(max(c + sign * a, lo), hi)
        s = end - c
        if s * sign < 0:  # already beyond the range in this direction: hold
            s = 0.0
        return n, s


# ---------------------------------------------------------------------------------------------
# the causal generator
# ---------------------------------------------------------------------------------------------
class Generator:
    """Causal template-warping synthesis over a growing feature matrix.

    ``system`` supplies ``_choose(j, template, state, F, t, rng) -> (d, a)``; the generator
    keeps the per-axis segment lists and renders frames."""

    def __init__(self, system, *, rng: np.random.Generator, fps: float):
        self.sys = system
        self.rng = rng
        self.fps = fps
        lim: Limits = system.limits_
        self.segs = [[] for _ in range(3)]  # (start_frame, n_frames, s, c)
        self.next_change = np.zeros(3, dtype=np.int64)
        self.F = np.zeros((0, system.n_features_))
        self.rendered = 0
        self.ctx = system._init_generation() if hasattr(system, "_init_generation") else {}
        for j in range(3):
            n, s = lim.clip(j, lim.d_mean[j], lim.a_mean[j], lim.mean[j] - lim.a_mean[j] / 2, 1.0, fps)
            c = lim.mean[j] - s / 2
            self.segs[j].append((0, n, s, c))
            self.next_change[j] = n

    def axis_state(self, j: int):
        st, n, s, c = self.segs[j][-1]
        return st, n, s, c

    def push_features(self, F_new: np.ndarray) -> None:
        if len(F_new):
            self.F = np.vstack([self.F, F_new]) if len(self.F) else np.asarray(F_new, dtype=np.float64)

    def run(self, final: bool, total: int | None = None) -> int:
        """Process change points whose speech is available; return the number of final frames."""
        avail = len(self.F)
        while True:
            j = int(np.argmin(self.next_change))
            t = int(self.next_change[j])
            if t >= avail:  # the speech frame at the change point is not here (yet, or ever)
                break
            st, n, s, c = self.segs[j][-1]
            c_new = c + s
            template = 1 if s > 0 or (s == 0 and len(self.segs[j]) % 2 == 0) else 0
            sign = 1.0 if template == 0 else -1.0
            others = []
            for i in range(3):
                if i != j:
                    _, ni, si, _ = self.segs[i][-1]
                    others += [ni / self.fps, abs(si)]
            state = dict(prev=np.array([n / self.fps, abs(s), c_new]), others=np.array(others),
                         seg_start=st, gen=self.ctx)
            d, a = self.sys._choose(j, template, state, self.F, t, self.rng)
            n_new, s_new = self.sys.limits_.clip(j, d, a, c_new, sign, self.fps)
            self.segs[j].append((t, n_new, s_new, c_new))
            self.next_change[j] = t + n_new
        return int(self.next_change.min())

    def render(self, a: int, b: int) -> np.ndarray:
        """Frames [a, b) of all axes, (b-a, 3)."""
        out = np.empty((max(b - a, 0), 3))
        if b <= a:
            return out
        tt = np.arange(a, b, dtype=np.float64)
        for j in range(3):
            arr = np.asarray(self.segs[j], dtype=np.float64)
            starts, ns, ss, cs = arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3]
            k = np.searchsorted(starts, tt, side="right") - 1
            k = np.clip(k, 0, len(arr) - 1)
            ph = np.clip((tt - starts[k]) / ns[k], 0.0, 1.0)
            out[:, j] = cs[k] + ss[k] * 0.5 * (1 - np.cos(np.pi * ph))
        return out


class TwsStream:
    """Streaming synthesis: push 16-bit-scaled float samples (any chunk size), get final frames.

    Latency: a feature block (``feature_block`` frames) plus its right context must be complete
    before its change points can be processed, so the algorithmic latency is
    ``(feature_block + feature_context) / fps`` seconds at most (0.7 s with the defaults)."""

    def __init__(self, system, *, seed: int | None, gain: float = 1.0):
        self.sys = system
        self.fps = system.fps_
        self.sr = system.sample_rate_
        self.gen = Generator(system, rng=np.random.default_rng(seed), fps=self.fps)
        self.buf = np.zeros(0, dtype=np.float32)
        self.block = system.feature_block
        self.ctx = system.feature_context
        self.next_block = 0
        self.emitted = 0
        self.gain = gain
        self.latency_ms = 1000.0 * (self.block + self.ctx) / self.fps

    def _frames_in_buffer(self) -> int:
        return _n_frames(len(self.buf), self.sr, self.fps)

    def _extract_ready(self, final: bool) -> None:
        T = self._frames_in_buffer()
        while True:
            f0 = self.next_block * self.block
            f1 = f0 + self.block
            if f0 >= T:
                break
            if not final and f1 + self.ctx > T - 1:
                break
            F = self.sys._features_blocks(Audio(self.buf, self.sr), T if final else f1 + self.ctx,
                                          start_block=self.next_block, stop_frame=min(f1, T))
            self.gen.push_features(F)
            self.next_block += 1

    def push(self, samples) -> Motion:
        x = np.asarray(samples, dtype=np.float32).ravel()
        self.buf = np.concatenate([self.buf, x])
        self._extract_ready(final=False)
        ready = self.gen.run(final=False)
        return self._emit(min(ready, len(self.gen.F)))

    def flush(self) -> Motion:
        self._extract_ready(final=True)
        T = self._frames_in_buffer()
        self.gen.run(final=True, total=T)
        return self._emit(T)

    def _emit(self, upto: int) -> Motion:
        a, b = self.emitted, max(self.emitted, upto)
        rv = self.gen.render(a, b)
        self.emitted = b
        return Motion(self.sys._apply_gain(rv, self.gain), self.fps)


# ---------------------------------------------------------------------------------------------
# the shared system skeleton
# ---------------------------------------------------------------------------------------------
from .base import Synthesizer  # noqa: E402


class TwsBase(Synthesizer):
    """Feature handling, training-data collection, generation, streaming and persistence shared
    by :class:`~headmotion.systems.tws_basic.TwsBasic` and
    :class:`~headmotion.systems.tws_hier.TwsHier`.  Subclasses implement ``_fit_axes(data)``,
    ``_choose(...)``, ``_model_state()`` and ``_load_model_state(config, arrays)``."""

    causal = True
    _with_frames = False

    def _init_common(self, features, fps, method, stochastic, gain, feature_block, feature_context, seed):
        if method not in ("ml", "mmse", "sample"):
            raise ParameterError(f"method must be 'ml', 'mmse' or 'sample'; got {method!r}")
        self.features = features
        self.fps = fps
        self.method = method
        self.stochastic = stochastic
        self.gain = gain
        self.feature_block = int(feature_block)
        self.feature_context = int(feature_context)
        self.seed = seed

    # -- features ---------------------------------------------------------------------------
    def _config(self):
        if not hasattr(self, "feature_config_"):
            self.feature_config_ = make_feature_config(self.features, self.fps_)
        return self.feature_config_

    def _features_full(self, audio: Audio, T: int) -> np.ndarray:
        tr = self._config().extract(audio, n_frames=T)
        return np.asarray(self.normalizer_.transform(np.asarray(tr.values, dtype=np.float64)), dtype=np.float64)

    def _features_blocks(self, audio: Audio, T: int, *, start_block: int = 0, stop_frame: int | None = None):
        F = extract_blocked(audio, self._config(), T, block=self.feature_block, context=self.feature_context,
                            start_block=start_block, stop_frame=stop_frame)
        if F.size == 0:
            return np.zeros((0, self.n_features_))
        return np.asarray(self.normalizer_.transform(F), dtype=np.float64)

    # -- training ---------------------------------------------------------------------------
    def fit(self, corpus, *, progress=None):
        from ..features import Normalizer

        recs = list(corpus)
        if not recs:
            raise ParameterError("cannot train on an empty corpus")
        fps_set = sorted({float(r.motion.fps) for r in recs})
        self.fps_ = float(self.fps) if self.fps else fps_set[0]
        self.sample_rate_ = int(recs[0].audio.sample_rate)
        self.feature_config_ = make_feature_config(self.features, self.fps_)
        total = len(recs) + 2
        motions, raw, names = [], [], []
        for i, r in enumerate(recs):
            m = r.motion if abs(r.motion.fps - self.fps_) < 1e-9 else r.motion.resample(self.fps_)
            T = len(m)
            if T < 2 * min_segment_frames(self.fps_):
                continue
            tr = self.feature_config_.extract(r.audio, n_frames=T)
            motions.append(np.asarray(m.rotvec))
            raw.append(np.asarray(tr.values, dtype=np.float64))
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
        data = collect(motions, feats, self.fps_, with_frames=self._with_frames)
        n_seg = [len(d.y) for d in data]
        if min(n_seg) < 4:
            raise ParameterError(
                f"too little motion to train {self.name}: segments per axis {n_seg} (need >= 4 each); "
                "give longer recordings or more of them")
        self.limits_ = Limits.from_training(motions, data, self.fps_)
        if progress:
            progress(len(recs) + 1, total, "models")
        self._fit_axes(data, progress=progress)
        self.corpus_summary_ = corpus.summary() if hasattr(corpus, "summary") else None
        self.fitted_ = True
        if progress:
            progress(total, total, "done")
        return self

    # -- synthesis ----------------------------------------------------------------------------
    def _apply_gain(self, rv: np.ndarray, gain: float) -> np.ndarray:
        g = float(self.gain if gain is None else gain)
        if g == 1.0:
            return rv
        m = self.limits_.mean
        return m + g * (rv - m)

    def _audio_frames(self, audio: Audio) -> int:
        if not isinstance(audio, Audio):
            raise ParameterError(f"predict expects an Audio; got {type(audio).__name__}")
        if audio.sample_rate != self.sample_rate_:
            from ..io.audio import resample

            audio = Audio(resample(audio.samples, audio.sample_rate, self.sample_rate_), self.sample_rate_)
        return audio, _n_frames(len(audio.samples), audio.sample_rate, self.fps_)

    def predict(self, audio: Audio, *, seed: int | None = None, gain: float | None = None,
                blocked: bool = False) -> Motion:
        """Synthesise head motion for ``audio`` (resampled to the training rate if needed).

        Parameters
        ----------
        audio : Audio
        seed : random seed (stochastic modes); default the model's ``seed``
        gain : amplitude scale about the mean pose (default the model's ``gain``)
        blocked : compute features block by block exactly as :meth:`stream` does, so the output
            equals the streamed output sample for sample; the default computes them over the whole
            utterance (as in training), which differs only by edge effects at block boundaries.
        """
        self._check_fitted()
        audio, T = self._audio_frames(audio)
        if T == 0:
            return Motion(np.zeros((0, 3)), self.fps_, meta={"system": self.name})
        gen = Generator(self, rng=np.random.default_rng(self.seed if seed is None else seed), fps=self.fps_)
        gen.push_features(self._features_blocks(audio, T) if blocked else self._features_full(audio, T))
        gen.run(final=True, total=T)
        rv = gen.render(0, T)
        return Motion(self._apply_gain(rv, gain), self.fps_, meta={"system": self.name, "seed": seed})

    def stream(self, *, seed: int | None = None, gain: float | None = None) -> TwsStream:
        self._check_fitted()
        return TwsStream(self, seed=self.seed if seed is None else seed, gain=gain)

    # -- persistence --------------------------------------------------------------------------
    def get_params(self) -> dict:
        """The ``__init__`` parameters (JSON-serialisable), as scikit-learn's ``get_params``."""
        import inspect

        out = {}
        for name in inspect.signature(type(self).__init__).parameters:
            if name == "self":
                continue
            v = getattr(self, name)
            if hasattr(v, "to_dict"):
                v = v.to_dict()
            out[name] = v
        return out

    def _common_params(self) -> dict:
        return {"fps": self.fps, "method": self.method, "stochastic": self.stochastic, "gain": self.gain,
                "feature_block": self.feature_block, "feature_context": self.feature_context, "seed": self.seed}

    def _get_state(self):
        cfg, arrays = self._model_state()
        cfg = dict(cfg)
        cfg.update({"params": self.get_params(), "fps": self.fps_, "sample_rate": self.sample_rate_,
                    "features": self.feature_config_.to_dict(), "n_features": self.n_features_,
                    "feature_names": list(self.feature_names_)})
        arrays = dict(arrays)
        arrays.update(self.limits_.to_arrays())
        arrays.update(self.normalizer_.to_arrays("norm_"))
        return cfg, arrays

    def _set_state(self, config, arrays):
        from ..features import FeatureConfig, Normalizer

        self.__init__(**config["params"])
        self.fps_ = float(config["fps"])
        self.sample_rate_ = int(config["sample_rate"])
        self.feature_config_ = FeatureConfig.from_dict(config["features"])
        self.n_features_ = int(config["n_features"])
        self.feature_names_ = list(config.get("feature_names", []))
        self.limits_ = Limits.from_arrays(arrays)
        self.normalizer_ = Normalizer.from_arrays(arrays, "norm_")
        self._load_model_state(config, arrays)


__all__ = ["TwsBase", "collect", "Limits", "Generator", "TwsStream", "extract_blocked", "make_feature_config",
           "context_frames", "CONTEXT", "MAX_HMM_FRAMES", "segment_motion"]
