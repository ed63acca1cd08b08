"""The one contract every synthesis system shares, and the registry of systems (docs/design.md).

A system is an estimator in scikit-learn's manner:

* ``__init__`` only stores its keyword arguments under their own names
  (``self._store_params(locals())``); :meth:`get_params` and :meth:`set_params` are derived from
  ``__init__``'s signature (one implementation, here).
* Parameters are validated in :meth:`fit` and :meth:`predict` (a subclass's ``_validate_params``),
  never in ``__init__``, so ``set_params`` may change them.
* ``random_state`` is the *training* randomness (EM / k-means / network initialisation, data
  splits); ``seed`` is the *synthesis* randomness (what a stochastic system samples).  A system
  with a ``seed`` parameter uses it when ``predict(seed=None)``; the rule and its check are
  :func:`headmotion.seeds.resolve_seed`, applied once per synthesis.
* ``stochastic`` — what a stochastic system samples — is an ordinary parameter with one
  vocabulary for every system, :data:`STOCHASTIC`: ``"none"``, ``"choice"`` (the discrete choice:
  tws-basic's speed class, tws-hier's cluster; the thesis's words ``"class"`` and ``"cluster"``
  are accepted for it), ``"params"`` (the warping parameters) or ``"both"``.  Systems without it
  are deterministic; ``set_params(stochastic=...)`` on them raises ParameterError.
* Fitted attributes end in ``_``; :meth:`predict` and :meth:`stream` raise NotFittedError before
  :meth:`fit` or :meth:`load`.  Every fitted system has ``mean_pose_`` (pitch, yaw, roll of the
  training motion, radians) and may list training warnings in ``fit_warnings_`` (the evaluation
  copies them into its report).

Synthesis::

    predict(audio, *, seed=None) -> Motion        # at model.frame_rate
    stream(*, seed=None) -> MotionStream          # CAUSAL or STREAMING systems

``audio`` may be at any sample rate: it is resampled once, where the features are computed.
:attr:`Synthesizer.sample_rate` is the rate the features analyse (and the rate a stream's
``push`` expects).  The output is at :attr:`Synthesizer.frame_rate`; the caller resamples.
``predict_seeded(audio, seed)`` and ``stream_seeded(seed)`` are the same with a seed the caller
has resolved (:func:`headmotion.synthesize` and :func:`headmotion.open_stream` do).  A system's
output is its own motion: gain, offset and the other user controls act above the systems, once
(:func:`headmotion.synthesis.apply_controls`; gain about the training data's mean pose
``mean_pose_``, :func:`headmotion.motion.control.apply_gain`).

A fitted system may declare the pose range it can reach by overriding :meth:`reachable_range`
(``(3, 2)`` radians; default None) — the evaluation measures saturation against it.

Capabilities are declared, not sniffed: ``capabilities`` is a frozenset of :data:`CAUSAL`
(``stream()`` works with at most a short lookahead, and the stream equals ``predict``; such a
system may also synthesise hour-long files block by block), :data:`STREAMING` (``stream()`` works,
with the lookahead its stream's ``latency_ms`` states — the DNN systems: their ±25-frame context
and post-filter segments need ~0.8 s of future audio), :data:`EMBEDDING` (``embed(audio, fps=, n_frames=)`` gives a learned
embedding), :data:`NEEDS_OTHER_SPEAKERS` (train on the other speakers' recordings).

Subclasses implement ``fit``, ``_predict(audio, *, seed) -> Motion``,
``_stream(*, seed)`` when causal or streaming, ``_get_state`` / ``_set_state`` for persistence through
:mod:`headmotion.models.serialization` (no pickle), and ``_legacy_mean_pose`` for model files
written before ``mean_pose`` was stored.
"""

from __future__ import annotations

import functools
import importlib
import inspect
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, ClassVar, Protocol

import numpy as np

from ..errors import ModelFileError, NotFittedError, ParameterError
from ..models.serialization import load_model_file, save_model_file
from ..registry import SYSTEMS  # the table lives below the systems: shipped.py reads it too
from ..seeds import resolve_seed
from ..types import Audio, Motion

#: capability names
CAUSAL = "causal"
STREAMING = "streaming"
EMBEDDING = "embedding"
NEEDS_OTHER_SPEAKERS = "needs_other_speakers"

#: the ``stochastic`` vocabulary, and the thesis's words for "choice"
STOCHASTIC = ("none", "choice", "params", "both")
STOCHASTIC_ALIASES = {"class": "choice", "cluster": "choice"}


