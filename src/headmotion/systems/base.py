"""The one interface every synthesis system shares, and the registry of systems (DESIGN.md).

A system is an estimator in scikit-learn's style: ``__init__`` stores parameters only, ``fit``
learns from a :class:`~headmotion.corpus.Corpus` and returns ``self``, fitted attributes end in
``_``.  ``predict`` turns :class:`~headmotion.types.Audio` into :class:`~headmotion.types.Motion`.
Persistence goes through :mod:`headmotion.models.serialization` (no pickle): a subclass provides
``_get_state() -> (config, arrays)`` and ``_set_state(config, arrays)``.

Causal systems also offer ``stream()`` returning a :class:`MotionStream`: ``push(samples)`` gives
the frames whose values are final so far, ``flush()`` the rest.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, ClassVar, Protocol

import numpy as np

from ..errors import ModelFileError, NotFittedError, ParameterError
from ..models.serialization import load_model_file, save_model_file
from ..types import Audio, Motion

#: registry name → "module:Class" (modules are imported on first use)
SYSTEMS: dict[str, str] = {
    "tws-basic": "headmotion.systems.tws_basic:TwsBasic",
    "tws-hier": "headmotion.systems.tws_hier:TwsHier",
    "le2012": "headmotion.systems.le2012:Le2012",
    "cccae": "headmotion.systems.dnn:CccaeSystem",
    "ae-dnn": "headmotion.systems.dnn:AeDnnSystem",
    "mfcc-dnn": "headmotion.systems.dnn:MfccDnnSystem",
    "fbank-dnn": "headmotion.systems.dnn:FbankDnnSystem",
    "f0e-dnn": "headmotion.systems.dnn:F0eDnnSystem",
    "wav-dnn": "headmotion.systems.dnn:WavDnnSystem",
}

#: anchors (evaluation conditions, thesis §4.2.4, §4.3.1) — not trainable models
ANCHORS: dict[str, str] = {
    "ground-truth": "headmotion.systems.anchors:GroundTruth",
    "desync": "headmotion.systems.anchors:Desync",
    "other-speaker": "headmotion.systems.anchors:OtherSpeaker",
    "shaped-noise": "headmotion.systems.anchors:ShapedNoise",
    "still": "headmotion.systems.anchors:Still",
}


class MotionStream(Protocol):
    """Incremental synthesis: push audio, get the frames that are final."""

    latency_ms: float

    def push(self, samples: np.ndarray) -> Motion: ...

    def flush(self) -> Motion: ...


class Synthesizer(ABC):
    """Base class of every system: speech in, head motion out."""

    #: the registry name, e.g. ``"tws-hier"``
    name: ClassVar[str] = ""
    #: True when ``stream()`` is available
    causal: ClassVar[bool] = False

    # -- the interface -------------------------------------------------------------------------
    @abstractmethod
    def fit(self, corpus, *, progress=None) -> "Synthesizer":
        """Learn from a corpus; returns ``self``.  ``progress`` is an optional callable
        ``progress(done: float, total: float, description: str)``."""

    @abstractmethod
    def predict(self, audio: Audio, *, seed: int | None = None) -> Motion:
        """Synthesise head motion for ``audio``."""

    def stream(self, *, seed: int | None = None) -> MotionStream:
        raise ParameterError(f"system {self.name!r} is not causal and cannot stream")

    @abstractmethod
    def _get_state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """``(config, arrays)`` describing the fitted model (config must be JSON-serialisable)."""

    @abstractmethod
    def _set_state(self, config: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        """Restore a fitted model from what ``_get_state`` returned."""

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
        return save_model_file(path, system=self.name, config=config, arrays=arrays)

    @classmethod
    def load(cls, path) -> "Synthesizer":
        config, arrays = load_model_file(path, expect_system=cls.name or None)
        obj = cls.__new__(cls)
        try:
            obj._set_state(config, arrays)
        except (KeyError, ValueError, TypeError, IndexError) as exc:
            raise ModelFileError(f"{path}: model file is damaged or incomplete ({type(exc).__name__}: {exc})") from exc
        obj.corpus_summary_ = config.get("corpus")
        obj.fitted_ = True
        return obj


def _import(spec: str):
    mod, cls = spec.split(":")
    return getattr(importlib.import_module(mod), cls)


def system_class(name: str) -> type:
    """The class registered under ``name`` (a system or an anchor)."""
    if name in SYSTEMS:
        return _import(SYSTEMS[name])
    if name in ANCHORS:
        return _import(ANCHORS[name])
    raise ParameterError(
        f"unknown system {name!r}; expected one of {sorted(SYSTEMS)} or anchors {sorted(ANCHORS)}")


def create(name: str, **params) -> Synthesizer:
    """A new, unfitted system by registry name."""
    return system_class(name)(**params)


def load_model(path) -> Synthesizer:
    """Load any model file, whatever system made it."""
    config, _ = load_model_file(path)
    system = config.get("system")
    if system not in SYSTEMS:
        raise ModelFileError(f"{path}: model is for system {system!r}, which this headmotion does not know")
    return system_class(system).load(path)


__all__ = ["Synthesizer", "MotionStream", "SYSTEMS", "ANCHORS", "system_class", "create", "load_model"]