def check_stochastic(value, system: str) -> str:
    """The canonical ``stochastic`` value, or ParameterError naming the vocabulary."""
    v = STOCHASTIC_ALIASES.get(value, value)
    if v not in STOCHASTIC:
        raise ParameterError(
            f"the 'stochastic' parameter of {system} must be one of {list(STOCHASTIC)} "
            f"(or 'class' / 'cluster' for 'choice'); got {value!r}")
    return v


class MotionStream(Protocol):
    """Incremental synthesis: push audio samples (float, at the model's ``sample_rate``), get the
    frames that are final; ``flush()`` gives the rest."""

    latency_ms: float

    def push(self, samples: np.ndarray) -> Motion: ...

    def flush(self) -> Motion: ...


@functools.lru_cache(maxsize=None)
def _init_params(cls) -> tuple[str, ...]:
    """The names of ``cls.__init__``'s parameters (read once per class: a model's load asks ~30 times)."""
    sig = inspect.signature(cls.__init__)
    return tuple(p.name for p in sig.parameters.values()
                 if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD))


class Synthesizer(ABC):
    """Base class of every system: speech in, head motion out (see the module docstring)."""

    #: the registry name, e.g. ``"tws-hier"``
    name: ClassVar[str] = ""
    #: what the system can do beyond ``predict``: a subset of {CAUSAL, EMBEDDING, NEEDS_OTHER_SPEAKERS}
    capabilities: ClassVar[frozenset[str]] = frozenset()

    # -- parameters (scikit-learn style) ----------------------------------------------------
    @classmethod
    def _param_names(cls) -> list[str]:
        return list(_init_params(cls))

    def _store_params(self, values: dict[str, Any]) -> None:
        """All an ``__init__`` does: store each of its parameters, unchanged, under its own name
        (``values``: the ``__init__``'s ``locals()``)."""
        for k in self._param_names():
            setattr(self, k, values[k])

    def get_params(self) -> dict[str, Any]:
        """The ``__init__`` parameters and their current values."""
        return {k: getattr(self, k) for k in self._param_names()}

    def set_params(self, **params) -> "Synthesizer":
        """Change parameters (validated at the next ``fit`` / ``predict``); returns ``self``."""
        names = self._param_names()
        for k, v in params.items():
            if k not in names:
                raise ParameterError(f"{self.name or type(self).__name__} has no parameter {k!r}; "
                                     f"its parameters are {names}")
            setattr(self, k, v)
        return self

    def _validate_params(self) -> None:  # noqa: B027  (an optional hook: no parameters to check by default)
        """Raise ParameterError for a bad parameter (called by ``fit`` and ``predict``)."""

    @property
    def causal(self) -> bool:
        return CAUSAL in self.capabilities

    @property
    def can_stream(self) -> bool:
        """``stream()`` works: CAUSAL or STREAMING (the stream's ``latency_ms`` states its lookahead)."""
        return bool({CAUSAL, STREAMING} & self.capabilities)

    # -- rates --------------------------------------------------------------------------------
    @property
    def sample_rate(self) -> int:
        """Hz of the audio the model's features analyse (a stream's ``push`` expects this rate)."""
        self._check_fitted()
        return int(self.sample_rate_)

    @property
    def frame_rate(self) -> float:
        """Frames per second of ``predict``'s and ``stream``'s output."""
        self._check_fitted()
        return float(self.fps_)

    # -- the interface -------------------------------------------------------------------------
    def _training_recordings(self, corpus, *, budget: bool = False) -> list:
        """The recordings of ``corpus`` after the parameters are checked; ParameterError when
        there are none (the start of every ``fit``).  ``budget``: the system has
        ``max_train_hours`` — only the recordings of :func:`headmotion.systems.budget.training_recordings`
        are read."""
        self._validate_params()
        if budget:
            from .budget import training_recordings

            recs = training_recordings(self, corpus)
        else:
            recs = list(corpus)
        if not recs:
            raise ParameterError(f"cannot fit {self.name} on an empty corpus")
        return recs

    @abstractmethod
    def fit(self, corpus, *, progress=None) -> "Synthesizer":
        """Learn from a corpus; returns ``self``.  ``progress`` is an optional callable
        ``progress(done: float, total: float, description: str)``."""

    def predict(self, audio: Audio, *, seed: int | None = None) -> Motion:
        """Head motion for ``audio`` (any sample rate) at :attr:`frame_rate`: the system's own
        motion, which :func:`headmotion.synthesize` then controls (gain, offset, style …).

        ``seed`` — synthesis randomness; None: the model's ``seed`` parameter, or
        :data:`headmotion.seeds.DEFAULT_SEED` (:func:`headmotion.seeds.resolve_seed`)."""
        return self.predict_seeded(audio, resolve_seed(self, seed))

    def predict_seeded(self, audio: Audio, seed: int) -> Motion:
        """:meth:`predict` with a seed already resolved by :func:`headmotion.seeds.resolve_seed`
        (what :func:`headmotion.synthesize` calls: it resolves the seeds of all its samples once)."""
        self._check_fitted()
        if not isinstance(audio, Audio):
            raise ParameterError(f"{self.name}.predict expects an Audio; got {type(audio).__name__}")
        self._validate_params()
        return self._predict(audio, seed=seed)

    @abstractmethod
    def _predict(self, audio: Audio, *, seed: int) -> Motion:
        """The system's motion (``seed`` already resolved)."""

    def _own_synthesis(self, recs, motions) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """This system's synthesis of the speech of the training recordings ``recs`` (recording k
        with seed k, so that it is not one seed's draws) and their motion ``motions`` (rotation
        vectors at the model's rate), each pair cut to the shorter: what the post stages of the
        template systems are fitted on (le2012 keeps its ascent apart from the pause settling, which
        its ``idle="auto"`` varies: ``Le2012._raw_synthesis``)."""
        return pair_shortest((self._predict(r.audio, seed=k).rotvec for k, r in enumerate(recs)), motions)

    def stream(self, *, seed: int | None = None) -> MotionStream:
        """Incremental synthesis (systems with the CAUSAL or STREAMING capability); ``seed`` as
        in :meth:`predict`."""
        return self.stream_seeded(resolve_seed(self, seed))

    def stream_seeded(self, seed: int) -> MotionStream:
        """:meth:`stream` with a seed already resolved (what :func:`headmotion.open_stream` calls)."""
        if not self.can_stream:
            raise ParameterError(f"system {self.name!r} cannot stream (it has neither the causal nor the "
                                 f"streaming capability)")
        self._check_fitted()
        self._validate_params()
        return self._stream(seed=seed)

    def _stream(self, *, seed: int) -> MotionStream:  # noqa: ARG002  (the causal systems' hook)
        raise ParameterError(f"system {self.name!r} is not causal and cannot stream")

    @abstractmethod
    def _get_state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """``(config, arrays)`` describing the fitted model (config must be JSON-serialisable)."""

    @abstractmethod
    def _set_state(self, config: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        """Restore a fitted model from what ``_get_state`` returned."""

    def _legacy_mean_pose(self) -> np.ndarray:
        """The mean pose for a model file without one (older files); override per system."""
        return np.zeros(3)

    def reachable_range(self) -> np.ndarray | None:
        """The pose range the fitted model can reach, ``(3, 2)`` lower/upper (pitch, yaw, roll,
        radians) — e.g. the clip limits of the template systems — or None when the system declares
        none (the default).  Optional: the evaluation's *saturation* measure (share of frames within
        1° of this range) uses it and reports nan for systems without one."""
        return None

    # -- shared behaviour --------------------------------------------------------------------
    @property
    def is_fitted(self) -> bool:
        return bool(getattr(self, "fitted_", False))

    def _check_fitted(self) -> None:
        if not self.is_fitted:
            raise NotFittedError(f"this {self.name} model is not fitted yet: call fit() or load a model file")

    def save(self, path) -> Path:
        self._check_fitted()
        config, arrays = self._get_state()
        config = dict(config)
        config.setdefault("corpus", getattr(self, "corpus_summary_", None))
        arrays = dict(arrays)
        arrays["mean_pose"] = np.asarray(self.mean_pose_, dtype=np.float64)
        return save_model_file(path, system=self.name, config=config, arrays=arrays)

    @classmethod
    def load(cls, path) -> "Synthesizer":
        config, arrays = load_model_file(path, expect_system=cls.name or None)
        return cls._from_state(path, config, arrays)

    @classmethod
    def _from_state(cls, path, config, arrays) -> "Synthesizer":
        obj = cls.__new__(cls)
        try:
            obj._set_state(config, arrays)
            obj.mean_pose_ = (np.asarray(arrays["mean_pose"], dtype=np.float64) if "mean_pose" in arrays
                              else np.asarray(obj._legacy_mean_pose(), dtype=np.float64))
        except (KeyError, ValueError, TypeError, IndexError) as exc:
            raise ModelFileError(f"{path}: model file is damaged or incomplete ({type(exc).__name__}: {exc})") from exc
        obj.corpus_summary_ = config.get("corpus")
        obj.fitted_ = True
        return obj


def _import(spec: str):
    mod, cls = spec.split(":")
    return getattr(importlib.import_module(mod), cls)


def pair_shortest(predicted, motions) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Synthesis and recorded motion paired recording by recording, each pair cut to the shorter
    (a frame more or less at the end): the input of the post stages' fits."""
    pred, targ = [], []
    for x, m in zip(predicted, motions):
        x, m = np.asarray(x), np.asarray(m)
        n = min(len(x), len(m))
        pred.append(x[:n])
        targ.append(m[:n])
    return pred, targ


def cross_fit_groups(recs, *, by_speaker: bool = False) -> np.ndarray:
    """Two halves of the recordings ``recs`` for a cross-fitted calibration (group 0 or 1 per
    recording): alternating by duration, so that the halves carry similar amounts of speech.
    With ``by_speaker`` (and at least two speakers) whole speakers alternate, by their total
    duration, so that each half model meets only speakers it was not trained on."""
    dur = np.array([len(r.motion) / r.motion.fps for r in recs])
    speakers = sorted({r.speaker for r in recs})
    if by_speaker and len(speakers) >= 2:
        total = {s: dur[[r.speaker == s for r in recs]].sum() for s in speakers}
        order = sorted(speakers, key=lambda s: -total[s])   # stable: ties keep the name order
        half = {s: i % 2 for i, s in enumerate(order)}
        return np.array([half[r.speaker] for r in recs], dtype=int)
    order = np.argsort(-dur, kind="stable")
    group = np.zeros(len(recs), dtype=int)
    group[order[1::2]] = 1
    return group


def cross_fitted(system: "Synthesizer", recs, overrides: dict, synthesize, *, sample_rate=None,
                 by_speaker: bool = True) -> list:
    """The ``cross_fit`` calibration synthesis of le2012, the template systems and the DNN
    systems: ``synthesize(half, recording, k)`` for every recording ``k`` of ``recs``, ``half`` a
    model of ``system``'s class and parameters (with ``overrides``, e.g. its post stages off)
    trained on the *other* half of ``recs`` (:func:`cross_fit_groups`, ``by_speaker`` as there) —
    speech that model has not seen, as at synthesis; with ``by_speaker`` also speakers it has not
    seen, as a new user's are (``docs/decisions/cross-fitting.md``).  The corpora of the halves take ``sample_rate`` (default: the
    first recording's)."""
    from ..corpus import Corpus

    group = cross_fit_groups(recs, by_speaker=by_speaker)
    params = {**system.get_params(), **overrides}
    sr = int(sample_rate or recs[0].audio.sample_rate)
    out: list = [None] * len(recs)
    for g in (0, 1):
        half = type(system)(**params).fit(Corpus([r for r, k in zip(recs, group) if k != g], sample_rate=sr))
        for i in np.flatnonzero(group == g):
            out[i] = synthesize(half, recs[i], int(i))
    return out


def system_class(name: str) -> type:
    """The class registered under ``name``."""
    if name in SYSTEMS:
        return _import(SYSTEMS[name])
    raise ParameterError(f"unknown system {name!r}; expected one of {sorted(SYSTEMS)}")


def create(name: str, **params) -> Synthesizer:
    """A new, unfitted system by registry name."""
    return system_class(name)(**params)


def load_model(path) -> Synthesizer:
    """Load any model file, whatever system made it (the file is read once); a shipped model's
    name (``"default"``, ``"stream"``) is its file (:func:`headmotion.shipped.resolve_model_path`).
    :func:`headmotion.load_model` is this, and passes a model already loaded through."""
    from ..shipped import resolve_model_path

    path = resolve_model_path(path)
    config, arrays = load_model_file(path)
    system = config.get("system")
    if system not in SYSTEMS:
        raise ModelFileError(f"{path}: model is for system {system!r}, which this headmotion does not know")
    return system_class(system)._from_state(path, config, arrays)


__all__ = ["Synthesizer", "MotionStream", "SYSTEMS", "system_class", "create", "load_model", "pair_shortest", "cross_fitted", "CAUSAL", "EMBEDDING",
           "NEEDS_OTHER_SPEAKERS", "STREAMING", "STOCHASTIC", "check_stochastic"]
